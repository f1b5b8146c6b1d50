"""Line extraction (thesis 3.2.1.1) and vertices where consecutive lines meet (3.2.1.2)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from _synthetic import l_room, room, scan_of

from fuzzybrep.lines import LineConfig, anchored_runs, extract, hough_accumulator, intersect, tolerance
from fuzzybrep.polygon import NONE, RETURN, PolygonConfig, scan_polygon
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
