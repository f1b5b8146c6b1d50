"""Path planning: known shortest paths, refusals, connections, clearance, and real maps.

Every path is checked against the safe region independently of the planner: covered by the
inner α-cut shrunk by the radius (grown by GEOS's tolerance), and never nearer than the radius
to the edge of the free space.
"""

from __future__ import annotations

import gc
import json
import math
import os
import re

import numpy as np
import pytest
import shapely
import shapely.affinity
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from fuzzybrep.brep import BRepMap, Region, Ring
from fuzzybrep.cli import main
from fuzzybrep.errors import FuzzyBrepError, GeometryError, NoConnectionError, PlanError, PointNotFreeError
from fuzzybrep.use import plan as plan_module
from fuzzybrep.fuzzy.map import FuzzyBRepMap, fuzzify
from fuzzybrep.use.plan import RADIUS_FACTOR, free_points, plan, planner, safe_region
from fuzzybrep.use.medial import MedialAxis
from fuzzybrep.use.visibility import Corners, Triangulation, VisibilityGraph

TOL = 1e-7


def box(x0, y0, x1, y1):
    return shapely.box(x0, y0, x1, y1)


_GROWN: dict[int, tuple] = {}


def _grown(free):
    """free grown by TOL, and its boundary, prepared: computed once per region."""
    if id(free) not in _GROWN:
        grown, edge = shapely.buffer(free, TOL), free.boundary
        shapely.prepare(grown)
        _GROWN[id(free)] = (free, grown, edge)  # holding free keeps its id from being reused
    return _GROWN[id(free)][1:]


def assert_safe(p, free, radius: float = 0.0) -> None:
    """The path lies in ``free`` shrunk by ``radius`` (checked without the planner's own region)."""
    grown, edge = _grown(free)
    line = shapely.LineString(p.path)
    assert shapely.covers(grown, line), "path leaves the free space"
    if radius > 0:
        assert shapely.distance(line, edge) >= radius - TOL, "path comes nearer the edge than the radius"
        assert p.clearance >= radius - TOL
    assert p.length == pytest.approx(line.length)


def hull_chain_length(obstacle, s, g) -> float:
    """Shortest way round one convex obstacle: the shorter chain of hull(obstacle ∪ {s, g})."""
    hull = shapely.MultiPoint([*obstacle.exterior.coords, s, g]).convex_hull.exterior
    a, b = hull.project(shapely.Point(s)), hull.project(shapely.Point(g))
    chain = abs(a - b)
    return min(chain, hull.length - chain)


# ------------------------------------------------------------------- known shortest paths

U = shapely.difference(box(0, 0, 10, 10), box(2, 0, 8, 8))  # two arms joined along the top


def test_u_corridor_path_wraps_both_inner_corners():
    p = plan(U, (1, 1), (9, 1))
    assert p.length == pytest.approx(2 * math.hypot(1, 7) + 6, rel=1e-12)
    np.testing.assert_allclose(p.path, [(1, 1), (2, 8), (8, 8), (9, 1)])
    assert p.mode == "shortest" and p.alpha is None and p.radius == 0
    assert p.clearance == pytest.approx(0, abs=1e-12)
    assert_safe(p, U)


def test_direct_line_when_in_sight_and_start_equal_goal():
    p = plan(U, (0.5, 0.5), (1.5, 9.5))
    assert len(p.path) == 2 and p.length == pytest.approx(math.hypot(1, 9))
    q = plan(U, (1, 1), (1, 1))
    assert q.length == 0 and len(q.path) == 2


ROOM = box(0, 0, 10, 6)


def test_room_with_a_pillar_path_length_is_analytic():
    pillar = box(4, 2, 6, 4)
    free = ROOM.difference(pillar)
    s, g = (1, 3), (9, 3)
    p = plan(free, s, g)
    assert p.length == pytest.approx(2 * math.sqrt(10) + 2, rel=1e-12)
    assert len(p.path) == 4
    assert_safe(p, free)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(n=st.integers(3, 12), turn=st.floats(0, 2 * math.pi), size=st.floats(0.3, 1.8),
       sy=st.floats(1.0, 5.0), gy=st.floats(1.0, 5.0))
def test_way_round_a_convex_pillar_is_the_shorter_hull_chain(n, turn, size, sy, gy):
    a = turn + np.arange(n) * 2 * math.pi / n
    pillar = shapely.Polygon(np.column_stack((5 + size * np.cos(a), 3 + size * np.sin(a))))
    free = box(-10, -10, 20, 16).difference(pillar)  # walls far enough not to matter
    s, g = (1.0, sy), (9.0, gy)
    p = plan(free, s, g)
    expected = hull_chain_length(pillar, s, g) if shapely.LineString([s, g]).intersects(pillar) else math.dist(s, g)
    assert p.length == pytest.approx(expected, rel=1e-9, abs=1e-9)
    assert_safe(p, free)


def brute_force_length(safe, s, g) -> float:
    """Shortest path length by the plain visibility graph: start, goal and every vertex of the
    region, joined where GEOS finds the segment covered (within TOL), searched by Dijkstra."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    pts = np.vstack((s, g, np.unique(shapely.get_coordinates(safe), axis=0)))
    i, j = np.triu_indices(len(pts), 1)
    ok = shapely.covers(shapely.buffer(safe, TOL), shapely.linestrings(np.stack((pts[i], pts[j]), axis=1)))
    w = np.hypot(*(pts[i] - pts[j]).T)
    graph = csr_matrix((np.maximum(w[ok], 1e-300), (i[ok], j[ok])), shape=(len(pts), len(pts)))
    return float(dijkstra(graph, directed=False, indices=0)[1])


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(holes=st.lists(st.tuples(st.floats(1, 9), st.floats(1, 5), st.floats(0.1, 1.5), st.floats(0.1, 1.5),
                                st.floats(0, math.pi)), min_size=1, max_size=5),
       radius=st.sampled_from([0.0, 0.15]), seed=st.integers(0, 2**16))
def test_shortest_paths_are_as_short_as_the_full_visibility_graphs(holes, radius, seed):
    # rotated rectangles, overlapping or touching the walls or each other at random
    obstacles = [shapely.affinity.rotate(box(x - w, y - h, x + w, y + h), turn, use_radians=True)
                 for x, y, w, h, turn in holes]
    free = ROOM.difference(shapely.union_all(obstacles))
    pl = plan_module.Planner(free, radius)
    if pl.safe.is_empty:
        return
    rng = np.random.default_rng(seed)
    for s, g in free_points(pl.safe, 6, rng).reshape(3, 2, 2):
        try:
            p = pl.plan(s, g)
        except NoConnectionError:
            assert pl.piece(s) != pl.piece(g)
            continue
        assert p.note is None
        assert p.length == pytest.approx(brute_force_length(pl.safe, s, g), rel=1e-9, abs=1e-9)
        assert_safe(p, free, radius)


def test_safe_region_shrinks_by_the_radius_and_no_more_than_two_percent_more():
    free = ROOM.difference(box(4, 2, 6, 4))
    safe = safe_region(free, radius=0.5)
    assert shapely.covers(shapely.buffer(free, -0.5 + TOL, quad_segs=64), safe)  # never nearer than 0.5
    pts = shapely.get_coordinates(shapely.segmentize(safe.boundary, 0.05))
    d = shapely.distance(shapely.points(pts), free.boundary)
    assert d.min() >= 0.5 - TOL and d.max() <= 0.5 * 1.021 + TOL


@pytest.mark.parametrize("grid", [0.01, 0.1, 0.5])
def test_a_region_with_a_precision_grid_is_shrunk_like_any_other(grid):
    # shapely.set_precision leaves a fixed precision model on the geometry, and GEOS computes
    # a buffer of it on that grid: the shrink came out too large (0.01), empty (0.1), or
    # larger than the free space itself (0.5)
    free = shapely.set_precision(ROOM.difference(shapely.Polygon([(4, 2), (6, 2.3), (5.2, 4.1)])), grid)
    assert shapely.get_precision(free) == grid
    floating = shapely.set_precision(free, 0)  # the same coordinates: what the checks measure in
    safe = safe_region(free, radius=0.3)
    assert safe.equals_exact(safe_region(floating, radius=0.3), 0)
    assert shapely.covers(shapely.buffer(floating, -0.3 + TOL, quad_segs=64), safe)
    p = plan(free, (1, 3), (9, 3), radius=0.3)
    assert_safe(p, floating, 0.3)


def test_radius_keeps_the_path_off_the_corners():
    free = ROOM.difference(box(4, 2, 6, 4))
    p = plan(free, (1, 3), (9, 3), radius=0.3)
    assert_safe(p, free, 0.3)
    assert p.length > 2 * math.sqrt(10) + 2  # the way round is longer with a body


# ------------------------------------------------------------------- refusals and connections


@pytest.fixture(scope="module")
def pillar_room() -> FuzzyBRepMap:
    """A 10 × 6 m room with a 2 × 2 m pillar, TME 0.2 m."""
    return fuzzify(BRepMap.from_shapely(ROOM.difference(box(4, 2, 6, 4))), tme=0.2)


def test_refuses_a_start_inside_an_obstacle(pillar_room):
    with pytest.raises(PointNotFreeError, match="inside an obstacle") as e:
        plan(pillar_room, (5, 3), (1, 1))
    assert e.value.which == "start" and e.value.alpha_needed is None
    # 1 m to the pillar's face, plus the safe cut's offset there: every face moves TME (the
    # thesis's sweep moves the corners TME along the bisector, so the faces only TME·sin 45°)
    assert e.value.distance == pytest.approx(1.2, rel=1e-9)
    with pytest.raises(PointNotFreeError) as e:
        plan(pillar_room, (5, 3), (1, 1), method="thesis")
    assert e.value.distance == pytest.approx(1 + 0.2 / math.sqrt(2), rel=1e-9)
    assert isinstance(e.value, PlanError) and isinstance(e.value, FuzzyBrepError)


def test_refuses_a_goal_outside_the_map(pillar_room):
    with pytest.raises(PointNotFreeError, match="goal .* outside the map"):
        plan(pillar_room, (1, 1), (12, 3))


def test_refuses_a_point_in_the_support_band_and_says_which_alpha_frees_it(pillar_room):
    # the safe cut moves the walls d = 0.2 at α = 0 and (1 − α)·d at α: a point 0.1 from a wall
    # is free from α = 1 − 0.1/d on, and 0.1 short of the safe region at α = 0; the thesis's
    # sweep moves the room's corners 0.2 along their bisectors, so its walls only 0.2·sin 45°
    for method, d in (("safe", 0.2), ("thesis", 0.2 / math.sqrt(2))):
        with pytest.raises(PointNotFreeError, match="band") as e:
            plan(pillar_room, (1, 0.1), (1, 1), method=method)
        assert e.value.alpha_needed == pytest.approx(1 - 0.1 / d, abs=1e-6)
        assert e.value.distance == pytest.approx(d - 0.1, abs=1e-6)
        assert f"free from about α = {1 - 0.1 / d:.3g} on" in str(e.value)
    assert plan(pillar_room, (1, 0.1), (1, 1), alpha=0.6).length == pytest.approx(0.9)


def test_a_point_on_the_crisp_wall_is_said_to_be_free_at_alpha_one(pillar_room):
    # μ = 1 on the crisp boundary: at α = 1 the inner cut is the crisp map, and a point on its
    # edge is free there (test_a_point_on_an_edge_is_free), so the error names α = 1
    with pytest.raises(PointNotFreeError, match="band") as e:
        plan(pillar_room, (1, 0), (1, 1), alpha=0.5)
    assert e.value.alpha_needed == 1.0
    assert "it is free from about α = 1 on" in str(e.value)
    assert plan(pillar_room, (1, 0), (1, 1), alpha=1.0).length == pytest.approx(1.0)


def test_refuses_a_point_the_radius_pushes_out(pillar_room):
    with pytest.raises(PointNotFreeError, match="closer than the radius 0.3") as e:
        plan(pillar_room, (1, 0.4), (1, 1), radius=0.3)
    # the wall is d = 0.2 in at α = 0 (see above), the radius 2 % more (``_shrink``)
    d = 0.2
    assert e.value.distance == pytest.approx(d + 0.3 * RADIUS_FACTOR - 0.4, abs=1e-6)
    # the safe region keeps 0.3·RADIUS_FACTOR off the wall, (1 − α)·d in at α: the point is free
    # from the α at which that disc's edge, 0.4 − 0.3·RADIUS_FACTOR from the wall, leaves the band
    # (the disc of the radius alone gave 1 − 0.1/d, 0.045 too low: not free there)
    need = 1 - (0.4 - 0.3 * RADIUS_FACTOR) / d
    assert e.value.alpha_needed == pytest.approx(need, abs=1e-3)
    assert f"free from about α = {need:.3g} on with radius 0.3" in str(e.value)
    planner(pillar_room, need + 1e-3, 0.3).piece((1, 0.4))
    with pytest.raises(PointNotFreeError):
        planner(pillar_room, need - 1e-3, 0.3).piece((1, 0.4))
    with pytest.raises(PointNotFreeError, match="no α frees it"):
        plan(pillar_room, (1, 0.25), (1, 1), radius=0.3)


def test_a_point_in_the_margin_beyond_the_radius_is_not_said_to_be_closer_than_it(pillar_room):
    # the safe region keeps radius × RADIUS_FACTOR (about 1.02 r) off the edge (``_shrink``): a
    # point between r and that was refused as "closer than the radius r", which it is not
    margin = f"within the radius 0.3 plus the planner's 2 % margin ({0.3 * RADIUS_FACTOR:.4g} in all) of"
    with pytest.raises(PointNotFreeError) as e:
        plan(ROOM.difference(box(4, 2, 6, 4)), (1, 0.303), (1, 3), radius=0.3)
    assert f"{margin} the edge of the free space" in str(e.value) and "closer than" not in str(e.value)
    d = 0.2  # the wall at α = 0 (see above)
    with pytest.raises(PointNotFreeError) as e:
        plan(pillar_room, (1, d + 0.303), (1, 3), radius=0.3)
    assert f"{margin} the edge of the space free at α = 0; it is free from about α = " in str(e.value)
    # 0.303 from the crisp wall: no α frees it (it said "free from about α = 1 on")
    with pytest.raises(PointNotFreeError) as e:
        plan(pillar_room, (1, 0.303), (1, 3), radius=0.3)
    assert f"{margin} the crisp boundary, so no α frees it" in str(e.value) and e.value.alpha_needed is None
    with pytest.raises(PointNotFreeError):
        planner(pillar_room, 1.0, 0.3).piece((1, 0.303))
    # but by the pillar's corner GEOS's chords come nearer than the margin, and α = 1 frees
    # points there: they are not said to be beyond every α
    corner = (4 + 0.304 * math.cos(math.radians(217.5)), 2 + 0.304 * math.sin(math.radians(217.5)))
    planner(pillar_room, 1.0, 0.3).piece(corner)
    with pytest.raises(PointNotFreeError) as e:
        plan(pillar_room, corner, (1, 3), radius=0.3)
    assert "no α frees it" not in str(e.value)


@pytest.mark.parametrize("dx", [0.0, 0.01, 0.03])
def test_the_alpha_that_frees_a_point_by_a_sharp_corner(dx):
    # a spike 0.2 wide and 3 long into the room: the sweep moves its tip 0.2 along the bisector,
    # so the band about the tip is a wedge 2 cm wide where the disc crosses it, which 48 samples
    # of the disc's edge missed (α = 0 given, 0.499 true for dx = 0.01)
    room = ROOM.difference(shapely.Polygon([(4.9, -1), (5.1, -1), (5, 2)]))
    fz = fuzzify(BRepMap.from_shapely(room), tme=0.2)
    p = (5 + dx, 2.1 + 0.3 * RADIUS_FACTOR)  # free once the tip, 2 + 0.2·(1 − α), is down to 2.1
    with pytest.raises(PointNotFreeError) as e:
        plan(fz, p, (1, 3), radius=0.3)
    need = e.value.alpha_needed
    assert need == pytest.approx(0.5, abs=0.01 + 2 * dx)
    planner(fz, min(need + 2e-3, 1), 0.3).piece(p)  # free where the error says
    # and not much before: the buffer's chords round the tip up to 2 % of the radius nearer
    # (``_shrink``), 0.03 in α here, so the planner frees it from between 0.47 and 0.5
    with pytest.raises(PointNotFreeError):
        planner(fz, need - 0.04, 0.3).piece(p)


def test_the_alpha_that_frees_a_point_beside_a_sharp_tip_is_where_the_tip_last_lies_in_its_disc():
    # the thesis's sweep moves the spike's tip along the spike's axis, from 2.2 at α = 0 to 2 at
    # α = 1; the disc the safe region keeps clear about p first holds the tip's path at
    # y* = p_y − √(R² − dx²): p is free once the tip is below y*, from α = 1 − (y* − 2)/0.2 on.
    # Sampling the disc's edge alone came within 1.5e-3 of it
    room = ROOM.difference(shapely.Polygon([(4.9, -1), (5.1, -1), (5, 2)]))
    fz = fuzzify(BRepMap.from_shapely(room), tme=0.2)
    R = 0.3 * RADIUS_FACTOR
    p = (5.005, 2.1 + R)
    with pytest.raises(PointNotFreeError) as e:
        plan(fz, p, (1, 3), radius=0.3, method="thesis")
    y = p[1] - math.sqrt(R * R - 0.005**2)
    assert e.value.alpha_needed == pytest.approx(1 - (y - 2) / 0.2, abs=1e-4)
    # the safe cut's fan about the tip ends in a segment tangent to the disc of (1 − α)·0.2 at
    # the spike's axis, flat for ±(1 − α)·0.2·tan(ψ/8) about it: the disc about p holds its
    # middle, which reaches 2.1 = p_y − R at α = 0.5
    with pytest.raises(PointNotFreeError) as e:
        plan(fz, p, (1, 3), radius=0.3)
    assert e.value.alpha_needed == pytest.approx(0.5, abs=1e-4)


TILTED = shapely.affinity.rotate(ROOM.difference(box(4, 2, 6, 4)), 17, origin=(0, 0))


def refused(pl: plan_module.Planner, free) -> list[tuple[np.ndarray, PointNotFreeError]]:
    """Random points about ``free`` that ``pl`` refuses, with its errors."""
    x0, y0, x1, y1 = free.bounds
    out = []
    for p in np.random.default_rng(0).uniform((x0 - 1, y0 - 1), (x1 + 1, y1 + 1), (80, 2)):
        try:
            pl.piece(p)
        except PointNotFreeError as e:
            out.append((p, e))
    assert len(out) > 40
    return out


@pytest.mark.parametrize("mode", ["shortest", "clearance"])
def test_the_nearest_free_point_an_error_suggests_is_free(mode):
    # the nearest point of the safe region, computed in floats, lies as often 1e-16 outside it
    # as inside: it was refused as "closer than the radius ... 1.5e-16 m away"
    pl = plan_module.Planner(TILTED, 0.3)
    goal = shapely.affinity.rotate(shapely.Point(1, 1), 17, origin=(0, 0)).coords[0]
    for _, e in refused(pl, TILTED):
        nearest = np.asarray(e.nearest)
        q = pl.plan(nearest, goal, mode)
        assert q.path[0].tolist() == nearest.tolist() and q.path[-1].tolist() == list(goal)
        assert_safe(q, TILTED, 0.3)
        assert pl.covers(q.path)


def printed_nearest(error: PointNotFreeError) -> tuple[float, float]:
    x, y = re.search(r"the nearest free point is \(([^,]+), ([^)]+)\)", str(error)).groups()
    return float(x), float(y)


def test_the_nearest_free_point_as_printed_is_free():
    # printed to 4 significant digits the nearest point was rounded out of the safe region two
    # times in three (Intel): here (7.60553, 8.27921) was printed "(7.606, 8.279)", 0.4 mm out
    pl = plan_module.Planner(TILTED, 0.3)
    for p, e in refused(pl, TILTED):
        shown = printed_nearest(e)
        pl.piece(shown)
        assert math.dist(shown, e.nearest) < 1e-2 and math.dist(p, shown) < e.distance + 1e-2


def test_a_point_on_an_edge_is_free():
    free = ROOM.difference(shapely.Polygon([(4, 2), (6, 2.3), (5.2, 4.1)]))
    a, b = np.array([4.0, 2.0]), np.array([6.0, 2.3])
    into_the_obstacle = np.array([-0.3, 2.0]) / math.hypot(0.3, 2.0)
    for t in np.linspace(0.01, 0.99, 37):
        on_edge = a + t * (b - a)  # on the obstacle's edge, to within the last bit
        p = plan(free, on_edge, (9, 1))
        assert p.path[0].tolist() == on_edge.tolist()
        assert_safe(p, free)
        with pytest.raises(PointNotFreeError):  # but not a micrometre inside the obstacle
            plan(free, on_edge + 1e-6 * into_the_obstacle, (9, 1))


def test_disconnected_pieces_are_no_connection():
    two_rooms = shapely.union(box(0, 0, 4, 4), box(5, 0, 9, 4))
    with pytest.raises(NoConnectionError, match="different pieces") as e:
        plan(two_rooms, (1, 1), (8, 1))
    assert {e.value.start_piece, e.value.goal_piece} == {0, 1}
    assert str(e.value).endswith("no path joins them")  # a polygon has no α: no hint to give


DOOR = shapely.union_all([box(0, 0, 4, 4), box(4, 1.7, 5, 2.3), box(5, 0, 9, 4)])  # a 0.6 m door


def test_radius_closes_a_narrow_door():
    p = plan(DOOR, (1, 1), (8, 1), radius=0.25)
    assert_safe(p, DOOR, 0.25)
    with pytest.raises(NoConnectionError):
        plan(DOOR, (1, 1), (8, 1), radius=0.35)


def test_support_closes_a_door_the_crisp_map_leaves_open():
    # the safe sweep moves the door's walls by the whole d_in = 0.5·(1 − α) each (the thesis's
    # sweep by only 0.5·sin 45° = 0.35 at its corners)
    fz = fuzzify(BRepMap.from_shapely(DOOR), tme=0.5)
    with pytest.raises(NoConnectionError, match="α = 0") as e:
        plan(fz, (1, 1), (8, 1))
    # the message says at which α they are joined (issue 20: it gave no hint): the walls close
    # the door 0.6 wide below α = 0.4 (1.0·(1 − α) > 0.6), so the first step that joins is 0.5
    assert str(e.value).endswith("; at α = 0.5 (radius 0) they are joined")
    with pytest.raises(NoConnectionError, match="at α = 0.25 .*they are joined"):
        plan(fz, (1, 1), (8, 1), method="thesis")  # the thesis's: below α = 1/7 (0.7·(1 − α) > 0.6)
    p = plan(fz, (1, 1), (8, 1), alpha=0.9)
    assert_safe(p, fz.alpha_cut(0.9).inner)
    # with a radius: the higher α and the smaller radius it names both plan, the steps before do not
    with pytest.raises(NoConnectionError) as e:
        plan(fz, (1, 1), (8, 1), alpha=0.6, radius=0.25)  # a gap of 0.2 between the cut's walls
    m = re.search(r"at α = ([0-9.]+) \(radius 0.25\) they are joined and at radius ([0-9.]+) \(α = 0.6\)", str(e.value))
    assert m, str(e.value)
    a, r = float(m.group(1)), float(m.group(2))
    assert (a, r) == (1.0, 0.0625)  # gaps 0.6 ≥ 2·0.25 and 0.2 ≥ 2·0.0625 (not 0.45 nor 2·0.125)
    assert plan(fz, (1, 1), (8, 1), alpha=a, radius=0.25).length > 7
    assert plan(fz, (1, 1), (8, 1), alpha=0.6, radius=r).length > 7
    with pytest.raises(NoConnectionError):
        plan(fz, (1, 1), (8, 1), alpha=a - 0.25, radius=0.25)


def test_bad_arguments_are_value_errors():
    with pytest.raises(ValueError, match="mode"):
        plan(U, (1, 1), (9, 1), mode="fastest")
    with pytest.raises(ValueError, match="radius"):
        plan(U, (1, 1), (9, 1), radius=-1)
    with pytest.raises(ValueError, match="start"):
        plan(U, (1, 1, 1), (9, 1))
    with pytest.raises(ValueError, match="goal"):
        plan(U, (1, 1), (math.nan, 1))


@pytest.mark.filterwarnings("error")
def test_a_start_or_goal_too_far_out_to_compute_with_is_refused_clearly(pillar_room):
    # a start at 1e300 was refused after an overflow warning, one at (−1e308, 1e308) with an
    # AttributeError; a radius near the largest float made GEOS's buffer overflow (a warning)
    for s in ((1e300, 1), (-1e308, 1e308), (1, -1e61)):
        with pytest.raises(PointNotFreeError, match=r"far outside the map, beyond ±1e\+60 m") as e:
            plan(pillar_room, s, (1, 1))
        assert e.value.which == "start" and e.value.distance is None
    with pytest.raises(PointNotFreeError, match="goal .* far outside"):
        plan(pillar_room, (1, 1), (1e300, 1), mode="clearance")
    with pytest.raises(PointNotFreeError, match="is empty"):
        plan(pillar_room, (1, 1), (1, 2), radius=1.7e308)


@pytest.mark.filterwarnings("error")
def test_a_map_too_large_to_compute_with_is_refused_clearly(pillar_room):
    # one 1e80 across overflowed GEOS's triangulation (a warning, then a path, or a QhullError).
    # (No ``pytest.raises(...) as e`` here: it would keep these maps, in the planners' cache, alive
    # until the garbage collector runs, which test_planners_are_kept_with_their_map counts on.)
    # Since issue 19 such a map is refused when it is fuzzified (validate_map holds every ring to
    # ±LARGEST); the planner's own check stays for the crisp maps and polygons it is given
    geom = shapely.affinity.scale(ROOM.difference(box(4, 2, 6, 4)), 1e79, 1e79, origin=(0, 0))
    crisp = BRepMap.from_shapely(geom)
    with pytest.raises(GeometryError, match=r"coordinate \[1e\+80, 0.0\] is beyond ±1e\+60"):
        fuzzify(crisp, tme=2e78)
    with pytest.raises(PlanError, match=r"coordinates reach 1e\+80 m: the planner works within ±1e\+60 m"):
        plan_module.Planner(geom)
    for source in (crisp, geom):  # the safe region of a crisp map or a polygon too
        with pytest.raises(PlanError, match="coordinates reach"):
            plan_module.safe_region(source, radius=1e78)
    # 1e50 across is still planned in
    k = 1e49
    big = fuzzify(BRepMap.from_shapely(shapely.affinity.scale(ROOM.difference(box(4, 2, 6, 4)), k, k,
                                                              origin=(0, 0))), tme=0.2 * k)
    assert plan(big, (k, 3 * k), (9 * k, 3 * k), mode="clearance").length > 8 * k
    assert plan(big, (k, 3 * k), (9 * k, 3 * k)).length == pytest.approx(plan(pillar_room, (1, 3), (9, 3)).length * k)


def test_bad_arguments_where_alpha_does_not_apply_are_value_errors_too():
    # α = 5, −1 or NaN was ignored for a crisp map or a polygon (a bad method was not)
    crisp = BRepMap.from_shapely(U)
    for source in (crisp, U):
        for alpha in (5, -1, math.nan, "x"):
            with pytest.raises(ValueError, match="α must"):
                plan(source, (1, 1), (9, 1), alpha=alpha)
        with pytest.raises(ValueError, match="α must"):
            plan_module.free_space(source, 2.0)
        with pytest.raises(ValueError, match="method"):
            plan_module.safe_region(source, 0.0, 0.1, "buffer")
        assert plan(source, (1, 1), (9, 1), alpha=None).alpha is None
        assert plan(source, (1, 1), (9, 1), alpha=0.7).length == pytest.approx(2 * math.hypot(1, 7) + 6)


def test_a_planner_takes_a_region_and_covers_takes_points():
    # AttributeError ('list' object has no attribute 'is_empty') and IndexError before
    with pytest.raises(TypeError, match="Shapely"):
        plan_module.Planner([(0, 0), (1, 0), (1, 1)])
    pl = plan_module.Planner(U)
    for path in ([], np.zeros((0, 2)), [1.0, 1.0], [[1, 1, 1]]):
        with pytest.raises(ValueError, match=r"\(k, 2\)"):
            pl.covers(path)
    assert pl.covers([[1, 1]]) and not pl.covers([[1, 1], [9, 1]])


def test_a_crisp_map_is_planned_in_as_it_is():
    p = plan(BRepMap.from_shapely(U), (1, 1), (9, 1))
    assert p.alpha is None and p.method is None
    assert p.length == pytest.approx(2 * math.hypot(1, 7) + 6)


def test_planners_are_kept_with_their_map_and_share_its_alpha_cut(pillar_room):
    a = planner(pillar_room, 0.0, 0.1)
    assert planner(pillar_room, 0, 0.1) is a
    assert planner(pillar_room, 0.0, 0.3).free is a.free
    assert planner(pillar_room, 0.0, 0.1, "exact").free is not a.free
    fz = fuzzify(BRepMap.from_shapely(U), tme=0.1)
    planner(fz, 0.0).plan((1, 1), (9, 1))
    assert planner(pillar_room, 0.0, 0.1, "sweep") is planner(pillar_room, 0.0, 0.1, "thesis")  # its old name
    gc.collect()  # maps other tests left for the collector go now, not in the count below
    n = len(plan_module._PLANNERS)
    del fz
    gc.collect()
    assert len(plan_module._PLANNERS) == n - 1  # the cache does not keep a map alive


def test_an_edge_that_fails_the_check_is_dropped_and_the_search_repeated(monkeypatch):
    free = ROOM.difference(box(4, 2, 6, 4))
    search = VisibilityGraph.shortest_path
    calls = []

    def through_the_pillar_first(self, s, g, part, exclude=None):
        calls.append(exclude)
        return np.array([s, (5.0, 3.0), g]) if len(calls) == 1 else search(self, s, g, part, exclude)

    monkeypatch.setattr(VisibilityGraph, "shortest_path", through_the_pillar_first)
    p = plan(free, (1, 3), (9, 3))
    assert len(calls) == 2 and len(calls[1]) == 2
    assert p.length == pytest.approx(2 * math.sqrt(10) + 2)
    assert_safe(p, free)


def test_when_the_graph_fails_a_path_through_the_triangles_is_returned(monkeypatch):
    monkeypatch.setattr(VisibilityGraph, "shortest_path", lambda *a, **k: None)
    free = ROOM.difference(box(4, 2, 6, 4))
    p = plan(free, (1, 3), (9, 3))
    assert_safe(p, free)
    assert p.length >= 2 * math.sqrt(10) + 2
    assert "not the shortest" in p.note


def test_the_largest_piece_of_an_empty_safe_region_is_a_plan_error(pillar_room):
    # a radius wider than every corridor: NumPy's "attempt to get argmax of an empty sequence"
    for pl in (planner(pillar_room, 0.0, 5.0), plan_module.Planner(shapely.Polygon())):
        assert len(pl.pieces) == 0
        with pytest.raises(PlanError, match=r"the safe region \(.*radius \d.*\) is empty"):
            pl.largest_piece
    assert planner(pillar_room, 0.0, 0.1).largest_piece.area > 40


def test_the_graphs_of_an_empty_safe_region_are_a_plan_error():
    # IndexError ("boolean index did not match indexed array") from visibility.py, where
    # benchmarks/plan.py met it first at a radius wider than every corridor
    pl = plan_module.Planner(ROOM, 4)
    for graph, name in (("visibility", "visibility graph"), ("medial", "medial axis"),
                        ("axis_links", "visibility graph")):
        with pytest.raises(PlanError, match=rf"the safe region \(radius 4\) is empty: it has no {name}"):
            getattr(pl, graph)


def test_free_points_refuses_a_region_with_no_area():
    # the empty safe region (a radius that leaves nothing free) failed with NumPy's "Range exceeds
    # valid bounds", and a region of no area, a line, drew forever
    empty = plan_module.Planner(ROOM, 4).safe
    for region in (empty, shapely.LineString([(0, 0), (1, 1)])):
        with pytest.raises(ValueError, match="no area"):
            free_points(region, 2, np.random.default_rng(0))
    assert shapely.contains_xy(ROOM, *free_points(ROOM, 5, np.random.default_rng(0)).T).all()


# ------------------------------------------------------------------- clearance mode

L_CORRIDOR = shapely.union(box(0, 0, 2, 10), box(0, 8, 12, 10))  # 2 m wide, turning right


def test_clearance_mode_keeps_further_from_the_walls_than_shortest_mode():
    s, g = (1, 1), (11, 9)  # on the centre line
    short = plan(L_CORRIDOR, s, g)
    clear = plan(L_CORRIDOR, s, g, mode="clearance")
    assert_safe(short, L_CORRIDOR)
    assert_safe(clear, L_CORRIDOR)
    assert short.clearance == pytest.approx(0, abs=1e-12)  # it cuts the inner corner
    assert clear.clearance > 0.9  # the centre line is 1 m from both walls; the turn cuts a little
    assert clear.note is None and clear.mode == "clearance"
    assert short.length < clear.length < 1.2 * short.length


def test_clearance_mode_with_a_radius_stays_inside(pillar_room):
    p = plan(pillar_room, (1, 3), (9, 3), radius=0.3, mode="clearance")
    assert_safe(p, pillar_room.alpha_cut(0).inner, 0.3)
    assert p.clearance > 0.6  # between pillar and wall the middle is 1 m from each


# ------------------------------------------------------------------- visibility walks


def jagged_room(seed: int = 3) -> shapely.Geometry:
    rng = np.random.default_rng(seed)
    c = rng.uniform(0.5, 19.5, (60, 2))
    w = rng.uniform(0.1, 0.8, (60, 2))
    clutter = shapely.union_all(shapely.box(*(c - w).T, *(c + w).T))
    a = np.linspace(0, 2 * np.pi, 90, endpoint=False)
    wall = shapely.Polygon(np.column_stack((10 + (9.8 + 0.3 * np.sin(7 * a)) * np.cos(a),
                                            10 + (9.8 + 0.3 * np.sin(7 * a)) * np.sin(a))))
    return shapely.orient_polygons(wall.difference(clutter))


def test_walks_agree_with_geos_on_a_cluttered_room():
    region = max(shapely.get_parts(jagged_room()), key=lambda g: g.area)
    tri = Triangulation.of(region)
    v = tri.points
    rng = np.random.default_rng(0)
    i, j = rng.integers(0, len(v), 3000), rng.integers(0, len(v), 3000)
    seen = tri.visible(i, v[j], j)
    covered = shapely.covers(shapely.buffer(region, TOL), shapely.linestrings(np.stack((v[i], v[j]), axis=1)))
    assert not (seen & ~covered).any()  # a walk never sees through a wall
    # and sees everything GEOS covers, but for segments through a vertex (blocked by convention)
    d = v[j] - v[i]
    through = np.zeros(len(i), bool)
    for k in np.flatnonzero(covered & ~seen):
        rel = v - v[i[k]]
        cross = rel[:, 0] * d[k, 1] - rel[:, 1] * d[k, 0]
        t = rel @ d[k] / (d[k] @ d[k])
        through[k] = ((np.abs(cross) <= 1e-9 * (d[k] @ d[k])) & (t > 1e-12) & (t < 1 - 1e-12)).any()
    assert (~seen & covered <= through).all()
    assert seen.sum() > 100


def test_walks_follow_the_documented_conventions():
    """The region is closed: a segment to a point of the boundary is inside. A segment through a
    vertex other than its ends is blocked, even along a straight wall (module docstring)."""
    tri = Triangulation.of(shapely.Polygon([(0, 0), (4, 0), (0, 4)]))
    o = tri.vertex_index(np.array([[0.0, 0.0]]))
    assert tri.visible(o, np.array([[2.0, 2.0]])).tolist() == [True]  # the middle of the far edge
    wall = shapely.Polygon([(0, 0), (2, 0), (4, 0), (4, 4), (0, 4)])  # a flat vertex at (2, 0)
    tri = Triangulation.of(wall)
    o = tri.vertex_index(np.array([[0.0, 0.0], [0.0, 0.0]]))
    far = np.array([[4.0, 0.0], [3.0, 0.0]])
    assert tri.visible(o, far, tri.vertex_index(far)).tolist() == [False, False]
    assert tri.visible(tri.vertex_index(np.array([[2.0, 0.0]])), np.array([[4.0, 0.0]])).tolist() == [True]


def test_corners_keep_flat_vertices_and_tangents_along_an_edge():
    """Flat vertices are corners, so a path may run along a straight wall of several edges; a line
    along one of a corner's edges is tangent there (it leaves both edges on one side)."""
    assert Corners.of(shapely.Polygon([(0, 0), (2, 0), (4, 0), (4, 4), (0, 4)])).xy.tolist() == [[2.0, 0.0]]
    corners = Corners.of(shapely.Polygon([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)]))  # reflex at (2, 2)
    assert corners.xy.tolist() == [[2.0, 2.0]]
    along, across = np.array([[3.0, 2.0]]), np.array([[3.0, 3.0]])
    assert corners.tangent(np.array([0]), along).tolist() == [True]
    assert corners.tangent(np.array([0]), across).tolist() == [False]


def test_medial_axis_refuses_a_spacing_that_is_not_positive():
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="spacing must be positive"):
            MedialAxis.of(box(0, 0, 4, 2), bad)


def test_visibility_graph_edges_are_inside_and_tangent():
    region = max(shapely.get_parts(jagged_room()), key=lambda g: g.area)
    graph = VisibilityGraph.of(region)
    pts = graph.triangulation.points
    segs = shapely.linestrings(np.stack((pts[graph.edges[:, 0]], pts[graph.edges[:, 1]]), axis=1))
    assert shapely.covers(shapely.buffer(region, TOL), segs).all()
    assert len(graph.edges) > len(Corners.of(region))


# ------------------------------------------------------------------- command line


@pytest.fixture(scope="module")
def room_file(tmp_path_factory, pillar_room):
    path = tmp_path_factory.mktemp("plan") / "room.json"
    pillar_room.save(path)
    return path


def test_cli_json_and_plot(room_file, tmp_path, capsys):
    png = tmp_path / "plan.png"
    assert main(["plan", str(room_file), "--start", "1", "3", "--goal", "9", "3", "--radius", "0.1", "--json",
                 "--plot", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mode"] == "shortest" and out["alpha"] == 0 and out["radius"] == 0.1 and out["method"] == "safe"
    path = np.array(out["path"])
    assert path[0].tolist() == [1, 3] and path[-1].tolist() == [9, 3]
    assert out["length"] == pytest.approx(shapely.LineString(path).length)
    assert out["clearance"] >= 0.1 - TOL
    assert png.stat().st_size > 10_000


def test_cli_text_and_clearance_mode(room_file, capsys):
    assert main(["plan", str(room_file), "--start", "1", "3", "--goal", "9", "3", "--mode", "clearance",
                 "--method", "exact", "--alpha", "0.5"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("clearance path: length ") and "α = 0.5" in lines[0] and "exact" in lines[0]
    assert lines[1] == "1 3" and lines[-1] == "9 3"


def test_cli_text_lengths_in_mm_print_without_an_exponent(tmp_path, capsys):
    # the thesis's unit: a path of over 10000 mm across a 10 x 6 m room (before, 4 digits:
    # "length 1.087e+04 mm"); read back, the figures are the plan's to 6 digits
    mm = BRepMap.from_shapely(shapely.affinity.scale(ROOM.difference(box(4, 2, 6, 4)), 1000, 1000, origin=(0, 0)),
                              unit="mm")
    fuzzify(mm, tme=200.0).save(tmp_path / "mm.json")
    assert main(["plan", str(tmp_path / "mm.json"), "--start", "500", "500", "--goal", "9500", "5500"]) == 0
    head = capsys.readouterr().out.splitlines()[0]
    length, clearance = (float(head.split(k)[1].split()[0].rstrip(",")) for k in ("length ", "clearance "))
    assert "e+" not in head and 10000 < length < 12000 and clearance >= 0
    assert main(["plan", str(tmp_path / "mm.json"), "--start", "500", "500", "--goal", "9500", "5500", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert length == pytest.approx(out["length"], rel=1e-5) and clearance == pytest.approx(out["clearance"], rel=1e-5, abs=1e-9)


@pytest.mark.parametrize("mode", ["shortest", "clearance"])
def test_cli_text_path_read_back_stays_in_the_safe_region_far_from_the_origin(tmp_path, capsys, mode):
    # UTM-like coordinates: 6 significant digits were metres here, and the path read back
    # crossed the pillar; now each point is printed to within an eighth of the tolerance
    dx, dy = 5e5, 4e6
    fz = fuzzify(BRepMap.from_shapely(shapely.affinity.translate(ROOM.difference(box(4, 2, 6, 4)), dx, dy)), tme=0.2)
    fz.save(tmp_path / "utm.json")
    s, g = (dx + 1.3, dy + 2.9), (dx + 8.7, dy + 3.1)
    assert main(["plan", str(tmp_path / "utm.json"), "--start", *map(repr, s), "--goal", *map(repr, g),
                 "--radius", "0.3", "--mode", mode]) == 0
    lines = capsys.readouterr().out.splitlines()
    path = np.array([[float(v) for v in line.split()] for line in lines[1:]])
    pl = planner(fz, 0.0, 0.3)
    assert len(path) > 2 and pl.covers(path)
    assert np.abs(path - pl.plan(s, g, mode).path).max() <= pl.tolerance / 16
    assert lines[1] == "500001.3 4000002.9" and lines[-1] == "500008.7 4000003.1"


@given(st.floats(min_value=-1e300, max_value=1e300), st.floats(min_value=1e-300, max_value=1e300))
@example(v=7.0000355399440856e+16, step=10.0)  # 16 digits, but the float read back is 8 away (floats are 16 apart there)
@settings(max_examples=300, deadline=None)
def test_cli_coordinates_are_printed_within_half_a_step(v, step):
    # (not near the largest float: rounded up, 1.79769313485e308 reads back as inf; paths lie
    # within ±plan.LARGEST)
    from fuzzybrep.commands.plan import _coordinate

    assert abs(float(_coordinate(v, step)) - v) <= step / 2


def test_cli_coordinates_are_printed_with_the_digits_the_step_needs():
    from fuzzybrep.commands.plan import _coordinate

    for v, step, text in [(-9.8, 2**-30, "-9.8"), (4.0, 2**-30, "4"), (0.0, 1e-9, "0"), (-0.0, 1e-9, "0"),
                          (500003.70548387617, 1.2e-9, "500003.705483876"), (-123456.0, 1e4, "-1.2e+05"),
                          (0.3, 1.0, "0.3"), (-1e-300, 1e-9, "-1e-300"), (1 / 3, 1e-300, "0.33333333333333331")]:
        assert _coordinate(v, step) == text, (v, step)


def test_cli_says_why_in_one_line_and_exits_2(room_file, capsys):
    assert main(["plan", str(room_file), "--start", "5", "3", "--goal", "9", "3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("fuzzybrep plan: error: start (5, 3) is not free: it lies inside an obstacle")


def test_cli_takes_negative_numbers_with_an_exponent(room_file, capsys):
    # argparse took "-1e-3" for an option: "argument --goal: expected 2 arguments"
    assert main(["plan", str(room_file), "--start", "1", "1", "--goal", "-1e-3", "3"]) == 2
    assert capsys.readouterr().err.startswith("fuzzybrep plan: error: goal (-0.001, 3) is not free: it lies "
                                              "outside the map")
    assert main(["plan", str(room_file), "--start", "1", "1", "--goal", "9", "3", "--alpha", "1", "--radius",
                 "1E-1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["radius"] == 0.1
    with pytest.raises(SystemExit):
        main(["plan", str(room_file), "--start", "1", "1", "--goal", "9", "3", "--radius", "-1e-3"])
    assert "radius must be a finite number ≥ 0, got -1e-3" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["plan", str(room_file), "--start", "1", "1", "--goal", "-inf", "3"])
    assert "-inf must be a finite number" in capsys.readouterr().err


def test_cli_a_start_too_far_out_is_one_line_with_no_warning(room_file, capsys):
    assert main(["plan", str(room_file), "--start", "1e300", "1", "--goal", "9", "3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["fuzzybrep plan: error: start (1e+300, 1) is not free: it lies far outside the map, beyond "
                   "±1e+60 m, too far for its distance to be measured"]


# ------------------------------------------------------------------- real maps

REAL = ["intel", "aces"]
if os.environ.get("FUZZYBREP_SLOW_TESTS"):
    REAL.append("freiburg")  # about 45 s to build: only when asked for


@pytest.fixture(scope="module", params=REAL)
def real(request, built_map):
    """A map built by ``fuzzybrep build`` from a CARMEN log, loaded, and its α = 0 cut."""
    out, fz = built_map(request.param)
    return request.param, out, fz, planner(fz, 0.0).free  # the α-cut, kept for every radius


@pytest.mark.reallog
@pytest.mark.parametrize("radius", [0.0, 0.2])
def test_real_map_paths_stay_in_the_safe_region(real, radius):
    name, _, fz, free = real
    pl = planner(fz, 0.0, radius)
    rng = np.random.default_rng(7)
    pts = free_points(pl.largest_piece, 120, rng)
    for s, g in zip(pts[:60], pts[60:]):
        p = pl.plan(s, g)
        assert_safe(p, free, radius)
        assert pl.covers(p.path)
        assert p.length >= math.dist(s, g) - TOL
    # points anywhere in the safe region: a path, or different pieces
    pts = free_points(pl.safe, 40, rng)
    for s, g in zip(pts[:20], pts[20:]):
        try:
            assert_safe(pl.plan(s, g), free, radius)
        except NoConnectionError:
            assert pl.piece(s) != pl.piece(g)


def mean_clearance(path, free) -> float:
    pts = shapely.get_coordinates(shapely.segmentize(shapely.LineString(path), 0.05))
    return float(shapely.distance(shapely.points(pts), _grown(free)[1]).mean())


@pytest.mark.reallog
def test_real_map_clearance_paths_stay_inside_and_keep_clear(real):
    name, _, fz, free = real
    pl = planner(fz, 0.0, 0.2)
    pts = free_points(pl.largest_piece, 40, np.random.default_rng(11))
    gain = []
    for s, g in zip(pts[:20], pts[20:]):
        p = pl.plan(s, g, mode="clearance")
        assert_safe(p, free, 0.2)
        assert p.note is None, p.note
        short = pl.plan(s, g)
        # never nearer the walls than the shortest path comes. (Its mean distance from them may be
        # a little less: a short hop across an open hall detours to the medial axis and back.)
        assert p.clearance >= short.clearance - 0.02
        gain.append(mean_clearance(p.path, free) - mean_clearance(short.path, free))
    assert np.mean(gain) > 0.1  # and on average well away from them


@pytest.mark.reallog
def test_real_map_refuses_points_that_are_not_free(real):
    name, _, fz, free = real
    crisp = fz.crisp_geometry
    x0, y0, x1, y1 = crisp.bounds
    with pytest.raises(PointNotFreeError, match="outside the map"):
        plan(fz, (x1 + 5, y1 + 5), shapely.get_coordinates(shapely.point_on_surface(free))[0])
    band = shapely.difference(crisp, shapely.buffer(free, 0.01))
    rng = np.random.default_rng(3)
    inside = free_points(free, 1, rng)[0]
    for p in free_points(band, 10, rng):
        with pytest.raises(PointNotFreeError) as e:
            plan(fz, p, inside)
        assert e.value.distance > 0 and e.value.which == "start"
        planner(fz, 0.0).piece(printed_nearest(e.value))  # the point it names is free as printed
    holes = [shapely.Polygon(h.closed_coords()) for h in fz.crisp.regions[0].holes]
    hole = max(holes, key=lambda h: h.area)
    with pytest.raises(PointNotFreeError, match="obstacle|outside"):
        plan(fz, inside, shapely.get_coordinates(shapely.point_on_surface(hole))[0])


@pytest.mark.reallog
def test_real_map_the_alpha_an_error_names_frees_the_point(real):
    name, _, fz, free = real
    pl = planner(fz, 0.0, 0.2)
    band = shapely.difference(fz.crisp_geometry, pl.safe)
    checked = 0
    for p in free_points(band, 40, np.random.default_rng(8)):
        with pytest.raises(PointNotFreeError) as e:
            pl.plan(p, p)
        need = e.value.alpha_needed
        if need is None or need > 0.94:
            continue
        plan_module.Planner.of(fz, need + 0.01, 0.2).piece(p)  # the disc of the radius alone: never
        with pytest.raises(PointNotFreeError):  # nor long before (chords: ``_shrink``)
            plan_module.Planner.of(fz, max(need - 0.05, 0), 0.2).piece(p)
        checked += 1
        if checked == 3:
            break
    assert checked == 3


@pytest.mark.reallog
def test_real_map_plan_command(real, capsys):
    name, path, fz, free = real
    pl = planner(fz, 0.0, 0.2)
    s, g = free_points(pl.largest_piece, 2, np.random.default_rng(5))
    assert main(["plan", str(path), "--start", *map(str, s), "--goal", *map(str, g), "--radius", "0.2",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert shapely.covers(shapely.buffer(pl.safe, TOL), shapely.LineString(out["path"]))


def test_bad_planner_arguments_raise_plan_errors():
    # before: bare ValueErrors from the planner's checks of a radius or a point
    fz = fuzzify(BRepMap((Region(Ring([(0, 0), (4, 0), (4, 4), (0, 4)])),)), tme=0.1)
    for radius in (-1.0, math.nan, "x"):
        with pytest.raises(PlanError, match="radius must be"):
            planner(fz, 0.0, radius)
    pl = planner(fz, 0.0, 0.1)
    with pytest.raises(PlanError, match=r"goal must be a point \(x, y\) of two finite numbers, got \[nan, 1.0\]"):
        pl.plan((1, 1), [math.nan, 1.0])
    with pytest.raises(PlanError, match=r"start must be a point \(x, y\)"):
        pl.plan("here", (2, 2))
