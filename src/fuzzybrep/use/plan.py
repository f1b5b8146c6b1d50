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

import weakref
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely

from ..brep import LARGEST, BRepMap
from ..errors import NoConnectionError, PlanError, PointNotFreeError
from ..fuzzy.map import DEFAULT_METHOD, FuzzyBRepMap, check_method
from ..geometry import polygonal
from . import plan_diagnosis
from .clearance import axis_links, clearance_path
from .medial import MedialAxis
from .safe_region import (  # noqa: F401  (the planner's public names)
    RADIUS_FACTOR,
    RELATIVE_TOLERANCE,
    applies,
    check_radius,
    check_size,
    extent_of,
    floating,
    free_space,
    safe_region,
    shrink,
)
from .visibility import Triangulation, VisibilityGraph

MODES = ("shortest", "clearance")
#: start and goal this far outside the safe region, times ``Planner.tolerance``, are on its edge
#: (``Planner.piece``): with the move into the region (``Planner._into``) at most 5/16 of the
#: tolerance, which the tolerance's buffer (one chord per quarter circle) covers everywhere
ON_EDGE = 1 / 4
#: clearance mode: boundary points for the medial axis, at most about this many
_MEDIAL_SITES = 40_000


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
        self.radius = check_radius(radius)
        self.alpha = alpha
        self.method = method
        # weakly: a planner kept with its map (``planner``) must not keep the map alive
        self._fuzzy = None if fuzzy is None else weakref.ref(fuzzy)
        self.unit = fuzzy.unit if fuzzy is not None else unit
        if not isinstance(free, shapely.Geometry):
            raise TypeError(f"a Planner plans in a Shapely (Multi)Polygon, not a {type(free).__name__}: "
                            "Planner.of takes maps")
        self.free = floating(polygonal(check_size(free, self.unit)))
        self.safe = shrink(self.free, self.radius)
        self.pieces = shapely.get_parts(self.safe)
        shapely.prepare(self.safe)
        shapely.prepare(self.pieces)
        self.extent = extent_of(self.free)
        self.tolerance = RELATIVE_TOLERANCE * self.extent
        self._spacing = spacing

    @classmethod
    def of(cls, source, alpha: float = 0.0, radius: float = 0.0, method: str = DEFAULT_METHOD, **kw) -> "Planner":
        """A planner for a fuzzy map at α (or for a crisp map or polygon, where α does not apply)."""
        alpha = applies(source, alpha, method)
        method = check_method(method)
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

    def _where(self) -> str:
        """The planner's α, radius and method, for messages (``plan_diagnosis.where``)."""
        return plan_diagnosis.where(self)

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
    def medial_tree(self):
        from scipy.spatial import cKDTree

        return cKDTree(self.medial.nodes) if len(self.medial.nodes) else None

    @cached_property
    def axis_links(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each corner of the visibility graph joined to the nearest medial-axis nodes it sees
        (``clearance.axis_links``)."""
        return axis_links(self)

    @cached_property
    def _triangulation(self) -> Triangulation:
        return self.visibility.triangulation if "visibility" in self.__dict__ else Triangulation.of(self.safe)

    @cached_property
    def covering(self) -> shapely.Geometry:
        g = shapely.buffer(self.safe, self.tolerance, quad_segs=1)
        shapely.prepare(g)
        return g

    @cached_property
    def free_boundary(self) -> shapely.Geometry:
        return shapely.boundary(self.free)

    # -- queries ----------------------------------------------------------------------------

    def piece(self, point, which: str = "point") -> int:
        """Index of the piece of the safe region holding ``point`` (its boundary included, to
        within ``ON_EDGE`` × ``tolerance``); PointNotFreeError saying why and how far off if none
        does.

        A point on the region's edge computed in floats (one between two vertices, or the
        nearest free point a PointNotFreeError names) lies as often just outside the edge as
        on it, and snapping the region's coordinates (``shrink``) moves its edges by up to
        10⁻¹⁰ of the map's size: such a point is free as well."""
        p = _point(point, which)
        if np.abs(p).max() > LARGEST:  # the map lies within ±LARGEST (``check_size``)
            raise PointNotFreeError(which, p, f"it lies far outside the map, beyond ±{LARGEST:g} {self.unit}, "
                                              "too far for its distance to be measured")
        inside = np.flatnonzero(shapely.intersects_xy(self.pieces, p[0], p[1]))
        if len(inside) == 0:
            d = shapely.distance(self.pieces, shapely.Point(p))
            if len(d) and d.min() <= ON_EDGE * self.tolerance:
                return int(np.argmin(d))
            raise plan_diagnosis.not_free(self, which, p)
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
        return bool(shapely.covers(self.covering, line))

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
                f"{self.unit}²): no path joins them{plan_diagnosis.connecting(self, s, g, planner)}", ps, pg)
        given = s, g
        s, g = self._into(s, ps), self._into(g, pg)
        if s is None or g is None:
            raise PlanError(f"no verified path found between {tuple(given[0])} and {tuple(given[1])}: "
                            f"{'start' if s is None else 'goal'} lies on the edge of the safe region{self._where()}, "
                            "and rounding keeps it out")
        note = None
        path = clearance_path(self, s, g, ps) if mode == "clearance" else None
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
        clearance = float(shapely.distance(line, self.free_boundary)) if not self.free.is_empty else 0.0
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
        return ~shapely.covers(self.covering, shapely.linestrings(np.stack((path[:-1], path[1:]), axis=1)))





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


def planner(source, alpha: float = 0.0, radius: float = 0.0, method: str = DEFAULT_METHOD) -> Planner:
    """A planner for a map at (α, radius, method), kept with the map while it lives so that its
    α-cut and graphs are built once (α-cuts are shared between radii). Shapely geometries get
    a new planner each time: keep it yourself."""
    if not isinstance(source, (FuzzyBRepMap, BRepMap)):
        return Planner.of(source, alpha, radius, method)
    a = applies(source, alpha, method)
    method = check_method(method)
    fuzzy = source if isinstance(source, FuzzyBRepMap) else None
    m = method if fuzzy is not None else None
    r = check_radius(radius)
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
         method: str = DEFAULT_METHOD) -> Plan:
    """Plan a path from ``start`` to ``goal`` in the space a fuzzy map holds free at confidence α,
    kept ``radius`` from its edge (``safe_region``).

    source  a FuzzyBRepMap (planned in its inner α-cut), a BRepMap or a Shapely (Multi)Polygon
            (planned in as given; α and method do not apply)
    mode    ``shortest``: the exact Euclidean shortest path (visibility graph);
            ``clearance``: along the medial axis, as far from obstacles as the region allows
    method  α-cut by ``safe`` (default: the conservative sweep), ``thesis`` (or ``sweep``) or ``exact``
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
