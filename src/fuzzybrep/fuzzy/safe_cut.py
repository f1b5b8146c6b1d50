"""α-cuts and μ by the conservative sweep (``safe_sweep``), the default method: functions of a
``FuzzyBRepMap`` (``fz``), which caches what they share (``fz.safe``).

One symmetric function for every vertex: the α-cut is the raw offset curve read from the stored
per-vertex directions in O(n), made proper by one positive-winding union (``safe_sweep``'s
Lemmas 1 and 2). Otherwise (sided or several functions): every edge's circumscribed stadium by
the largest distance of its vertices, united with the crisp map the same way. μ is defined so that
μ ≥ α exactly where ``alpha_cut(α).band`` is: the function of the smallest distance at which a
rectangle, fan or stadium covers the point.
"""

from __future__ import annotations

import numpy as np
import shapely

from . import safe_sweep as S


def prepare(fz) -> dict:
    """What every safe α-cut and μ of the map shares: the rings oriented with the free space on
    their left, the one symmetric function (or None), the stored directions, the integer grid,
    and an STRtree of the oriented edges."""
    s = fz.stack
    shell = s["shell"][s["start"]]
    free_left = (s["own"] == 1) == shell
    order = S.orient(s["V"], s["sizes"], free_left)
    V = s["V"][order]
    fm = s["fm"][order]
    used = np.unique(fm)
    funcs = {fz.table[int(k)] for k in used}
    f = next(iter(funcs)) if len(funcs) == 1 else None
    if f is not None and not f.symmetric:
        f = None
    centre, scale = S.grid(V)
    out = {"V": V, "fm": fm, "sizes": s["sizes"], "start": s["start"], "next": s["next"], "function": f,
           "centre": centre, "scale": scale, "reach": float(S.REACH), "shell": shell,
           "region": np.repeat(np.arange(len(fz.crisp.regions)), [len(r.rings) for r in fz.crisp.regions]),
           "inradius": S.inradius_bound(V, s["start"], s["sizes"])}
    if f is not None:
        out["lines"] = S.safe_lines(V, s["sizes"])
    segs = shapely.linestrings(np.stack((V, V[s["next"]]), axis=1))
    out["tree"] = shapely.STRtree(segs)
    return out


def edge_reach(fz, alpha: float) -> np.ndarray:
    """(N,) every oriented edge's stadium half-width at α: the largest distance, inward or
    outward, of its two vertices' functions."""
    sf = fz.safe
    fm, nxt = sf["fm"], sf["next"]
    d = np.maximum(fz.offset(fz.table.d_in(fm, alpha)), fz.offset(fz.table.d_out(fm, alpha)))
    return np.maximum(d, d[nxt])


def safe_cut(fz, alpha: float) -> tuple[shapely.Geometry, shapely.Geometry]:
    """(inner, outer) of the conservative sweep's α-cut."""
    sf = fz.safe
    crisp = fz.crisp_geometry
    centre, scale = sf["centre"], sf["scale"]
    f = sf["function"]
    if f is not None:
        d = float(fz.offset(f.d_in(alpha)))
        if d == 0.0:
            return crisp, crisp
        lines = sf["lines"]
        return tuple(S.proper(S.cut_paths(lines, side, d, scale, S.vanishing(sf["inradius"], sf["region"], sf["shell"],
                                                                              side, d)), centre, scale)
                     for side in (0, 1))
    r = edge_reach(fz, alpha)
    if not (r > 0).any():
        return crisp, crisp
    return tuple(S.proper(S.stadium_paths(sf["V"], sf["sizes"], r, side, scale), centre, scale) for side in (0, 1))


def corner_paths(fz) -> tuple[np.ndarray, np.ndarray] | None:
    """(crisp end, α = 0 end) of the path every inner α-cut corner moves along (the free side's
    raw-curve points, V and V + support·u), or None where the cut is not read from lines."""
    sf = fz.safe
    if sf["function"] is None:
        return None
    d = float(sf["function"].support_in)
    v, u, _ = sf["lines"].select(0, d)
    return v, v + d * u


# ---------------------------------------------------------------------------------------------
# Membership


def _pairs(fz, p: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
    x, y = p[:, 0], p[:, 1]
    return fz.safe["tree"].query(shapely.box(x - reach, y - reach, x + reach, y + reach))


def _frame(V, nxt, e):
    a, b = V[e], V[nxt[e]]
    t = b - a
    length = np.hypot(t[:, 0], t[:, 1])
    t = t / length[:, None]
    return a, b, t, np.column_stack((-t[:, 1], t[:, 0])), length


def membership_safe(fz, p: np.ndarray) -> np.ndarray:
    """μ of the conservative sweep at points p (m, 2): 1 on the crisp boundary, 0 beyond every
    rectangle, fan and stadium at α = 0, and μ(p) ≥ α exactly where p is in ``alpha_cut(α).band``
    (rounding margin aside)."""
    sf = fz.safe
    f = sf["function"]
    return _mu_uniform(fz, p, f) if f is not None else _mu_stadiums(fz, p)


def _mu_uniform(fz, p: np.ndarray, f) -> np.ndarray:
    """f of the smallest D at which a free-side (inside the crisp map) or other-side (outside)
    rectangle R_e(D) or fan F_V(D) holds the point."""
    sf = fz.safe
    V, nxt = sf["V"], sf["next"]
    inside = shapely.contains_xy(fz.crisp_geometry, p[:, 0], p[:, 1])
    reach = float(f.support_in) * S.REACH * (1 + 1e-9)
    pi, e = _pairs(fz, p, reach)
    delta = np.full(len(p), np.inf)
    if len(pi):
        a, b, t, n, length = _frame(V, nxt, e)
        sigma = np.where(inside[pi], 1.0, -1.0)
        q = p[pi] - a
        along = np.einsum("ij,ij->i", q, t)
        h = sigma * np.einsum("ij,ij->i", q, n)
        rect = (along >= 0) & (along <= length) & (h >= 0)
        np.minimum.at(delta, pi[rect], h[rect])
        # the fan of the edge's first vertex (every vertex starts one edge), on the arc side
        prv = np.empty_like(nxt)
        prv[nxt] = np.arange(len(nxt))
        te = V[e] - V[prv[e]]
        te = te / np.hypot(te[:, 0], te[:, 1])[:, None]
        ne = np.column_stack((-te[:, 1], te[:, 0]))
        cross = te[:, 0] * t[:, 1] - te[:, 1] * t[:, 0]
        dot = np.einsum("ij,ij->i", te, t)
        psi = np.arctan2(cross, dot)
        spike = (np.abs(cross) <= S._SPIKE) & (dot < 0)
        turn = sigma * psi
        arc = (turn < 0) & ~spike
        me, mh = sigma[:, None] * ne, sigma[:, None] * n
        # in the wedge between m_e and m_h (angle |ψ| ≤ π, turning by ψ from m_e)
        w1 = np.sign(psi) * (me[:, 0] * q[:, 1] - me[:, 1] * q[:, 0])
        w2 = np.sign(psi) * (q[:, 0] * mh[:, 1] - q[:, 1] * mh[:, 0])
        fan = arc & (w1 >= 0) & (w2 >= 0)
        if fan.any():
            k = S.fan_pieces(psi[fan]).astype(np.float64)
            j = np.arange(int(S.CAP_PIECES) + 1)[None, :]
            ang = np.minimum(j, k[:, None]) * (psi[fan] / k)[:, None]
            c, s_ = np.cos(ang), np.sin(ang)
            m0 = me[fan]
            tau = np.stack((c * m0[:, :1] - s_ * m0[:, 1:], s_ * m0[:, :1] + c * m0[:, 1:]), axis=-1)
            g = np.einsum("ijk,ik->ij", tau, q[fan]).max(axis=1)
            np.minimum.at(delta, pi[fan], g)
        if spike.any():
            ang = np.arange(2 * S.CAP_PIECES) * (np.pi / S.CAP_PIECES)
            tau = np.column_stack((np.cos(ang), np.sin(ang)))
            g = (q[spike] @ tau.T).max(axis=1)
            np.minimum.at(delta, pi[spike], g)
    return np.where(inside, f.mu(-delta), f.mu(delta))


def _mu_stadiums(fz, p: np.ndarray) -> np.ndarray:
    """The largest α at which some edge's stadium holds the point: for each edge, the most any
    of its two vertices' functions grants at the stadium's gauge, inward or outward."""
    sf = fz.safe
    V, nxt, fm = sf["V"], sf["next"], sf["fm"]
    reach = max(max(fz.table[int(k)].support_in, fz.table[int(k)].support_out) for k in np.unique(fm))
    reach = reach / np.cos(np.pi / (2 * S.CAP_PIECES)) * (1 + 1e-9)
    mu = np.zeros(len(p))
    pi, e = _pairs(fz, p, reach)
    if not len(pi):
        return mu
    a, b, t, n, length = _frame(V, nxt, e)
    q = p[pi] - a
    gauge = np.abs(np.einsum("ij,ij->i", q, n))
    ang = np.arange(1, S.CAP_PIECES) * (np.pi / S.CAP_PIECES)  # the caps' slanted tangents
    c, s_ = np.cos(ang), np.sin(ang)
    qb = p[pi] - b
    for ci, si in zip(c, s_):
        gauge = np.maximum(gauge, np.einsum("ij,ij->i", qb, -n * ci + t * si))
        gauge = np.maximum(gauge, np.einsum("ij,ij->i", q, n * ci - t * si))
    for v in (e, nxt[e]):
        for k in np.unique(fm[v]):
            sel = fm[v] == k
            f = fz.table[int(k)]
            g = np.maximum(f.mu(-gauge[sel]), f.mu(gauge[sel]))
            np.maximum.at(mu, pi[sel], g)
    return mu
