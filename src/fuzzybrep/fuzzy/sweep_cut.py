"""α-cuts by the thesis's sweep (single normal vertex method, thesis 4.1.2): the offset vertices
read from the parametric lines in O(n), then made proper, all rings at once.

Functions of a ``FuzzyBRepMap`` (``fz``), which caches what they share (``fz.stack``).
"""

from __future__ import annotations

import numpy as np
import shapely

from ..geometry import clean, free_space
from .sweep import folded_bands, proper_polygon

#: rings of at most this many vertices are made proper in one vectorised GEOS pass
SMALL_RING = 64


def offset_vertices(fz, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Read the α-cut's vertices from the parametric lines: O(n) array operations, no GEOS.

    Returns (shrink, grow), both (N, 2) over all rings stacked in ``crisp.rings`` order:
    ``shrink`` bounds the inner polygons (principal IN, holes OUT), ``grow`` the outer ones
    (principal OUT, holes IN). The point at inward distance d is at t = 1 − d/support_in,
    at outward distance d at t = 1 + d/support_in (module ``sweep``).
    """
    s = fz.stack
    d_in = fz.table.d_in(s["fm"], alpha)
    d_out = fz.table.d_out(s["fm"], alpha)
    # no offset within rounding: a ring moved by an ulp or two made GEOS take outer − inner
    # for the whole map
    d_in, d_out = fz.offset(d_in), fz.offset(d_out)
    t_shrink = np.where(s["shell"], 1.0 - d_in / s["SI"], 1.0 + d_out / s["SI"])
    t_grow = np.where(s["shell"], 1.0 + d_out / s["SI"], 1.0 - d_in / s["SI"])
    # x = U + T·t, y = W + V·t, evaluated as X + T·(t − 1) so that t = 1 is the crisp vertex
    return s["V"] + s["TV"] * (t_shrink - 1.0)[:, None], s["V"] + s["TV"] * (t_grow - 1.0)[:, None]


def proper_all(fz, pts: np.ndarray, grow: bool) -> list:
    """Proper polygon of every ring's offset, vectorised over rings.

    ``grow`` False: principal polygons IN, holes OUT; True: principal OUT, holes IN. Rings
    whose offset is simple, wound like the crisp ring and unfolded (the usual case) are
    their offset polygons; the others are their crisp polygon minus (IN) or plus (OUT) the
    swept hulls of their bands: small rings all in one GEOS pass, long ones strip by strip
    (``sweep.proper_polygon``).
    """
    s = fz.stack
    side = np.where(s["shell"] != grow, 1, -1)  # per vertex: +1 IN, −1 OUT
    rings = shapely.linearrings(pts[s["closed"]], indices=s["closed_ring"])
    simple = shapely.is_simple(rings)
    x, y = pts[:, 0], pts[:, 1]
    nxt = s["next"]
    area = 0.5 * np.add.reduceat(x * y[nxt] - x[nxt] * y, s["start"])
    own = s["own"]
    V = s["V"]
    folds = folded_bands(V, V[nxt], pts - V, pts[nxt] - V[nxt], own[s["ring_of"]] * side)
    folded = np.bincount(s["ring_of"], weights=folds, minlength=len(rings)) > 0
    # a ring collapsed to (almost) nothing is not a polygon: it goes the slow way and vanishes
    extent = np.maximum(np.maximum.reduceat(x, s["start"]) - np.minimum.reduceat(x, s["start"]),
                        np.maximum.reduceat(y, s["start"]) - np.minimum.reduceat(y, s["start"]))
    ok = simple & (area * own > 1e-12 * extent * extent) & ~folded
    polys = np.empty(len(rings), dtype=object)
    polys[ok] = shapely.polygons(rings[ok])
    slow = np.flatnonzero(~ok)
    small = slow[s["sizes"][slow] <= SMALL_RING]
    if len(small):
        polys[small] = swept_small(fz, pts, small, side[s["start"][small]])
    for k in slow[s["sizes"][slow] > SMALL_RING]:
        a, n = s["start"][k], s["sizes"][k]
        polys[k] = proper_polygon(V[a:a + n], pts[a:a + n], int(own[k]), int(side[a])).geometry
    return list(polys)


def swept_small(fz, pts: np.ndarray, rings: np.ndarray, side: np.ndarray) -> np.ndarray:
    """Proper polygons of short rings: crisp polygon ∓ the union of their bands' swept regions.

    As in ``sweep.proper_polygon``: each run of unfolded bands is one strip polygon when
    valid (else its bands' hulls), each folded band its convex hull; one row of an array per
    ring, reduced by GEOS without a Python loop over rings.
    """
    s = fz.stack
    V, nxt = s["V"], s["next"]
    own = s["own"][rings]
    sizes = s["sizes"][rings]
    starts = s["start"][rings]
    ring_row = np.repeat(np.arange(len(rings)), sizes)
    local = np.arange(sizes.sum()) - np.repeat(np.cumsum(sizes) - sizes, sizes)
    band = np.repeat(starts, sizes) + local
    folds = folded_bands(V[band], V[nxt[band]], pts[band] - V[band], pts[nxt[band]] - V[nxt[band]],
                         np.repeat(own * side, sizes))
    # rotate every ring to start just after its first folded band, so no run wraps around
    first = np.full(len(rings), 0)
    has = np.bincount(ring_row, weights=folds, minlength=len(rings)) > 0
    idx_first = np.flatnonzero(folds)
    first_of = np.full(len(rings), np.iinfo(np.int64).max)
    np.minimum.at(first_of, ring_row[idx_first], local[idx_first])
    first[has] = first_of[has] + 1
    rot = np.repeat(starts, sizes) + (local + np.repeat(first, sizes)) % np.repeat(sizes, sizes)
    good = ~folds[np.searchsorted(band, rot)]  # band is increasing: position of each rotated band
    # rings without any fold (self-intersecting or inverted offsets): bands one by one
    good &= np.repeat(has, sizes)
    prev_good = np.r_[False, good[:-1]] & (np.r_[-1, ring_row[:-1]] == ring_row)
    run = np.cumsum(good & ~prev_good) - 1
    run = np.where(good, run, -1)
    parts_row, parts = [], []
    if (run >= 0).any():
        g = np.flatnonzero(run >= 0)
        rid = run[g]
        nrun = rid.max() + 1
        length = np.bincount(rid, minlength=nrun)
        b0 = rot[g]  # bands of every run, in order
        last = np.cumsum(length) - 1
        end_vertex = nxt[b0[last]]
        # strip: crisp starts of its bands, the end vertex, offsets back, closing vertex
        crisp_idx = np.insert(b0, last + 1, end_vertex)
        crisp_run = np.insert(rid, last + 1, np.arange(nrun))
        offs_idx, offs_run = crisp_idx[::-1], crisp_run[::-1]
        order = np.argsort(np.concatenate((crisp_run, offs_run)), kind="stable")
        vidx = np.concatenate((crisp_idx, offs_idx))[order]
        from_off = np.concatenate((np.zeros(len(crisp_idx), bool), np.ones(len(offs_idx), bool)))[order]
        vrun = np.concatenate((crisp_run, offs_run))[order]
        coords = np.where(from_off[:, None], pts[vidx], V[vidx])
        heads = np.searchsorted(vrun, np.arange(nrun))
        coords = np.insert(coords, np.r_[heads[1:], len(coords)], coords[heads], axis=0)
        vrun = np.insert(vrun, np.r_[heads[1:], len(vrun)], np.arange(nrun))
        strips = shapely.polygons(shapely.linearrings(coords, indices=vrun))
        run_ring = ring_row[g][np.searchsorted(rid, np.arange(nrun))]
        x, y = coords[:, 0], coords[:, 1]
        cross = np.append(x[:-1] * y[1:] - x[1:] * y[:-1], 0.0)
        cstart = np.searchsorted(vrun, np.arange(nrun))
        cend = np.r_[cstart[1:], len(coords)] - 1
        area = 0.5 * (np.add.reduceat(cross, cstart) - cross[cend])
        fine = shapely.is_valid(strips) & (area * (own * side)[run_ring] > 0)
        parts_row.append(run_ring[fine])
        parts.append(strips[fine])
        good &= ~np.isin(run, np.flatnonzero(~fine))
    h = ~good
    hb = rot[h]
    hulls = shapely.convex_hull(shapely.multipoints(np.stack((V[hb], V[nxt[hb]], pts[nxt[hb]], pts[hb]), axis=1)))
    parts_row.append(ring_row[h])
    parts.append(hulls)
    prow = np.concatenate(parts_row)
    pgeo = np.concatenate(parts)
    order = np.argsort(prow, kind="stable")
    prow, pgeo = prow[order], pgeo[order]
    col = np.arange(len(prow)) - np.searchsorted(prow, prow)
    table = np.full((len(rings), (col.max() + 2) if len(col) else 1), None, dtype=object)
    table[prow, col + 1] = pgeo
    base = s["ring_polys"][rings]
    grow = side < 0
    table[grow, 0] = base[grow]  # one n-ary union with the crisp polygon (see proper_polygon)
    swept = shapely.union_all(table, axis=1)
    out = np.where(grow, swept, None)
    out[~grow] = shapely.difference(base[~grow], swept[~grow])
    # slivers and collapsed pieces of the overlays would confuse the ones that follow
    x0, y0 = pts.min(axis=0)
    x1, y1 = pts.max(axis=0)
    tiny = 1e-12 * max(x1 - x0, y1 - y0) ** 2
    bad = (shapely.get_num_geometries(out) > 1) | (shapely.get_num_interior_rings(shapely.get_geometry(out, 0)) > 0)
    bad |= ~shapely.is_valid(out) | (shapely.area(out) <= tiny)
    for r in np.flatnonzero(bad):
        out[r] = clean(out[r], tiny)
    return out


def combine(fz, polys: list, disjoint_holes: bool = False) -> shapely.Geometry:
    shells, holes, k = [], [], 0
    for region in fz.crisp.regions:
        shells.append(polys[k])
        holes.append(polys[k + 1:k + 1 + len(region.holes)])
        k += 1 + len(region.holes)
    return free_space(shells, holes, disjoint_holes)


def sweep_cut(fz, alpha: float) -> tuple[shapely.Geometry, shapely.Geometry]:
    """(inner, outer) of the sweep's α-cut: read from the parametric lines and made proper."""
    shrink, grow = offset_vertices(fz, alpha)
    inner = combine(fz, proper_all(fz, shrink, grow=False))
    # shrunk holes stay inside their crisp holes, which do not overlap: no union needed
    outer = combine(fz, proper_all(fz, grow, grow=True), disjoint_holes=True)
    return inner, outer
