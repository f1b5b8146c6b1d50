"""Visibility inside a polygonal region: triangle walks in its constrained Delaunay triangulation.

A segment from a vertex ``a`` of the region to a point ``q`` lies inside the (closed) region iff
the straight walk from ``a`` towards ``q`` through the triangulation reaches the triangle holding
``q`` without crossing a boundary edge. Every walk here steps in lockstep with all the others,
one triangle per NumPy step, so a million candidate segments cost a few array operations per
triangle crossed; most blocked segments stop at the first or second triangle.

Conventions: a segment that passes exactly through a vertex other than its own ends counts as
blocked. Nothing is lost for shortest paths: where the segment can go straight through that
vertex the vertex is reflex or flat (a graph node), and the path through it is as long.

The triangulation is GEOS's (``shapely.constrained_delaunay_triangles``): its vertices are the
region's vertices, its triangles tile the region exactly and its boundary edges are the
region's edges.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely

#: candidate segments walked at once: bounds the memory of the lockstep arrays
_CHUNK = 400_000


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _keys(xy: np.ndarray) -> np.ndarray:
    # complex numbers sort by real then imaginary part: a lexicographic key for a point
    return xy[:, 0] + 1j * xy[:, 1]


@dataclass(frozen=True, eq=False)
class Triangulation:
    """The constrained Delaunay triangulation of a polygonal region, with adjacency.

    points     (m, 2) distinct vertices, sorted by x then y
    triangles  (t, 3) vertex indices, counter-clockwise
    neighbors  (t, 3) triangle across the edge opposite each corner; −1 across a boundary edge
    """

    points: np.ndarray
    triangles: np.ndarray
    neighbors: np.ndarray

    @classmethod
    def of(cls, region: shapely.Geometry) -> "Triangulation":
        parts = shapely.get_parts(shapely.constrained_delaunay_triangles(region))
        corners = shapely.get_coordinates(parts).reshape(-1, 4, 2)[:, :3]
        area2 = _cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        # a flat triangle has no inside to walk through; dropping it only makes a walk stop early
        corners = corners[area2 != 0]
        cw = area2[area2 != 0] < 0
        corners[cw] = corners[cw][:, ::-1]
        keys, inverse = np.unique(_keys(corners.reshape(-1, 2)), return_inverse=True)
        points = np.column_stack((keys.real, keys.imag))
        tri = inverse.reshape(-1, 3).astype(np.int64)
        return cls(points, tri, _neighbors(tri, len(points)))

    def vertex_index(self, xy: np.ndarray) -> np.ndarray:
        """Index of each point of (n, 2) ``xy`` among ``points``; −1 where it is no vertex."""
        keys = _keys(self.points)
        q = _keys(np.asarray(xy, dtype=np.float64).reshape(-1, 2))
        if len(keys) == 0:
            return np.full(len(q), -1, np.int64)
        i = np.minimum(np.searchsorted(keys, q), len(keys) - 1)
        return np.where(keys[i] == q, i, -1)

    @cached_property
    def _star(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Triangles around each vertex as CSR: (order, start, count)."""
        flat = self.triangles.ravel()
        order = np.argsort(flat, kind="stable") // 3
        count = np.bincount(flat, minlength=len(self.points))
        start = np.concatenate(([0], np.cumsum(count)[:-1]))
        return order, start, count

    def visible(self, origin: np.ndarray, target: np.ndarray, target_vertex: np.ndarray | None = None) -> np.ndarray:
        """Whether each segment from vertex ``origin[i]`` to point ``target[i]`` lies in the region.

        origin         (n,) vertex indices
        target         (n, 2) points
        target_vertex  (n,) vertex index of each target, −1 where the target is no vertex
                       (None: none is)
        Returns (n,) bool. A segment along a boundary edge is inside; one through a vertex other
        than its ends is not (module docstring).
        """
        origin = np.asarray(origin, dtype=np.int64).reshape(-1)
        target = np.asarray(target, dtype=np.float64).reshape(-1, 2)
        tv = np.full(len(origin), -1, np.int64) if target_vertex is None else np.asarray(target_vertex, np.int64)
        out = np.zeros(len(origin), bool)
        for k in range(0, len(origin), _CHUNK):
            sl = slice(k, k + _CHUNK)
            out[sl] = self._walk(origin[sl], target[sl], tv[sl])
        return out

    @cached_property
    def _tree(self) -> shapely.STRtree:
        P = self.points
        return shapely.STRtree(shapely.polygons(P[np.column_stack((self.triangles, self.triangles[:, :1]))]))

    def locate(self, points) -> np.ndarray:
        """(n,) a triangle holding each point (closed), −1 where none does."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        pi, ti = self._tree.query(shapely.points(p), predicate="intersects")
        out = np.full(len(p), -1, np.int64)
        out[pi[::-1]] = ti[::-1]  # the first triangle found wins
        return out

    def near(self, point, distance: float) -> np.ndarray:
        """Indices of the triangles within ``distance`` of ``point``, nearest first."""
        pt = shapely.Point(np.asarray(point, dtype=np.float64).reshape(2))
        t = self._tree.query(pt, predicate="dwithin", distance=distance)
        return t[np.argsort(shapely.distance(self._tree.geometries[t], pt), kind="stable")]

    def channel(self, start, goal) -> np.ndarray | None:
        """A polyline from ``start`` to ``goal`` through the midpoints of the edges between the
        triangles of a shortest chain of adjacent triangles; None if no chain joins them.

        Each piece lies in one triangle, so the polyline lies in the region whatever the
        rounding: the fallback when a visibility search comes back empty. Not a shortest path.
        """
        s, g = np.asarray(start, np.float64), np.asarray(goal, np.float64)
        ts, tg = self.locate(np.vstack((s, g)))
        if ts < 0 or tg < 0:
            return None
        if ts == tg:
            return np.vstack((s, g))
        T, N = self.triangles, self.neighbors
        c = self.points[T].mean(axis=1)
        a, k = np.nonzero(N > np.arange(len(T))[:, None])  # each pair of neighbours once
        b = N[a, k]
        chain = shortest_chain(a, b, np.hypot(*(c[a] - c[b]).T), len(T), int(ts), int(tg))
        if chain is None:
            return None
        t0, t1 = chain[:-1], chain[1:]
        k = np.argmax(N[t0] == t1[:, None], axis=1)
        mid = 0.5 * (self.points[T[t0, (k + 1) % 3]] + self.points[T[t0, (k + 2) % 3]])
        return np.vstack((s, mid, g))

    def _walk(self, origin: np.ndarray, q: np.ndarray, tv: np.ndarray) -> np.ndarray:
        P, T, N = self.points, self.triangles, self.neighbors
        n = len(origin)
        seen = np.zeros(n, bool)
        if n == 0:
            return seen
        a = P[origin]
        d = q - a
        same = (tv == origin) | ((d[:, 0] == 0) & (d[:, 1] == 0))
        seen[same] = True
        # first triangle: the one around the origin whose corner holds the direction d
        order, start, count = self._star
        c = count[origin]
        rep = np.repeat(np.arange(n), c)
        tri = order[np.repeat(start[origin] - np.cumsum(c) + c, c) + np.arange(len(rep))]
        j = np.argmax(T[tri] == origin[rep, None], axis=1)
        p1 = T[tri, (j + 1) % 3]
        p2 = T[tri, (j + 2) % 3]
        dr, ar = d[rep], a[rep]
        inside = (_cross(P[p1] - ar, dr) >= 0) & (_cross(dr, P[p2] - ar) >= 0)
        rep, tri, j, p1, p2 = rep[inside], tri[inside], j[inside], p1[inside], p2[inside]
        first = np.r_[True, rep[1:] != rep[:-1]]  # rep is sorted: keep each walk's first triangle
        rep, tri, j, p1, p2 = rep[first], tri[first], j[first], p1[first], p2[first]
        keep = ~same[rep]
        i, tri, j, R, L = rep[keep], tri[keep], j[keep], p1[keep], p2[keep]
        # the target is one of the corner's other two vertices, or inside the first triangle
        hit = (tv[i] == R) | (tv[i] == L)
        pt = tv[i] < 0
        hit |= pt & (_cross(P[L] - P[R], q[i] - P[R]) >= 0)
        seen[i[hit]] = True
        through = (_cross(d[i], P[R] - a[i]) == 0) | (_cross(d[i], P[L] - a[i]) == 0)
        go = ~hit & ~through
        i, cur, R, L = i[go], N[tri[go], j[go]], R[go], L[go]
        for _ in range(len(T) + 1):
            ok = cur >= 0  # −1: the walk crossed a boundary edge
            i, cur, R, L = i[ok], cur[ok], R[ok], L[ok]
            if len(i) == 0:
                break
            t = T[cur]
            k = np.argmax((t != R[:, None]) & (t != L[:, None]), axis=1)
            p3 = t[np.arange(len(t)), k]
            hit = tv[i] == p3
            ai, di, qi = a[i], d[i], q[i]
            o = _cross(di, P[p3] - ai)
            left = o > 0
            # the ray leaves this triangle through (p3, R) if p3 is left of it, else (L, p3)
            e0 = np.where(left[:, None], P[R], P[L])
            e1 = P[p3]
            sq = _cross(e1 - e0, qi - e0)
            sa = _cross(e1 - e0, ai - e0)
            pt = tv[i] < 0
            hit |= pt & (o != 0) & ((sq == 0) | ((sq > 0) == (sa > 0)))
            hit |= pt & (o == 0) & (np.einsum("ij,ij->i", P[p3] - qi, di) >= 0)
            seen[i[hit]] = True
            go = ~hit & (o != 0)
            # the edge the ray leaves by: its corner opposite is the vertex not on it
            L = np.where(left, p3, L)
            R = np.where(left, R, p3)
            opp = np.argmax((t != R[:, None]) & (t != L[:, None]), axis=1)
            i, cur, R, L = i[go], N[cur, opp][go], R[go], L[go]
        return seen


def _ring_vertices(region: shapely.Geometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every ring's vertices without the closing repeat, rings one after the other:
    (xy (n, 2), ring index (n,), polygon index (n,))."""
    rings, part_of = shapely.get_rings(shapely.get_parts(region), return_index=True)
    xy, ring = shapely.get_coordinates(rings, return_index=True)
    closing = np.r_[ring[1:] != ring[:-1], True]
    return xy[~closing], ring[~closing], part_of[ring[~closing]].astype(np.int64)


def boundary_edges(region: shapely.Geometry) -> tuple[np.ndarray, np.ndarray]:
    """Every edge of every ring: (start points (e, 2), end points (e, 2))."""
    xy, ring = shapely.get_coordinates(shapely.get_rings(shapely.get_parts(region)), return_index=True)
    same = ring[1:] == ring[:-1]
    return xy[:-1][same], xy[1:][same]


def _neighbors(tri: np.ndarray, m: int) -> np.ndarray:
    """(t, 3): the triangle sharing the edge opposite each corner, −1 on the region's boundary."""
    a = tri[:, [1, 2, 0]].ravel()
    b = tri[:, [2, 0, 1]].ravel()
    key = np.minimum(a, b) * m + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    pair = np.flatnonzero(ks[1:] == ks[:-1])
    nb = np.full(len(key), -1, np.int64)
    nb[order[pair]] = order[pair + 1] // 3
    nb[order[pair + 1]] = order[pair] // 3
    return nb.reshape(-1, 3)


@dataclass(frozen=True, eq=False)
class Corners:
    """The reflex and flat vertices of a region (free space on the left of every edge).

    Shortest paths in a polygonal region bend only at reflex vertices (interior angle > 180°);
    flat ones (exactly 180°) are kept so that a path may run along a straight wall of several
    edges. One row per occurrence: a vertex where two rings touch appears once per ring.

    xy, prev, next  (k, 2) the vertex and its two neighbours on its ring
    part            (k,) which polygon of the region it belongs to
    """

    xy: np.ndarray
    prev: np.ndarray
    next: np.ndarray
    part: np.ndarray

    @classmethod
    def of(cls, region: shapely.Geometry) -> "Corners":
        v, ring, part = _ring_vertices(shapely.orient_polygons(region, exterior_cw=False))
        # each ring's vertices are contiguous: its first and last are each other's neighbours
        first = np.r_[True, ring[1:] != ring[:-1]]
        last = np.r_[ring[1:] != ring[:-1], True]
        idx = np.arange(len(v))
        start = np.maximum.accumulate(np.where(first, idx, 0))
        end = np.minimum.accumulate(np.where(last, idx, len(v))[::-1])[::-1]
        nxt = np.where(last, start, idx + 1)
        prv = np.where(first, end, idx - 1)
        turn = _cross(v - v[prv], v[nxt] - v)
        keep = turn <= 0  # interior on the left: a right turn (or none) is reflex (or flat)
        return cls(v[keep], v[prv][keep], v[nxt][keep], part[keep])

    def __len__(self) -> int:
        return len(self.xy)

    def tangent(self, i: np.ndarray, towards: np.ndarray) -> np.ndarray:
        """Whether the line from corner ``i`` towards each point leaves both its edges on one side.

        A shortest path through a reflex vertex wraps around it: the lines to the previous and
        next path points are tangent to the boundary there, so any other line is no use.
        """
        o = self.xy[i]
        u = towards - o
        return _cross(u, self.prev[i] - o) * _cross(u, self.next[i] - o) >= 0


def bitangent_pairs(corners: Corners, block: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """All pairs (i < j) of corners of one polygon whose line is tangent at both ends.

    Vectorised over blocks of ``block`` rows against the columns after them: O(k²/2) work,
    O(block·k) memory.
    """
    k = len(corners)
    out_i, out_j = [], []
    xy, prv, nxt, part = corners.xy, corners.prev, corners.next, corners.part
    for r0 in range(0, k, block):
        r = np.arange(r0, min(r0 + block, k))
        c = np.arange(r0, k)
        o = xy[r, None]
        u = xy[None, c] - o  # from each row corner to each column corner
        ok = (part[r, None] == part[None, c]) & (c[None] > r[:, None])
        ok &= _cross(u, prv[r, None] - o) * _cross(u, nxt[r, None] - o) >= 0
        ok &= _cross(u, prv[None, c] - xy[None, c]) * _cross(u, nxt[None, c] - xy[None, c]) >= 0
        ii, jj = np.nonzero(ok)
        out_i.append(r[ii])
        out_j.append(c[jj])
    if not out_i:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(out_i), np.concatenate(out_j)


@dataclass(frozen=True, eq=False)
class OutsideMask:
    """Raster cells that lie wholly outside a region: a quick, certain test that a segment is blocked.

    A cell no boundary passes through is wholly inside or wholly outside; one whose centre is
    outside is then wholly outside, and a segment with a point in it cannot lie in the region.
    Cells the boundary may touch are never marked, so the test only ever says "blocked" when
    it is; walks decide the rest.
    """

    origin: np.ndarray
    cell: float
    outside: np.ndarray  # (ny, nx) bool

    @classmethod
    def of(cls, region: shapely.Geometry, max_cells: int = 1 << 20) -> "OutsideMask":
        x0, y0, x1, y1 = region.bounds
        w, h = max(x1 - x0, 1e-300), max(y1 - y0, 1e-300)
        cell = max(np.sqrt(w * h / max_cells), max(w, h) / 4096)
        nx, ny = int(np.ceil(w / cell)) + 1, int(np.ceil(h / cell)) + 1
        origin = np.array([x0, y0])
        cx = x0 + (np.arange(nx) + 0.5) * cell
        cy = y0 + (np.arange(ny) + 0.5) * cell
        gx, gy = np.meshgrid(cx, cy)
        inside = shapely.intersects_xy(region, gx, gy)
        # every boundary point lies within cell/4 of a sample, so within the sample's 3×3 cells
        near = np.zeros((ny, nx), bool)
        a, b = boundary_edges(region)
        seg = b - a
        n = np.maximum(np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / (cell / 2)), 1).astype(np.int64)
        s = np.repeat(np.arange(len(seg)), n)
        t = (np.arange(len(s)) - np.repeat(np.cumsum(n) - n, n)) / n[s]
        p = a[s] + t[:, None] * seg[s]
        ix = np.clip(((p[:, 0] - x0) / cell).astype(np.int64), 0, nx - 1)
        iy = np.clip(((p[:, 1] - y0) / cell).astype(np.int64), 0, ny - 1)
        near[iy, ix] = True
        grown = near.copy()
        grown[1:] |= near[:-1]
        grown[:-1] |= near[1:]
        g2 = grown.copy()
        g2[:, 1:] |= grown[:, :-1]
        g2[:, :-1] |= grown[:, 1:]
        return cls(origin, float(cell), ~inside & ~g2)

    def blocked(self, a: np.ndarray, b: np.ndarray, samples: int = 15) -> np.ndarray:
        """(n,) bool: one of ``samples`` points spread evenly along segment a→b is certainly
        outside. (Trying the middle first and dropping the segments it blocks does not pay:
        most tangent lines that are blocked are blocked near their ends, by the next bump of a
        jagged wall, which only a walk sees.)"""
        a = np.asarray(a, dtype=np.float64).reshape(-1, 2)
        b = np.asarray(b, dtype=np.float64).reshape(-1, 2)
        out = np.zeros(len(a), bool)
        for t in np.arange(1, samples + 1) / (samples + 1):
            out |= self._outside(a + t * (b - a))
        return out

    def _outside(self, p: np.ndarray) -> np.ndarray:
        ny, nx = self.outside.shape
        q = (p - self.origin) / self.cell
        ix, iy = np.floor(q[:, 0]), np.floor(q[:, 1])
        off = (ix < 0) | (iy < 0) | (ix >= nx) | (iy >= ny)  # beyond the bounds: outside
        ix = np.clip(ix, 0, nx - 1).astype(np.int64)
        iy = np.clip(iy, 0, ny - 1).astype(np.int64)
        return off | self.outside[iy, ix]


@dataclass(frozen=True, eq=False)
class VisibilityGraph:
    """The reduced visibility graph of a region: its reflex (and flat) corners, joined where they
    see each other along a line tangent at both ends.

    Every Euclidean shortest path in a polygonal region with holes is a polyline whose inner
    points are reflex vertices, each segment tangent to the boundary at its ends, so searching
    this graph plus start and goal finds the exact shortest path (Lozano-Pérez and Wesley 1979;
    the tangent reduction is the "extremity" graph of Vinther et al.).

    edges    (e, 2) vertex indices into ``triangulation.points``, each unordered pair once
    lengths  (e,) Euclidean length of each edge
    counts   how many pairs each stage kept: tangent, walked (not ruled out by the mask), edges
    """

    region: shapely.Geometry
    triangulation: Triangulation
    corners: Corners
    vertex: np.ndarray  # (k,) triangulation vertex of each corner
    mask: OutsideMask
    edges: np.ndarray
    lengths: np.ndarray
    counts: dict

    @classmethod
    def of(cls, region: shapely.Geometry) -> "VisibilityGraph":
        """Build the graph: O(k²) tangent tests in blocks, then walks for the few that survive
        the outside-cell test (``OutsideMask``)."""
        tri = Triangulation.of(region)
        corners = Corners.of(region)
        vertex = tri.vertex_index(corners.xy)
        if (vertex < 0).any():
            # cannot happen for a valid region: its triangulation has exactly its vertices
            raise ValueError(f"corner {corners.xy[np.argmax(vertex < 0)]} is no vertex of the triangulation")
        i, j = bitangent_pairs(corners)
        keep = vertex[i] != vertex[j]  # two corners at one point (rings touching) need no edge
        i, j = i[keep], j[keep]
        tangent = len(i)
        # a finer mask costs more to make and saves more walks: scale it with the pairs
        mask = OutsideMask.of(region, int(np.clip(tangent // 2, 1 << 16, 1 << 20)))
        free = ~mask.blocked(corners.xy[i], corners.xy[j])
        i, j = i[free], j[free]
        seen = tri.visible(vertex[i], corners.xy[j], vertex[j])
        u, v = vertex[i[seen]], vertex[j[seen]]
        e = np.unique(np.column_stack((np.minimum(u, v), np.maximum(u, v))), axis=0).reshape(-1, 2)
        d = tri.points[e[:, 1]] - tri.points[e[:, 0]]
        counts = {"corners": len(corners), "tangent": tangent, "walked": len(i), "edges": len(e)}
        return cls(region, tri, corners, vertex, mask, e, np.hypot(d[:, 0], d[:, 1]), counts)

    def reach(self, point, part: int) -> tuple[np.ndarray, np.ndarray]:
        """Vertices of corners of polygon ``part`` that see ``point`` along a line tangent at the
        corner, and their distances to it."""
        p = np.asarray(point, dtype=np.float64).reshape(2)
        c = np.flatnonzero(self.corners.part == part)
        c = c[self.corners.tangent(c, p)]
        c = c[~self.mask.blocked(self.corners.xy[c], np.broadcast_to(p, (len(c), 2)))]
        c = c[self.triangulation.visible(self.vertex[c], np.broadcast_to(p, (len(c), 2)))]
        v = np.unique(self.vertex[c])
        d = self.triangulation.points[v] - p
        return v, np.hypot(d[:, 0], d[:, 1])

    def shortest_path(self, start, goal, part: int, exclude: np.ndarray | None = None) -> np.ndarray | None:
        """The shortest polyline from ``start`` to ``goal`` (both in polygon ``part``) through the
        graph, as a (k, 2) array; None if the graph does not join them.

        ``exclude``: (x, 2) vertex pairs not to use, start being vertex −1 and goal −2.
        """
        s, g = np.asarray(start, np.float64), np.asarray(goal, np.float64)
        vs, ds = self.reach(s, part)
        vg, dg = self.reach(g, part)
        m = len(self.triangulation.points)
        S, G = m, m + 1
        rows = np.concatenate((self.edges[:, 0], np.full(len(vs), S), vg))
        cols = np.concatenate((self.edges[:, 1], vs, np.full(len(vg), G)))
        w = np.concatenate((self.lengths, ds, dg))
        if exclude is not None and len(exclude):
            ex = np.where(exclude == -1, S, np.where(exclude == -2, G, exclude))
            ex = np.concatenate((ex, ex[:, ::-1]))
            drop = np.isin(rows * (m + 2) + cols, ex[:, 0] * (m + 2) + ex[:, 1])
            rows, cols, w = rows[~drop], cols[~drop], w[~drop]
        chain = shortest_chain(rows, cols, w, m + 2, S, G)
        if chain is None:
            return None
        return np.vstack((s, self.triangulation.points[chain[1:-1]], g))


def shortest_chain(rows: np.ndarray, cols: np.ndarray, weights: np.ndarray, size: int, source: int,
                   target: int) -> np.ndarray | None:
    """Nodes of a shortest path from ``source`` to ``target`` in the undirected graph with edges
    rows[i]–cols[i] of ``weights[i]`` (Dijkstra, scipy.sparse.csgraph); None if none joins them.

    Each unordered pair must appear once (a sparse matrix adds duplicates up). A weight of 0
    becomes the smallest positive float: a sparse graph has no zero-weight edges.
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    w = np.maximum(weights, np.finfo(np.float64).tiny)
    graph = csr_matrix((w, (rows, cols)), shape=(size, size))
    dist, pred = dijkstra(graph, directed=False, indices=source, return_predecessors=True)
    if not np.isfinite(dist[target]):
        return None
    chain = [target]
    while chain[-1] != source:  # along the path found, not over the graph
        chain.append(int(pred[chain[-1]]))
    return np.array(chain[::-1], dtype=np.int64)
