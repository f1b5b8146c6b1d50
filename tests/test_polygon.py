"""Scan polygons (thesis 3.2.1): always simple, and never free space the scan did not see."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from _synthetic import room, scan_of
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from fuzzybrep.brep import FRONTIER, OBSTACLE
from fuzzybrep.mapping.lines import LineConfig
from fuzzybrep.scans.filters import CLIPPED, FAR, NONE, RETURN, depth_continuous
from fuzzybrep.mapping.scan_polygon import PolygonConfig, scan_polygon, scan_polygons
from fuzzybrep.scans.filters import BeamConfig, classify, classify_all
from fuzzybrep.scans.scan import Scan, even_bearings


#: the fan alone, without the robot's footprint about the sensor (tested on its own below)
FAN = PolygonConfig(footprint=0.0)


def polygon(scan, cfg=BeamConfig(), polygon_cfg=FAN):
    free, status = classify(scan, cfg)
    return scan_polygon(scan, free, status, polygon_cfg)


# at least 45 beams over 180° (4°): coarser scanners leave the space between beams to guesswork
ranges_st = arrays(np.float64, st.integers(45, 200), elements=st.one_of(
    st.floats(0.2, 7.5), st.just(8.0), st.floats(8.5, 30.0)))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ranges=ranges_st, full=st.booleans(), heading=st.floats(-np.pi, np.pi), x=st.floats(-50, 50))
# a corner window reaching past a short line's middle put its two corners out of order
@example(ranges=np.r_[np.full(9, 0.375), 0.25, np.full(35, 0.375)], full=False, heading=0.0, x=0.0)
@example(ranges=np.r_[np.full(31, 0.375), 0.25, np.full(13, 0.375)], full=False, heading=0.0, x=0.0)
def test_scan_polygon_is_always_simple_and_star_shaped(ranges, full, heading, x):
    n = len(ranges) * (2 if full else 1)
    ranges = np.resize(ranges, n)
    fov = 2 * np.pi * (n - 1) / n if full else np.pi
    scan = Scan(ranges, even_bearings(n, fov), np.array([x, -x / 2, heading]), 0.0, 8.0)
    ring = polygon(scan).ring
    g = shapely.Polygon(ring.vertices)
    assert g.is_valid, shapely.is_valid_reason(g)
    assert ring.signed_area > 0  # counter-clockwise, like a principal polygon
    # star-shaped around the sensor: every vertex seen from the sensor without crossing the boundary
    v = ring.vertices - scan.pose[:2]
    ang = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
    r = np.hypot(*v.T)
    moving = r > 1e-9  # the apex of a 180° fan is the sensor itself
    assert np.all(np.diff(ang[moving]) >= -1e-9)
    # nothing is claimed much beyond where the beams ended (or the usable maximum): a corner of
    # two lines may stand out by the line tolerance (at most 4 x max(1% of range, 3 cm))
    assert r.max() <= min(max(ranges.max(), 0.05), 8.0) * 1.04 + 0.12 + 1e-9


def test_a_scan_is_split_into_runs_and_kinds():
    scan = scan_of(room(6, 4), (3.0, 2.0, 0.0), n=181)
    ring = polygon(scan).ring
    # the fan's apex and its two edge rays are frontiers; the walls are obstacle edges
    assert np.allclose(ring.vertices[0], [3.0, 2.0])
    assert ring.kinds[0] == FRONTIER and ring.kinds[-1] == FRONTIER
    assert (ring.kinds == OBSTACLE).sum() >= 3


def test_depth_jump_does_not_fan_into_the_shadow():
    # a pillar in front of a wall: the space behind the pillar was not seen
    world = shapely.Polygon(shapely.box(0, 0, 7.5, 6).exterior, [shapely.box(4.0, 2.8, 4.4, 3.2).exterior])
    scan = scan_of(world, (1.0, 3.0, 0.0), n=361)
    g = shapely.Polygon(polygon(scan).ring.vertices)
    shadow = shapely.points([(5.0, 3.0), (7.0, 3.0), (7.3, 3.0), (6.0, 3.1)])
    assert not shapely.contains(g, shadow).any()
    # while beside the shadow the free space reaches the far wall
    assert shapely.contains(g, shapely.points([(7.3, 1.5), (7.3, 4.5)])).all()


def test_no_return_gap_is_unknown_and_far_beams_stop_at_the_usable_range():
    r = np.full(181, 3.0)
    r[80:100] = 81.83  # nothing came back: unknown
    r[120:140] = 20.0  # a return beyond the usable range
    scan = Scan(r, even_bearings(181), np.zeros(3), 0.0, 81.83)
    b = scan.bearings
    along = lambda i, d: (d * np.cos(b[i]), d * np.sin(b[i]))  # noqa: E731
    free, status = classify(scan, BeamConfig(no_return_chord=False))
    assert (status[80:100] == NONE).all() and (status[120:140] == FAR).all()
    g = shapely.Polygon(scan_polygon(scan, free, status, FAN).ring.vertices)
    assert not g.contains(shapely.Point(along(90, 1.0)))  # no return: not even 1 m is claimed
    assert g.contains(shapely.Point(along(130, 7.0)))  # far beam: free up to 8 m
    assert not g.contains(shapely.Point(along(130, 8.5)))
    # by default the gap claims up to the segment joining its neighbours' returns, 3 m either
    # side of 20 beams: 3 cos(10.5°) = 2.95 m in its middle, and nothing beyond
    free, status = classify(scan)
    assert (status[80:100] == NONE).all()
    np.testing.assert_allclose(free[89:91], 3 * np.cos(np.radians(10.5)) / np.cos(np.radians(0.5)), rtol=1e-9)
    g = shapely.Polygon(scan_polygon(scan, free, status, FAN).ring.vertices)
    assert g.contains(shapely.Point(along(90, 2.9))) and not g.contains(shapely.Point(along(90, 3.0)))


def test_spikes_through_glass_and_narrow_gaps_add_nothing():
    r = np.full(181, 2.0)
    r[50] = 7.0  # one beam through glass
    r[100:103] = 6.0  # three beams through a narrow gap in the wall
    scan = Scan(r, even_bearings(181), np.zeros(3), 0.0, 81.83)
    free, status = classify(scan)
    assert (status[[50, 100, 101, 102]] == CLIPPED).all()
    g = shapely.Polygon(scan_polygon(scan, free, status).ring.vertices)
    b = scan.bearings
    for i in (50, 101):
        assert not g.contains(shapely.Point(3.0 * np.cos(b[i]), 3.0 * np.sin(b[i])))
    # a wide opening (a doorway seen from close by) is not a spike
    r2 = np.full(181, 2.0)
    r2[80:110] = 6.0
    f2, s2 = classify(Scan(r2, even_bearings(181), np.zeros(3), 0.0, 81.83))
    assert (s2[80:110] == RETURN).all() and np.allclose(f2[80:110], 6.0)


def test_full_circle_scan_has_no_apex_and_covers_the_room():
    scan = scan_of(room(6, 4), (3.0, 2.0, 0.7), n=360, fov=2 * np.pi - np.radians(1))
    assert scan.full_circle
    ring = polygon(scan).ring
    assert not np.any(np.all(np.isclose(ring.vertices, [3.0, 2.0]), axis=1))
    g = shapely.Polygon(ring.vertices)
    assert g.area > 0.98 * 24


def test_batched_polygons_equal_one_at_a_time():
    rng = np.random.default_rng(7)
    scans = [scan_of(room(6, 4), (rng.uniform(1, 5), rng.uniform(1, 3), rng.uniform(-3, 3)), n=181, sigma=0.01, seed=k)
             for k in range(6)]
    beams = classify_all(scans)
    together = scan_polygons(scans, [f for f, _ in beams], [s for _, s in beams])
    for s, (f, st_), p in zip(scans, beams, together):
        one = scan_polygon(s, f, st_)
        assert one.ring.equals_exactly(p.ring)


def fan(free, status, bearings=None, cfg=FAN):
    """The polygon of a 180° scan at the origin with the given free ranges and statuses."""
    free = np.asarray(free, np.float64)
    b = even_bearings(len(free)) if bearings is None else bearings
    scan = Scan(free, b, np.zeros(3), 0.0, 81.83)
    return scan_polygon(scan, free, np.asarray(status), cfg).ring


def bearing(v):
    return np.arctan2(v[:, 1], v[:, 0])


def test_adaptive_depth_jump_threshold_of_borges_and_aldon():
    # D_max = r sin Δφ / sin(λ - Δφ) + floor: at r = 2 m, Δφ = 1°, λ = 10°, 5 cm: 0.2731 m
    limit = 2 * np.sin(np.radians(1)) / np.sin(np.radians(9)) + 0.05
    f1 = np.array([2 + limit - 0.005, 2 + limit + 0.005, 2 - limit + 0.005])
    assert np.isclose(limit, 0.2731, atol=1e-4)
    cont = depth_continuous(np.full(3, 2.0), f1, np.radians([1.0, 1.0, 1.0]), PolygonConfig())
    # the nearer range sets the limit: 2 - limit + 0.005 is within the limit at 2 m, but at
    # its own (nearer) range the allowance is smaller still and it is a jump
    assert list(cont) == [True, False, False]


def test_the_wedge_across_a_depth_jump_is_free_only_to_the_nearer_range():
    r = np.r_[np.full(91, 2.0), np.full(90, 6.0)]  # a wall at 2 m, then an opening to 6 m
    g = shapely.Polygon(fan(r, np.full(181, RETURN)).vertices)
    b = even_bearings(181)
    mid = (b[90] + b[91]) / 2
    # (were the wedge free to the farther range, its edge would cross the middle at about 3 m)
    assert g.contains(shapely.Point(1.9 * np.cos(mid), 1.9 * np.sin(mid)))
    assert not g.contains(shapely.Point(2.5 * np.cos(mid), 2.5 * np.sin(mid)))
    assert g.contains(shapely.Point(4.0 * np.cos(b[91] + 0.001), 4.0 * np.sin(b[91] + 0.001)))


def test_missing_beams_leave_a_frontier_not_a_wall():
    # beams 85..89 lost (a 5° gap, less than the jump angle): nothing looked there, so the edge
    # across the gap is a frontier even though the ranges on both sides agree
    keep = np.r_[0:85, 90:181]
    b = even_bearings(181)[keep]
    ring = fan(np.full(len(keep), 2.0), np.full(len(keep), RETURN), b)
    v, k = ring.vertices, ring.kinds
    ang = bearing(v)
    nxt = np.roll(np.arange(len(v)), -1)
    across = (ang <= b[84] + 1e-9) & (ang[nxt] >= b[85] - 1e-9) & (np.hypot(*v.T) > 0)
    assert across.sum() == 1 and k[across][0] == FRONTIER


def test_the_first_ray_claims_nothing_beyond_the_first_beam():
    # a 180° fan whose first beam (clipped at 2 m) is depth-continuous with the next ones at
    # 2.2 m: the boundary leaves the sensor along the first ray only as far as that beam
    r = np.full(181, 2.2)
    r[0] = 2.0
    st_ = np.full(181, RETURN)
    st_[0] = CLIPPED
    ring = fan(r, st_)
    g = shapely.Polygon(ring.vertices)
    assert g.is_valid, shapely.is_valid_reason(g)
    b0 = even_bearings(181)[0]
    v = ring.vertices
    on_first = (np.abs(v[:, 0] * np.sin(b0) - v[:, 1] * np.cos(b0)) < 1e-9) & (v @ [np.cos(b0), np.sin(b0)] >= 0)
    assert np.hypot(*v[on_first].T).max() <= 2.0 + 1e-9


def test_the_wedge_from_a_return_to_a_far_beam_is_a_frontier():
    # the left half saw a wall at 2 m, the right half nothing up to the usable range (cut to
    # 2 m here): only edges between two seen beams are obstacles
    st_ = np.r_[np.full(91, RETURN), np.full(90, FAR)]
    ring = fan(np.full(181, 2.0), st_)
    v, k = ring.vertices, ring.kinds
    b90 = even_bearings(181)[90]
    nxt = np.roll(np.arange(len(v)), -1)
    moving = np.hypot(*v.T) > 1e-9
    beyond = moving & (bearing(v) > b90 + 1e-9) | moving[nxt] & (bearing(v[nxt]) > b90 + 1e-9)
    assert beyond.any() and (k[beyond] == FRONTIER).all()
    assert (k[~beyond & moving & moving[nxt]] == OBSTACLE).all()


def test_a_full_circle_of_walls_is_all_obstacle():
    # a 360° scan of a closed room: the wall across the scan's seam is a wall too
    scan = scan_of(room(6, 4), (2.5, 1.5, 0.3), n=360, fov=2 * np.pi - np.radians(1))
    ring = polygon(scan).ring
    assert (ring.kinds == OBSTACLE).all()


def test_a_full_circle_with_a_depth_jump_keeps_every_wall_whole():
    # a pillar in front of the east wall: the scan starts again after a depth jump, and every
    # return is still on one of six lines (four walls, the east one in two pieces either side of
    # the pillar's shadow, and the pillar's face), none left as a stray point
    world = shapely.Polygon(shapely.box(0, 0, 7.5, 6).exterior, [shapely.box(4.0, 2.8, 4.4, 3.2).exterior])
    scan = scan_of(world, (1.0, 3.0, 0.0), n=360, fov=2 * np.pi - np.radians(1))
    lines = polygon(scan).lines
    assert len(lines) == 6 and lines.is_line.all()


@pytest.mark.parametrize("bend", [8.0, 12.0, 20.0, 30.0])
@pytest.mark.parametrize("toward", [True, False])
@pytest.mark.parametrize("n", [181, 361])
def test_a_wall_that_bends_gets_its_corner(bend, toward, n):
    # a wall 3 m ahead bends by `bend` degrees at (3, 0), its corner toward the sensor or away.
    # Each fitted line takes a few beams of the other wall (they lie within its tolerance), so
    # neither ends near the corner; before, the corner was refused for that, and so for every
    # bend under 15°, and the line's end stood 4-5 cm off both walls
    phi, L = np.radians(bend) / 2, 4.0
    x = 3.0 + (1 if toward else -1) * L * np.sin(phi)
    free = shapely.Polygon([(-1, -L * np.cos(phi)), (x, -L * np.cos(phi)), (3, 0), (x, L * np.cos(phi)), (-1, L * np.cos(phi))])
    for sigma, seed in ((0.0, 0), (0.01, 1), (0.01, 2)):
        scan = scan_of(free, (0, 0, 0), n=n, sigma=sigma, seed=seed)
        v = polygon(scan).ring.vertices
        front = v[np.hypot(*v.T) > 2.5]  # the vertices on the front wall and its ends, in order
        t = np.linspace(0, 1, 11)[:, None, None]
        along = (front[:-1] + t * (front[1:] - front[:-1])).reshape(-1, 2)  # points along their edges
        assert shapely.distance(free.exterior, shapely.points(along)).max() < 0.015


def test_lines_meeting_at_less_than_the_corner_angle_share_no_vertex():
    # the north wall is a roof whose two halves meet at 30°: a shared vertex at its ridge with
    # corner_angle 15°, none when corner_angle is 35°
    ridge = np.array([3.0, 4 + 3 * np.tan(np.radians(15))])
    free = shapely.Polygon([(0, 0), (6, 0), (6, 4), ridge, (0, 4)])
    for pose in [(2.9, 1.5, 0.0), (2.2, 1.0, 0.0)]:
        scan = scan_of(free, pose, n=361, fov=2 * np.pi - np.radians(1))
        f, s = classify(scan)
        near = [np.hypot(*(scan_polygon(scan, f, s, PolygonConfig(corner_angle=np.radians(a))).ring.vertices - ridge).T).min()
                for a in (15, 35)]
        assert near[0] <= 0.01 < 0.02 <= near[1]


def test_a_corner_replaces_up_to_corner_bridge_stray_points():
    # the two beams nearest the corner (6, 4) fall 10 cm short: they fit neither wall, and with
    # corner_bridge = 2 the corner of the two walls replaces them; with 1 they stay
    scan = scan_of(room(6, 4), (4.5, 2.5, 0.0), n=361, fov=2 * np.pi - np.radians(1))
    free, status = classify(scan)
    b = scan.bearings
    corner = np.array([6.0, 4.0])
    toward = np.arctan2(*(corner - scan.pose[:2])[::-1])
    i = np.argsort(np.abs((b - toward + np.pi) % (2 * np.pi) - np.pi))[:2]
    free[i] -= 0.1
    strays = scan.pose[:2] + free[i, None] * np.column_stack((np.cos(b[i]), np.sin(b[i])))
    lc = LineConfig(tol_rel=0.0, tol_min=0.02, relax=(1.0,))
    for bridge, bridged in ((2, True), (1, False)):
        v = scan_polygon(scan, free, status, PolygonConfig(lines=lc, corner_bridge=bridge)).ring.vertices
        assert (np.hypot(*(v - corner).T).min() < 1e-6) == bridged
        assert all((np.hypot(*(v - p).T).min() < 1e-9) != bridged for p in strays)


def test_a_line_ends_on_the_fitted_line_not_at_its_last_beam():
    # a 180° fan from the middle of the room facing east: the first beam (straight south) hits
    # (3, 0); it comes back 2 cm long, within the tolerance; the line along the south wall is
    # fitted to ~45 beams, so the vertex where it meets the first ray is still on the wall
    scan = scan_of(room(6, 4), (3.0, 2.0, 0.0), n=181)
    free, status = classify(scan)
    free[0] += 0.02
    v = scan_polygon(scan, free, status, FAN).ring.vertices
    assert np.allclose(v[0], (3.0, 2.0))  # the apex
    assert np.hypot(*(v[1] - (3.0, 0.0))) <= 0.002


def test_the_robots_footprint_is_free_behind_the_laser_and_up_to_its_own_returns_in_front():
    # a 180° scan whose beams all return nothing but one, 0.1 m ahead: the robot stood here, so a
    # disc of the footprint's radius about the laser is free, bar what its own laser saw nearer
    r = np.full(181, 81.83)
    r[90] = 0.1  # straight ahead, something 10 cm away
    scan = Scan(r, even_bearings(181), np.array([2.0, 1.0, 0.5]), 0.0, 81.83)
    free, status = classify(scan)
    ring = scan_polygon(scan, free, status, PolygonConfig(footprint=0.3)).ring
    g = shapely.Polygon(ring.vertices)
    assert g.is_valid and ring.signed_area > 0
    c, h = scan.pose[:2], scan.pose[2]
    at = lambda ang, d: shapely.Point(c + d * np.array([np.cos(h + ang), np.sin(h + ang)]))  # noqa: E731
    assert g.contains(at(np.pi, 0.28)) and not g.contains(at(np.pi, 0.31))  # behind: the disc
    assert g.contains(at(-np.pi / 2, 0.25)) and g.contains(at(np.radians(45), 0.28))  # beside, ahead: the disc
    assert g.contains(at(0.0, 0.09)) and not g.contains(at(0.0, 0.12))  # its own return, nearer
    assert g.area == pytest.approx(np.pi * 0.3 ** 2, rel=0.05)
    assert (ring.kinds == FRONTIER).all()  # nothing of it is a wall: the robot's body, and no line
    # with no footprint, the fan of a scan that saw nothing has no area beyond the sensor's own body
    ring0 = scan_polygon(scan, free, status, FAN).ring
    assert shapely.Polygon(ring0.vertices).area < 0.01


@given(arrays(np.float64, st.tuples(st.integers(0, 40), st.just(2)), elements=st.floats(-1e6, 1e6)))
def test_signed_area_is_the_shoelace_sum_with_the_ring_rolled_by_one(v):
    # the shoelace formula as written before (np.roll), to the last bit: orientation tests hang on it
    from fuzzybrep.geometry import signed_area

    x, y = v[:, 0], v[:, 1]
    assert signed_area(v) == 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
