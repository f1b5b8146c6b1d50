"""Line extraction (thesis 3.2.1.1) and vertices where consecutive lines meet (3.2.1.2)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from _synthetic import l_room, room, scan_of

from fuzzybrep.mapping.lines import (LineConfig, Lines, absorb_strays, anchored_runs, demote_misfits, extract,
                                     hough_accumulator, iepf_lines, intersect, tolerance)
from fuzzybrep.scans.filters import NONE, RETURN
from fuzzybrep.mapping.scan_polygon import PolygonConfig, scan_polygon
from fuzzybrep.scans.filters import classify


def reference_runs(points, stop, tol, theta_step):
    """The anchored Hough run length the slow way: scan the accumulator column by column."""
    theta, rho = hough_accumulator(points, theta_step)
    out = []
    for a in range(len(points)):
        if a + 1 >= stop:
            out.append(1)
            continue
        inlier = np.abs(rho[a + 1 : stop] - rho[a]) <= tol[a]
        # leading run of inliers for every θ, then the best θ
        lead = np.where(inlier.all(axis=0), len(inlier), np.argmin(inlier, axis=0))
        out.append(1 + int(lead.max()))
    return np.array(out)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("theta_step", [1.0, 0.5, 2.0])
def test_closed_form_hough_equals_the_accumulator(seed, theta_step):
    rng = np.random.default_rng(seed)
    # a chain of points along a few walls, with noise: the kind of run line extraction sees
    k = rng.integers(2, 5)
    corners = rng.uniform(-4, 4, size=(k + 1, 2))
    pts = np.vstack([np.linspace(corners[i], corners[i + 1], 12, endpoint=False) for i in range(k)])
    pts += rng.normal(0, 0.01, pts.shape)
    n = len(pts)
    tol = np.full(n, 0.03)
    L, theta = anchored_runs(pts, np.full(n, n), tol, theta_step, window=n)
    ref = reference_runs(pts, n, tol, theta_step)
    assert np.array_equal(L, ref)
    # and the θ it reports is a grid angle on which the whole run fits
    step = np.radians(theta_step)
    for a in np.flatnonzero(L >= 3):
        assert np.isclose((theta[a] / step) % 1.0, 0, atol=1e-6) or np.isclose((theta[a] / step) % 1.0, 1, atol=1e-6)
        c, s = np.cos(theta[a]), np.sin(theta[a])
        rho = pts[a : a + L[a], 0] * c + pts[a : a + L[a], 1] * s
        assert np.all(np.abs(rho - rho[0]) <= tol[a] + 1e-9)


def test_thesis_example_intersection():
    # Figure 3.8: y = -0.637x + 1410.270 and y = +1.570x + 608.100 (mm)
    def normal_form(m, q):  # y = m x + q  ->  x cos θ + y sin θ = ρ
        th = np.arctan2(1.0, -m)
        return th, q * np.sin(th)

    x, y = intersect(*normal_form(-0.637, 1410.270), *normal_form(1.570, 608.100))
    x_true = (1410.270 - 608.100) / (1.570 + 0.637)
    assert np.isclose(x, x_true) and np.isclose(y, 1.570 * x_true + 608.100)


def test_intersection_special_cases():
    # parallel lines (AE = BD): no vertex
    x, y = intersect(0.3, 1.0, 0.3, 2.0)
    assert np.isnan(x) and np.isnan(y)
    # a vertical line (θ = 0: x = 2) and a horizontal one (θ = 90°: y = 3)
    x, y = intersect(0.0, 2.0, np.pi / 2, 3.0)
    assert np.isclose(x, 2.0) and np.isclose(y, 3.0)
    x, y = intersect(np.pi / 2, 3.0, 0.0, 2.0)
    assert np.isclose(x, 2.0) and np.isclose(y, 3.0)
    # lines meeting at a shallow angle count as parallel when asked to
    x, _ = intersect(0.0, 1.0, np.radians(5), 1.0, min_angle=np.radians(10))
    assert np.isnan(x)


def corner_errors(poly, corners):
    """Distance from each true corner to the nearest vertex of the scan polygon."""
    v = poly.ring.vertices
    return np.array([np.min(np.hypot(*(v - c).T)) for c in corners])


def polygon_of(scan, method="hough", theta_step=1.0):
    free, status = classify(scan)
    cfg = PolygonConfig(lines=LineConfig(method=method, theta_step=theta_step))
    return scan_polygon(scan, free, status, cfg)


@pytest.mark.parametrize("method", ["hough", "iepf"])
@pytest.mark.parametrize("pose", [(3.0, 2.0, np.pi / 2), (1.5, 1.0, 0.9), (4.2, 3.1, 2.4)])
def test_vertices_within_2cm_at_zero_noise(method, pose):
    free = room(6, 4)
    scan = scan_of(free, pose, n=361, fov=2 * np.pi - np.radians(1))
    poly = polygon_of(scan, method)
    corners = np.array([(0, 0), (6, 0), (6, 4), (0, 4)])
    assert corner_errors(poly, corners).max() <= 0.02
    # and every vertex lies on a wall (no invented geometry)
    d = shapely.distance(free.boundary, shapely.points(poly.ring.vertices))
    assert d.max() <= 0.02


@pytest.mark.parametrize("method", ["hough", "iepf"])
@pytest.mark.parametrize("n", [720, 1440])
@pytest.mark.parametrize("pose", [(3.5478, 1.5396, -2.8841), (1.5, 1.0, 0.9), (4.2, 3.1, 2.4)])
def test_corners_of_finer_scans_are_where_the_walls_meet(method, n, pose):
    # at 0.5° and 0.25° a few beams of one wall next to a corner are within the tolerance of
    # the other wall's line and join it; the corner is still where the two lines meet, and no
    # line runs on past it out of the room
    free = room(6, 4)
    scan = scan_of(free, pose, n=n, fov=2 * np.pi * (n - 1) / n)
    poly = polygon_of(scan, method)
    corners = np.array([(0, 0), (6, 0), (6, 4), (0, 4)])
    assert corner_errors(poly, corners).max() <= 0.02
    d = shapely.distance(free.boundary, shapely.points(poly.ring.vertices))
    assert d.max() <= 0.02


@pytest.mark.parametrize("method", ["hough", "iepf"])
@pytest.mark.parametrize("seed", range(6))
def test_vertices_within_3_sigma_with_noise(method, seed):
    sigma = 0.01
    free = room(6, 4)
    rng = np.random.default_rng(seed)
    # anywhere at least 1 m from the walls: every wall is seen, none only at a grazing angle
    pose = (rng.uniform(1.0, 5.0), rng.uniform(1.0, 3.0), rng.uniform(-np.pi, np.pi))
    scan = scan_of(free, pose, n=361, fov=2 * np.pi - np.radians(1), sigma=sigma, seed=seed)
    poly = polygon_of(scan, method)
    corners = np.array([(0, 0), (6, 0), (6, 4), (0, 4)])
    assert corner_errors(poly, corners).max() <= 3 * sigma


def test_occluding_corner_is_placed_within_one_beam_spacing():
    # the reflex corner of an L-shaped room hides what lies behind it: the scan sees where the
    # wall ends only to within the spacing of two beams, and claims nothing beyond its last beam
    free = l_room()
    pose = (2.0, 1.0, 0.0)
    scan = scan_of(free, pose, n=361, fov=2 * np.pi - np.radians(1))
    poly = polygon_of(scan)
    reflex = np.array([4.0, 2.0])
    spacing = np.hypot(*(reflex - pose[:2])) * np.radians(1)
    assert corner_errors(poly, [reflex])[0] <= spacing + 0.005
    # nothing behind the corner is claimed as free
    hidden = shapely.points([(5.0, 3.0), (6.0, 5.0), (4.5, 4.0)])
    assert not shapely.contains(shapely.Polygon(poly.ring.vertices), hidden).any()


def test_theta_step_is_configurable_and_refitted_lines_do_not_depend_on_it():
    scan = scan_of(room(6, 4), (2.0, 1.5, 0.4), n=361, fov=2 * np.pi - np.radians(1))
    corners = np.array([(0, 0), (6, 0), (6, 4), (0, 4)])
    for step in (0.5, 1.0, 3.0):
        assert corner_errors(polygon_of(scan, "hough", step), corners).max() <= 0.02


def test_lines_are_ordered_by_scan_index_and_cover_each_run_once():
    scan = scan_of(l_room(), (2.0, 1.0, 0.0), n=181)
    free, status = classify(scan)
    b = scan.bearings
    pts = np.column_stack((free * np.cos(b), free * np.sin(b)))
    runs = np.array([[0, 60], [60, 181]])
    for method in ("hough", "iepf"):
        lines = extract(pts, free, runs, LineConfig(method=method))
        assert np.all(np.diff(lines.start) > 0)
        assert np.array_equal(lines.start[1:], lines.stop[:-1])  # contiguous, no point twice
        assert lines.start[0] == 0 and lines.stop[-1] == 181 and 60 in lines.start


def test_relaxed_tolerance_when_no_line_fits():
    # a noisy wall: at the strict tolerance no 4 points share a θ, relaxed they do
    rng = np.random.default_rng(3)
    x = np.linspace(-1, 1, 30)
    pts = np.column_stack((x, 2.0 + rng.normal(0, 0.03, 30)))
    r = np.hypot(*pts.T)
    strict = LineConfig(tol_min=0.01, tol_rel=0.0, relax=(1.0,))
    relaxed = LineConfig(tol_min=0.01, tol_rel=0.0, relax=(1.0, 4.0, 8.0))
    runs = np.array([[0, 30]])
    a, b = extract(pts, r, runs, strict), extract(pts, r, runs, relaxed)
    # strict: the wall falls apart into short pieces and stray points; relaxed: a few long lines
    assert len(b) < len(a)
    assert (b.stop - b.start)[b.is_line].max() >= 10 > (a.stop - a.start)[a.is_line].max(initial=0)
    assert np.allclose(tolerance(np.array([1.0, 10.0]), LineConfig()), [0.03, 0.1])


def test_no_return_beams_are_not_used_for_lines():
    scan = scan_of(room(30, 4), (1.0, 2.0, 0.0), n=181, max_range=8.0)
    free, status = classify(scan)
    assert (status == NONE).any() and (status == RETURN).any()
    poly = scan_polygon(scan, free, status)
    # nothing beyond 8 m is claimed, and the far wall (29 m away) is not in the polygon
    assert shapely.Polygon(poly.ring.vertices).bounds[2] <= 1.0 + 8.0 + 1e-6


def test_accumulator_is_rho_of_table_3_3():
    # ρ(θ) = x cos θ + y sin θ: at θ = 0 the point's x, at 90° its y
    theta, rho = hough_accumulator(np.array([[3.0, 4.0]]), 45.0)
    assert np.allclose(np.degrees(theta), [0, 45, 90, 135])
    assert np.allclose(rho[0], [3.0, 7 / np.sqrt(2), 4.0, 1 / np.sqrt(2)])
    # points on the line x cos 30° + y sin 30° = 2 share one ρ in the 30° column, and only there
    th0 = np.radians(30)
    t = np.linspace(-1, 1, 5)
    pts = np.column_stack((2 * np.cos(th0) - t * np.sin(th0), 2 * np.sin(th0) + t * np.cos(th0)))
    theta, rho = hough_accumulator(pts, 1.0)
    spread = np.ptp(rho, axis=0)
    assert np.argmin(spread) == 30 and np.allclose(rho[:, 30], 2.0)


def on_line(theta, rho, t):
    """Points at arc positions t along x cos θ + y sin θ = ρ."""
    return np.column_stack((rho * np.cos(theta) - t * np.sin(theta), rho * np.sin(theta) + t * np.cos(theta)))


@pytest.mark.parametrize("method", ["hough", "iepf"])
def test_a_run_of_exactly_min_points_collinear_points_is_a_line(method):
    pts = on_line(np.radians(30), 2.0, np.array([-0.3, -0.1, 0.1, 0.3]))
    lines = extract(pts, np.hypot(*pts.T), np.array([[0, 4]]), LineConfig(method=method, min_points=4))
    assert len(lines) == 1 and lines.start[0] == 0 and lines.stop[0] == 4
    assert np.isclose(lines.theta[0], np.radians(30)) and np.isclose(lines.rho[0], 2.0)


def test_a_long_wall_found_at_a_relaxed_tolerance_is_extended_at_that_tolerance():
    # a zigzag ±2 cm about y = 2: at 1 cm no 4 consecutive points share a θ (the middle one of
    # three is 4 cm off the line through its neighbours' parity), at 4 cm the whole wall does and
    # every point is within 2 cm of the refitted line; so the wall is one line, not pieces of
    # the window's length
    n = 60
    pts = np.column_stack((np.linspace(-1.5, 1.5, n), 2.0 + 0.02 * (-1.0) ** np.arange(n)))
    cfg = LineConfig(tol_min=0.01, tol_rel=0.0, relax=(1.0, 4.0), window=16)
    lines = extract(pts, np.hypot(*pts.T), np.array([[0, n]]), cfg)
    assert len(lines) == 1 and lines.stop[0] == n
    assert np.isclose(lines.theta[0], np.pi / 2, atol=0.01) and np.isclose(lines.rho[0], 2.0, atol=0.005)


def test_iepf_splits_at_a_bend_just_beyond_the_tolerance():
    # a roof: the apex is 1.5 τ above the chord of the ends, so IEPF splits there; every line it
    # returns has all its points within τ of its chord
    tol = 0.03
    x = np.linspace(-1, 1, 21)
    pts = np.column_stack((x, 2.0 + 1.5 * tol * (1 - np.abs(x))))
    cfg = LineConfig(method="iepf", tol_min=tol, tol_rel=0.0, relax=(1.0,))
    lines = iepf_lines(pts, np.hypot(*pts.T), np.array([[0, 21]]), cfg)
    assert list(zip(lines.start, lines.stop)) == [(0, 11), (11, 21)]
    for s, e in zip(lines.start, lines.stop):
        p0, p1, q = pts[s], pts[e - 1], pts[s:e]
        u = (p1 - p0) / np.hypot(*(p1 - p0))
        assert np.all(np.abs((q[:, 0] - p0[0]) * u[1] - (q[:, 1] - p0[1]) * u[0]) <= tol + 1e-12)


def test_iepf_splits_three_points_bent_beyond_the_tolerance():
    # three points whose middle one is 2 τ off the chord: IEPF must split, leaving no line even
    # when three points may make one
    tol = 0.03
    pts = np.array([[-0.5, 2.0], [0.0, 2.0 + 2 * tol], [0.5, 2.0]])
    cfg = LineConfig(method="iepf", tol_min=tol, tol_rel=0.0, relax=(1.0,), min_points=3)
    lines = iepf_lines(pts, np.hypot(*pts.T), np.array([[0, 3]]), cfg)
    assert not lines.is_line.any()
    # three points on the chord are a line
    pts[1, 1] = 2.0
    assert iepf_lines(pts, np.hypot(*pts.T), np.array([[0, 3]]), cfg).is_line.all()


def test_strays_join_both_ends_of_a_line_in_one_pass():
    # points 0..5 on y = 1; the line claims 1..4, points 0 and 5 are strays on either end
    pts = np.column_stack((np.arange(6.0), np.ones(6)))
    lines = Lines(np.array([0, 1, 5]), np.array([1, 5, 6]), np.array([np.nan, np.pi / 2, np.nan]),
                  np.array([np.nan, 1.0, np.nan]))
    out = absorb_strays(pts, lines, np.full(6, 0.01), np.full(6, 6), passes=1)
    assert list(zip(out.start, out.stop)) == [(0, 6)]


def test_a_line_that_misses_one_of_its_points_falls_apart():
    # five points on y = 1 but the middle one 0.5 off: the refitted line misses some point by
    # more than 0.1, so the "line" is five single points; the same points straight stay a line
    pts = np.column_stack((np.arange(5.0), np.ones(5)))
    pts[2, 1] = 1.5
    bent = Lines(np.array([0]), np.array([5]), np.array([np.pi / 2]), np.array([1.1]))
    out = demote_misfits(pts, bent, np.full(5, 0.1), 4)
    assert list(out.start) == [0, 1, 2, 3, 4] and not out.is_line.any()
    pts[2, 1] = 1.0
    straight = Lines(np.array([0]), np.array([5]), np.array([np.pi / 2]), np.array([1.0]))
    assert demote_misfits(pts, straight, np.full(5, 0.1), 4) is straight
