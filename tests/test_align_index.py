"""The scan matcher's fast paths (issue 22's cost): they must give what the plain ones give."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import least_squares

from fuzzybrep.registration import pose_graph
from fuzzybrep.registration.config import AlignConfig
from fuzzybrep.registration.surfaces import _Surfaces
from fuzzybrep.scans.scan import Scan, relative
from fuzzybrep.registration.segment_match import SegmentIndex, _inverse, _solve, transform


def _polylines(rng: np.random.Generator, n: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Random wiggly walls: n chained segments in a few polylines."""
    a, b = [], []
    for _ in range(4):
        p = rng.uniform(-5, 5, 2)
        for _ in range(n // 4):
            q = p + rng.normal(0, 0.15, 2)
            a.append(p)
            b.append(q)
            p = q
    return np.array(a), np.array(b)


def test_fit_rows_gives_nearests_segments_distances_and_normals():
    rng = np.random.default_rng(3)
    a, b = _polylines(rng)
    index = SegmentIndex(a, b, 0.05)
    # points near the walls, some on them, some far from everything
    pts = np.vstack((a + rng.normal(0, 0.08, a.shape), (a + b) / 2, rng.uniform(-20, 20, (30, 2))))
    for reach in (0.1, 0.3, 1.6):
        seg, dist, _, normal = index.nearest(pts, reach)
        j, d, nx, ny = index.fit_rows(pts, reach)
        near = seg >= 0
        assert near.any() and (~near).any()
        np.testing.assert_array_equal(j[near], seg[near])
        np.testing.assert_allclose(d[near], dist[near], atol=1e-12)
        # the normal: the same direction, or (on the segment) the segment's normal either way round
        dot = nx[near] * normal[near, 0] + ny[near] * normal[near, 1]
        assert np.all(np.abs(dot) > 1 - 1e-9)
        assert np.all((dot > 0) | (d[near] < 1e-9))
        # what nearest finds nothing for lies beyond the reach (no weight in the fit)
        assert np.all(d[~near] > reach)


def test_small_solves_give_numpys_answers():
    rng = np.random.default_rng(1)
    for _ in range(200):
        A = rng.normal(size=(3, 3))
        H, g = A @ A.T + 1e-3 * np.eye(3), rng.normal(size=3)
        np.testing.assert_allclose(_solve(H, g), -np.linalg.solve(H, g), rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(_inverse(H), np.linalg.inv(H), rtol=1e-7, atol=1e-9)
    assert _solve(np.zeros((3, 3)), np.ones(3)) is None
    with pytest.raises(np.linalg.LinAlgError):
        _inverse(np.ones((3, 3)))


def _scans(rng: np.random.Generator, n: int) -> list[Scan]:
    bearings = np.linspace(-math.pi / 2, math.pi / 2, 181)
    return [Scan(2 + np.abs(np.sin(3 * bearings + k)) + rng.uniform(0, 0.01, len(bearings)), bearings,
                 np.zeros(3), float(k), 30.0) for k in range(n)]


def test_a_placed_local_map_is_the_index_of_its_scans_segments_and_is_kept_while_they_stay():
    rng = np.random.default_rng(2)
    scans = _scans(rng, 5)
    cfg = AlignConfig()
    surf = _Surfaces(scans, cfg)
    poses = rng.normal(0, 1, (5, 3))
    index = surf.index([1, 3, 4], poses)
    # the same segments as placing every scan's polylines by hand and indexing them afresh
    ends = [(transform(surf.segments[k][0], poses[k]), transform(surf.segments[k][1], poses[k])) for k in (1, 3, 4)]
    fresh = SegmentIndex(np.vstack([e[0] for e in ends]), np.vstack([e[1] for e in ends]), cfg.spacing)
    np.testing.assert_allclose(index.a, fresh.a, atol=1e-12)
    np.testing.assert_allclose(index.direction, fresh.direction, atol=1e-12)
    pts = rng.uniform(-4, 4, (300, 2))
    d1, d2 = index.fit_rows(pts, 0.3)[1], fresh.fit_rows(pts, 0.3)[1]
    within = (d1 <= 0.3) | (d2 <= 0.3)
    np.testing.assert_allclose(d1[within], d2[within], atol=1e-9)
    # kept: given again while the poses stay, made again once one moves
    kept = surf.index([1, 3, 4], poses, keep="x")
    assert surf.index([1, 3, 4], poses.copy(), keep="x") is kept
    moved = poses.copy()
    moved[3, 0] += 0.5
    again = surf.index([1, 3, 4], moved, keep="x")
    assert again is not kept
    np.testing.assert_allclose(again.a[len(ends[0][0]):][:3], ends[1][0][:3] + [0.5, 0.0], atol=1e-12)


def test_pose_graph_solve_is_the_least_squares_solution():
    rng = np.random.default_rng(5)
    n = 8
    true = np.cumsum(rng.normal(0, 0.5, (n, 3)), axis=0)
    true[0] = 0
    i = np.r_[np.arange(n - 1), [0, 2, 1]]
    j = np.r_[np.arange(1, n), [5, 7, 6]]
    z = relative(true[i], true[j]) + rng.normal(0, 0.05, (len(i), 3))
    A = rng.normal(size=(len(i), 3, 3))
    info = A @ np.swapaxes(A, 1, 2) + np.eye(3)
    start = true + rng.normal(0, 0.1, true.shape)
    start[0] = true[0]
    x = pose_graph.solve(start, i, j, z, info, iterations=30, tolerance=1e-12)
    L = np.linalg.cholesky(info)  # Ω = L Lᵀ: ‖Lᵀ e‖² = eᵀ Ω e

    def whitened(v):
        p = np.vstack((start[:1], v.reshape(-1, 3)))
        return np.einsum("eba,eb->ea", L, pose_graph.residuals(p, i, j, z)).ravel()

    ref = least_squares(whitened, start[1:].ravel(), xtol=1e-14, ftol=1e-14, gtol=1e-14).x.reshape(-1, 3)
    np.testing.assert_allclose(x[1:], ref, atol=1e-7)
    np.testing.assert_array_equal(x[0], start[0])
