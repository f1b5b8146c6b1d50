"""The crisp B-rep map: one principal polygon bounding the free space, hole polygons for obstacles.

Each boundary is a ``Ring``: its vertex table (Table 3.1) as an (n, 2) array, its edge table
(Table 3.2) implied by the order (edge i runs from vertex i to vertex i+1, the last edge closes
the ring), one kind per edge (obstacle or frontier) and one membership-function index (FM) per
vertex. The principal polygon runs counter-clockwise and holes clockwise, so the free space is
always on the left of every edge.

If the explored space comes out in several pieces, the largest is the principal region and the
others are kept as further regions, largest first: no data is dropped. Thesis 3.1.1-3.1.2, 3.2.3.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely

from .errors import GeometryError
from .geometry import NESTS_FROM, nests, polygonal, signed_area

#: Edge kinds: an obstacle edge is where a laser return was seen; a frontier edge is the limit of
#: what was seen (no return, maximum range, the side of a ray past an occluding object).
OBSTACLE = np.uint8(0)
FRONTIER = np.uint8(1)
KIND_NAMES = {int(OBSTACLE): "obstacle", int(FRONTIER): "frontier"}


def frontier_fm(kinds: np.ndarray, fm, k: int) -> np.ndarray:
    """The FM column with a frontier function of index k: k at every vertex that touches a
    frontier edge (edge i or edge i−1, a frontier's position being less certain), ``fm`` elsewhere."""
    frontier = kinds == FRONTIER
    # np.roll(frontier, 1) written out (roll's overhead is most of the work on a map's small rings)
    return np.where(frontier | np.concatenate((frontier[-1:], frontier[:-1])), k, fm)


#: maps with coordinates beyond ± this are refused (``validate_ring``; ``membership`` and the
#: planner check the maps they are given too): μ (``sweep.band_parameter``) and GEOS's
#: triangulation multiply four coordinates together, which passes the largest float (1.8e308)
#: from about 1e77 on (a map 1e75 across planned; at 1e80 the triangulation overflowed, Qhull
#: failed and μ came out wrong), and distances to a point beyond 1e154 overflow
LARGEST = 1e60


#: the shortest edge a map keeps, by its unit: a millimetre (the rounding step of the compact map,
#: the viewer and the pictures; 0.5 % of the thesis's TME). Unions and simplification leave edges
#: of 1e-15 m to under 1 mm where two rings nearly touch; such an edge has no direction worth the
#: name (its corner's normal is noise, and at the viewer's 1 mm rounding none at all), so every map
#: built, fuzzified or loaded has them merged away (``drop_short_edges``). Other units: 1e-3.
#: (Shorter by more than ``SLACK`` of it, for rounding's sake.)
MIN_EDGE = {"m": 1e-3, "cm": 0.1, "mm": 1.0}


#: an edge of exactly the tolerance, from coordinates rounded to it (the compact map's), can come
#: out a rounding error short: edges shorter than the tolerance by more than this part of it go
SLACK = 1e-6


def min_edge(unit: str) -> float:
    """The shortest edge a map in ``unit`` keeps (``MIN_EDGE``)."""
    return MIN_EDGE.get(unit, 1e-3)


@dataclass(frozen=True, eq=False)
class Ring:
    """One closed boundary: the vertex table with its edge table implied.

    vertices (n, 2) float64, not repeating the first vertex at the end.
    kinds    (n,) uint8: kind of edge i = (vertex i, vertex i+1 mod n).
    fm       (n,) int32: membership-function index of vertex i (Table 4.1's FM column, 1-based).
    """

    vertices: np.ndarray
    kinds: np.ndarray = field(default=None)  # type: ignore[assignment]
    fm: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        v = np.array(self.vertices, dtype=np.float64, copy=True).reshape(-1, 2)
        n = len(v)
        k = np.zeros(n, np.uint8) if self.kinds is None else np.array(self.kinds, dtype=np.uint8).reshape(-1)
        f = np.ones(n, np.int32) if self.fm is None else np.array(self.fm, dtype=np.int32).reshape(-1)
        if len(k) != n or len(f) != n:
            raise GeometryError(f"{n} vertices but {len(k)} edge kinds and {len(f)} FM indices")
        for a in (v, k, f):
            a.setflags(write=False)
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "kinds", k)
        object.__setattr__(self, "fm", f)

    def __len__(self) -> int:
        return len(self.vertices)

    @property
    def edges(self) -> np.ndarray:
        """(n, 2) int: the edge table, Vstart and Vend indices of every edge (Table 3.2)."""
        i = np.arange(len(self.vertices))
        return np.column_stack((i, (i + 1) % len(i)))

    @property
    def signed_area(self) -> float:
        """Shoelace area: positive for counter-clockwise rings."""
        return signed_area(self.vertices)

    def without_short_edges(self, tol: float) -> "Ring":
        """This ring with every edge shorter than ``tol`` merged away (itself if it has none).

        Walking round from vertex 1, a vertex closer than ``tol`` to the last one kept is dropped
        (and the last ones closer than ``tol`` to vertex 1): every edge left is at least ``tol``
        long, and no vertex moves (the boundary moves less than ``tol``). A merged edge
        takes the kind of the longest edge it replaces; a kept vertex keeps its FM. The result
        can have fewer than 3 vertices; the caller checks it (``drop_short_edges``)."""
        v = self.vertices
        n = len(v)
        if n < 2:
            return self
        tol = tol * (1 - SLACK)
        step = np.hypot(*(np.concatenate((v[1:], v[:1])) - v).T)
        if not (step < tol).any():
            return self
        keep, last = [0], v[0]
        for j in range(1, n):
            if np.hypot(*(v[j] - last)) >= tol:
                keep.append(j)
                last = v[j]
        while len(keep) > 1 and np.hypot(*(v[keep[-1]] - v[0])) < tol:
            keep.pop()
        ends = keep[1:] + [n]
        kinds = [self.kinds[a + int(np.argmax(step[a:b]))] for a, b in zip(keep, ends)]
        return Ring(v[keep], np.array(kinds, np.uint8), self.fm[keep])

    def closed_coords(self) -> np.ndarray:
        return np.vstack((self.vertices, self.vertices[:1]))

    def equals_exactly(self, other: "Ring") -> bool:
        return (
            self.vertices.shape == other.vertices.shape
            and np.array_equal(self.vertices, other.vertices)
            and np.array_equal(self.kinds, other.kinds)
            and np.array_equal(self.fm, other.fm)
        )


@dataclass(frozen=True, eq=False)
class Region:
    """One connected piece of free space: its outer boundary (shell) and its holes."""

    shell: Ring
    holes: tuple[Ring, ...] = ()

    @property
    def rings(self) -> tuple[Ring, ...]:
        return (self.shell, *self.holes)

    @property
    def area(self) -> float:
        return self.shell.signed_area + sum(h.signed_area for h in self.holes)

    def to_shapely(self) -> shapely.Polygon:
        return shapely.Polygon(self.shell.closed_coords(), [h.closed_coords() for h in self.holes])


@dataclass(frozen=True, eq=False)
class BRepMap:
    """A crisp B-rep map: regions[0] holds the principal polygon and its holes (thesis 3.1.1).

    Further regions are pieces of explored space not connected to the principal one, largest
    first; they are kept so that nothing seen is dropped.
    """

    regions: tuple[Region, ...]
    unit: str = "m"

    @property
    def principal(self) -> Ring:
        return self.regions[0].shell

    @property
    def holes(self) -> tuple[Ring, ...]:
        return self.regions[0].holes

    @property
    def rings(self) -> list[Ring]:
        return [r for region in self.regions for r in region.rings]

    @property
    def n_vertices(self) -> int:
        return sum(len(r) for r in self.rings)

    @property
    def n_holes(self) -> int:
        return sum(len(region.holes) for region in self.regions)

    @property
    def area(self) -> float:
        return sum(region.area for region in self.regions)

    def ring_names(self) -> list[str]:
        """Human names for rings in ``rings`` order: principal, hole 1, ..., piece 2, piece 2 hole 1."""
        names = []
        for k, region in enumerate(self.regions):
            base = "principal" if k == 0 else f"piece {k + 1}"
            names.append(base)
            names += [f"{'' if k == 0 else base + ' '}hole {j + 1}" for j in range(len(region.holes))]
        return names

    def to_shapely(self) -> shapely.Polygon | shapely.MultiPolygon:
        polys = [region.to_shapely() for region in self.regions]
        return polys[0] if len(polys) == 1 else shapely.MultiPolygon(polys)

    @classmethod
    def from_shapely(cls, geom, unit: str = "m", min_area: float = 0.0) -> "BRepMap":
        """Crisp map from a Shapely (Multi)Polygon: principal = largest piece, orientation fixed.

        Pieces of area ``min_area`` or less are dropped (by default those of no area). Raises
        GeometryError if nothing with area is left or the geometry is invalid.
        """
        polys = [g for g in shapely.get_parts(polygonal(geom)) if g.area > min_area]
        if not polys:
            raise GeometryError("the map has no free space with area")
        out = cls._from_parts(polys, unit)
        try:
            return drop_short_edges(out, drop_vanishing=True)
        except GeometryError:
            # merging an edge away made a ring touch another (a vertex within the tolerance of an
            # edge): snap-round to the tolerance's grid instead, which GEOS keeps valid, and
            # whose distinct vertices lie a grid step apart at least
            tol = min_edge(unit)
            snapped = [g for g in shapely.get_parts(polygonal(shapely.set_precision(geom, tol)))
                       if g.area > min_area]
            if not snapped:
                raise GeometryError("the map has no free space with area") from None
            return drop_short_edges(cls._from_parts(snapped, unit), drop_vanishing=True)

    @classmethod
    def _from_parts(cls, polys: list, unit: str) -> "BRepMap":
        polys.sort(key=lambda g: -g.area)
        regions = []
        for g in polys:
            g = shapely.orient_polygons(g, exterior_cw=False)
            shell = Ring(np.asarray(g.exterior.coords)[:-1])
            holes = (Ring(np.asarray(h.coords)[:-1]) for h in g.interiors)
            # a hole collapsed to a line (simplification can do that to a tiny one) bounds nothing
            regions.append(Region(shell, tuple(h for h in holes if len(h) >= 3 and h.signed_area < 0)))
        return cls(tuple(regions), unit)

    def with_rings(self, rings: list[Ring]) -> "BRepMap":
        """The same structure with new rings, given in ``rings`` order."""
        it = iter(rings)
        regions = tuple(Region(next(it), tuple(next(it) for _ in region.holes)) for region in self.regions)
        return BRepMap(regions, self.unit)

    def validate(self) -> None:
        """Raise GeometryError naming the ring and vertex if any boundary is degenerate or invalid."""
        names = self.ring_names()
        for name, ring in zip(names, self.rings):
            validate_ring(ring.vertices, name)
        first = 0  # index in ``names`` of the region's outer ring
        for region in self.regions:
            region_names = names[first:first + 1 + len(region.holes)]
            first += len(region_names)
            check_region(region, region_names)
            if region.shell.signed_area <= 0:
                raise GeometryError("outer boundary must run counter-clockwise", ring=region_names[0])
            for name, h in zip(region_names[1:], region.holes):
                if h.signed_area >= 0:
                    raise GeometryError("hole must run clockwise", ring=name)

    def equals_exactly(self, other: "BRepMap") -> bool:
        return (
            self.unit == other.unit
            and len(self.rings) == len(other.rings)
            and [len(r.holes) for r in self.regions] == [len(r.holes) for r in other.regions]
            and all(a.equals_exactly(b) for a, b in zip(self.rings, other.rings))
        )


def drop_short_edges(crisp: BRepMap, tol: float | None = None, *, drop_vanishing: bool = False) -> BRepMap:
    """The map with every edge shorter than ``tol`` (default ``min_edge(crisp.unit)``) merged away
    (``Ring.without_short_edges``); ``crisp`` itself when it has none. GeometryError naming the
    ring if a changed ring or its region is no longer valid (a ring of a few short edges would
    vanish, or a vertex lay within ``tol`` of another edge). ``drop_vanishing``: a hole that would
    vanish (fewer than 3 vertices left, or no area) is dropped instead."""
    tol = min_edge(crisp.unit) if tol is None else tol
    names = crisp.ring_names()
    regions, changed, k = [], False, 0
    for region in crisp.regions:
        region_names = names[k:k + len(region.rings)]
        k += len(region.rings)
        rings = [r.without_short_edges(tol) for r in region.rings]
        if drop_vanishing:
            gone = [j for j in range(1, len(rings)) if len(rings[j]) < 3 or rings[j].signed_area >= 0]
            rings = [r for j, r in enumerate(rings) if j not in gone]
            region_names = [n for j, n in enumerate(region_names) if j not in gone]
            region_rings = [r for j, r in enumerate(region.rings) if j not in gone]
            changed = changed or bool(gone)
        else:
            region_rings = list(region.rings)
        moved = [a is not b for a, b in zip(rings, region_rings)]
        if not any(moved):
            regions.append(Region(rings[0], tuple(rings[1:])) if len(rings) != len(region.rings) else region)
            continue
        changed = True
        for name, r, m in zip(region_names, rings, moved):
            if m:
                if len(r) < 3:
                    raise GeometryError(f"made of edges shorter than {tol:g} {crisp.unit}: nothing is left once "
                                        f"they are merged away", ring=name)
                validate_ring(r.vertices, name)
        new = Region(rings[0], tuple(rings[1:]))
        check_region(new, region_names)
        regions.append(new)
    return BRepMap(tuple(regions), crisp.unit) if changed else crisp


def shortest_edge(crisp: BRepMap) -> float:
    """The length of the map's shortest edge."""
    return min(float(np.hypot(*(np.roll(r.vertices, -1, axis=0) - r.vertices).T).min()) for r in crisp.rings)


def validate_ring(vertices: np.ndarray, name: str = "ring") -> None:
    """Raise GeometryError naming the vertex if a ring is degenerate or self-intersecting."""
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 2:
        raise GeometryError(f"vertices must be an (n, 2) array, got shape {v.shape}", ring=name)
    if len(v) < 3:
        raise GeometryError(f"a polygon needs at least 3 vertices, got {len(v)}", ring=name)
    bad = ~np.isfinite(v).all(axis=1)
    if bad.any():
        raise GeometryError("coordinate is not finite", ring=name, vertex=int(np.argmax(bad)) + 1)
    far = (np.abs(v) > LARGEST).any(axis=1)
    if far.any():
        raise GeometryError(f"coordinate {v[np.argmax(far)].tolist()} is beyond ±{LARGEST:g}, where the map's "
                            f"arithmetic overflows", ring=name, vertex=int(np.argmax(far)) + 1)
    dup = np.all(v == np.roll(v, -1, axis=0), axis=1)
    if dup.any():
        i = int(np.argmax(dup))
        raise GeometryError(f"repeats vertex {(i + 1) % len(v) + 1}", ring=name, vertex=i + 1)
    if shapely.area(shapely.convex_hull(shapely.multipoints(v))) == 0:
        raise GeometryError("polygon has zero area (all vertices on one line)", ring=name)
    if not shapely.LinearRing(v).is_simple:
        reason = shapely.is_valid_reason(shapely.Polygon(v))
        raise GeometryError(f"self-intersecting: {reason}", ring=name, vertex=_nearest_vertex(v, reason))


def _nearest_vertex(v: np.ndarray, reason: str) -> int | None:
    """1-based index of the vertex nearest to the location GEOS names in ``reason``."""
    import re

    m = re.search(r"\[([-0-9.eE+]+)\s+([-0-9.eE+]+)", reason)
    if not m:
        return None
    p = np.array([float(m.group(1)), float(m.group(2))])
    return int(np.argmin(np.hypot(*(v - p).T))) + 1


def locate_vertex(rings: Sequence[np.ndarray], names: Sequence[str], reason: str) -> tuple[str | None, int | None]:
    """(ring name, 1-based vertex in that ring) nearest the location GEOS names in ``reason``.

    ``rings`` are the vertex arrays of one polygon (outer ring first, then its holes) and ``names``
    theirs; (None, None) when the reason carries no location.
    """
    v = _nearest_vertex(np.vstack(rings), reason)
    if v is None:
        return None, None
    ends = np.cumsum([len(r) for r in rings])
    k = int(np.searchsorted(ends, v - 1, side="right"))
    return names[k], v - (int(ends[k - 1]) if k else 0)


def check_region(region: Region, names: Sequence[str]) -> None:
    """GeometryError naming the ring and vertex if a region of simple rings is invalid (holes
    overlapping, or not inside its principal polygon). With many holes the indexed ``nests``
    test goes first: it vouches for most valid regions at a fraction of ``is_valid``'s cost."""
    if len(region.holes) * len(region.shell) > NESTS_FROM:
        polys = rings_to_shapely(list(region.rings))
        if nests(polys[0], polys[1:]):
            return
    g = region.to_shapely()
    if not g.is_valid:
        reason = shapely.is_valid_reason(g)
        ring_name, vertex = locate_vertex([r.vertices for r in region.rings], names, reason)
        raise GeometryError(f"invalid region: {reason}", ring=ring_name or names[0], vertex=vertex)


def validate_map(crisp: BRepMap) -> None:
    """Raise GeometryError naming ring and vertex if a ring is degenerate or a region invalid.

    Unlike ``BRepMap.validate`` the ring order is not checked: the sweep works with either.
    """
    if not crisp.regions:
        raise GeometryError("the map has no regions")
    names = crisp.ring_names()
    rings = crisp.rings
    sizes = np.array([len(r) for r in rings])
    suspect = sizes < 3
    if not suspect.any():
        V = np.vstack([r.vertices for r in rings])
        start = np.concatenate(([0], np.cumsum(sizes)[:-1]))
        ring_of = np.repeat(np.arange(len(rings)), sizes)
        nxt = np.arange(len(V)) + 1
        nxt[start + sizes - 1] = start
        with np.errstate(invalid="ignore"):
            finite = (np.abs(V) <= LARGEST).all(axis=1)  # NaN and ±inf too
        dup = np.all(V == V[nxt], axis=1)
        # a ring with a vertex beyond ±LARGEST (or not finite) is suspect already: 0 in its place
        # keeps NumPy and GEOS from warning (lines before the error), and validate_ring names it;
        # judged only by area and simplicity, a ring reaching 1e308 passed unchecked
        Vf = np.where(finite[:, None], V, 0.0)
        x, y = Vf[:, 0], Vf[:, 1]
        with np.errstate(over="ignore", invalid="ignore"):
            area = 0.5 * np.add.reduceat(x * y[nxt] - x[nxt] * y, start)
        closed = np.concatenate([np.append(np.arange(a, a + n), a) for a, n in zip(start, sizes)])
        simple = shapely.is_simple(shapely.linearrings(Vf[closed], indices=ring_of[closed]))
        suspect = (np.bincount(ring_of, weights=~finite | dup, minlength=len(rings)) > 0) | (area == 0) | ~simple
    for k in np.flatnonzero(suspect):  # the detailed message comes from validate_ring
        validate_ring(rings[k].vertices, names[k])
    k = 0
    for region in crisp.regions:
        region_names, k = names[k:k + len(region.rings)], k + len(region.rings)
        check_region(region, region_names)  # the rings are simple now
    _check_disjoint(crisp)


def _check_disjoint(crisp: BRepMap) -> None:
    """GeometryError if two regions overlap or share an edge. Each region is a piece of free space
    apart from the others, meeting them at points at most (as a valid MultiPolygon's parts do):
    overlapping ones were taken as they were, their common area counted twice and the α-cuts and
    rasters of each drawn over the other's; ones sharing an edge made the crisp geometry invalid,
    and ``alpha-cut --alpha 1 --method exact`` wrote invalid polygons."""
    if len(crisp.regions) < 2:
        return
    polys = np.array([region.to_shapely() for region in crisp.regions], dtype=object)
    a, b = shapely.STRtree(polys).query(polys, predicate="intersects")
    a, b = a[a < b], b[a < b]
    inside = shapely.relate_pattern(polys[a], polys[b], "T********")  # interiors meet
    edge = shapely.relate_pattern(polys[a], polys[b], "****1****")  # boundaries share a line
    bad = inside | edge
    if not bad.any():
        return
    k = int(np.argmax(bad))
    i, j = int(a[k]), int(b[k])
    names = ["principal" if n == 0 else f"piece {n + 1}" for n in range(len(polys))]
    shell = crisp.regions[j].shell.vertices
    if inside[k]:
        within = np.flatnonzero(shapely.contains_xy(polys[i], shell[:, 0], shell[:, 1]))
        x, y = (shell[within[0]] if within.size else
                np.asarray(shapely.intersection(polys[i], polys[j]).representative_point().coords[0]))
        raise GeometryError(f"overlaps {names[i]} near ({x:.6g}, {y:.6g}): regions are separate pieces of free space",
                            ring=names[j], vertex=int(within[0]) + 1 if within.size else None)
    common = shapely.intersection(polys[i].boundary, polys[j].boundary)
    on = np.flatnonzero(shapely.intersects_xy(common, shell[:, 0], shell[:, 1]))
    x, y = shell[on[0]] if on.size else np.asarray(common.representative_point().coords[0])
    raise GeometryError(f"shares an edge with {names[i]} near ({x:.6g}, {y:.6g}): regions are separate pieces of free "
                        f"space, meeting at points at most", ring=names[j], vertex=int(on[0]) + 1 if on.size else None)


def rings_to_shapely(rings: list[Ring]) -> np.ndarray:
    """Shapely polygons (one per ring, no holes) built in one vectorised call."""
    if not rings:
        return np.empty(0, dtype=object)
    coords = np.vstack([r.closed_coords() for r in rings])
    idx = np.repeat(np.arange(len(rings)), [len(r) + 1 for r in rings])
    return shapely.polygons(shapely.linearrings(coords, indices=idx))
