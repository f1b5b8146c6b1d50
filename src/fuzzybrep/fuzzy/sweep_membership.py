"""μ of the sweep's fuzzy boundary (thesis 2.1.3, 4.1.2): the largest α whose band still covers a
point, in closed form along each swept edge, by bisection where a band folds or its ends carry
different functions.

Functions of a ``FuzzyBRepMap`` (``fz``), which caches the bands (``fz.bands``).
"""

from __future__ import annotations

import numpy as np
import shapely

from .sweep import band_parameter, folded_bands, in_hull


def bands(fz) -> dict:
    """Every edge's inner and outer band (crisp edge to support edge), with an STRtree of boxes."""
    s = fz.stack
    V, nxt = s["V"], s["next"]
    vin = np.vstack([ln.vin for ln in fz.lines])
    vout = np.vstack([ln.vout for ln in fz.lines])
    si = s["SI"]
    so = np.concatenate([ln.support_out for ln in fz.lines])
    c0 = np.concatenate((V, V))
    c1 = np.concatenate((V[nxt], V[nxt]))
    a0 = np.concatenate((vin - V, vout - V))
    a1 = np.concatenate((vin[nxt] - V[nxt], vout[nxt] - V[nxt]))
    n = len(V)
    side = np.repeat([1, -1], n)  # +1: IN band, −1: OUT band
    ring = np.concatenate((s["ring_of"], s["ring_of"]))
    fm0 = np.concatenate((s["fm"], s["fm"]))
    fm1 = np.concatenate((s["fm"][nxt], s["fm"][nxt]))
    folded = folded_bands(c0, c1, a0, a1, s["own"][ring] * side)
    corners = np.stack((c0, c1, c0 + a0, c1 + a1), axis=1)
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    tree = shapely.STRtree(shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1]))
    shell = np.concatenate((s["shell"], s["shell"]))
    region_of_ring = np.repeat(np.arange(len(fz.crisp.regions)), [len(r.rings) for r in fz.crisp.regions])
    ring_polys = fz.ring_polygons
    region_polys = np.array([r.to_shapely() for r in fz.crisp.regions], dtype=object)
    shapely.prepare(region_polys)
    return {"c0": c0, "c1": c1, "a0": a0, "a1": a1, "tree": tree, "side": side, "ring": ring,
            "region": region_of_ring[ring], "shell": shell, "fm0": fm0, "fm1": fm1,
            "D0": np.concatenate((si, so)), "D1": np.concatenate((si[nxt], so[nxt])),
            "closed_form": (fm0 == fm1) & ~folded, "ring_polys": ring_polys, "region_polys": region_polys}


def membership_sweep(fz, p: np.ndarray) -> np.ndarray:
    """μ(p) = sup{α : p in the band outer(α) − inner(α)} of the sweep's α-cuts.

    A point in the crisp free space (closed) is in the band at α iff some IN band of its
    region's principal polygon, or OUT band of one of its holes, covers it at α; a point
    outside, iff some OUT band of a principal polygon it is outside of, or IN band of the
    hole it is in, does. Each band covers at α the hull of its crisp edge and its α-cut
    edge (``sweep.swept_hulls``), so μ is the largest α at which a band still covers p.
    """
    B = fz.bands
    x, y = p[:, 0], p[:, 1]
    pi, bi = B["tree"].query(shapely.points(p))
    mu = np.zeros(len(p))
    if len(pi) == 0:
        return mu
    in_crisp = shapely.intersects_xy(fz.crisp_geometry, x, y)[pi]
    free_side = (B["side"][bi] > 0) == B["shell"][bi]  # principal IN or hole OUT
    ok = np.zeros(len(pi), bool)
    a = in_crisp & free_side
    ok[a] = shapely.intersects_xy(B["region_polys"][B["region"][bi[a]]], x[pi[a]], y[pi[a]])
    b = ~in_crisp & ~free_side
    inside_ring = shapely.intersects_xy(B["ring_polys"][B["ring"][bi[b]]], x[pi[b]], y[pi[b]])
    ok[b] = np.where(B["shell"][bi[b]], ~inside_ring, inside_ring)
    pi, bi = pi[ok], bi[ok]
    val = np.full(len(pi), np.nan)
    cf = B["closed_form"][bi]
    if cf.any():
        i, b = pi[cf], bi[cf]
        u = band_parameter(p[i], B["c0"][b], B["c1"][b], B["a0"][b], B["a1"][b])
        xs = -B["side"][b] * u * B["D0"][b]  # signed distance: negative IN
        m = np.full(len(b), np.nan)
        fm = B["fm0"][b]
        for k in np.unique(fm):
            sel = (fm == k) & np.isfinite(xs)
            m[sel] = fz.table[int(k)].mu(xs[sel])
        val[cf] = m
    if (~cf).any():
        val[~cf] = hull_levels(fz, p[pi[~cf]], bi[~cf])
    good = np.isfinite(val)
    np.maximum.at(mu, pi[good], val[good])
    return np.clip(mu, 0.0, 1.0)


def d_at(fz, fm: np.ndarray, side: np.ndarray):
    """d(α) per pair: d_in on IN bands, d_out on OUT ones, each pair's function from ``fm``.

    Groups by function once; the returned function of α (one per pair) is what bisection calls.
    """
    groups = []
    for k in np.unique(fm):
        sel = fm == k
        groups.append((sel, side[sel] > 0, fz.table[int(k)]))

    def d(alpha: np.ndarray) -> np.ndarray:
        out = np.empty(len(fm))
        for sel, inward, f in groups:
            out[sel] = np.where(inward, f.d_in(alpha[sel]), f.d_out(alpha[sel]))
        return out

    return d


def hull_levels(fz, p: np.ndarray, b: np.ndarray, iterations: int = 45) -> np.ndarray:
    """Largest α at which band b's swept hull still holds p, by bisection (NaN if not at α = 0).

    For bands that fold over, or whose ends carry different functions: no closed form, but
    the hull shrinks as α grows, so bisection on α is exact to 2^−45. Vectorised over pairs.
    """
    B = fz.bands
    c0, c1, a0, a1, side = B["c0"][b], B["c1"][b], B["a0"][b], B["a1"][b], B["side"][b]
    D0, D1 = B["D0"][b], B["D1"][b]
    d0, d1 = d_at(fz, B["fm0"][b], side), d_at(fz, B["fm1"][b], side)

    def holds(alpha):
        p0 = c0 + a0 * (d0(alpha) / D0)[:, None]
        p1 = c1 + a1 * (d1(alpha) / D1)[:, None]
        return in_hull(p, np.stack((c0, c1, p1, p0), axis=1))

    lo, hi = np.zeros(len(p)), np.ones(len(p))
    start = holds(lo)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        h = holds(mid)
        lo = np.where(h, mid, lo)
        hi = np.where(h, hi, mid)
    return np.where(start, lo, np.nan)