"""The crisp B-rep map from scan polygons: their union, and the vertex reduction (thesis 3.2.2,
3.2.3).

GEOS unites all scan polygons at once, on both cores; the boundaries are then simplified within
a tolerance tied to TME (thesis 5.3), keeping topology, and pieces and holes too small to bound
anything the map can resolve are dropped.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import shapely

from ..geometry import polygonal

#: what the union is computed with: Clipper2 (pyclipr), a pairwise tree of plain paths, or GEOS's
#: cascaded union. On the build's own scan polygons Clipper2 is the faster with the same result
#: (benchmarks/union.py: the symmetric difference under 1e-5 of the area); GEOS is kept for
#: coordinates too large for Clipper2's 64-bit integers at a nanometre
ENGINES = ("clipper", "geos")
#: Clipper2 works in integers: coordinates times this (a nanometre of a metre: every vertex moves
#: by half of it at most), unless |x| · scale would pass 2^61 (GEOS unites those)
CLIPPER_SCALE = 1e9
_CLIPPER_LIMIT = 2.0**61


def union(polygons, simplify: float = 0.0, engine: str = "clipper") -> shapely.Geometry:
    """Union of scan polygons (thesis 3.2.2, 3.2.3).

    Uniting all at once gives the same set as uniting them one after another into the map, in
    any order, but in O(n log n) instead of O(n²). Holes form where the union encloses space no
    scan saw free. Each polygon is first simplified within ``simplify`` (topology kept), if given.
    ``engine``: "clipper" (Clipper2's pairwise tree, ``clipper_union``) or "geos" (GEOS's
    cascaded union); Clipper2 hands over to GEOS where the coordinates are too large for it.
    """
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
    polys = np.asarray(polygons, dtype=object)

    def valid(part):
        bad = ~shapely.is_valid(part)
        if bad.any():
            part = part.copy()
            part[bad] = shapely.make_valid(part[bad])
        return part

    def prepared(part):
        # simplifying and checking go polygon by polygon, so each part's worker does its own
        part = valid(part)
        if simplify > 0:
            # plain Douglas-Peucker, five times faster than the topology-preserving one (0.28 s
            # against 1.4 s for Freiburg's 4791 polygons). Given valid polygons only: GEOS mends
            # what it makes invalid by buffer(0), which drops a lobe of an invalid input
            part = valid(shapely.simplify(part, simplify, preserve_topology=False))
        return part

    polys = threaded(prepared, polys)
    if engine == "clipper" and len(polys):
        reach = float(np.abs(shapely.bounds(polys)).max(initial=0.0))
        scale = CLIPPER_SCALE if reach * CLIPPER_SCALE < _CLIPPER_LIMIT else None
        out = clipper_union(polys, scale) if scale else None
        if out is not None:
            return out
    workers = os.cpu_count() or 1
    if workers > 1 and len(polys) >= 64:
        # GEOS releases the GIL: unite parts on every core, then unite the parts
        with ThreadPoolExecutor(workers) as ex:
            polys = np.array(list(ex.map(shapely.union_all, np.array_split(polys, workers))), dtype=object)
    return polygonal(shapely.union_all(polys))


#: scan polygons from which the Clipper2 tree is split between two processes: pyclipr holds
#: the GIL while it unites, so threads ran one after the other; a forked process costs some
#: 20-50 ms, worth it only for a longer log
PROCESS_FROM = 1000


def clipper_union(polys: np.ndarray, scale: float = CLIPPER_SCALE):
    """The union of valid polygons by Clipper2 (non-zero fill), as a valid (Multi)Polygon, or None
    where its rings cannot be put together (a hole inside no outer ring: never seen).

    The polygons are united two at a time, then the results two at a time, and so on (a pairwise
    tree: each union is of neighbours in scan order, which overlap, so the partial maps stay
    small), as plain paths; on a machine with two cores or more the first half of the scans in a
    forked process (``PROCESS_FROM``). The outer rings (counter-clockwise) and holes (clockwise)
    of the result are then put together: each hole into the smallest outer ring that contains
    it, found with an STRtree; a polygon GEOS finds invalid (Clipper2 lets rings touch
    themselves at a vertex) is mended by make_valid.
    """
    parts, owner = shapely.get_parts(shapely.orient_polygons(polys), return_index=True)
    rings, ring_part = shapely.get_rings(parts, return_index=True)
    xy, which = shapely.get_coordinates(rings, return_index=True)
    ends = np.r_[np.flatnonzero(np.diff(which)) + 1, len(which)]
    paths = [p[:-1] for p in np.split(xy, ends[:-1])]  # a ring without its closing repeat
    polygon_of_ring = owner[ring_part]
    starts = np.searchsorted(polygon_of_ring, np.arange(len(polys) + 1))
    groups = [paths[starts[k]:starts[k + 1]] for k in range(len(polys))]
    half = len(groups) // 2
    if (os.cpu_count() or 1) > 1 and len(groups) >= PROCESS_FROM and "fork" in multiprocessing.get_all_start_methods():
        # fork: the child has the paths already and imports nothing; only its result is sent back
        with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork")) as ex:
            first = ex.submit(_tree, groups[:half], scale)
            b = _tree(groups[half:], scale)
            a = first.result()
        result = _unite(a, b, scale)[0] if len(a[0]) and len(b[0]) else (a[0] or b[0])
    else:
        result = _tree(groups, scale)[0]
    return _assemble(result)


def _boxes(paths) -> np.ndarray:
    return np.array([(*p.min(axis=0), *p.max(axis=0)) for p in paths]).reshape(-1, 4)


def _unite(a, b, scale: float):
    """Clipper2's union of two lists of plain rings with their boxes (``_tree``'s levels).

    Only rings that reach where the other's rings are can change: the rest pass as they are (a
    ring of either beyond the other's box crosses nothing, and the union only grows, so a hole
    passed on still lies inside its outer ring, an island in its hole)."""
    import pyclipr  # only the union needs it: not on every command's start-up

    (pa, ba), (pb, bb) = a, b
    lo, hi = np.maximum(ba[:, :2].min(0), bb[:, :2].min(0)), np.minimum(ba[:, 2:].max(0), bb[:, 2:].max(0))
    ia = np.all(ba[:, :2] <= hi, 1) & np.all(ba[:, 2:] >= lo, 1)
    ib = np.all(bb[:, :2] <= hi, 1) & np.all(bb[:, 2:] >= lo, 1)
    c = pyclipr.Clipper()
    c.scaleFactor = int(scale)
    c.addPaths([p for p, i in zip(pa, ia) if i] + [p for p, i in zip(pb, ib) if i], pyclipr.Subject)
    new = [np.asarray(p, dtype=np.float64) for p in c.execute(pyclipr.Union, pyclipr.FillRule.NonZero)]
    keep_a, keep_b = np.flatnonzero(~ia), np.flatnonzero(~ib)
    return ([*new, *(pa[k] for k in keep_a), *(pb[k] for k in keep_b)],
            np.concatenate([_boxes(new), ba[keep_a], bb[keep_b]]))


def _tree(groups, scale: float):
    """The pairwise tree over groups of plain rings: (rings, their boxes) of the union."""
    level = [(g, _boxes(g)) for g in groups if g]
    while len(level) > 1:
        level = [_unite(level[j], level[j + 1], scale) if j + 1 < len(level) else level[j]
                 for j in range(0, len(level), 2)]
    return level[0] if level else ([], np.zeros((0, 4)))


def _assemble(paths: list[np.ndarray]):
    """Plain rings (outer counter-clockwise, holes clockwise) as a valid (Multi)Polygon: each hole
    in the smallest outer ring that holds it. None if a hole lies in no outer ring."""
    paths = [p for p in paths if len(p) >= 3]
    if not paths:
        return shapely.MultiPolygon()
    count = np.array([len(p) for p in paths])
    xy = np.vstack(paths)
    idx = np.repeat(np.arange(len(paths)), count)
    filled = shapely.polygons(shapely.linearrings(xy, indices=idx))
    area = _signed_areas(xy, idx, len(paths))
    outer, hole = np.flatnonzero(area > 0), np.flatnonzero(area < 0)
    owner = np.full(len(paths), -1)
    owner[outer] = outer
    if len(hole):
        # each outer ring (prepared) asked which holes it contains: the one large ring of a map
        # and its thousands of holes cost one index, not a scan of the ring per hole
        o, h = shapely.STRtree(filled[hole]).query(filled[outer], predicate="contains")
        o, h = outer[o], hole[h]
        best = np.lexsort((area[o], h))  # per hole, the smallest outer ring first
        first = best[np.r_[True, h[best][1:] != h[best][:-1]]]
        owner[h[first]] = o[first]
        if (owner[hole] < 0).any():
            return None
    keep = np.flatnonzero(area != 0)
    order = keep[np.lexsort((area[keep] < 0, owner[keep]))]  # by outer ring, the outer ring first
    rank = np.unique(owner[order], return_inverse=True)[1]
    polys = shapely.polygons(shapely.get_exterior_ring(filled[order]), indices=rank.reshape(-1))
    bad = ~shapely.is_valid(polys)
    if bad.any():
        mended = [shapely.get_parts(polygonal(g)) for g in shapely.make_valid(polys[bad])]
        polys = np.concatenate([polys[~bad], *mended])
    return polys[0] if len(polys) == 1 else shapely.MultiPolygon(list(polys))


def _signed_areas(xy: np.ndarray, idx: np.ndarray, n: int) -> np.ndarray:
    """Shoelace area of every ring (vertices xy, ring idx, not closed): > 0 counter-clockwise."""
    nxt = np.arange(1, len(xy) + 1)
    last = np.r_[idx[1:] != idx[:-1], True]
    nxt[last] = np.flatnonzero(np.r_[True, idx[1:] != idx[:-1]])
    cross = xy[:, 0] * xy[nxt, 1] - xy[nxt, 0] * xy[:, 1]
    return np.bincount(idx, weights=cross, minlength=n) / 2


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
      own ring) is split at the original vertex farthest from it: one more Douglas-Peucker step
      where the rings clash. Rings that touched at a vertex may touch there still, where their
      edges at it are the original ones (else one could fold over the other there);
    * a ring that moved across another ring's vertex (a hole left its shell, or a shell its
      hole, without any crossing: a "jump") has its segments near that vertex split likewise.

    Repeated until nothing clashes (each step restores vertices of the original rings, which did
    not clash), the maps are those GEOS gives whole (Freiburg 079: 0.09 % of the area moves, 0.9 %
    more vertices; freiburg-campus: 0.002 %, 0.03 %).
    """
    parts = shapely.get_parts(polygonal(geom))
    if not len(parts):
        return shapely.MultiPolygon()
    rings, owner = shapely.get_rings(parts, return_index=True)
    reduced = threaded(lambda a: shapely.simplify(a, tolerance, preserve_topology=True), shapely.polygons(rings))
    xy, ring = _ring_vertices(rings)
    start = np.searchsorted(ring, np.arange(len(rings)))
    size = np.diff(np.r_[start, len(ring)])
    after = np.arange(1, len(ring) + 1)  # the next original vertex along each ring
    after[start + size - 1] = start
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
        bad = _crossings(xy, v, w, r, fresh[v] | fresh[w], after)
        for code in jumps:  # a few a map
            q, p = divmod(int(code), n)
            seg = np.arange(np.searchsorted(r, q), np.searchsorted(r, q, side="right"))
            d = shapely.distance(shapely.linestrings(np.stack((xy[v[seg]], xy[w[seg]]), axis=1)), points[p])
            bad[seg[(d <= tolerance * 1.001) | (d == d.min())]] = True
        if not bad.any():
            break
        added, a, b = _split(xy, ring, start, size, v[bad], w[bad], tolerance)
        if not len(added):  # every clashing segment an original edge already: nothing left to give back
            break
        fresh[:] = False
        fresh[added] = True
        kept[added] = True
        jumps = _jumps(xy, ring, kept, points, point_tree, was_inside, a, added, b, jumps)
    out = shapely.polygons(shapely.linearrings(xy[kept], indices=ring[kept]))
    polys = shapely.polygons(shapely.get_exterior_ring(out), indices=owner)
    return polys[0] if len(polys) == 1 else shapely.MultiPolygon(list(polys))


def _jumps(xy, ring, kept, points, point_tree, was_inside, a, c, b, before) -> np.ndarray:
    """Codes q·n + p of rings q whose reduced form holds ring p's point inside where the original
    did not, or the other way round, after vertices c were put back between a and b: only a point
    inside a triangle (a, c, b) can have changed sides, or one of the jumps ``before`` not yet
    mended (one more Douglas-Peucker step may not reach back over the point)."""
    n = len(points)
    t, p = point_tree.query(shapely.polygons(np.stack((xy[a], xy[c], xy[b]), axis=1)), predicate="intersects")
    q = np.r_[ring[c[t]], before // n]
    p = np.r_[p, before % n]
    keep = q != p
    if not keep.any():
        return np.zeros(0, np.int64)
    q, p = np.unique(np.c_[q[keep], p[keep]], axis=0).T
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


def _crossings(xy, v, w, r, fresh, after) -> np.ndarray:
    """bool over the segments v→w (of ring r): those that meet a segment other than in a vertex
    both have, and where both are original edges (``after``: the next original vertex of each
    along its ring), checked for the ``fresh`` segments (against all)."""
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
        # and only where neither ring's edges at that vertex changed: rings that touched at a
        # vertex and keep touching there may otherwise cross there, or one fold over the other
        # (a hole swallowing the hole it touched) without any other crossing
        touch &= (w[i] == after[v[i]]) & (w[j] == after[v[j]])
    clash = ~touch
    bad[i[clash]] = True
    bad[j[clash]] = True
    return bad


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
