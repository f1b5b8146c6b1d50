"""The 2-D pose graph of ``registration.pose_graph`` solved by GTSAM (issue 33, item 2).

``solve`` takes and returns what ``pose_graph.solve`` does: poses (N, 3) as the start, edges
(i, j, z, Ω) saying that pose j seen from pose i is z (x, y, θ) with information Ω (3 × 3, in i's
frame), ``robust`` edges (loop closures) under Cauchy's kernel of scale ``pose_graph.ROBUST_SCALE``
after ``plain`` iterations with every edge weighed fully, pose 0 held where it is. It is built on
GTSAM's factor graph: one ``BetweenFactorPose2`` an edge with a ``noiseModel.Gaussian.Information``
(wrapped in ``noiseModel.Robust`` with ``mEstimator.Cauchy`` on robust edges once the plain
iterations are done), a ``NonlinearEqualityPose2`` (a hard constraint) on pose 0, and Gauss-Newton
iterations stepped one at a time so that ``iterations`` and ``tolerance`` (the largest change of
any pose coordinate in a step) mean what they mean in ``pose_graph.solve``. ``solve_gnc`` is GTSAM's
graduated non-convexity (Yang et al. 2020) over the same graph, robust edges as the candidates for
outliers and every other edge a known inlier.

GTSAM is imported inside the functions: the package works without it (it is an optional
dependency, ``pip install gtsam``).

The error of an edge. ``pose_graph.residuals`` takes e = (R_iᵀ (t_j − t_i) − z_xy,
wrap(θ_j − θ_i − z_θ)): the translation's error in pose i's frame, the angle's wrapped. GTSAM's
``BetweenFactorPose2`` takes e' = Logmap(z⁻¹ · (x_i⁻¹ x_j)): the error pose in z's frame (i's frame
turned by z_θ), mapped to the tangent space, whose translation part is V(δθ)⁻¹ times the error
pose's translation (V the SE(2) left Jacobian, I + O(δθ)). So e' = (R(z_θ)ᵀ e_xy + O(δθ ‖e_xy‖),
e_θ): the translation error turned by z_θ, and equal to it for small errors up to a second-order
term. ``solve`` turns each edge's information into z's frame (Ω' = Bᵀ Ω B, B = diag(R(z_θ), 1)),
so eᵀ Ω e and e'ᵀ Ω' e' agree to second order and the two solvers find the same poses within a
fraction of the edges' errors (tests/test_pose_graph_gtsam.py: 1 mm on a loop of 41 poses); with
an isotropic translation information the turn changes nothing. GTSAM's Cauchy kernel is ρ(r) =
k²/2 log(1 + r²/k²) on the whitened error's norm r, with the weight 1 / (1 + r²/k²) of
``pose_graph.solve``'s reweighting, so the robust solves agree as well.
"""

from __future__ import annotations

import numpy as np

from ..scans.scan import wrap
from .pose_graph import ROBUST_SCALE


def _edges(poses, i, j, z, info, robust):
    """The arrays of ``solve``'s arguments, checked (as ``pose_graph.solve`` does)."""
    x = np.array(poses, np.float64).reshape(-1, 3)
    i, j = np.asarray(i, np.int64).reshape(-1), np.asarray(j, np.int64).reshape(-1)
    z = np.asarray(z, np.float64).reshape(-1, 3)
    info = np.asarray(info, np.float64).reshape(-1, 3, 3)
    n, m = len(x), len(i)
    if m and (i.min() < 0 or j.min() < 0 or max(i.max(), j.max()) >= n):
        raise ValueError(f"an edge names a pose outside 0..{n - 1}")
    robust = np.zeros(m, bool) if robust is None else np.asarray(robust, bool).reshape(-1)
    return x, i, j, z, info, robust


def _in_z_frame(z: np.ndarray, info: np.ndarray) -> np.ndarray:
    """Each edge's information turned from i's frame into z's (module docstring): Bᵀ Ω B."""
    c, s = np.cos(z[:, 2]), np.sin(z[:, 2])
    B = np.zeros((len(z), 3, 3))
    B[:, 0, 0], B[:, 0, 1], B[:, 1, 0], B[:, 1, 1], B[:, 2, 2] = c, -s, s, c, 1.0
    out = np.swapaxes(B, 1, 2) @ info @ B
    return 0.5 * (out + np.swapaxes(out, 1, 2))


def _graph(gtsam, x, i, j, z, info, robust, kernel: str | None):
    """The factor graph: pose 0 held by a hard constraint, one between-factor an edge, robust edges
    under ``kernel`` ("cauchy", "dcs", "huber" or None: plain Gaussian)."""
    graph = gtsam.NonlinearFactorGraph()
    graph.add(gtsam.NonlinearEqualityPose2(0, gtsam.Pose2(*x[0])))
    om = _in_z_frame(z, info)
    for e in range(len(i)):
        model = gtsam.noiseModel.Gaussian.Information(om[e])
        if kernel is not None and robust[e]:
            est = {"cauchy": gtsam.noiseModel.mEstimator.Cauchy,
                   "dcs": gtsam.noiseModel.mEstimator.DCS,
                   "huber": gtsam.noiseModel.mEstimator.Huber}[kernel](ROBUST_SCALE)
            model = gtsam.noiseModel.Robust.Create(est, model)
        graph.add(gtsam.BetweenFactorPose2(int(i[e]), int(j[e]), gtsam.Pose2(*z[e]), model))
    return graph


def _values(gtsam, x):
    values = gtsam.Values()
    for k, p in enumerate(x):
        values.insert(k, gtsam.Pose2(*p))
    return values


def _poses(gtsam, values, n: int) -> np.ndarray:
    out = gtsam.utilities.extractPose2(values)
    if out.shape != (n, 3):  # keys are 0..n-1, so extractPose2's order is theirs; check anyway
        out = np.array([[values.atPose2(k).x(), values.atPose2(k).y(), values.atPose2(k).theta()] for k in range(n)])
    return out


def _steps(gtsam, graph, x, count: int, tolerance: float, stop: bool, optimizer: str):
    """``count`` iterations of Gauss-Newton (or Levenberg-Marquardt) from ``x``, one at a time;
    with ``stop``, ended early once no coordinate moves ``tolerance`` or more. Returns the poses
    and whether they converged."""
    n = len(x)
    if optimizer == "lm":
        params = gtsam.LevenbergMarquardtParams()
        params.setMaxIterations(1)
        opt = gtsam.LevenbergMarquardtOptimizer(graph, _values(gtsam, x), params)
    else:
        params = gtsam.GaussNewtonParams()
        params.setMaxIterations(1)
        opt = gtsam.GaussNewtonOptimizer(graph, _values(gtsam, x), params)
    for _ in range(count):
        opt.iterate()
        new = _poses(gtsam, opt.values(), n)
        d = new - x
        d[:, 2] = wrap(d[:, 2])
        x = new
        if not np.isfinite(x).all():
            break
        if stop and np.abs(d).max() < tolerance:
            return x, True
    return x, False


def solve(poses: np.ndarray, i: np.ndarray, j: np.ndarray, z: np.ndarray, info: np.ndarray,
          robust: np.ndarray | None = None, iterations: int = 10, tolerance: float = 1e-4, plain: int = 3) -> np.ndarray:
    """The poses (N, 3) that best agree with the edges, from ``poses`` (N, 3) as the start; pose 0
    fixed. i, j (E,) node indices; z (E, 3); info (E, 3, 3); robust (E,) bool or None. As
    ``pose_graph.solve``, solved by GTSAM's Gauss-Newton (module docstring): the first ``plain``
    iterations weigh every edge fully, the rest put Cauchy's kernel on the robust edges."""
    return _solve(poses, i, j, z, info, robust, iterations, tolerance, plain)


def _solve(poses, i, j, z, info, robust=None, iterations=10, tolerance=1e-4, plain=3,
           kernel: str = "cauchy", optimizer: str = "gn") -> np.ndarray:
    """``solve`` with a choice of ``kernel`` ("cauchy", "dcs", "huber") and ``optimizer`` ("gn", "lm")."""
    x, i, j, z, info, robust = _edges(poses, i, j, z, info, robust)
    if len(i) == 0 or len(x) < 2:
        return x
    import gtsam

    start = x[0].copy()
    if not robust.any():
        x, _ = _steps(gtsam, _graph(gtsam, x, i, j, z, info, robust, None), x, iterations, tolerance, True, optimizer)
    else:
        first = min(plain, iterations)
        if first:
            x, _ = _steps(gtsam, _graph(gtsam, x, i, j, z, info, robust, None), x, first, tolerance, False, optimizer)
        if iterations > first and np.isfinite(x).all():
            x, _ = _steps(gtsam, _graph(gtsam, x, i, j, z, info, robust, kernel), x, iterations - first,
                          tolerance, True, optimizer)
    x[:, 2] = wrap(x[:, 2])
    x[0] = start  # held by the constraint; set so that it is the start bit for bit
    return x


def solve_gnc(poses: np.ndarray, i: np.ndarray, j: np.ndarray, z: np.ndarray, info: np.ndarray,
              robust: np.ndarray | None = None, iterations: int = 10, tolerance: float = 1e-4, plain: int = 3,
              loss: str = "tls", probability: float = 0.99) -> np.ndarray:
    """The poses by GTSAM's graduated non-convexity (GncLMOptimizer): the robust edges are the
    candidates for outliers, the others (and pose 0's constraint) known inliers; ``loss`` "tls"
    (truncated least squares) or "gm" (Geman-McClure), an edge is an inlier while its whitened
    error is within the χ² (3 dof) quantile ``probability``. ``iterations`` bounds the inner
    Levenberg-Marquardt solves, ``tolerance`` and ``plain`` are accepted for ``solve``'s signature
    (GNC starts from the convex least-squares problem itself)."""
    x, i, j, z, info, robust = _edges(poses, i, j, z, info, robust)
    if len(i) == 0 or len(x) < 2:
        return x
    import gtsam

    start = x[0].copy()
    graph = _graph(gtsam, x, i, j, z, info, robust, None)
    lm = gtsam.LevenbergMarquardtParams()
    lm.setMaxIterations(max(int(iterations), 1))
    params = gtsam.GncLMParams(lm)
    params.setLossType(gtsam.GncLossType.TLS if loss == "tls" else gtsam.GncLossType.GM)
    params.setKnownInliers([0] + [int(e) + 1 for e in np.flatnonzero(~robust)])  # factor 0: pose 0's constraint
    opt = gtsam.GncLMOptimizer(graph, _values(gtsam, x), params)
    opt.setInlierCostThresholdsAtProbability(probability)
    x = _poses(gtsam, opt.optimize(), len(x))
    x[:, 2] = wrap(x[:, 2])
    x[0] = start
    return x
