"""An analytic check of the safe α-cut's promise, independent of GEOS's arcs: inner(α) ⊆ crisp ⊖ d_in(α)
and outer(α) ⊇ crisp ⊕ d_out(α), half-edge by half-edge with each vertex's own function and side.

If a point p inside inner lay closer than its distance to a crisp half-edge h, the segment from p to
the nearest point of h would leave inner through its boundary at a point c closer still, and on the
same side of h's ring (the open segment from p to c stays inside the crisp map, so it crosses no
ring). So it suffices that every boundary segment of inner keeps its side's distance from every
half-edge, and inner ⊆ crisp; likewise outside outer, with crisp ⊆ outer.
"""

from __future__ import annotations

import numpy as np
import shapely


def half_edges(fz, alpha: float):
    """(segments (k, 2, 2), ring index, d_in, d_out) of every half-edge: each edge split at its
    middle, each half with its own vertex's distances at α (as the exact method splits them)."""
    s = fz.stack
    V, nxt, fm = s["V"], s["next"], s["fm"]
    mid = 0.5 * (V + V[nxt])
    segs = np.concatenate((np.stack((V, mid), 1), np.stack((mid, V[nxt]), 1)))
    own = np.concatenate((np.arange(len(V)), nxt))
    d_in = fz.table.d_in(fm[own], alpha)
    d_out = fz.table.d_out(fm[own], alpha)
    ring = np.concatenate((s["ring_of"], s["ring_of"]))
    return segs, ring, d_in, d_out


def boundary_segments(geom) -> np.ndarray:
    b = shapely.boundary(geom)
    if b is None or b.is_empty:
        return np.zeros((0, 2, 2))
    xy, part = shapely.get_coordinates(shapely.get_parts(b), return_index=True)
    link = part[1:] == part[:-1]
    return np.stack((xy[:-1][link], xy[1:][link]), axis=1)


def violations(fz, alpha: float, geom, tol: float) -> float:
    """The largest shortfall (how much closer than its distance) of any boundary segment of geom
    to any crisp half-edge, on the side of the half-edge's ring the segment lies; 0 if none."""
    segs, ring, d_in, d_out = half_edges(fz, alpha)
    reach = float(max(d_in.max(), d_out.max()))
    bs = boundary_segments(geom)
    if not len(bs) or reach <= 0:
        return 0.0
    blines = shapely.linestrings(bs)
    hlines = shapely.linestrings(segs)
    i, j = shapely.STRtree(hlines).query(blines, predicate="dwithin", distance=reach)
    if not len(i):
        return 0.0
    mid = 0.5 * (bs[i, 0] + bs[i, 1])
    inside = shapely.contains_xy(fz.ring_polygons[ring[j]], mid[:, 0], mid[:, 1])
    need = np.where(inside, d_in[j], d_out[j])
    dist = shapely.distance(blines[i], hlines[j])
    short = need - dist
    return float(max(0.0, short.max()))


def check_cut(fz, cut, tol: float) -> None:
    """Assert the containment of the safe cut (inner in crisp ⊖, outer holds crisp ⊕) within tol."""
    crisp = fz.crisp_geometry
    perimeter = float(shapely.length(crisp))
    assert shapely.difference(cut.inner, crisp).area <= tol * perimeter
    assert shapely.difference(crisp, cut.outer).area <= tol * perimeter
    assert violations(fz, cut.alpha, cut.inner, tol) <= tol, "inner reaches into the exact band"
    assert violations(fz, cut.alpha, cut.outer, tol) <= tol, "outer leaves out part of the exact band"
