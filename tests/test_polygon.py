"""Scan polygons (thesis 3.2.1): always simple, and never free space the scan did not see."""

from __future__ import annotations

import numpy as np
import shapely
from _synthetic import room, scan_of
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from fuzzybrep.brep import FRONTIER, OBSTACLE
from fuzzybrep.polygon import CLIPPED, FAR, NONE, RETURN, scan_polygon, scan_polygons
from fuzzybrep.scans.filters import BeamConfig, classify, classify_all
from fuzzybrep.scans.scan import Scan, even_bearings


def polygon(scan, cfg=BeamConfig()):
    free, status = classify(scan, cfg)
    return scan_polygon(scan, free, status)


# at least 45 beams over 180° (4°): coarser scanners leave the space between beams to guesswork
ranges_st = arrays(np.float64, st.integers(45, 200), elements=st.one_of(
    st.floats(0.2, 7.5), st.just(8.0), st.floats(8.5, 30.0)))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ranges=ranges_st, full=st.booleans(), heading=st.floats(-np.pi, np.pi), x=st.floats(-50, 50))
# a corner window reaching past a short line's middle put its two corners out of order
@example(ranges=np.r_[np.full(9, 0.375), 0.25, np.full(35, 0.375)], full=False, heading=0.0, x=0.0)
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
    free, status = classify(scan)
    assert (status[80:100] == NONE).all() and (status[120:140] == FAR).all()
    g = shapely.Polygon(scan_polygon(scan, free, status).ring.vertices)
    b = scan.bearings
    along = lambda i, d: (d * np.cos(b[i]), d * np.sin(b[i]))  # noqa: E731
    assert not g.contains(shapely.Point(along(90, 1.0)))  # no return: not even 1 m is claimed
    assert g.contains(shapely.Point(along(130, 7.0)))  # far beam: free up to 8 m
    assert not g.contains(shapely.Point(along(130, 8.5)))


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
