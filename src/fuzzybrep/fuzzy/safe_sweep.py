"""The conservative sweep: α-cuts that never promise more free space than the uncertainty allows,
read in O(n) from lines stored per vertex and made proper by one winding-number union.

The thesis's single normal vertex moves a corner d along its bisector, so the offset edges lie only
d·sin(θ/2) from the crisp ones near a corner of angle θ: its inner cut reaches into the band where
the boundary may lie. This sweep keeps the thesis's idea (every α-cut vertex is a stored vertex
moved along a stored direction by the α-cut's distance, no offsetting algorithm run per α) with
the directions chosen so that the cut is provably on the safe side of the exact one (the Extension
principle, ``exact``):

    inner(α) ⊆ crisp ⊖ d_in(α)        outer(α) ⊇ crisp ⊕ d_out(α)

(⊖, ⊕: erosion and dilation by a disc whose radius is the distance of the nearest boundary's own
membership function), for every map and α.

**Rectangles and fans.** Orient every ring with the free space on its left (principal polygons
counter-clockwise, holes clockwise). For edge e and a distance D, R_e(D) is the rectangle of
height D on a chosen side of e. At a vertex where that side is the outside of the turn (the *arc
side*: there the exact offset is an arc of radius D about the vertex), the fan F_V(D) is the
polygon V, V + D·n_e, c_0, …, c_{k−1}, V + D·n_h (n_e, n_h the two edges' normals on that side),
where the chain c_j = V + D·u_j circumscribes the arc: k tangent
segments of equal angle ψ/k (ψ the turn), c_j at angle (j + ½)·ψ/k from the first edge's normal
and radius D / cos(ψ/2k). c_0 lies on e's offset line and c_{k−1} on the next edge's, so the fan
contains the disc sector the exact offset sweeps there. k (``fan_pieces``): one point (the
mitre, D/sin(θ/2) along the bisector) up to a 60° turn, two (a bevel tangent to the disc) up to
120°, four beyond: an even k above 60° puts a tangent point on the bisector, so the cut is exact
at a sharp corner's tip (three pieces for a spike put a chain vertex there, 15 % of D further
out). A fan's area beyond its sector is D²·k·(tan x − x), x = ψ/2k ≤ 30°: at most 10.3 % of the
sector's area, the only place the band is wider than the exact one (on the real maps, where most
corners turn by 90-170°, the band is about 1 % wider).

**Lemma 1 (cover).** For a closed region F bounded by rings, one distance D, and a point p ∈ F
with dist(p, ∂F) < D, let q be a nearest point of ∂F. The segment pq lies in F, so p
is on the free side of the boundary at q. If q is inside edge e, p ∈ R_e(D) on its free side. If q
is a vertex V, p − V lies in the vertex's normal cone, which is non-trivial only on the arc side,
between the two edge normals; there p is in the sector of radius D, so in F_V(D). Hence
{p ∈ F : dist(p, ∂F) < D} ⊆ ∪ R_e(D) ∪ ∪ F_V(D), all on the free side (the same holds outside F,
with rectangles and fans on the other side).

**Lemma 2 (winding).** Let C be the rings (as a 1-cycle; winding number w_C = 1 in the crisp free
space, 0 outside, holes being clockwise) and L the *raw offset curve*: every edge's offset segment
at height D on the free side, joined at each vertex by a detour V + D·n_e → V → V + D·n_h on the
inside of the turn, or by the chain c_0 … c_{k−1} on the arc side. Then, as 1-chains,

    L = C − Σ_e ∂R_e − Σ_V ∂F_V            (∂: counter-clockwise boundary)

because ∂R_e = e + (up at its end) + (its top, backwards) + (down at its start), so C − Σ ∂R_e
is every top joined by the detours, and the chain equals the detour minus the fan's boundary (the
chain turns clockwise round V on the arc side). So w_L(x) = w_C(x) − #{rectangles and fans ∋ x}
and the positive-winding region {w_L > 0} is exactly F − ∪R_e − ∪F_V. On the other side the same
curve with +: w = w_C + #{…}, and {w > 0} = F ∪ ∪R_e ∪ ∪F_V.

Together: {w_L > 0} ⊆ F ⊖ D (Lemma 1; the crisp region minus more than the exact band), and the
outer region ⊇ F ⊕ D. Only fans add area beyond the exact band, so the band is at most 10.3 %
(of the fans' share of it) wider. The union with the *positive* fill rule (Clipper2 through
``pyclipr``; any winding-number overlay does) is the proper-polygon step of thesis 4.1.2: it
removes exactly what folded or self-intersected (inverted loops have w ≤ 0; narrow corridors,
where the walls' rectangles overlap, go; a spike's tip that the offset passes over goes) and
adds nothing, for every ring and every map, however the rings interact, since w counts every
rectangle of every ring.

**Mitres inside the turn.** A detour costs three points (and two crossings for the union to
resolve). Where the turn ψ is at most 90°, both edges are at least D·sin ψ long and the ring is
at least 3·D across, the detour is replaced by the apex A where the two offset lines meet (one point),
chosen per α (``SafeLines.upto``): w changes by ±1 in the kite V, V + D·n_e, A, V + D·n_h (+ on the free
side, − on the other), and the kite lies in both R_e and R_h (its corners are at most D·sin ψ from V
along each edge and at most D above it). A point in the kites of k corners of a ring, not all of
its corners, lies in the rectangles of at least k + 1 of its edges, so on the free side w ≤
1 − (k + 1) + k ≤ 0 stays so, and on the other side w ≥ (k + 1) − k > 0 stays so: {w > 0} does
not change. No point lies in every kite of a ring wider than 2√2·D (a kite is within √2·D of its
corner), hence the ring's 3·D (a small hole that the offset swallows whole keeps its detours:
with mitres at all four corners of a square of side D, its rectangles and kites cancel exactly,
a case the property tests found). Sharper turns keep the detour: there the kite reaches beyond
both rectangles' common part, and two corners' kites may hold a point that only their own
rectangles cover.

**Rings the offset swallows.** A hole with no disc of radius D inside it (its inradius, bounded
once per map from GEOS's maximum inscribed circle, is under D: a thin wall however long) is all
band, and so is a piece of explored space that narrow: their rings are left out of the union of
the side that swallows them (``vanishing``), which gives the same region and spares the union
their loops (on the shared logs' maps at α = 0.9, a third of the outer cut's points).

**Several distances.** Lemma 1 needs the distance of the nearest boundary, and with different
functions the band of one edge can reach past a nearer boundary whose own distance is smaller (a
wide band behind a thin wall), or a d_in band can meet a d_out one (sided functions, in another
piece of explored space). So the O(n) raw curve above is used only when one symmetric function
serves every vertex (``uniform``: every map fuzzybrep builds, frontiers included, unless
``--frontier-mf`` or ``--mf`` gives sided or several functions). Otherwise every edge gets its own
*stadium* S_e: the segment's buffer by r_e = the largest distance of its two vertices (inward and
outward), circumscribed (straight sides at ±r_e, each cap a chain of 4 tangent segments). The
exact band is the union over half-edges of their buffers by their own vertex's distance on the
side each point lies, so it lies in ∪S_e (a half-edge's cap at the edge's middle reaches at most
r_e beyond it, into S_e's rectangle or its end cap); the cut is crisp − ∪S_e and crisp ∪ ∪S_e,
with the same winding union (w = w_C ∓ #{S_e ∋ x}). Its band is wider than the exact one where a
sided function's narrow side takes its wide distance.

**Nesting and α = 1.** Every rectangle, fan and stadium grows with its distance, and d_in(α),
d_out(α) do not increase with α, so the removed (added) set shrinks as α grows: the cuts nest.
At α = 1 every distance is 0 and the cut is the crisp map itself (no union is run).

**Rounding.** Clipper2 works on integers: coordinates are taken relative to the map's centre and
scaled so that the map spans 2^40 units, and every distance is enlarged by ROUND_UNITS units
(4·10^-12 of the map's size), which covers the rounding of the input points (half a unit) and of
the union's intersection points (one unit), so the containment holds for the floats returned.

Arrays in, arrays out; ``SafeLines`` is what is stored per vertex (thesis 4.1.2 keeps T, U, V, W),
``cut_paths`` reads an α-cut's paths from it in O(n) and ``proper`` is the union.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

#: largest turn one tangent segment of a fan may cover (radians): 60°, so a fan is at most
#: tan(30°)/30° − 1 = 10.3 % larger than its sector. 90° (two points for any turn beyond a right
#: angle, where 60° takes four beyond 120°) made the cut a quarter faster on the shared logs'
#: maps, whose frontier combs turn that sharply at most vertices, but their band 1.1-2.4 % wider
#: than the exact one (0.5-0.9 % here), and the held-out violations of fhw's safe band 0.10
#: points under the exact band's (0.04 here): the fans' excess takes free space at obstacle
#: corners, where the endpoints are
MAX_PIECE = np.pi / 3


def fan_pieces(psi: np.ndarray) -> np.ndarray:
    """Tangent segments of the fan round a turn ψ (radians): 1 up to MAX_PIECE, then an even
    number of at most MAX_PIECE each (2 up to 120°, 4 beyond), so that one touches the arc on
    the corner's bisector."""
    a = np.abs(np.asarray(psi, dtype=np.float64))
    return np.where(a <= MAX_PIECE * (1 + 1e-9), 1, 2 * np.ceil(a / (2 * MAX_PIECE) - 1e-9)).astype(np.int64)


#: how far beyond the distance a fan's or a stadium cap's corners reach: 1/cos(30°)
REACH = 1 / np.cos(max(MAX_PIECE / 2, np.pi / (2 * 4)))
#: pieces of a stadium's half-circle cap (45° each), and of the disc put round an exact spike
CAP_PIECES = 4
#: the map spans this many integer units in the union
SPAN_UNITS = 2.0**40
#: every distance is enlarged by this many units, which covers the rounding to the integer grid
ROUND_UNITS = 4.0
#: a turn within this of ±180° (sin of the angle between the edges) is a spike of unknown side
_SPIKE = 1e-12


@dataclass(frozen=True, eq=False)
class SafeLines:
    """Per-vertex directions of the conservative sweep, for every ring stacked (free space left).

    For side ``s`` (0: the free side, what the inner cut offsets; 1: the other side, the outer
    cut) the α-cut's path points are ``V[base[s]] + D · unit[s]``, one path per ring (``ring[s]``
    says whose; rings beyond the map's, ``ring[s] ≥ rings``, are the discs round exact spikes).
    Inside a turn every vertex stores its detour (three points, the middle one flagged in
    ``mid[s]``) and, in ``apex[s]``, the mitre that replaces it for distances up to
    ``upto[s]`` (−1: never), so that an α-cut keeps the one point where it may.
    """

    vertices: np.ndarray          # (N, 2) oriented vertices
    base: tuple[np.ndarray, np.ndarray]
    unit: tuple[np.ndarray, np.ndarray]
    ring: tuple[np.ndarray, np.ndarray]
    mid: tuple[np.ndarray, np.ndarray]
    apex: tuple[np.ndarray, np.ndarray]
    upto: tuple[np.ndarray, np.ndarray]
    rings: int

    def select(self, side: int, d: float, drop: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(vertex of each point, its direction, its ring) of one side at distance d, without the
        rings ``drop`` (bool per map ring) says to leave out (the spike discs always stay)."""
        b, mid = self.base[side], self.mid[side]
        mitre = self.upto[side] >= d  # per point: its vertex may take the apex at this distance
        keep = ~mitre | mid
        if drop is not None and drop.any():
            ring = self.ring[side]
            mapped = np.flatnonzero(ring < len(drop))  # the spike discs (rings beyond the map's) stay
            keep[mapped] &= ~drop[ring[mapped]]
        keep = np.flatnonzero(keep)
        u = self.unit[side][keep]
        apex = mitre[keep]  # of the points kept, only the detours' middles take the apex
        u[apex] = self.apex[side][keep[apex]]
        return self.vertices[b[keep]], u, self.ring[side][keep]

    def points(self, side: int, d: float, drop: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(points (M, 2), ring of each) of one side at distance d: O(n) array arithmetic."""
        v, u, r = self.select(side, d, drop)
        u *= d
        u += v
        return u, r


def orient(vertices: np.ndarray, sizes: np.ndarray, free_left: np.ndarray) -> np.ndarray:
    """Index array that reverses every ring whose free space is not on its left (``free_left``
    per ring False), so that principal polygons run counter-clockwise and holes clockwise."""
    sizes = np.asarray(sizes)
    start = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    idx = np.arange(int(sizes.sum()))
    local = idx - np.repeat(start, sizes)
    flip = ~np.repeat(np.asarray(free_left, bool), sizes)
    return np.where(flip, np.repeat(start + sizes - 1, sizes) - local, idx)


def _rot(u: np.ndarray, a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.column_stack((c * u[:, 0] - s * u[:, 1], s * u[:, 0] + c * u[:, 1]))


def safe_lines(vertices: np.ndarray, sizes: np.ndarray) -> SafeLines:
    """The conservative sweep's per-vertex directions of rings oriented with the free space on
    their left (``orient``). O(n), once per map."""
    v = np.asarray(vertices, dtype=np.float64)
    sizes = np.asarray(sizes)
    n = len(v)
    start = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    ring = np.repeat(np.arange(len(sizes)), sizes)
    nxt = np.arange(n) + 1
    nxt[start + sizes - 1] = start
    prv = np.empty_like(nxt)
    prv[nxt] = np.arange(n)
    d = v[nxt] - v  # edge i: vertex i -> i + 1
    length = np.hypot(d[:, 0], d[:, 1])
    t = d / np.where(length > 0, length, 1.0)[:, None]
    t_e, t_h = t[prv], t  # at vertex i: incoming edge i − 1, outgoing edge i
    n_e = np.column_stack((-t_e[:, 1], t_e[:, 0]))  # left normals
    n_h = np.column_stack((-t_h[:, 1], t_h[:, 0]))
    cross = t_e[:, 0] * t_h[:, 1] - t_e[:, 1] * t_h[:, 0]
    dot = np.einsum("ij,ij->i", t_e, t_h)
    psi = np.arctan2(cross, dot)  # the turn, + to the left
    spike = (np.abs(cross) <= _SPIKE) & (dot < 0)
    # the mitre inside a turn of at most 90° stands in for the detour up to the distance that
    # both edges are long and a third of the ring's extent (the docstring's kites), with a
    # little slack for rounding
    span = float(np.ptp(v, axis=0).max()) if n else 0.0
    extent = np.maximum(np.maximum.reduceat(v[:, 0], start) - np.minimum.reduceat(v[:, 0], start),
                        np.maximum.reduceat(v[:, 1], start) - np.minimum.reduceat(v[:, 1], start))
    # the kite reaches D·max(sin ψ, tan ψ/2) = D·sin ψ (ψ ≤ 90°) along each edge from the corner
    reach = np.maximum(np.maximum(np.sin(np.abs(psi)), np.tan(np.abs(psi) / 2)), 1e-300)
    upto = (np.minimum(np.minimum(length[prv], length) / reach, extent[ring] / 3) - 1e-9 * span) / (1 + 1e-6)
    upto = np.where(np.abs(psi) <= np.pi / 2, upto, -1.0)
    base, unit, rings, mids, apexes, uptos = [], [], [], [], [], []
    for sigma in (1.0, -1.0):  # free side (left), other side (right)
        m_e, m_h = sigma * n_e, sigma * n_h
        arc = (sigma * psi < 0) & ~spike  # this side is outside the turn
        k = np.where(arc, fan_pieces(psi), 0)
        count = np.where(arc, k, 3)
        first = np.concatenate(([0], np.cumsum(count)[:-1]))
        total = int(count.sum())
        owner = np.repeat(np.arange(n), count)
        j = np.arange(total) - first[owner]
        u = np.empty((total, 2))
        # outside the turn: chain vertex j at angle (j + ½)·ψ/k from m_e, radius 1/cos(ψ/2k)
        a = arc[owner]
        half = psi[owner[a]] / (2 * k[owner[a]])
        u[a] = _rot(m_e[owner[a]], (2 * j[a] + 1) * half) / np.cos(half)[:, None]
        # inside the turn: the detour V + n_e, V, V + n_h, and the apex of the offset lines
        q = ~a
        oq, jq = owner[q], j[q]
        u[q] = np.where((jq == 0)[:, None], m_e[oq], np.where((jq == 1)[:, None], 0.0, m_h[oq]))
        mid = q.copy()
        mid[q] = jq == 1
        apex = np.zeros((total, 2))
        me, mh = m_e[owner[mid]], m_h[owner[mid]]
        cos = np.einsum("ij,ij->i", me, mh)  # −1 only at spikes, which never take the apex
        apex[mid] = (me + mh) / np.where(cos > -1.0, 1.0 + cos, 1.0)[:, None]
        up = np.where(q & ~spike[owner], upto[owner], -1.0)
        r = ring[owner]
        b = owner
        # exact spikes: a circumscribed disc round the vertex as a loop of its own, both sides
        sp = np.flatnonzero(spike)
        if len(sp):
            ang = (np.arange(2 * CAP_PIECES) + 0.5) * (np.pi / CAP_PIECES)
            disc = np.column_stack((np.cos(ang), np.sin(ang))) / np.cos(np.pi / (2 * CAP_PIECES))
            if sigma > 0:  # the free side subtracts it: clockwise
                disc = disc[::-1]
            m = len(disc) * len(sp)
            b = np.concatenate((b, np.repeat(sp, len(disc))))
            u = np.vstack((u, np.tile(disc, (len(sp), 1))))
            r = np.concatenate((r, len(sizes) + np.repeat(np.arange(len(sp)), len(disc))))
            mid = np.concatenate((mid, np.zeros(m, bool)))
            apex = np.vstack((apex, np.zeros((m, 2))))
            up = np.concatenate((up, np.full(m, -1.0)))
        base.append(b)
        unit.append(u)
        rings.append(r)
        mids.append(mid)
        apexes.append(apex)
        uptos.append(up)
    arrays = (v, *base, *unit, *rings, *mids, *apexes, *uptos)
    for arr in arrays:
        arr.setflags(write=False)
    return SafeLines(v, tuple(base), tuple(unit), tuple(rings), tuple(mids), tuple(apexes), tuple(uptos),
                     len(sizes))


def stadiums(vertices: np.ndarray, sizes: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every edge's circumscribed stadium at half-width r (N,) (edges with r = 0 left out):
    (points (8m, 2), start of each stadium). Counter-clockwise."""
    v = np.asarray(vertices, dtype=np.float64)
    sizes = np.asarray(sizes)
    n = len(v)
    start = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    nxt = np.arange(n) + 1
    nxt[start + sizes - 1] = start
    keep = np.flatnonzero(r > 0)
    a, b = v[keep], v[nxt[keep]]
    t = b - a
    t /= np.hypot(t[:, 0], t[:, 1])[:, None]
    nrm = np.column_stack((-t[:, 1], t[:, 0]))
    ang = (np.arange(CAP_PIECES) + 0.5) * (np.pi / CAP_PIECES)  # from −n through t to +n at b
    c, s = np.cos(ang) / np.cos(np.pi / (2 * CAP_PIECES)), np.sin(ang) / np.cos(np.pi / (2 * CAP_PIECES))
    # at b: −n·cos + t·sin ; at a: +n·cos − t·sin
    rr = r[keep][:, None, None]
    cap_b = b[:, None] + rr * (-nrm[:, None] * c[None, :, None] + t[:, None] * s[None, :, None])
    cap_a = a[:, None] + rr * (nrm[:, None] * c[None, :, None] - t[:, None] * s[None, :, None])
    pts = np.concatenate((cap_b, cap_a), axis=1).reshape(-1, 2)
    return pts, 2 * CAP_PIECES * np.arange(len(keep))


# ---------------------------------------------------------------------------------------------
# The union: positive winding, Clipper2 (pyclipr)


def cut_paths(lines: SafeLines, side: int, d: float, scale: float,
              drop: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The raw offset curve of one side at distance d (enlarged by the rounding margin): all
    points (M, 2) and where each ring's (and each spike disc's) path starts. O(n) from the
    stored directions. ``drop``: rings (bool per ring) left out, as ones the offset swallows
    whole (``vanishing``)."""
    pts, ring = lines.points(side, d + ROUND_UNITS / scale, drop)
    return pts, np.flatnonzero(np.r_[True, ring[1:] != ring[:-1]])


def inradius_bound(vertices: np.ndarray, start: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """(rings,) an upper bound on each ring's polygon's inradius (the radius of the largest disc
    inside it; the polygon's erosion by a larger distance is empty): the smaller of half its
    box's smaller side and GEOS's maximum inscribed circle plus twice that search's tolerance
    (1 % of the box's smaller side; the search stops once no unsearched cell can hold a disc
    larger than its best by more than the tolerance). Once per map."""
    lo_x, hi_x = np.minimum.reduceat(vertices[:, 0], start), np.maximum.reduceat(vertices[:, 0], start)
    lo_y, hi_y = np.minimum.reduceat(vertices[:, 1], start), np.maximum.reduceat(vertices[:, 1], start)
    half = 0.5 * np.minimum(hi_x - lo_x, hi_y - lo_y)
    polygons = shapely.polygons(shapely.linearrings(vertices, indices=np.repeat(np.arange(len(sizes)), sizes)))
    tol = np.maximum(0.02 * half, 1e-12)
    mic = shapely.length(shapely.maximum_inscribed_circle(polygons, tol))
    return np.minimum(half, mic * (1 + 1e-9) + 2 * tol)


def vanishing(inradius: np.ndarray, region_of: np.ndarray, shell: np.ndarray, side: int, d: float) -> np.ndarray:
    """Rings (bool per ring) whose part of one side's raw curve may be left out at distance d:
    every point of a ring's polygon whose inradius (``inradius_bound``) is under d is nearer
    than d to its ring, so the offset into it swallows it whole. On the free side
    (the inner cut) a region whose principal polygon is swallowed has no inner cut: all its rings
    go (a point of another region near them is nearer still to its own region's boundary, which
    its own rectangles cover, Lemma 1); on the other side (the outer cut) a swallowed hole is all
    band: without its ring, the winding number inside it is its principal polygon's, 1."""
    small = inradius < d
    if side == 1:
        return small & ~shell
    gone = np.zeros(int(region_of.max()) + 1, bool)
    gone[region_of[shell & small]] = True
    return gone[region_of]


def stadium_paths(vertices: np.ndarray, sizes: np.ndarray, r: np.ndarray, side: int,
                  scale: float) -> tuple[np.ndarray, np.ndarray]:
    """The oriented crisp rings and every edge's stadium (clockwise for the free side, which
    they are taken from; counter-clockwise for the other side, to which they are added), as
    ``cut_paths`` gives them: all points and where each path starts."""
    r = np.where(r > 0, r + ROUND_UNITS / scale, 0.0)
    pts, st = stadiums(vertices, sizes, r)
    if side == 0:  # every stadium backwards: 8 points each
        pts = pts.reshape(-1, 2 * CAP_PIECES, 2)[:, ::-1].reshape(-1, 2)
    ring_starts = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    return np.vstack((vertices, pts)), np.concatenate((ring_starts, len(vertices) + st))


def grid(vertices: np.ndarray) -> tuple[np.ndarray, float]:
    """(centre, scale) of the integer grid the union works on: the map spans SPAN_UNITS."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    span = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-300))
    return 0.5 * (lo + hi), SPAN_UNITS / span


def proper(paths: tuple[np.ndarray, np.ndarray], centre: np.ndarray, scale: float) -> shapely.Geometry:
    """The region of positive winding number of closed ``paths`` (points, start of each path, as
    ``cut_paths`` gives them), as a valid
    Polygon or MultiPolygon: one union with Clipper2's positive fill rule (its flat output: outer
    rings counter-clockwise, holes clockwise), every hole given to the smallest outer ring that
    holds its first vertex, and all polygons made in one vectorised call."""
    import pyclipr

    c = pyclipr.Clipper()
    # coordinates of order one, and Clipper's own scale for the rest: pyclipr refuses a scale
    # factor of 1e-38 (a map 1e50 across)
    unit = SPAN_UNITS**0.5 / scale
    c.scaleFactor = SPAN_UNITS**0.5
    pts, starts = paths
    pts = (pts - centre) / unit
    ends = np.r_[starts[1:], len(pts)]
    big = np.flatnonzero(ends - starts >= 3).tolist()  # slices: np.split costs 7 µs a path
    c.addPaths([pts[starts[k]:ends[k]] for k in big], pyclipr.Subject)
    out = [r for r in c.execute(pyclipr.Union, pyclipr.FillRule.Positive) if len(r) >= 3]
    if not out:
        return shapely.MultiPolygon()
    sizes = np.array([len(r) for r in out])
    xy = np.vstack(out) * unit + centre  # pyclipr returns them unscaled
    ring_of = np.repeat(np.arange(len(out)), sizes)
    x, y = xy[:, 0], xy[:, 1]
    heads = np.cumsum(sizes) - sizes
    nxt = np.arange(len(xy)) + 1
    nxt[heads + sizes - 1] = heads
    area = 0.5 * np.add.reduceat(x * y[nxt] - x[nxt] * y, heads)
    rings = shapely.linearrings(xy, indices=ring_of)  # Shapely closes each ring
    outer = np.flatnonzero(area > 0)
    hole = np.flatnonzero(area < 0)
    owner = np.full(len(out), -1)
    owner[outer] = outer
    if len(hole):
        shells = shapely.polygons(rings[outer])
        # boxes first: a hole inside one outer ring's box only is that ring's (most are)
        h, o = shapely.STRtree(shells).query(shapely.points(xy[heads[hole]]))
        count = np.bincount(h, minlength=len(hole))
        one = count[h] == 1
        owner[hole[h[one]]] = outer[o[one]]
        many = ~one
        if many.any():
            inside = shapely.within(shapely.points(xy[heads[hole[h[many]]]]), shells[o[many]])
            hh, oo = h[many][inside], o[many][inside]
            # nested outer rings (an island in a hole): the smallest that holds it
            order = np.argsort(-area[outer[oo]])  # largest first, so the smallest is written last
            owner[hole[hh[order]]] = outer[oo[order]]
    keep = owner >= 0
    group = np.argsort(np.where(keep, owner, len(out)) * 2 + (area < 0), kind="stable")[: int(keep.sum())]
    owners = np.unique(owner[group])
    polys = shapely.polygons(rings[group], indices=np.searchsorted(owners, owner[group]))
    # Clipper2's output does not cross itself, but rings may touch at a vertex, which GEOS calls
    # invalid within a ring (and along an edge between rings): such rings repeat a point. Only
    # polygons with a repeated point are asked (GEOS's is_valid on every one cost as much as the
    # union itself)
    # sorted by x alone first (a tenth of a lexsort's time): most outputs have no two points
    # with the same x, and then no repeated point; else x + iy sorts as (x, y), in a third of it
    xs = np.sort(x)
    same = np.zeros(0, bool)
    if (xs[1:] == xs[:-1]).any():
        z = x + 1j * y
        order = np.argsort(z)
        zs = z[order]
        same = zs[1:] == zs[:-1]
    if same.any():
        twice = ring_of[np.concatenate((order[1:][same], order[:-1][same]))]
        which = np.unique(np.searchsorted(owners, owner[twice[owner[twice] >= 0]]))
        bad = which[~shapely.is_valid(polys[which])]
        polys[bad] = shapely.make_valid(polys[bad], method="structure", keep_collapsed=False)
        parts = shapely.get_parts(polys)
        polys = parts[shapely.get_type_id(parts) == 3]
    return polys[0] if len(polys) == 1 else shapely.multipolygons(polys)
