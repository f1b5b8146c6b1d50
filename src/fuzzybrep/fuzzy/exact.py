"""The exact fuzzification by the Extension principle (thesis 2.1.4): μ is the membership function
of the signed distance to the crisp boundary, and its α-cuts are the crisp map buffered with round
joins (GEOS), edge by edge where the distances differ.

Functions of a ``FuzzyBRepMap`` (``fz``), which caches what they share (``fz.edge_groups``).
"""

from __future__ import annotations

import numpy as np
import shapely

from ..geometry import clean, segment_distance
from .sweep_cut import SMALL_RING

#: arcs of the exact α-cuts: segments per quarter circle (GEOS buffer's quad_segs)
EXACT_QUAD_SEGS = 32
#: union of many polygons: GEOS's disjoint-subset union (3.12 on) first splits them into groups
#: apart from each other, as the buffered holes of a map mostly are (20× faster than the cascaded
#: union on the jagged benchmark floor, 1.3-2× on Freiburg 079); the same result
_union_all = shapely.disjoint_subset_union_all if shapely.geos_version >= (3, 12, 0) else shapely.union_all


def edge_groups(fz) -> list[dict]:
    """Crisp edges grouped by (membership function, ring role), for the exact method.

    An edge whose two vertices carry different functions is split at its middle, each half
    taking its vertex's function.
    """
    s = fz.stack
    V, fm, nxt = s["V"], s["fm"], s["next"]
    a, b, mid = V, V[nxt], 0.5 * (V + V[nxt])
    same = fm == fm[nxt]
    segs = np.concatenate((np.stack((a, b), 1)[same], np.stack((a, mid), 1)[~same], np.stack((mid, b), 1)[~same]))
    seg_fm = np.concatenate((fm[same], fm[~same], fm[nxt][~same]))
    seg_shell = np.concatenate((s["shell"][same], s["shell"][~same], s["shell"][~same]))
    seg_ring = np.concatenate((s["ring_of"][same], s["ring_of"][~same], s["ring_of"][~same]))
    groups = []
    for k in np.unique(seg_fm):
        for shell in (True, False):
            sel = (seg_fm == k) & (seg_shell == shell)
            if sel.any():
                lines = shapely.linestrings(segs[sel])
                groups.append({"fm": int(k), "shell": shell, "a": segs[sel][:, 0], "b": segs[sel][:, 1],
                               "ring": seg_ring[sel], "lines": lines, "tree": shapely.STRtree(lines)})
    return groups


def cut_distances(fz, alpha: float) -> tuple[list, list]:
    """(symmetric, sided): the α-cut's distances per edge group, (group, d) for a symmetric
    function, (group, d_in, d_out) for an asymmetric one."""
    symmetric, sided = [], []
    for g in fz.edge_groups:
        f = fz.table[g["fm"]]
        # GEOS buffers at a distance near rounding (α → 1) can come back perturbed by more
        # than the distance (precision-reduction fallback)
        d_in, d_out = float(fz.offset(f.d_in(alpha))), float(fz.offset(f.d_out(alpha)))
        if f.symmetric:  # d_in = d_out
            symmetric.append((g, d_in))
        else:
            sided.append((g, d_in, d_out))
    return symmetric, sided


def exact_cut(fz, alpha: float, quad_segs: int = EXACT_QUAD_SEGS) -> tuple[shapely.Geometry, shapely.Geometry]:
    """(inner, outer) of the exact α-cut: the crisp map buffered by ∓d(α), or minus and plus the
    band edge by edge where the distances differ (``exact_band``)."""
    crisp = fz.crisp_geometry
    symmetric, sided = cut_distances(fz, alpha)
    ds = {d for _, d in symmetric}
    if sided or len(ds) > 1:
        return exact_band(fz, crisp, symmetric, sided, quad_segs)
    d = ds.pop()
    if d == 0.0:
        return crisp, crisp
    return buffered(fz, -d, quad_segs), buffered(fz, d, quad_segs)


def exact_band(fz, crisp, symmetric: list, sided: list, quad_segs: int) -> tuple:
    """Inner and outer exact cuts when the distances differ (several functions, or an
    asymmetric one): crisp map minus and plus the band {p : μ(p) ≥ α}, built edge by edge.

    An edge's band reaches d_in(α) into the inside of its own ring and d_out(α) out of it.
    That is not the free space's side everywhere: a point in a hole near the principal
    polygon's wall is inside the principal ring (IN for that wall), a point of another piece
    of explored space lying in a hole is inside that hole's ring. Buffering the crisp map by
    −d and +d sides every boundary by the free space, so it is used only when one symmetric
    distance applies (``_buffered``).

    Every edge is buffered alone (one vectorised call) and the buffers are united once:
    GEOS buffering a MultiLineString of a map's edges nodes all their curves together, which
    took 40-170 s on Freiburg 079 (the union: 3-5 s). Their union is the MultiLineString's
    buffer, round caps at every vertex; rings buffered whole would have joins there instead,
    whose arcs differ (by 5e-6 of the map's area on Intel).
    """
    parts = [shapely.buffer(g["lines"], d, quad_segs=quad_segs) for g, d in symmetric if d > 0]
    polys = fz.ring_polygons
    for g, d_in, d_out in sided:
        if d_in == d_out == 0.0:
            continue
        # both sides to the smaller distance, then the wider side on its own: cut by the ring,
        # so that the crisp edges (where the cut runs) lie inside the band, never on its
        # boundary (GEOS overlays of polygons sharing edges were seen to go wrong)
        if min(d_in, d_out) > 0:
            parts.append(shapely.buffer(g["lines"], min(d_in, d_out), quad_segs=quad_segs))
        wide = shapely.buffer(g["lines"], max(d_in, d_out), quad_segs=quad_segs)
        cut = shapely.intersection if d_in > d_out else shapely.difference
        # short rings: each edge's buffer cut by its ring's polygon, all in one call; long
        # ones united first and cut once (edge by edge, a ring of n edges cost n overlays
        # with its whole polygon: 24 s at 20 000 vertices)
        ring = g["ring"]
        long = np.bincount(ring)[ring] > SMALL_RING
        parts.append(cut(wide[~long], polys[ring[~long]]))
        for k in np.unique(ring[long]):
            parts.append(np.array([cut(_union_all(wide[ring == k]), polys[k])], dtype=object))
    if not parts:
        return crisp, crisp
    band = _union_all(np.concatenate(parts))
    return clean(shapely.difference(crisp, band)), clean(shapely.union(crisp, band))


def buffered(fz, d: float, quad_segs: int) -> shapely.Geometry:
    """The crisp map buffered by d with round joins (d < 0 erodes it, d > 0 dilates it), ring
    by ring: the geometry of ``shapely.buffer(crisp_geometry, d)``, 6-12× faster on the real
    maps (thousands of holes).

    GEOS nodes the offset curves of all a polygon's rings together, which grows faster than
    linearly with the number of holes (3.5 s on Freiburg 079's 2977). A disc distributes over
    the rings instead. For a region F = P − ∪H_i (principal polygon P, holes H_i inside it
    that meet each other or P's ring at points at most)

        erosion(F, d)  = erosion(P, d) − ∪ dilation(H_i, d)    a disc in F misses every hole
        dilation(F, d) = dilation(P, d) − ∪ erosion(H_i, d)    a disc in ∪H_i lies in one H_i

    and the regions, apart but for points, erode and dilate one by one: the map's erosion and
    dilation are the unions of theirs. So every ring's polygon is buffered alone, all in one
    vectorised call (most small holes vanish when eroded), and each region takes one union
    of its holes and one difference.
    """
    s = fz.stack
    shell = s["shell"][s["start"]]
    rings = shapely.buffer(s["ring_polys"], np.where(shell, d, -d), quad_segs=quad_segs)
    pieces, k = [], 0
    for region in fz.crisp.regions:
        principal, holes = rings[k], rings[k + 1:k + len(region.rings)]
        k += len(region.rings)
        holes = holes[~shapely.is_empty(holes)]
        if len(holes) and not principal.is_empty:
            principal = shapely.difference(principal, _union_all(holes))
        pieces.append(principal)
    # the dilations of regions can overlap (a piece of explored space inside a hole)
    return clean(pieces[0] if len(pieces) == 1 else _union_all(pieces))


def membership_exact(fz, p: np.ndarray) -> np.ndarray:
    x, y = p[:, 0], p[:, 1]
    inside = shapely.contains_xy(fz.crisp_geometry, x, y)
    mu = np.zeros(len(p))
    for g in fz.edge_groups:
        f = fz.table[g["fm"]]
        reach = max(f.support_in, f.support_out)  # beyond it μ = 0: look no further
        pi, si = g["tree"].query(shapely.box(x - reach, y - reach, x + reach, y + reach))
        dist = np.full(len(p), np.inf)
        pair = segment_distance(p[pi], g["a"][si], g["b"][si])
        if not f.symmetric:
            # x < 0 inside the edge's own ring, which is not always the free space's side of
            # it (a point in a hole near the principal polygon's wall is inside the principal
            # ring): nearest edge on each side, each through its own half of the function
            own = shapely.intersects_xy(fz.ring_polygons[g["ring"][si]], p[pi, 0], p[pi, 1])
            d_in = np.full(len(p), np.inf)
            np.minimum.at(d_in, pi[own], pair[own])
            np.minimum.at(dist, pi[~own], pair[~own])
            mu = np.maximum(mu, np.maximum(f.mu(-d_in), f.mu(dist)))
            continue
        np.minimum.at(dist, pi, pair)
        # IN of a principal polygon is the free space; IN of a hole is the obstacle (for a
        # symmetric function the side does not change μ)
        mu = np.maximum(mu, f.mu(np.where(inside == g["shell"], -dist, dist)))
    return mu