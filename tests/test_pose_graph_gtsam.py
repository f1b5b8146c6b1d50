"""Issue 33: the pose graph solved by GTSAM (registration.pose_graph_gtsam) against registration.pose_graph."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("gtsam")

from fuzzybrep.registration import pose_graph, pose_graph_gtsam  # noqa: E402
from fuzzybrep.scans.scan import compose, relative, wrap  # noqa: E402
from test_align import _drifted_chain, _false_loop_graph, _rmse, _square_loop  # noqa: E402

INFO_ODO = np.diag([1 / 0.05 ** 2, 1 / 0.05 ** 2, 1 / math.radians(2) ** 2])


def _loop_graph(seed: int = 0, anisotropic: bool = False):
    """The square loop with drifting, noisy odometry and three true loops (robust)."""
    rng = np.random.default_rng(seed)
    true = _square_loop()
    steps, _ = _drifted_chain(true)
    steps = steps + rng.normal(0, [0.01, 0.01, math.radians(0.5)], steps.shape)
    n = len(true)
    odo = [true[0]]
    for s in steps:
        odo.append(compose(odo[-1], s))
    info_odo = INFO_ODO.copy()
    if anisotropic:
        info_odo[0, 1] = info_odo[1, 0] = 0.3 / 0.05 ** 2
        info_odo[1, 1] *= 4
    i, j, z = list(range(n - 1)), list(range(1, n)), list(steps)
    info, robust = [info_odo] * (n - 1), [False] * (n - 1)
    for a, b in ((0, n - 1), (5, n - 6), (2, n - 3)):
        i.append(a), j.append(b), info.append(np.diag([1e4, 1e4, 1e5])), robust.append(True)
        z.append(relative(true[a], true[b]) + rng.normal(0, [0.01, 0.01, math.radians(0.3)]))
    return true, np.array(odo), [np.array(v) for v in (i, j, z, info)], np.array(robust)


@pytest.mark.parametrize("anisotropic", [False, True])
def test_gtsam_agrees_with_pose_graph_on_a_loop(anisotropic):
    true, odo, args, robust = _loop_graph(anisotropic=anisotropic)
    assert np.hypot(*(odo[-1, :2] - true[-1, :2])) > 2.0  # a drift for the loops to close
    for r in (None, robust):
        ours = pose_graph.solve(odo, *args, robust=r, iterations=30, tolerance=1e-10)
        theirs = pose_graph_gtsam.solve(odo, *args, robust=r, iterations=30, tolerance=1e-10)
        assert np.abs(ours[:, :2] - theirs[:, :2]).max() < 1e-3
        assert np.abs(wrap(ours[:, 2] - theirs[:, 2])).max() < math.radians(0.05)
        assert _rmse(theirs, true) < 0.25 * _rmse(odo, true)
    # the optimum of one is (to its tolerance) the optimum of the other's cost as well
    assert pose_graph.cost(theirs, *args, robust) < 1.001 * pose_graph.cost(ours, *args, robust)


def test_gtsam_holds_the_first_pose():
    true, odo, args, robust = _loop_graph(1)
    odo = odo + [0.3, -0.2, 0.1]  # the start's frame is not the truth's: pose 0 still holds it
    solved = pose_graph_gtsam.solve(odo, *args, robust=robust)
    assert np.array_equal(solved[0], odo[0])
    # the rest solved in the frame pose 0 holds, as pose_graph.solve solves them
    assert np.abs(solved[:, :2] - pose_graph.solve(odo, *args, robust=robust)[:, :2]).max() < 1e-3
    gnc = pose_graph_gtsam.solve_gnc(odo, *args, robust=robust)
    assert np.array_equal(gnc[0], odo[0])
    assert solved.shape == gnc.shape == odo.shape


def test_gtsam_outvotes_a_false_loop_on_a_robust_edge():
    true, odo, args, robust = _false_loop_graph()
    solved = pose_graph_gtsam.solve(odo, *args, robust=robust)
    plain = pose_graph_gtsam.solve(odo, *args)
    assert _rmse(solved, true) < 0.15
    assert _rmse(plain, true) > 2 * _rmse(solved, true)  # without the kernel the false loop bends the square
    assert _rmse(pose_graph_gtsam.solve_gnc(odo, *args, robust=robust), true) < 0.15


def test_gtsam_rejects_an_edge_to_a_missing_pose_and_passes_an_empty_graph():
    p = np.zeros((3, 3))
    with pytest.raises(ValueError, match="outside 0..2"):
        pose_graph_gtsam.solve(p, np.array([0]), np.array([3]), np.zeros((1, 3)), np.eye(3)[None])
    out = pose_graph_gtsam.solve(p + 1, np.zeros(0, int), np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 3, 3)))
    np.testing.assert_array_equal(out, p + 1)
