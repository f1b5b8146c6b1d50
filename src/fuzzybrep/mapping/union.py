"""The crisp B-rep map from scan polygons: their union, and the vertex reduction (thesis 3.2.2,
3.2.3).

GEOS unites all scan polygons at once, on both cores; the boundaries are then simplified within
a tolerance tied to TME (thesis 5.3), keeping topology, and pieces and holes too small to bound
anything the map can resolve are dropped.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import shapely

from ..geometry import polygonal


def union(polygons, simplify: float = 0.0) -> shapely.Geometry:
    """Union of scan polygons (thesis 3.2.2, 3.2.3), by GEOS's cascaded union.

    Uniting all at once gives the same set as uniting them one after another into the map, in
    any order, but in O(n log n) instead of O(n²). Holes form where the union encloses space no
    scan saw free. Each polygon is first simplified within ``simplify`` (topology kept), if given.
    """
    polys = np.asarray(polygons, dtype=object)

    def valid(part):
        bad = ~shapely.is_valid(part)
        if bad.any():
            part = part.copy()
            part[bad] = shapely.make_valid(part[bad])
        return part

    def unite(part):
        # simplifying and checking go polygon by polygon, so each part's worker does its own
        part = valid(part)
        if simplify > 0:
            # plain Douglas-Peucker, five times faster than the topology-preserving one (0.28 s
            # against 1.4 s for Freiburg's 4791 polygons). Given valid polygons only: GEOS mends
            # what it makes invalid by buffer(0), which drops a lobe of an invalid input
            part = valid(shapely.simplify(part, simplify, preserve_topology=False))
        return shapely.union_all(part)

    workers = os.cpu_count() or 1
    if workers > 1 and len(polys) >= 64:
        # GEOS releases the GIL: unite parts on every core, then unite the parts
        with ThreadPoolExecutor(workers) as ex:
            polys = np.array(list(ex.map(unite, np.array_split(polys, workers))), dtype=object)
        return polygonal(shapely.union_all(polys))
    return polygonal(unite(polys))


def clean(geom, min_piece_area: float = 0.0, min_hole_area: float = 0.0, simplify: float = 0.0):
    """Drop pieces and holes below the given areas, then simplify boundaries within ``simplify``.

    Simplification keeps topology (no boundary crosses another, no hole leaves its shell:
    ``simplify_rings``), so it never merges a hole into the shell or turns a piece invalid. It
    can squash a tiny hole into a needle with (almost) no area: holes under a tenth of the
    tolerance squared bound nothing the map can resolve.
    """
    g = _drop_small(polygonal(geom), min_piece_area, min_hole_area)
    if simplify > 0 and not g.is_empty:
        g = simplify_rings(g, simplify)
        # (s/10)², written s/10 * s/10: a float's ** raises OverflowError (--simplify 1e300) where * gives inf
        g = _drop_small(g, min_piece_area, max(min_hole_area, simplify / 10 * (simplify / 10)))
    return g


def threaded(fn, geoms: np.ndarray, workers: int | None = None) -> np.ndarray:
    """``fn`` (a vectorised Shapely call, which releases the GIL) of ``geoms`` on every core: the
    array cut into one part a core of about equal vertices, the parts' answers joined in order."""
    workers = workers or os.cpu_count() or 1
    if workers < 2 or len(geoms) < 64:
        return fn(geoms)
    cum = np.cumsum(shapely.get_num_coordinates(geoms))
    parts = np.split(geoms, np.searchsorted(cum, cum[-1] * np.arange(1, workers) / workers))
    with ThreadPoolExecutor(workers) as ex:
        return np.concatenate(list(ex.map(fn, parts)))


def simplify_rings(geom, tolerance: float):
    """The (Multi)Polygon ``geom`` with every ring reduced within ``tolerance`` by GEOS's
    topology-preserving Douglas-Peucker, ring by ring, and the clashes between rings repaired.

    GEOS simplifies a polygon with all its holes at once by checking every candidate segment
    against every other ring (``ComponentJumpChecker``): quadratic in the holes, 24 s on a map
    with 29,000 of them. Ring by ring it is linear, and each ring stays simple; what that can
    break between rings is found with indexes (O(n log n)) and mended where it happened:

    * a reduced segment that crosses or touches another ring's (or a non-adjacent segment of its
      own ring), other than at a vertex both already shared, is split at the original vertex
      farthest from it: one more Douglas-Peucker step where the rings clash;
    * a ring that moved across another ring's vertex (a hole left its shell, or a shell its
      hole, without any crossing: a "jump") has its segments near that vertex split likewise.

    Repeated until nothing clashes (each step restores vertices of the original rings, which did
    not clash), the maps are those GEOS gives whole (Freiburg 079: 0.1 % of the area moves, 0.7 %
    more vertices). A part that still comes out invalid (never seen) is simplified by GEOS whole.
    """
    parts = shapely.get_parts(polygonal(geom))
    if not len(parts):
        return shapely.MultiPolygon()
    rings, owner = shapely.get_rings(parts, return_index=True)
    reduced = threaded(lambda a: shapely.simplify(a, tolerance, preserve_topology=True), shapely.polygons(rings))
    xy, ring = _ring_vertices(rings)
    start = np.searchsorted(ring, np.arange(len(rings)))
    size = np.diff(np.r_[start, len(ring)])
    kept = _kept(xy, ring, *_ring_vertices(shapely.get_exterior_ring(reduced)))
    # one vertex of every ring, kept by the reduction (so the same point before and after), and
    # which rings hold which of these points strictly inside, originally and reduced
    n = len(rings)
    first = np.flatnonzero(kept)[np.r_[True, ring[kept][1:] != ring[kept][:-1]]]
    points = shapely.points(xy[first])
    point_tree = shapely.STRtree(points)
    q, p = point_tree.query(shapely.polygons(rings), predicate="contains_properly")
    was_inside = np.sort(q * n + p)
    q, p = point_tree.query(reduced, predicate="contains_properly")
    jumps = np.setxor1d(was_inside, q * n + p)
    fresh = np.ones(len(xy), bool)  # vertices kept anew: the segments to check end at one
    for _ in range(len(xy)):  # each round keeps one vertex more at least: a bound, never reached
        v = np.flatnonzero(kept)
        r = ring[v]
        w = np.r_[v[1:], 0]  # each segment's far end: the next kept vertex of its ring
        last = np.r_[r[1:] != r[:-1], True]
        w[last] = v[np.searchsorted(r, r[last])]
        bad = _crossings(xy, v, w, r, fresh[v] | fresh[w])
        for code in jumps:  # a few a map
            q, p = divmod(int(code), n)
            seg = np.arange(np.searchsorted(r, q), np.searchsorted(r, q, side="right"))
            d = shapely.distance(shapely.linestrings(np.stack((xy[v[seg]], xy[w[seg]]), axis=1)), points[p])
            bad[seg[(d <= tolerance * 1.001) | (d == d.min())]] = True
        if not bad.any():
            break
        added, a, b = _split(xy, ring, start, size, v[bad], w[bad], tolerance)
        fresh[:] = False
        fresh[added] = True
        kept[added] = True
        jumps = _jumps(xy, ring, kept, points, point_tree, was_inside, a, added, b)
    out = shapely.polygons(shapely.linearrings(xy[kept], indices=ring[kept]))
    polys = shapely.polygons(shapely.get_exterior_ring(out), indices=owner)
    return polys[0] if len(polys) == 1 else shapely.MultiPolygon(list(polys))


def _jumps(xy, ring, kept, points, point_tree, was_inside, a, c, b) -> np.ndarray:
    """Codes q·n + p of rings q whose reduced form holds ring p's point inside where the original
    did not, or the other way round, after vertices c were put back between a and b: only a point
    inside a triangle (a, c, b) can have changed sides."""
    n = len(points)
    t, p = point_tree.query(shapely.polygons(np.stack((xy[a], xy[c], xy[b]), axis=1)), predicate="intersects")
    if not len(t):
        return np.zeros(0, np.int64)
    q = ring[c[t]]
    keep = q != p
    q, p = np.unique(np.c_[q[keep], p[keep]], axis=0).T if keep.any() else (q[:0], p[:0])
    which = np.unique(q)
    at = np.flatnonzero(kept & np.isin(ring, which))
    polys = shapely.polygons(shapely.linearrings(xy[at], indices=np.searchsorted(which, ring[at])))
    now = shapely.contains_properly(polys[np.searchsorted(which, q)], points[p])
    code = q * n + p
    return code[now != np.isin(code, was_inside)]


def _ring_vertices(rings) -> tuple[np.ndarray, np.ndarray]:
    """Every ring's vertices (without the closing repeat) and the ring each belongs to."""
    xy, ring = shapely.get_coordinates(rings, return_index=True)
    closing = np.r_[ring[1:] != ring[:-1], True]
    return xy[~closing], ring[~closing]


def _kept(xy, ring, rxy, rring) -> np.ndarray:
    """bool over the original vertices (xy, ring): those the reduced rings (rxy, rring) kept.
    A reduction only drops vertices, and a simple ring holds each point once."""
    key = np.rec.fromarrays([ring, xy[:, 0], xy[:, 1]])
    order = np.argsort(key, kind="stable")
    at = order[np.minimum(np.searchsorted(key[order], np.rec.fromarrays([rring, rxy[:, 0], rxy[:, 1]])), len(order) - 1)]
    kept = np.zeros(len(xy), bool)
    kept[at] = True
    return kept


def _crossings(xy, v, w, r, fresh) -> np.ndarray:
    """bool over the segments v→w (of ring r): those that meet a segment other than in a vertex
    both have, checked for the ``fresh`` segments (against all)."""
    segs = shapely.linestrings(np.stack((xy[v], xy[w]), axis=1))
    f = np.flatnonzero(fresh)
    i, j = shapely.STRtree(segs[f]).query(segs, predicate="intersects")
    j = f[j]
    # a segment meets itself and its neighbours along the ring at their shared ends
    keep = (i != j) & (w[i] != v[j]) & (w[j] != v[i])
    i, j = i[keep], j[keep]
    bad = np.zeros(len(v), bool)
    share = (v[i] == v[j]) | (v[i] == w[j]) | (w[i] == v[j]) | (w[i] == w[j])  # the same original vertex
    a, b = xy[v], xy[w]
    share |= (np.all(a[i] == a[j], 1) | np.all(a[i] == b[j], 1) | np.all(b[i] == a[j], 1) | np.all(b[i] == b[j], 1))
    # two rings touching at a vertex (a valid polygon's holes may): fine if that point is all they share
    touch = share.copy()
    if touch.any():
        touch[touch] = shapely.get_type_id(shapely.intersection(segs[i[touch]], segs[j[touch]])) == 0
        # and if they still only touch there: they cross at that vertex if the two edges of one
        # ring at it separate the two edges of the other
        k = np.flatnonzero(touch)
        touch[k] = ~_cross_at_vertex(xy, v, w, r, i[k], j[k])
    clash = ~touch
    bad[i[clash]] = True
    bad[j[clash]] = True
    return bad


def _cross_at_vertex(xy, v, w, r, i, j) -> np.ndarray:
    """bool per pair of segments i, j (v→w) that share an end point: the two rings cross there,
    the edges of i's ring at that point separating those of j's ring (angularly)."""
    first = np.r_[True, r[1:] != r[:-1]]
    last = np.r_[r[1:] != r[:-1], True]
    before, after = np.arange(len(v)) - 1, np.arange(len(v)) + 1
    before[first], after[last] = np.flatnonzero(last), np.flatnonzero(first)

    def edges(k, at):
        # the directions from ``at`` to its two neighbours along segment k's ring
        starts = np.all(xy[v[k]] == at, axis=1)
        prev = np.where(starts, v[before[k]], v[k])
        nxt = np.where(starts, w[k], w[after[k]])
        return [np.arctan2(*(xy[e] - at).T[::-1]) for e in (prev, nxt)]

    at = np.where(np.all(xy[v[i]] == xy[v[j]], 1)[:, None] | np.all(xy[v[i]] == xy[w[j]], 1)[:, None], xy[v[i]], xy[w[i]])
    a0, a1 = edges(i, at)
    b0, b1 = edges(j, at)
    arc = lambda x: (x - a0) % (2 * np.pi) < (a1 - a0) % (2 * np.pi)  # noqa: E731  strictly from a0 to a1, anticlockwise
    return arc(b0) != arc(b1)


def _split(xy, ring, start, size, a, b, tolerance):
    """Every reduced segment from original vertex a to b (along its ring) split at the original
    vertex between them farthest from it (none if a and b are adjacent), and each half then
    split further as Douglas-Peucker does until every original vertex lies within ``tolerance``
    of its segment. Returns the vertices put back and the ends (a, b) of the segment each split."""
    out = []
    must = True  # the clashing segments are split once whatever their vertices' distance
    while len(a):
        c, d, k = _farthest(xy, ring, start, size, a, b)
        if not must:
            c, k = c[d > tolerance], k[d > tolerance]
        must = False
        out.append((c, a[k], b[k]))
        a, b = np.r_[a[k], c], np.r_[c, b[k]]
    if not out:
        return np.zeros(0, np.int64), a, b
    return tuple(np.concatenate(x) for x in zip(*out))


def _farthest(xy, ring, start, size, a, b):
    """For segments a→b along their rings: the original vertex between a and b farthest from
    the segment, its distance, and the segment it belongs to (segments with none left out)."""
    rr = ring[a]
    la = a - start[rr]
    steps = (b - start[rr] - la) % size[rr]
    steps[steps == 0] = size[rr][steps == 0]
    m = steps - 1  # vertices between a and b
    seg = np.repeat(np.arange(len(a)), m)
    if not len(seg):
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64)
    off = np.arange(len(seg)) - np.repeat(np.cumsum(m) - m, m) + 1
    idx = start[rr][seg] + (la[seg] + off) % size[rr][seg]
    p, q, x = xy[a][seg], xy[b][seg], xy[idx]
    d = q - p
    length = np.hypot(d[:, 0], d[:, 1])
    cross = np.abs(d[:, 0] * (x[:, 1] - p[:, 1]) - d[:, 1] * (x[:, 0] - p[:, 0]))
    dist = np.where(length > 0, cross / np.where(length > 0, length, 1.0), np.hypot(*(x - p).T))
    order = np.lexsort((-dist, seg))
    top = order[np.r_[True, seg[order][1:] != seg[order][:-1]]]
    return idx[top], dist[top], seg[top]


def _drop_small(geom, min_piece_area: float, min_hole_area: float):
    """Pieces of at most min_piece_area and holes of at most min_hole_area removed, vectorised."""
    parts = shapely.get_parts(geom)
    parts = parts[shapely.area(parts) > min_piece_area] if len(parts) else parts
    if len(parts) == 0:
        return shapely.MultiPolygon()
    rings, owner = shapely.get_rings(parts, return_index=True)
    shell = np.r_[True, owner[1:] != owner[:-1]]
    keep = shell | (shapely.area(shapely.polygons(rings)) > min_hole_area)
    polys = shapely.polygons(rings[keep], indices=owner[keep])
    return polys[0] if len(polys) == 1 else shapely.MultiPolygon(list(polys))
