"""Path planning in the space free at confidence α: shortest paths, and paths that keep clear.

    free      = the inner α-cut: free at confidence α (principal polygon shrunk, holes grown)
    safe      = free shrunk by the robot's radius                 (thesis 4.2: a safety margin)
    shortest  = the reduced visibility graph of the safe region's reflex corners, searched from
                start to goal (``visibility``)                     exact Euclidean shortest path
    clearance = the medial axis of the safe region (the GVD of thesis 2.2.3), entered from start
                and goal (``medial``)                              as far from obstacles as it can
    verify    = every path returned is covered by the safe region, to within ``Planner.tolerance``

``plan(map, start, goal)`` does it all; a ``Planner`` keeps the safe region and its graphs for
many queries, and ``planner(map, α, radius)`` keeps one per (α, radius, method) and map.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely

from .brep import BRepMap
from .errors import NoConnectionError, PlanError, PointNotFreeError
from .fuzzy import LARGEST, METHODS, FuzzyBRepMap, _check_alpha
from .medial import MedialAxis
from .sweep import polygonal
from .visibility import Triangulation, VisibilityGraph, shortest_chain

MODES = ("shortest", "clearance")
#: segments per quarter circle where the radius shrink rounds an obstacle's corner
QUAD_SEGS = 6
#: the free space is buffered by radius × this, so that no point of the safe region comes
#: nearer than the radius to its edge (``_shrink``): 2 % more margin along straight walls
RADIUS_FACTOR = 1 / (math.cos(3 * math.pi / (8 * QUAD_SEGS)) - 1e-3)
#: chords per quarter circle of the exact α-cut planned in (``free_space``)
EXACT_CUT_QUAD_SEGS = 8
#: GEOS needs a little slack: coordinates are snapped to a grid of about 1e-10 of the map's size
#: (merging vertices that rounding left 1e-15 apart), and paths are checked against the safe
#: region grown by ``RELATIVE_TOLERANCE`` times the map's size
RELATIVE_TOLERANCE = 1e-9
#: start and goal this far outside the safe region, times ``Planner.tolerance``, are on its edge
#: (``Planner.piece``): with the move into the region (``Planner._into``) at most 5/16 of the
#: tolerance, which the tolerance's buffer (one chord per quarter circle) covers everywhere
ON_EDGE = 1 / 4
#: clearance mode: boundary points for the medial axis, at most about this many
_MEDIAL_SITES = 40_000
#: clearance mode: how many nearest medial-axis nodes to try to step onto from start and goal,
#: and from each corner
_ENTRIES = 24
_LINKS = 4
#: clearance mode: a straight step off the medial axis costs this many times its length
OFF_AXIS_COST = 4.0


@dataclass(frozen=True, eq=False)
class Plan:
    """A planned path.

    path       (k, 2) from start to goal; every point and segment lies in the safe region
    length     its Euclidean length
    clearance  smallest distance from the path to the edge of the free space (the inner α-cut,
               or the geometry planned in): at least ``radius``
    note       why the path is not what ``mode`` asked for, if it is not (else None)
    """

    path: np.ndarray
    length: float
    mode: str
    alpha: float | None
    radius: float
    method: str | None
    clearance: float
    unit: str = "m"
    note: str | None = None

    def to_json(self) -> dict:
        out = {"path": self.path.tolist(), "length": self.length, "mode": self.mode, "alpha": self.alpha,
               "radius": self.radius, "method": self.method, "clearance": self.clearance, "unit": self.unit}
        if self.note:
            out["note"] = self.note
        return out


def free_space(source, alpha: float = 0.0, method: str = "sweep") -> shapely.Geometry:
    """The space free at confidence α: a fuzzy map's inner α-cut; a crisp map or a Shapely
    (Multi)Polygon as it is (α and method do not apply to them, but a bad one is refused).

    The exact α-cut is drawn with ``EXACT_CUT_QUAD_SEGS`` chords per quarter circle, not the 32 of
    ``FuzzyBRepMap.alpha_cut``: every chord's end is a reflex corner of the free space, and the
    visibility graph's cost grows with their square (Intel, α = 0.3: 47 000 corners and 44 s
    with 32, 14 000 and 4 s with 8). Its rounded corners are then up to 1.1 % of the α-cut's
    distance more generous than circles (2 mm for a TME of 0.2 m).
    """
    _applies(source, alpha, method)
    if isinstance(source, FuzzyBRepMap):
        _check_size(source.crisp_geometry, source.unit)
        if method == "exact":
            return source.alpha_cut(alpha, method, quad_segs=EXACT_CUT_QUAD_SEGS).inner
        return source.alpha_cut(alpha, method).inner
    if isinstance(source, BRepMap):
        return _check_size(source.to_shapely(), source.unit)
    if isinstance(source, shapely.Geometry):
        _check_size(source)
        return polygonal(shapely.make_valid(source) if not source.is_valid else source)
    raise TypeError(f"cannot plan in a {type(source).__name__}: give a FuzzyBRepMap, a BRepMap or a Shapely polygon")


def safe_region(source, alpha: float = 0.0, radius: float = 0.0, method: str = "sweep") -> shapely.Geometry:
    """Where the centre of a round robot of ``radius`` may go: the free space at confidence α
    (``free_space``) shrunk by the radius. Thesis 4.2: at α = 0 this is the inner bound of the
    support, "the space that the robot can navigate freely" at the highest confidence.

    ``method``: ``sweep`` (default) uses the map's own α-cut, the thesis's single normal
    vertex method; ``exact`` the Extension principle's (the crisp map buffered).
    """
    return _shrink(free_space(source, alpha, method), _check_radius(radius))


def _applies(source, alpha, method: str) -> float | None:
    """α checked, for a fuzzy map; None for a crisp map or a polygon, where α does not apply (nor
    the method), though a bad α or method given for one is refused all the same."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if isinstance(source, FuzzyBRepMap):
        return _check_alpha(alpha)
    if alpha is not None:
        _check_alpha(alpha)
    return None


def _check_size(geom: shapely.Geometry, unit: str = "m") -> shapely.Geometry:
    """``geom``, if its coordinates lie within ±``LARGEST``; else PlanError."""
    if not geom.is_empty:
        reach = float(np.abs(geom.bounds).max())
        if reach > LARGEST:
            raise PlanError(f"the map's coordinates reach {reach:.3g} {unit}: the planner works within "
                            f"±{LARGEST:g} {unit}, beyond which its arithmetic overflows")
    return geom


def _check_radius(radius) -> float:
    try:
        r = float(radius)
    except (TypeError, ValueError):
        raise PlanError(f"radius must be a number ≥ 0, got {radius!r}") from None
    if not (math.isfinite(r) and r >= 0):
        raise PlanError(f"radius must be a finite number ≥ 0, got {radius!r}")
    return r


def _extent(geom: shapely.Geometry) -> float:
    if geom.is_empty:
        return 1.0
    x0, y0, x1, y1 = geom.bounds
    return max(x1 - x0, y1 - y0, 1e-300)


def _grid(extent: float) -> float:
    # a power of two: coordinates already on it (integers, halves, ...) stay bit for bit
    return 2.0 ** math.floor(math.log2(extent * RELATIVE_TOLERANCE / 8))


def _floating(geom: shapely.Geometry) -> shapely.Geometry:
    """``geom`` without a fixed precision model (``shapely.set_precision`` leaves one on its result),
    coordinates unchanged: GEOS computes a buffer of such a geometry on its grid, so a shrink by
    0.3 on a 0.1 grid came out empty, and on a 0.5 grid larger than the region itself."""
    return shapely.set_precision(geom, 0) if shapely.get_precision(geom) > 0 else geom


def _shrink(free: shapely.Geometry, radius: float) -> shapely.Geometry:
    """free ⊖ disc(radius), never larger than the exact erosion, snapped and oriented.

    GEOS's buffer rounds an obstacle's corner with chords whose ends lie on the circle, so a
    chord's middle is only d·cos(θ/2) from the corner; θ is the corner's angle over the number
    of chords, which GEOS rounds to the nearest integer, so θ can reach 1.5 × 90°/q (measured
    on the Intel map: 0.957·d for q = 4, 0.989·d for q = 8). Buffering by
    d = radius / (cos(3π/8q) − 10⁻³) keeps every point at least ``radius`` from the edge of the
    free space. (GEOS also simplifies its input first, but only where that moves the curve away.)
    """
    free = _floating(free)
    extent = _extent(free)
    if radius > 0:
        if radius * RADIUS_FACTOR >= extent:
            # nothing lies that far inside; and GEOS overflows on a radius near the largest float
            return shapely.MultiPolygon()
        free = shapely.buffer(free, -radius * RADIUS_FACTOR, quad_segs=QUAD_SEGS)
    safe = polygonal(shapely.set_precision(polygonal(free), _grid(extent)))
    # keep the snapped coordinates but not GEOS's fixed precision model: with it, a later
    # buffer by the tolerance can drop a hole (GEOS 3.14)
    safe = shapely.set_precision(safe, 0)
    return shapely.orient_polygons(safe, exterior_cw=False) if not safe.is_empty else safe


class Planner:
    """Plans paths in one safe region; build once per (α, radius, method), query many times.

    free       the free space (inner α-cut, or the geometry given)
    safe       free shrunk by ``radius`` (``safe_region``)
    pieces     the safe region's connected pieces (Polygons), in GEOS's order (``largest_piece``)
    tolerance  how far outside the safe region GEOS rounding may put a point of a path that is
               accepted (RELATIVE_TOLERANCE × the map's size)

    The visibility graph (shortest mode) and the medial axis (clearance mode) are built on
    first use and kept.
    """

    def __init__(self, free: shapely.Geometry, radius: float = 0.0, *, alpha: float | None = None,
                 method: str | None = None, fuzzy: FuzzyBRepMap | None = None, unit: str = "m",
                 spacing: float | None = None):
        self.radius = _check_radius(radius)
        self.alpha = alpha
        self.method = method
        # weakly: a planner kept with its map (``planner``) must not keep the map alive
        self._fuzzy = None if fuzzy is None else weakref.ref(fuzzy)
        self.unit = fuzzy.unit if fuzzy is not None else unit
        if not isinstance(free, shapely.Geometry):
            raise TypeError(f"a Planner plans in a Shapely (Multi)Polygon, not a {type(free).__name__}: "
                            "Planner.of takes maps")
        self.free = _floating(polygonal(_check_size(free, self.unit)))
        self.safe = _shrink(self.free, self.radius)
        self.pieces = shapely.get_parts(self.safe)
        shapely.prepare(self.safe)
        shapely.prepare(self.pieces)
        self.extent = _extent(self.free)
        self.tolerance = RELATIVE_TOLERANCE * self.extent
        self._spacing = spacing

    @classmethod
    def of(cls, source, alpha: float = 0.0, radius: float = 0.0, method: str = "sweep", **kw) -> "Planner":
        """A planner for a fuzzy map at α (or for a crisp map or polygon, where α does not apply)."""
        alpha = _applies(source, alpha, method)
        fuzzy = source if isinstance(source, FuzzyBRepMap) else None
        unit = source.unit if isinstance(source, (FuzzyBRepMap, BRepMap)) else kw.pop("unit", "m")
        return cls(free_space(source, alpha or 0.0, method), radius, alpha=alpha,
                   method=method if fuzzy is not None else None, fuzzy=fuzzy, unit=unit, **kw)

    @property
    def largest_piece(self) -> shapely.Polygon:
        """The safe region's largest connected piece: any two points in it are joined by a path.

        PlanError if the safe region is empty (e.g. a radius wider than every corridor): an empty
        Polygon would only move the failure on, to whatever then looks for points in it."""
        self._not_empty("largest piece")
        return self.pieces[np.argmax(shapely.area(self.pieces))]

    def _not_empty(self, what: str) -> None:
        if len(self.pieces) == 0:
            raise PlanError(f"the safe region{self._where()} is empty: it has no {what}")

    @property
    def fuzzy(self) -> FuzzyBRepMap | None:
        """The fuzzy map planned in, while it lives (it explains why a point is not free)."""
        return None if self._fuzzy is None else self._fuzzy()

    # -- the graphs, built on first use ------------------------------------------------------

    @cached_property
    def visibility(self) -> VisibilityGraph:
        """PlanError if the safe region is empty (as ``largest_piece``)."""
        self._not_empty("visibility graph")
        return VisibilityGraph.of(self.safe)

    @cached_property
    def spacing(self) -> float:
        """Distance between the boundary points the medial axis is made from."""
        if self._spacing is not None:
            return float(self._spacing)
        return max(self.safe.length / _MEDIAL_SITES, self.extent / 2000)

    @cached_property
    def medial(self) -> MedialAxis:
        """PlanError if the safe region is empty (as ``largest_piece``)."""
        self._not_empty("medial axis")
        return MedialAxis.of(self.safe, self.spacing)

    @cached_property
    def _medial_tree(self):
        from scipy.spatial import cKDTree

        return cKDTree(self.medial.nodes) if len(self.medial.nodes) else None

    @cached_property
    def _triangulation(self) -> Triangulation:
        return self.visibility.triangulation if "visibility" in self.__dict__ else Triangulation.of(self.safe)

    @cached_property
    def _covering(self) -> shapely.Geometry:
        g = shapely.buffer(self.safe, self.tolerance, quad_segs=1)
        shapely.prepare(g)
        return g

    @cached_property
    def _free_boundary(self) -> shapely.Geometry:
        return shapely.boundary(self.free)

    # -- queries ----------------------------------------------------------------------------

    def piece(self, point, which: str = "point") -> int:
        """Index of the piece of the safe region holding ``point`` (its boundary included, to
        within ``ON_EDGE`` × ``tolerance``); PointNotFreeError saying why and how far off if none
        does.

        A point on the region's edge computed in floats (one between two vertices, or the
        nearest free point a PointNotFreeError names) lies as often just outside the edge as
        on it, and snapping the region's coordinates (``_shrink``) moves its edges by up to
        10⁻¹⁰ of the map's size: such a point is free as well."""
        p = _point(point, which)
        if np.abs(p).max() > LARGEST:  # the map lies within ±LARGEST (``_check_size``)
            raise PointNotFreeError(which, p, f"it lies far outside the map, beyond ±{LARGEST:g} {self.unit}, "
                                              "too far for its distance to be measured")
        inside = np.flatnonzero(shapely.intersects_xy(self.pieces, p[0], p[1]))
        if len(inside) == 0:
            d = shapely.distance(self.pieces, shapely.Point(p))
            if len(d) and d.min() <= ON_EDGE * self.tolerance:
                return int(np.argmin(d))
            raise self._not_free(which, p)
        return int(inside[0])

    def _into(self, p: np.ndarray, piece: int) -> np.ndarray | None:
        """``p`` if it lies in the piece, else a point of the piece within (``ON_EDGE`` + 1/16) ×
        ``tolerance`` of it (None if rounding defeats that): the walks and the triangulation
        decide exactly, and find no way from a point just outside the region.

        The nearest point of the piece, moved a sixteenth of the tolerance towards the middle of
        a triangle of the piece beside it: triangles are convex, so that stays in the piece."""
        region = self.pieces[piece]
        if shapely.intersects_xy(region, p[0], p[1]):
            return p
        tri = self._triangulation
        n = np.asarray(shapely.shortest_line(region, shapely.Point(p)).coords)[0]
        near = tri.near(n, self.tolerance)
        c = tri.points[tri.triangles[near]].mean(axis=1)
        c = c[shapely.intersects_xy(region, c[:, 0], c[:, 1])]
        for q in n + np.minimum(1, self.tolerance / 16 / np.hypot(*(c - n).T))[:, None] * (c - n):
            if shapely.intersects_xy(region, q[0], q[1]):
                return q
        return None

    def covers(self, path) -> bool:
        """Whether the polyline lies in the safe region (grown by ``tolerance`` for GEOS)."""
        path = np.asarray(path, dtype=np.float64)
        if path.ndim != 2 or path.shape[1] != 2 or len(path) == 0:
            raise ValueError(f"path must be a (k, 2) array of k ≥ 1 points, got shape {path.shape}")
        line = shapely.linestrings(path) if len(path) > 1 else shapely.points(path[0])
        return bool(shapely.covers(self._covering, line))

    def plan(self, start, goal, mode: str = "shortest") -> Plan:
        """The shortest path (``mode="shortest"``) or one along the medial axis
        (``mode="clearance"``) from start to goal inside the safe region.

        Raises PointNotFreeError if start or goal is not in the safe region, NoConnectionError
        if they lie in different pieces of it.
        """
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        s, g = _point(start, "start"), _point(goal, "goal")
        ps, pg = self.piece(s, "start"), self.piece(g, "goal")
        if ps != pg:
            raise NoConnectionError(
                f"start and goal lie in different pieces of the safe region{self._where()} (pieces {ps + 1} and "
                f"{pg + 1} of {len(self.pieces)}, areas {self.pieces[ps].area:.3g} and {self.pieces[pg].area:.3g} "
                f"{self.unit}²): no path joins them", ps, pg)
        given = s, g
        s, g = self._into(s, ps), self._into(g, pg)
        if s is None or g is None:
            raise PlanError(f"no verified path found between {tuple(given[0])} and {tuple(given[1])}: "
                            f"{'start' if s is None else 'goal'} lies on the edge of the safe region{self._where()}, "
                            "and rounding keeps it out")
        note = None
        path = self._clearance_path(s, g, ps) if mode == "clearance" else None
        if path is None:
            path, note = self._shortest_path(s, g, ps)
            if mode == "clearance":
                note = "; ".join(filter(None, ("the medial axis does not join start and goal: shortest path instead",
                                               note)))
        if s is not given[0] or g is not given[1]:
            # planned from points moved into the region by at most (ON_EDGE + 1/16) × tolerance:
            # the path starts and ends where asked, and is still within the tolerance of it
            path = np.vstack((given[0], path[1:-1], given[1]))
            if not self.covers(path):
                raise PlanError(f"no verified path found between {tuple(given[0])} and {tuple(given[1])} "
                                f"on the edge of the safe region{self._where()}")
            s, g = given
        d = np.diff(path, axis=0)
        length = float(np.hypot(d[:, 0], d[:, 1]).sum())
        line = shapely.linestrings(path) if len(path) > 1 else shapely.points(path[0])
        clearance = float(shapely.distance(line, self._free_boundary)) if not self.free.is_empty else 0.0
        return Plan(path, length, mode, self.alpha, self.radius, self.method, clearance, self.unit, note)

    def _shortest_path(self, s: np.ndarray, g: np.ndarray, piece: int) -> tuple[np.ndarray, str | None]:
        """The shortest path, checked; or, should the graph fail, a path through the
        triangulation, with a note saying so."""
        direct = np.vstack((s, g))
        if np.array_equal(s, g) or self.covers(direct):
            return direct, None
        graph = self.visibility
        exclude = np.zeros((0, 2), np.int64)
        for _ in range(8):
            path = graph.shortest_path(s, g, piece, exclude)
            if path is None:
                break
            bad = self._uncovered_segments(path)
            if not bad.any():
                return path, None
            # a walk misjudged by rounding: drop the offending edges and search again
            v = graph.triangulation.vertex_index(path)
            v[0], v[-1] = -1, -2
            exclude = np.vstack((exclude, np.column_stack((v[:-1], v[1:]))[bad]))
        path = self._triangulation.channel(s, g)
        if path is None or not self.covers(path):
            raise PlanError(f"no verified path found between {tuple(s)} and {tuple(g)} although both lie in "
                            f"piece {piece + 1} of the safe region{self._where()}")
        return path, ("the visibility graph did not join start and goal (rounding): a path through the "
                      "triangulation instead, not the shortest")

    def _uncovered_segments(self, path: np.ndarray) -> np.ndarray:
        return ~shapely.covers(self._covering, shapely.linestrings(np.stack((path[:-1], path[1:]), axis=1)))

    def _clearance_path(self, s: np.ndarray, g: np.ndarray, piece: int) -> np.ndarray | None:
        """The cheapest path when moving along the medial axis costs its length and any straight
        step off it (between corners of the visibility graph, from a corner onto the axis, or
        from start to goal) costs ``OFF_AXIS_COST`` times its length; stepping from start and
        goal onto the axis costs its length. So the path keeps to the axis, and leaves it only
        where the axis breaks (a pinch of the safe region narrower than the spacing) or where
        following it would be a long way round."""
        axis, graph = self.medial, self.visibility
        if len(axis.nodes) == 0:
            return None
        n, m = len(axis.nodes), len(graph.triangulation.points)
        S, G = n + m, n + m + 1
        es, ds = self._entries(s)
        eg, dg = self._entries(g)
        vs, dvs = graph.reach(s, piece)
        vg, dvg = graph.reach(g, piece)
        lv, ln, ld = self._axis_links
        k = OFF_AXIS_COST
        # nodes: medial axis 0..n-1, triangulation vertices n..n+m-1, start, goal
        rows = np.concatenate((axis.edges[:, 0], n + graph.edges[:, 0], n + lv,
                               np.full(len(es) + len(vs) + 1, S), eg, n + vg))
        cols = np.concatenate((axis.edges[:, 1], n + graph.edges[:, 1], ln,
                               es, n + vs, [G], np.full(len(eg) + len(vg), G)))
        direct = float(np.hypot(*(g - s))) if self.covers(np.vstack((s, g))) else np.inf
        w = np.concatenate((axis.lengths, k * graph.lengths, k * ld, ds, k * dvs, [k * direct], dg, k * dvg))
        ok = np.isfinite(w)
        chain = shortest_chain(rows[ok], cols[ok], w[ok], n + m + 2, S, G)
        if chain is None:
            return None
        path = np.vstack((s, np.vstack((axis.nodes, graph.triangulation.points))[chain[1:-1]], g))
        # the axis zigzags by about the spacing: straighten within it where that stays inside
        smooth = np.asarray(shapely.simplify(shapely.linestrings(path), self.spacing).coords)
        for candidate in (smooth, path):
            if self.covers(candidate):
                return candidate
        return None

    @cached_property
    def _axis_links(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each corner of the visibility graph joined to the nearest medial-axis nodes it sees:
        (corner vertices, axis nodes, lengths)."""
        graph, axis = self.visibility, self.medial
        v = np.unique(graph.vertex)
        k = min(_LINKS, len(axis.nodes))
        d, i = self._medial_tree.query(graph.triangulation.points[v], k=k)
        v, d, i = np.repeat(v, k), d.reshape(-1), i.reshape(-1)
        seen = graph.triangulation.visible(v, axis.nodes[i])
        return v[seen], i[seen], d[seen]

    def _entries(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nearest medial-axis nodes that ``p`` sees, and their distances."""
        k = min(_ENTRIES, len(self.medial.nodes))
        d, i = self._medial_tree.query(p, k=k)
        d, i = np.atleast_1d(d), np.atleast_1d(i)
        segs = shapely.linestrings(np.stack((np.broadcast_to(p, (k, 2)), self.medial.nodes[i]), axis=1))
        ok = shapely.covers(self._covering, segs)
        return i[ok], d[ok]

    # -- messages ---------------------------------------------------------------------------

    def _where(self) -> str:
        parts = []
        if self.alpha is not None:
            parts.append(f"α = {self.alpha:g}")
        parts.append(f"radius {self.radius:g}")
        if self.method is not None:
            parts.append(self.method)
        return f" ({', '.join(parts)})"

    def _not_free(self, which: str, p: np.ndarray) -> PointNotFreeError:
        pt = shapely.Point(p)
        if self.safe.is_empty:
            return PointNotFreeError(which, p, f"the safe region{self._where()} is empty")
        nearest = np.asarray(shapely.shortest_line(pt, self.safe).coords)[1]
        distance = float(shapely.distance(pt, self.safe))
        why, alpha_needed = self._why_not_free(p, pt)
        return PointNotFreeError(which, p, f"{why}; the nearest free point is ({self._shown_free(pt, nearest)}), "
                                           f"{distance:.3g} {self.unit} away", distance, nearest, alpha_needed)

    def _shown_free(self, pt: shapely.Point, nearest: np.ndarray) -> str:
        """A free point next to ``nearest``, as text that is free read back.

        The nearest point lies on the safe region's edge: printed to 4 significant digits it was
        rounded out of the region two times in three, and given back as a start it was refused.
        So: the nearest point of the region shrunk by a ten-thousandth of the map's size (only
        about ``nearest``, cheaply), printed to a tenth of that; by less where the region is
        thinner (the tip of a sliver); the nearest point itself if nothing works."""
        x, y = nearest
        for k in range(4):
            step = self.extent * 1e-4 / 10**k
            decimals = max(0, math.ceil(-math.log10(step / 10)))
            near = shapely.clip_by_rect(self.safe, x - 20 * step, y - 20 * step, x + 20 * step, y + 20 * step)
            inner = shapely.buffer(near, -step, quad_segs=2)
            if inner.is_empty:
                continue
            q = np.asarray(shapely.shortest_line(pt, inner).coords)[1]
            text = f"{q[0]:.{decimals}f}, {q[1]:.{decimals}f}"
            if shapely.intersects_xy(self.safe, *map(float, text.split(", "))):
                return text
        return f"{x:.6g}, {y:.6g}"

    def _why_not_free(self, p: np.ndarray, pt: shapely.Point) -> tuple[str, float | None]:
        r = self.radius
        in_free = bool(shapely.intersects(self.free, pt))
        fuzzy = self.fuzzy
        if fuzzy is None:
            if not in_free:
                return "it lies outside the free space", None
            return self._too_close(pt, self._free_boundary, "the edge of the free space"), None
        crisp = fuzzy.crisp_geometry
        if not shapely.intersects(crisp, pt):
            shells = [shapely.Polygon(reg.shell.closed_coords()) for reg in fuzzy.crisp.regions]
            if any(s.intersects(pt) for s in shells):
                return "it lies inside an obstacle (a hole of the map)", None
            return "it lies outside the map", None
        edge = shapely.boundary(crisp)
        near = float(shapely.distance(pt, edge))
        if near < r or (near < r * RADIUS_FACTOR and not self._safe_in(crisp, p)):
            return (f"{self._too_close(pt, edge, 'the crisp boundary')}, so no α frees it "
                    f"(α = 1 is the crisp map)"), None
        need = self._alpha_needed(fuzzy, p)
        if not in_free:
            mu = float(fuzzy.membership(p[None], self.method or "sweep")[0])
            why = (f"it lies in the fuzzy boundary's band at α = {self.alpha:g} (μ = {mu:.3g} there)")
        else:
            why = self._too_close(pt, self._free_boundary, f"the edge of the space free at α = {self.alpha:g}")
        if need is not None and need > (self.alpha or 0.0):
            why += f"; it is free from about α = {need:.3g} on" + (f" with radius {r:g}" if r > 0 else "")
        return why, need

    def _too_close(self, pt: shapely.Point, edge: shapely.Geometry, name: str) -> str:
        """Why a point of the free space is not safe: it is closer than the radius to ``edge``,
        or, between the radius and radius × ``RADIUS_FACTOR`` from it, within the margin that the
        safe region keeps (``_shrink``)."""
        r = self.radius
        if shapely.distance(pt, edge) < r:
            return f"it is closer than the radius {r:g} to {name}"
        return f"it is within the radius {r:g} plus the planner's 2 % margin ({r * RADIUS_FACTOR:.4g} in all) of {name}"

    def _safe_in(self, free: shapely.Geometry, p: np.ndarray) -> bool:
        """Whether ``p`` is in ``free`` shrunk as the safe region is (``_shrink``), worked out
        near ``p`` only: the disc the shrink keeps clear about ``p`` is all that decides."""
        d = self.radius * RADIUS_FACTOR
        near = shapely.clip_by_rect(free, p[0] - 3 * d, p[1] - 3 * d, p[0] + 3 * d, p[1] + 3 * d)
        return bool(shapely.intersects_xy(shapely.buffer(near, -d, quad_segs=QUAD_SEGS), p[0], p[1]))

    def _alpha_needed(self, fuzzy: FuzzyBRepMap, p: np.ndarray) -> float | None:
        """About the smallest α at which ``p`` is safe: the largest μ over the disc that the safe
        region keeps clear around its points, of radius × ``RADIUS_FACTOR`` (``_shrink``).

        For a point of the crisp free space, μ is the largest α at which it is still outside the
        inner α-cut, so the disc fits in the inner α-cut from α = max μ over the disc on. μ is
        sampled where its largest values lie: on the disc's edge, densely and then more densely
        about the largest samples, and where the sweep's α-cut corners cross the disc (each
        moves along a line from its crisp vertex, and μ peaks narrowly about that line). With
        48 samples of the edge this missed by up to 0.24 on the real maps, and a disc of the
        radius alone put every answer too low by the 2 %. Exact at radius 0; else an estimate,
        not a bound: on the real maps the planner frees the point from within 0.01 of it, mostly
        a little below (GEOS's chords round corners nearer than radius × ``RADIUS_FACTOR``).
        """
        method = self.method or "sweep"
        R = self.radius * RADIUS_FACTOR
        if R == 0:
            # μ = 1 on the crisp boundary, which is free at α = 1 (the crisp map, edge included)
            return float(fuzzy.membership(p[None], method)[0])
        a = np.linspace(0, 2 * np.pi, _EDGE_SAMPLES, endpoint=False)
        step = 2 * np.pi / _EDGE_SAMPLES
        edge = fuzzy.membership(p + R * np.column_stack((np.cos(a), np.sin(a))), method)
        inner = [p[None], _corner_crossings(fuzzy, p, R)]
        for frac, n in ((2 / 3, 32), (1 / 3, 16)):
            b = np.linspace(0, 2 * np.pi, n, endpoint=False)
            inner.append(p + frac * R * np.column_stack((np.cos(b), np.sin(b))))
        best = max(edge.max(), fuzzy.membership(np.vstack(inner), method).max())
        for _ in range(2):
            # about the largest samples, 32 steps across the step either side of each
            a = (a[np.argsort(edge)[-16:], None] + np.linspace(-step, step, 33)).ravel()
            step /= 16
            edge = fuzzy.membership(p + R * np.column_stack((np.cos(a), np.sin(a))), method)
            best = max(best, edge.max())
        return float(best) if best < 1 else None


#: ``Planner._alpha_needed``: samples of the disc's edge before refining about the largest
_EDGE_SAMPLES = 256


def _corner_crossings(fuzzy: FuzzyBRepMap, p: np.ndarray, R: float) -> np.ndarray:
    """Where the sweep's inner α-cut corners, moving from α = 0 to α = 1, last lie in the disc
    of radius ``R`` about ``p``: the point of each corner's path (a segment from its place at
    α = 0 to its crisp vertex) nearest the crisp vertex within the disc. (k, 2)."""
    v, _ = fuzzy.offset_vertices(1.0)  # the crisp vertices
    w, _ = fuzzy.offset_vertices(0.0)
    d, f = w - v, v - p
    a = np.einsum("ij,ij->i", d, d)
    b = 2 * np.einsum("ij,ij->i", f, d)
    c = np.einsum("ij,ij->i", f, f) - R * R
    disc = b * b - 4 * a * c
    ok = (a > 0) & (disc >= 0)
    root = np.sqrt(np.where(ok, disc, 0))
    safe_a = np.where(ok, a, 1)
    t0, t1 = (-b - root) / (2 * safe_a), (-b + root) / (2 * safe_a)
    ok &= (t0 <= 1) & (t1 >= 0)
    t = np.clip(t0, 0, 1)[ok]
    return v[ok] + t[:, None] * d[ok]


def _point(point, which: str) -> np.ndarray:
    try:
        p = np.asarray(point, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise PlanError(f"{which} must be a point (x, y), got {point!r}") from None
    if p.shape != (2,) or not np.isfinite(p).all():
        raise PlanError(f"{which} must be a point (x, y) of two finite numbers, got {point!r}")
    return p


_PLANNERS: "weakref.WeakKeyDictionary[object, dict]" = weakref.WeakKeyDictionary()
#: planners kept per map (each holds its graphs); the oldest goes first
_KEEP = 8


def planner(source, alpha: float = 0.0, radius: float = 0.0, method: str = "sweep") -> Planner:
    """A planner for a map at (α, radius, method), kept with the map while it lives so that its
    α-cut and graphs are built once (α-cuts are shared between radii). Shapely geometries get
    a new planner each time: keep it yourself."""
    if not isinstance(source, (FuzzyBRepMap, BRepMap)):
        return Planner.of(source, alpha, radius, method)
    a = _applies(source, alpha, method)
    fuzzy = source if isinstance(source, FuzzyBRepMap) else None
    m = method if fuzzy is not None else None
    r = _check_radius(radius)
    cache = _PLANNERS.setdefault(source, {"free": {}, "planners": {}})
    cuts, planners = cache["free"], cache["planners"]
    if (a, r, m) not in planners:
        free = cuts.pop((a, m), None)
        cuts[(a, m)] = free if free is not None else free_space(source, a or 0.0, method)
        planners[(a, r, m)] = Planner(cuts[(a, m)], r, alpha=a, method=m, fuzzy=fuzzy, unit=source.unit)
        for kept in (cuts, planners):
            while len(kept) > _KEEP:
                del kept[next(iter(kept))]
    return planners[(a, r, m)]


def plan(source, start, goal, alpha: float = 0.0, radius: float = 0.0, mode: str = "shortest",
         method: str = "sweep") -> Plan:
    """Plan a path from ``start`` to ``goal`` in the space a fuzzy map holds free at confidence α,
    kept ``radius`` from its edge (``safe_region``).

    source  a FuzzyBRepMap (planned in its inner α-cut), a BRepMap or a Shapely (Multi)Polygon
            (planned in as given; α and method do not apply)
    mode    ``shortest``: the exact Euclidean shortest path (visibility graph);
            ``clearance``: along the medial axis, as far from obstacles as the region allows
    method  α-cut by the thesis's ``sweep`` (default, the map's own) or ``exact``
    """
    return planner(source, alpha, radius, method).plan(start, goal, mode)


__all__ = ["MODES", "Plan", "Planner", "free_space", "plan", "planner", "safe_region"]


def free_points(region, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 2) points drawn uniformly inside ``region`` (e.g. a safe region): starts and goals to try."""
    if not region.area > 0:  # no draw would ever land inside (and an empty one has no bounds)
        raise ValueError(f"cannot draw points inside a region with no area ({region.geom_type}, "
                         f"{'empty' if region.is_empty else 'area 0'})")
    x0, y0, x1, y1 = region.bounds
    out = np.zeros((0, 2))
    while len(out) < n:
        p = rng.uniform((x0, y0), (x1, y1), (4 * n, 2))
        out = np.vstack((out, p[shapely.contains_xy(region, p[:, 0], p[:, 1])]))
    return out[:n]
