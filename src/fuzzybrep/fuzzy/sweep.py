"""The sweep by the single normal vertex method: normal vertices, parametric lines, α-cuts.

Arrays in, arrays out: every function takes a ring's vertex table as an (n, 2) array and works
on all vertices at once; nothing here knows about files or map types (thesis 4.1.2).

Conventions (Table 4.1):

- The normal vertex of a vertex lies on the bisector of its corner. IN is the side of the ring's
  own interior, whatever the vertex order (for a hole: into the obstacle), OUT the other side.
- VIN and VOUT are the points at the α = 0 support distances along the bisector: VIN at
  ``support_in`` inward, VOUT at ``support_out`` outward. The distance is measured ALONG the
  bisector (V1 of Table 4.1 moves 141.42·√2 = 200), not perpendicular to the edges.
- The parametric line of a vertex is x = U + T·t, y = W + V·t with U, W = VIN and T, V = crisp
  vertex − VIN: t = 0 at the inner support, t = 1 at the crisp vertex (the core), and
  t = 1 + support_out/support_in at the outer support, which is t = 2 for a symmetric function.
  The line is one straight line through VIN and the crisp vertex; t is an affine coordinate of
  distance along it, so the point at inward distance d has t = 1 − d/support_in and the point at
  outward distance d has t = 1 + d/support_in.

An offset ring read from these lines may self-intersect (sharp and reflex corners, short edges,
narrow corridors); ``proper_polygon`` detects it (GEOS) and converts it to a proper polygon: the
crisp polygon minus what the edges swept over on their way to the offset, so no inverted loop
survives and α-cuts nest (thesis 4.1.2, proper polygons).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from ..errors import GeometryError
from ..geometry import clean, orientation, signed_area

#: below this, the two edge normals of a corner cancel: the corner is a spike (angle 0 or 360°)
_SPIKE = 1e-12


def normal_vertices(vertices: np.ndarray) -> np.ndarray:
    """(n, 2) unit vectors along the bisector of every corner, pointing IN. Thesis 4.1.2, Fig. 4.7.

    The bisector of corner V1-V2-V3 is the sum of the inward unit normals of edges V1V2 and V2V3,
    which handles convex and reflex corners alike and gives the edge normal at collinear
    vertices. At a spike, where the normals cancel, it points back along the incoming edge.
    """
    v = np.asarray(vertices, dtype=np.float64)
    s = orientation(v)  # the ring's own shoelace sum, as ``signed_area`` gives it, decides IN
    try:
        return normal_vertices_stacked(v, [len(v)], own=[s])[0]
    except GeometryError as e:  # one ring: the error names only the vertex
        raise GeometryError(e.reason, vertex=e.vertex) from None


def normal_vertices_stacked(vertices: np.ndarray, sizes: np.ndarray, own=None) -> tuple[np.ndarray, np.ndarray]:
    """``normal_vertices`` of many rings stacked in one (N, 2) array, ring k having sizes[k]
    vertices; also returns every ring's orientation (``own``: given, +1 or −1 per ring, it is
    used as is). One pass over all vertices.

    Raises GeometryError with ``vertex`` (1-based, within its ring) and the ring's position in
    ``ring`` (as a string) for a ring with a repeated vertex, or without area (judged from its
    vertices only when ``own`` is not given).
    """
    v = np.asarray(vertices, dtype=np.float64)
    sizes = np.asarray(sizes)
    start = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    ring = np.repeat(np.arange(len(sizes)), sizes)
    nxt = np.arange(len(v)) + 1
    nxt[start + sizes - 1] = start
    prv = np.empty_like(nxt)
    prv[nxt] = np.arange(len(v))
    if own is None:
        x, y = v[:, 0], v[:, 1]
        area = 0.5 * np.add.reduceat(x * y[nxt] - x[nxt] * y, start)
        bad = ~np.isfinite(area) | (area == 0)
        if bad.any():
            raise GeometryError("ring has no area, so it has no inside to offset into", ring=str(int(np.argmax(bad))))
        own = np.where(area > 0, 1, -1)
    own = np.asarray(own)
    d = v[nxt] - v  # edge i: vertex i -> i+1
    length = np.hypot(d[:, 0], d[:, 1])
    if np.any(length == 0):
        i = int(np.argmax(length == 0))
        k = ring[i]
        local = i - start[k]
        raise GeometryError(f"repeats vertex {(local + 1) % sizes[k] + 1}", ring=str(int(k)), vertex=int(local) + 1)
    d /= length[:, None]
    # inward normal: left of the edge for a counter-clockwise ring, right for a clockwise one
    n = own[ring][:, None] * np.column_stack((-d[:, 1], d[:, 0]))
    b = n[prv] + n  # vertex i: edge i-1 and edge i
    norm = np.hypot(b[:, 0], b[:, 1])
    spike = norm < _SPIKE
    if spike.any():
        b[spike] = -d[prv][spike]
        norm[spike] = 1.0
    return b / norm[:, None], own


@dataclass(frozen=True, eq=False)
class ParametricLines:
    """The parametric lines of one ring's vertices (Table 4.1's T, U, V, W), with their supports.

    vertices     (n, 2) crisp vertices (X, Y)
    bisector     (n, 2) unit normal-vertex directions, IN
    support_in   (n,) α = 0 inward distance of each vertex's membership function
    support_out  (n,) α = 0 outward distance
    """

    vertices: np.ndarray
    bisector: np.ndarray
    support_in: np.ndarray
    support_out: np.ndarray

    @property
    def vin(self) -> np.ndarray:
        """(n, 2) VIN: the inner support point, t = 0."""
        return self.vertices + self.bisector * self.support_in[:, None]

    @property
    def vout(self) -> np.ndarray:
        """(n, 2) VOUT: the outer support point, t = 1 + support_out/support_in."""
        return self.vertices - self.bisector * self.support_out[:, None]

    @property
    def U(self) -> np.ndarray:  # noqa: N802 - the thesis's name
        return self.vin[:, 0]

    @property
    def W(self) -> np.ndarray:  # noqa: N802
        return self.vin[:, 1]

    @property
    def T(self) -> np.ndarray:  # noqa: N802
        return -self.bisector[:, 0] * self.support_in

    @property
    def V(self) -> np.ndarray:  # noqa: N802
        return -self.bisector[:, 1] * self.support_in

    @property
    def t_out(self) -> np.ndarray:
        """(n,) t of VOUT: 2 for a symmetric function."""
        return 1.0 + self.support_out / self.support_in

    def at(self, t) -> np.ndarray:
        """(n, 2) points of the lines at parameter t (scalar or (n,)): x = U + T·t, y = W + V·t.

        Evaluated as X + T·(t − 1), the same line, so that t = 1 gives the crisp vertex exactly.
        """
        t1 = np.asarray(t, dtype=np.float64) - 1.0
        return self.vertices + np.column_stack((self.T, self.V)) * np.reshape(t1, (-1, 1))

    def inner(self, d_in) -> np.ndarray:
        """(n, 2) inner offset vertices at inward distances d_in ((n,) or scalar): the α-cut's IN side."""
        return self.at(1.0 - np.asarray(d_in, dtype=np.float64) / self.support_in)

    def outer(self, d_out) -> np.ndarray:
        """(n, 2) outer offset vertices at outward distances d_out: the α-cut's OUT side."""
        return self.at(1.0 + np.asarray(d_out, dtype=np.float64) / self.support_in)


def parametric_lines(vertices: np.ndarray, support_in, support_out) -> ParametricLines:
    """Normal vertices and parametric lines of every vertex of a ring, in O(n). Thesis 4.1.2."""
    v = np.asarray(vertices, dtype=np.float64)
    n = len(v)
    si = np.broadcast_to(np.asarray(support_in, dtype=np.float64), (n,)).copy()
    so = np.broadcast_to(np.asarray(support_out, dtype=np.float64), (n,)).copy()
    if np.any(~(si > 0)) or np.any(~(so > 0)):
        raise GeometryError("every vertex needs a positive inner and outer support distance")
    b = normal_vertices(v)
    for a in (v, b, si, so):
        a.setflags(write=False)
    return ParametricLines(v, b, si, so)


# ---------------------------------------------------------------------------------------------
# Proper polygons


@dataclass(frozen=True, eq=False)
class ProperPolygon:
    """One ring's side of an α-cut as a proper polygon (thesis 4.1.2).

    geometry      Polygon or MultiPolygon (possibly empty): the ring's polygon shrunk (IN side)
                  or grown (OUT side). When the offset splits, it has several pieces.
    simple        the offset ring was simple, positively wound and no band folded, so the
                  geometry is just the offset ring's polygon (no overlay was needed)
    vertex_kept   (n,) bool, or None if not asked for: offset vertex i lies on the proper
                  boundary (False: NULL in the fuzzy vertex table)
    edge_kept     (n,) bool, or None: some stretch of offset edge i lies on the proper boundary
    """

    geometry: shapely.Geometry
    simple: bool
    vertex_kept: np.ndarray | None = None
    edge_kept: np.ndarray | None = None


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def band_folds(crisp: np.ndarray, offset: np.ndarray, sign: int | np.ndarray) -> np.ndarray:
    """(n,) True where edge i's band (crisp edge to offset edge) is not a convex quadrilateral.

    The band of edge i is the bilinear patch (1−λ)(C_i + u·A_i) + λ(C_i+1 + u·A_i+1), A = offset −
    crisp. Its Jacobian is bilinear in (λ, u), so it keeps ``sign`` over the whole patch iff it
    does at the four corners; then the patch is a convex quadrilateral swept once. Otherwise
    the two normal-vertex lines cross inside it and the band folds over. ``sign`` = +1 for the IN
    side of a counter-clockwise ring (orientation × (+1 IN, −1 OUT) in general).
    """
    c, p = np.asarray(crisp, dtype=np.float64), np.asarray(offset, dtype=np.float64)
    nxt = np.roll(np.arange(len(c)), -1)
    return folded_bands(c, c[nxt], p - c, p[nxt] - c[nxt], sign)


def folded_bands(c0, c1, a0, a1, sign) -> np.ndarray:
    """``band_folds`` for bands given by their crisp ends c0, c1 and offset vectors a0, a1 (m, 2)."""
    e = c1 - c0
    far = e + a1 - a0
    size = np.hypot(e[:, 0], e[:, 1]) + np.hypot(a0[:, 0], a0[:, 1]) + np.hypot(a1[:, 0], a1[:, 1])
    tol = -1e-12 * size * size
    j = np.stack((_cross(e, a0), _cross(e, a1), _cross(far, a0), _cross(far, a1)), axis=-1) * np.reshape(sign, (-1, 1))
    return (j < tol[:, None]).any(axis=1)


def swept_hulls(crisp: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """(n,) convex hulls of {C_i, C_i+1, P_i, P_i+1}: the region edge i's α-cut edge sweeps, or
    a convex region holding it where the band folds. Shrinks as the offset moves back towards
    the crisp edge, which is what makes α-cuts nest."""
    nxt = np.roll(np.arange(len(crisp)), -1)
    pts = np.stack((crisp, crisp[nxt], offset[nxt], offset), axis=1)
    return shapely.convex_hull(shapely.multipoints(pts))


def _swept_parts(crisp: np.ndarray, offset: np.ndarray, sign: int, folds: np.ndarray) -> list:
    """Every edge's swept region, as strips of unfolded bands and hulls of folded ones.

    A run of consecutive unfolded bands is one polygon (crisp chain out, offset chain back)
    when that polygon is valid: its bands, convex and alike oriented, then tile it exactly.
    Runs that are not valid are halved until they are; folded bands add their convex hulls.
    Few pieces for the overlay, however long the ring.
    """
    n = len(crisp)
    nxt = np.roll(np.arange(n), -1)
    good = ~folds
    parts = []
    bad = np.flatnonzero(folds)
    if len(bad):
        parts.extend(swept_hulls(crisp, offset)[bad])
    # runs of good edges, in cyclic order, starting after a bad edge (or anywhere if none)
    first = int(bad[0]) + 1 if len(bad) else 0
    order = (first + np.arange(n)) % n
    g = good[order]
    runs = []
    k = 0
    while k < n:
        if not g[k]:
            k += 1
            continue
        j = k
        while j < n and g[j]:
            j += 1
        runs.append((int(order[k]), j - k))
        k = j
    queue = []
    for s0, length in runs:
        if length == n and n > 1:  # a whole cycle cannot be one strip: cut it in two
            queue += [(s0, n // 2), ((s0 + n // 2) % n, n - n // 2)]
        else:
            queue.append((s0, length))
    while queue:
        idx = [((s0 + np.arange(length + 1)) % n) for s0, length in queue]
        order_ = np.concatenate([np.concatenate((i, i[::-1], i[:1])) for i in idx])
        from_offset = np.concatenate([np.r_[np.zeros(len(i), bool), np.ones(len(i), bool), False] for i in idx])
        coords = np.where(from_offset[:, None], offset[order_], crisp[order_])
        sizes = np.array([2 * len(i) + 1 for i in idx])
        which = np.repeat(np.arange(len(queue)), sizes)
        polys = shapely.polygons(shapely.linearrings(coords, indices=which))
        ok = shapely.is_valid(polys)
        # shoelace area of every strip at once (each strip's closing vertex repeats its first)
        x, y = coords[:, 0], coords[:, 1]
        cross = x[:-1] * y[1:] - x[1:] * y[:-1]
        starts = np.concatenate(([0], np.cumsum(sizes)[:-1]))
        area = 0.5 * np.add.reduceat(np.append(cross, 0.0), starts)
        last = starts + sizes - 1  # the closing vertex to the next strip's first is not an edge
        area -= 0.5 * np.append(cross, 0.0)[last]
        ok &= area * sign > 0
        parts.extend(polys[ok])
        nxt_queue = []
        for (s0, length), fine in zip(queue, ok):
            if fine:
                continue
            if length > 1:
                h = length // 2
                nxt_queue += [(s0, h), ((s0 + h) % n, length - h)]
            else:
                parts.append(swept_hulls(crisp[[s0, nxt[s0]]], offset[[s0, nxt[s0]]])[0])
        queue = nxt_queue
    return [q for q in parts if q.geom_type in ("Polygon", "MultiPolygon") and not q.is_empty]


def proper_polygon(crisp: np.ndarray, offset: np.ndarray, own: int, side: int, *, kept: bool = False,
                   tol: float | None = None) -> ProperPolygon:
    """One ring's side of an α-cut as a proper polygon. Thesis 4.1.2.

    crisp, offset (n, 2): the crisp ring and its offset vertices read from the parametric lines;
    own: orientation of the crisp ring (+1 counter-clockwise); side: +1 for the IN side (the
    ring's polygon shrinks), −1 for the OUT side (it grows).

    If the offset ring is simple (GEOS), wound like the crisp ring and no band between them
    folds, the offset ring's polygon is the answer. Otherwise the ring self-intersects (sharp or
    reflex corners, short edges, narrow corridors) and the proper polygon is the crisp polygon
    minus (IN) or plus (OUT) the region swept by the edges on their way from the crisp ring to
    the offset: inverted loops have been swept over and do not survive, and what is left is
    wound positively. Of the positively wound regions only those no edge has swept over are
    kept, so that α-cuts nest (a region the sweep passed over, even if the ring winds round it
    again, is not certain free space). When the offset splits, the result has several pieces.

    With ``kept=True`` also says which offset vertices and edges survive on the boundary
    (within ``tol``, default 1e-9 of the ring's size).
    """
    c = np.asarray(crisp, dtype=np.float64)
    p = np.asarray(offset, dtype=np.float64)
    n = len(p)
    sign = own * side
    closed = np.vstack((p, p[:1]))
    folds = band_folds(c, p, sign)
    size = float(np.ptp(p, axis=0).max())
    simple = (bool(shapely.is_simple(shapely.linearrings(closed))) and signed_area(p) * own > 1e-12 * size * size
              and not folds.any())
    if simple:
        geom = shapely.polygons(closed)
        flags = np.ones(n, bool)
        return ProperPolygon(geom, True, flags if kept else None, flags.copy() if kept else None)
    base = shapely.polygons(np.vstack((c, c[:1])))
    swept = _swept_parts(c, p, sign, folds)
    # one n-ary union with the crisp polygon: GEOS's binary union of a polygon with a swept
    # region that touches it at a spike was seen to leave a spurious hole
    geom = shapely.difference(base, shapely.union_all(swept)) if side > 0 else shapely.union_all([base, *swept])
    geom = clean(geom, 1e-12 * float(np.ptp(np.vstack((c, p)), axis=0).max()) ** 2)
    if not kept:
        return ProperPolygon(geom, False)
    return ProperPolygon(geom, False, *survivors(geom, p, tol))


def survivors(geom: shapely.Geometry, p: np.ndarray, tol: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Which vertices of ring p (n, 2), and which of its edges, lie on the boundary of geom.

    A vertex survives within ``tol`` of the boundary. An edge survives where a stretch of it
    longer than min(4·tol, half the edge) is boundary: the boundary segments that run along it
    (both ends of the part beside the edge within ``tol`` of its line) are projected onto it and
    their union measured. Merely touching the boundary does not count, however shallow the angle
    (an edge leaving a surviving vertex at 8° to the boundary is within tol of it for 7·tol).
    Boundary segments are paired with edges through an STRtree, so this is O(n log n) in the
    sizes of ring and boundary.
    """
    n = len(p)
    if tol is None:
        tol = 1e-9 * max(1.0, float(np.ptp(p, axis=0).max()))
    boundary = shapely.boundary(geom)
    if boundary is None or boundary.is_empty:
        return np.zeros(n, bool), np.zeros(n, bool)
    # prepared boundary as the first argument: GEOS uses its index only there (else O(n) a test)
    shapely.prepare(boundary)
    vkept = shapely.dwithin(boundary, shapely.points(p), tol)
    q = np.roll(p, -1, axis=0)
    segs = shapely.linestrings(np.stack((p, q), axis=1))
    cand = np.flatnonzero(shapely.dwithin(boundary, segs, tol))
    ekept = np.zeros(n, bool)
    if not len(cand):
        return vkept, ekept
    xy, part = shapely.get_coordinates(shapely.get_parts(boundary), return_index=True)
    link = part[1:] == part[:-1]
    b0, b1 = xy[:-1][link], xy[1:][link]
    tree = shapely.STRtree(shapely.linestrings(np.stack((b0, b1), axis=1)))
    i, j = tree.query(segs[cand], predicate="dwithin", distance=tol)
    e = cand[i]
    edge_length = np.hypot(*(q - p).T)
    a, d = p[e], q[e] - p[e]
    length = np.where(edge_length[e] > 0, edge_length[e], np.nan)  # an edge collapsed to a point has no stretch
    # where each boundary segment's ends project onto the edge (0 at p, 1 at q), and how far off
    w0, w1 = b0[j] - a, b1[j] - a
    l0, l1 = np.einsum("ij,ij->i", w0, d) / length**2, np.einsum("ij,ij->i", w1, d) / length**2
    h0, h1 = _cross(d, w0) / length, _cross(d, w1) / length
    lo, hi = np.clip(np.minimum(l0, l1), 0.0, 1.0), np.clip(np.maximum(l0, l1), 0.0, 1.0)
    # offsets at the ends of the part beside the edge (linear along the boundary segment)
    span = np.where(l1 != l0, l1 - l0, 1.0)
    off_lo = np.abs(h0 + (lo - l0) / span * (h1 - h0))
    off_hi = np.abs(h0 + (hi - l0) / span * (h1 - h0))
    along = (hi > lo) & (off_lo <= tol) & (off_hi <= tol)  # False where NaN
    e, lo, hi = e[along], lo[along], hi[along]
    # length of the union of each edge's intervals: sorted by edge then start, an interval adds
    # what reaches beyond the furthest end so far (edges kept apart by offsets of 2)
    order = np.lexsort((lo, e))
    e, lo, hi = e[order], lo[order] + 2.0 * e[order], hi[order] + 2.0 * e[order]
    reach = np.maximum.accumulate(hi)
    before = np.r_[-np.inf, reach[:-1]]
    on = np.bincount(e, weights=np.maximum(0.0, hi - np.maximum(lo, before)), minlength=n)
    ekept = on * edge_length > np.minimum(4 * tol, 0.5 * edge_length)
    return vkept, ekept


# ---------------------------------------------------------------------------------------------
# Membership in a swept band


def band_parameter(p: np.ndarray, c0: np.ndarray, c1: np.ndarray, a0: np.ndarray, a1: np.ndarray,
                   eps: float = 1e-9) -> np.ndarray:
    """(m,) smallest u in [0, 1] at which the swept segment passes through each point, else NaN.

    One band of one edge: the segment from c0 + u·a0 to c1 + u·a1 (c crisp vertices, a the
    vectors to the support points VIN − C or VOUT − C), swept from u = 0 (crisp edge) to u = 1
    (support). Solves p = (1−λ)(c0 + u·a0) + λ(c1 + u·a1) for u with λ in [0, 1]: a quadratic
    in u. Where the band folds over (the two bisectors cross), the smaller u is returned.
    """
    q = p - c0
    e = c1 - c0
    da = a1 - a0

    def cross(u, v):
        return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]

    qa = -cross(a0, da)
    qb = cross(q, da) - cross(a0, e)
    qc = cross(q, e)
    scale = np.maximum(np.abs(qa) + np.abs(qb), 1e-300)
    lin = np.abs(qa) <= 1e-12 * scale
    disc = qb * qb - 4 * qa * qc
    sq = np.sqrt(np.maximum(disc, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        # numerically stable roots
        qq = -0.5 * (qb + np.copysign(sq, qb))
        r1 = np.where(lin, -qc / qb, qq / qa)
        r2 = np.where(lin, np.nan, qc / qq)
    r1 = np.where(disc < 0, np.nan, r1)
    r2 = np.where(disc < 0, np.nan, r2)
    size = np.hypot(e[:, 0], e[:, 1]) + np.hypot(a0[:, 0], a0[:, 1]) + np.hypot(a1[:, 0], a1[:, 1])
    best = np.full(len(p), np.nan)
    for r in (r1, r2):
        ok = np.isfinite(r) & (r >= -eps) & (r <= 1 + eps)
        u = np.clip(np.where(ok, r, 0.0), 0.0, 1.0)
        seg = e + u[:, None] * da
        start = q - u[:, None] * a0
        den = np.einsum("ij,ij->i", seg, seg)
        lam = np.where(den > 0, np.einsum("ij,ij->i", start, seg) / np.where(den > 0, den, 1.0), 0.5)
        ok &= (lam >= -eps) & (lam <= 1 + eps)
        # the point must lie on the segment, not only on its line (matters where it collapses)
        foot = start - np.clip(lam, 0, 1)[:, None] * seg
        ok &= np.hypot(foot[:, 0], foot[:, 1]) <= eps * size
        best = np.where(ok & ~(best <= u), u, best)
    return best


def in_hull(p: np.ndarray, quad: np.ndarray) -> np.ndarray:
    """(m,) whether each point p (m, 2) lies in the convex hull of its four points quad (m, 4, 2).

    The hull of four points is the union of the four triangles on three of them (Carathéodory),
    so this is four signed-area tests per point, with a tolerance relative to the quad's size.
    """
    size = np.ptp(quad, axis=1).max(axis=1)
    tol = 1e-12 * size * size
    lo, hi = quad.min(axis=1), quad.max(axis=1)
    inside = np.zeros(len(p), bool)
    for i, j, k in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)):
        a, b, c = quad[:, i], quad[:, j], quad[:, k]
        d1 = _cross(b - a, p - a)
        d2 = _cross(c - b, p - b)
        d3 = _cross(a - c, p - c)
        inside |= ((d1 >= -tol) & (d2 >= -tol) & (d3 >= -tol)) | ((d1 <= tol) & (d2 <= tol) & (d3 <= tol))
    margin = 1e-9 * size[:, None]
    return inside & np.all((p >= lo - margin) & (p <= hi + margin), axis=1)
