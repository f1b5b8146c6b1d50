"""Pose tracking on a fuzzy map: an extended Kalman filter whose motion is the odometry,
calibrated on the way, and whose measurement is the scan aligned to the map.

Each scan k:

1. **Motion** (``Tracker.motion``). The odometry's relative motion since scan k−1, corrected by
   ``OdometryCalibration``: the systematic errors of Appendix I (a distance scale, as E_s; a
   heading drift per metre driven, as E_d; a turn scale, as E_b) are estimated from the motions
   between the scans' alignments to the map by least squares, as a robot that knows where it
   is can calibrate its odometry while it drives (Roy & Thrun's idea, which Appendix I cites).
   The process noise is the odometry's random error (``odometry_sigma``, ``odometry_heading``,
   ``odometry_turn``, per √m and per √rad) plus what the calibration does not yet know.
2. **Measurement** (``Tracker.update``). The scan is aligned to the map's obstacle edges from
   the predicted pose (``align``; the range offset between laser and map estimated on the way),
   and fused with the prediction: the alignment's information (what its endpoints say) is capped
   by ``match_sigma`` and ``match_heading`` (a map is no better than its own boundary, and
   neighbouring endpoints share a wall's error, so they are not independent), and the Kalman
   gain weighs it against the predicted covariance.
3. **Checks**. An alignment whose mean grade fell below ``keep`` of the recent scans', or that
   lies implausibly far from the prediction (Mahalanobis distance over ``max_mahalanobis``), is
   tried again from the prediction with the narrow kernel and from the best poses of a local
   search (``mcl.local_search``); if none agrees with the map, the scan is not fused (the
   prediction stands) and is marked lost.

``rts_smooth`` runs the Rauch-Tung-Striebel smoother backwards over the filter's states: each
pose then also uses the scans after it (offline, for a log; the filter's poses are the online
estimate).
"""

from __future__ import annotations

import math

import numpy as np

from ..scans.scan import compose, decompose, recompose, relative, wrap
from ..registration.segment_match import Alignment, align
from .sensor_model import SensorModel

TRACKED, LOST = 0, 1


def mahalanobis(a: np.ndarray, b: np.ndarray, cov: np.ndarray) -> float:
    """√(eᵀ C⁻¹ e) of the pose difference e = a − b (heading wrapped)."""
    e = np.asarray(a, np.float64) - b
    e[2] = wrap(e[2])
    try:
        return float(math.sqrt(max(e @ np.linalg.solve(cov, e), 0.0)))
    except np.linalg.LinAlgError:
        return math.inf


def motion_jacobians(x: np.ndarray, step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """F = ∂(x ⊕ step)/∂x and G = ∂(x ⊕ step)/∂step (3 × 3 each)."""
    c, s = math.cos(x[2]), math.sin(x[2])
    F = np.array([[1.0, 0.0, -s * step[0] - c * step[1]], [0.0, 1.0, c * step[0] - s * step[1]], [0.0, 0.0, 1.0]])
    G = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return F, G


class OdometryCalibration:
    """The odometry's systematic errors, estimated from the motions the map measured.

    For a wheel step decomposed into (rot1, trans, rot2) (``scans.scan.decompose``) the corrected
    step is (β·rot1 + γ·trans/2, α·trans, β·rot2 + γ·trans/2): α scales distance (E_s), β scales
    turns (E_b), γ is the heading drift per metre driven (E_d). α from |measured distance| ≈ α ×
    |wheel distance|, (β, γ) from measured heading change ≈ β × wheel heading change + γ ×
    (signed) wheel distance, by least squares over every pair of consecutive scans the filter
    tracked, with a prior (α = β = 1, γ = 0) worth ``prior_metres`` of travel and
    ``prior_radians`` of turning, and pairs farther than 4σ from the fit left out.
    """

    def __init__(self, prior_metres: float = 5.0, prior_radians: float = 3.0):
        self.A = np.diag([prior_metres, prior_radians, prior_metres]).astype(np.float64)  # normal eqs
        self._prior = self.A.copy()
        self.b = np.array([prior_metres, prior_radians, 0.0])
        self.res = [0.0, 0.0]  # sums of squared residuals: distance, heading
        self.n = 0

    @property
    def params(self) -> np.ndarray:
        """(α, β, γ)."""
        alpha = self.b[0] / self.A[0, 0]
        beta, gamma = np.linalg.solve(self.A[1:, 1:], self.b[1:])
        return np.array([alpha, beta, gamma])

    #: σ of (α, β, γ) before the first pairs: 5 % of distance, 3 % of turns, 3°/m
    PRIOR_SIGMAS = np.array([0.05, 0.03, math.radians(3.0)])

    def sigmas(self) -> np.ndarray:
        """σ of (α, β, γ): the residual variance × the inverse normal equations, no less than
        the prior's share of the evidence."""
        if self.n <= 3:
            return self.PRIOR_SIGMAS.copy()
        vd = self.res[0] / max(self.n - 1, 1)
        vh = self.res[1] / max(self.n - 2, 1)
        cov = np.linalg.inv(self.A[1:, 1:]) * vh
        fit = np.sqrt([vd / self.A[0, 0], cov[0, 0], cov[1, 1]])
        prior = self.PRIOR_SIGMAS * np.sqrt(np.diag(self._prior) / np.array([self.A[0, 0], self.A[1, 1], self.A[2, 2]]))
        return np.maximum(fit, prior)

    def correct(self, step: np.ndarray) -> np.ndarray:
        r1, t, r2 = decompose(step)
        alpha, beta, gamma = self.params
        return recompose(beta * r1 + gamma * t / 2, alpha * t, beta * r2 + gamma * t / 2)[0]

    def add(self, wheel: np.ndarray, measured: np.ndarray) -> None:
        """One pair: the wheel step and the motion between the two scans' alignments."""
        _, t, _ = decompose(wheel)
        t, th = float(t[0]), float(wheel[2])
        # a turn of about half a revolution reads as +π or −π by chance (poses only know headings
        # modulo 2π): the measured turn is taken as the one nearest the wheels'
        dist, turn = math.hypot(measured[0], measured[1]), th + float(wrap(measured[2] - th))
        alpha, beta, gamma = self.params
        rd, rh = dist - alpha * abs(t), turn - beta * th - gamma * t
        if self.n > 10:
            sd, sh = math.sqrt(self.res[0] / self.n), math.sqrt(self.res[1] / self.n)
            if abs(rd) > 4 * sd + 1e-3 or abs(rh) > 4 * sh + 1e-4:
                return
        self.A[0, 0] += t * t
        self.b[0] += abs(t) * dist
        self.A[1:, 1:] += np.array([[th * th, th * t], [th * t, t * t]])
        self.b[1:] += np.array([th * turn, t * turn])
        self.res[0] += rd * rd
        self.res[1] += rh * rh
        self.n += 1


class Tracker:
    """The filter's state and its per-scan steps (module docstring). ``cfg`` is a
    ``localise.LocaliseConfig``; ``rng`` draws the local searches."""

    def __init__(self, model: SensorModel, cfg, rng: np.random.Generator):
        self.model, self.cfg, self.rng = model, cfg, rng
        self.width = cfg.kernel * model.tme
        self.offset = cfg.offset  # the range offset so far: the information-weighted mean of the scans
        self._offset_sum = self._offset_weight = 0.0
        self.offset_info = 1.0 / cfg.offset_sigma ** 2 if cfg.offset_sigma > 0 else math.inf
        self.recent: list[float] = []
        self.x = np.zeros(3)
        self.P = np.eye(3)
        self.calibration = OdometryCalibration()
        self.last_fix: np.ndarray | None = None  # the previous scan's alignment, if it was tracked

    # -- alignment to the map -----------------------------------------------------------------

    def align_to_map(self, pts: np.ndarray, pose: np.ndarray, prior_info: np.ndarray | None, start: float) -> Alignment:
        estimate = self.cfg.offset_sigma > 0
        return align(pts, self.model.index, pose, width=self.width, start_width=start,
                     prior=None if prior_info is None else (pose, prior_info), offset=self.offset,
                     offset_prior=(self.offset, self.offset_info) if estimate else None, support=self.model.tme,
                     tolerance=self.cfg.tolerance)

    def start_width(self, cov: np.ndarray) -> float:
        """3σ of the predicted pose at 2 m range, within [width, start_kernel]."""
        reach = 3.0 * math.sqrt(max(cov[0, 0], cov[1, 1]) + 4.0 * cov[2, 2])
        return min(max(reach, self.width), max(self.cfg.start_kernel, self.width))

    def accept(self, a: Alignment) -> None:
        """Remember a scan's grade and its range offset. The offset is the laser's and the map's,
        the same over a run, but one scan tells it from a step towards the walls it sees only
        weakly: each scan estimates it under a prior of σ ``offset_sigma`` around the mean so
        far, and the mean weighs each scan by what its own endpoints said about it."""
        self.recent = (self.recent + [a.mu])[-10:]
        if math.isfinite(a.offset_variance) and a.offset_variance > 0:
            h = 1.0 / a.offset_variance - self.offset_info  # the scan's own information on it
            if h > 0:
                self._offset_sum += h * a.offset
                self._offset_weight += h
                lim = self.cfg.offset_limit
                self.offset = float(np.clip(self._offset_sum / self._offset_weight, -lim, lim))

    # -- the filter ------------------------------------------------------------------------

    def begin(self, pose: np.ndarray, cov: np.ndarray) -> None:
        self.x, self.P = np.array(pose, np.float64), np.array(cov, np.float64)

    def motion(self, wheel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(step, covariance): the wheel step corrected by the calibration, and its noise: the
        random error per √m and per √rad, plus the calibration's own uncertainty, in the robot's
        frame."""
        cfg = self.cfg
        step = self.calibration.correct(wheel)
        t, turn = math.hypot(step[0], step[1]), abs(float(step[2]))
        sa, sb, sg = self.calibration.sigmas()
        st2 = cfg.odometry_sigma ** 2 * t + (sa * t) ** 2 + cfg.odometry_floor ** 2
        sh2 = (cfg.odometry_heading ** 2 * t + cfg.odometry_turn ** 2 * turn + (sb * turn) ** 2 + (sg * t) ** 2
               + cfg.odometry_heading_floor ** 2)
        return step, np.diag([st2, st2, sh2])

    def predict(self, step: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x⁻, P⁻, F): the state moved by ``step`` with noise ``cov`` (robot frame)."""
        F, G = motion_jacobians(self.x, step)
        return compose(self.x, step), F @ self.P @ F.T + G @ cov @ G.T, F

    def update(self, pts: np.ndarray, xp: np.ndarray, Pp: np.ndarray, wheel: np.ndarray | None = None
               ) -> tuple[Alignment, int]:
        """Fuse the scan's alignment to the map into the predicted state (x⁻, P⁻); ``wheel``:
        the wheel step that led here, for the calibration."""
        cfg = self.cfg
        # the prediction's full information as the alignment's prior (a maximum a posteriori
        # pose): along a corridor the scan's few across-the-corridor edges (door frames, a wall's
        # kinks) give Gauss-Newton a tiny curvature, and a tenth of the prediction's information
        # let it walk metres along it (the demo floor's ring corridor: 1.1 m from the true pose
        # with a narrow kernel; 4 of 8 seeded runs lost; none with the full prior, and the real
        # logs' errors unchanged within 1 mm)
        prior_info = np.linalg.inv(Pp)
        a = self.align_to_map(pts, xp, prior_info, self.start_width(Pp))
        R = self._measurement_cov(a)
        if self._doubtful(a, xp, Pp + R):
            a = self._recover(pts, xp, Pp, prior_info, a)
            R = self._measurement_cov(a)
            if self._doubtful(a, xp, Pp + R, 2 * cfg.max_mahalanobis):
                self.x, self.P = xp, Pp
                self.last_fix = None
                return a, LOST
        e = a.pose - xp
        e[2] = wrap(e[2])
        K = Pp @ np.linalg.inv(Pp + R)
        x = xp + K @ e
        x[2] = float(wrap(x[2]))
        self.x, self.P = x, (np.eye(3) - K) @ Pp
        self.accept(a)
        if wheel is not None and self.last_fix is not None:
            self.calibration.add(wheel, relative(self.last_fix, a.pose))
        self.last_fix = a.pose
        return a, TRACKED

    def _measurement_cov(self, a: Alignment) -> np.ndarray:
        """The alignment's covariance as a measurement: its endpoints' information, capped by
        the map's own accuracy (``match_sigma``, ``match_heading``)."""
        floor = np.diag([self.cfg.match_sigma ** 2, self.cfg.match_sigma ** 2, self.cfg.match_heading ** 2])
        try:
            return np.linalg.inv(a.information + 1e-9 * np.eye(3)) + floor
        except np.linalg.LinAlgError:
            return np.diag([1e12, 1e12, 1e12])

    def _doubtful(self, a: Alignment, xp: np.ndarray, S: np.ndarray, limit: float | None = None) -> bool:
        if a.matches < 4:
            return True
        if self.recent and a.mu < self.cfg.keep * float(np.median(self.recent)):
            return True
        return mahalanobis(a.pose, xp, S) > (self.cfg.max_mahalanobis if limit is None else limit)

    def _recover(self, pts, xp, Pp, prior_info, first: Alignment) -> Alignment:
        """The best of: the first alignment, one from the prediction with the narrow kernel, and
        one from each of the best poses of a local search around the prediction."""
        from .mcl import local_search

        cands = [first, self.align_to_map(pts, xp, prior_info, self.width)]
        spread = 4.0 * (Pp + np.diag([self.width ** 2, self.width ** 2, math.radians(2.0) ** 2]))
        for pose in local_search(self.model, pts, xp, spread, self.rng, self.cfg.beams):
            cands.append(self.align_to_map(pts, pose, prior_info, 2 * self.width))
        near = [c for c in cands if mahalanobis(c.pose, xp, Pp + self._measurement_cov(c)) <= 2 * self.cfg.max_mahalanobis]
        return max(near or cands, key=lambda c: c.mu)


def rts_smooth(x: np.ndarray, P: np.ndarray, xp: np.ndarray, Pp: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Rauch-Tung-Striebel: filtered states x (S, 3), P (S, 3, 3), predictions xp, Pp and motion
    Jacobians F (row k: the step into state k) -> smoothed poses (S, 3)."""
    xs = x.copy()
    for k in range(len(x) - 2, -1, -1):
        try:
            C = P[k] @ F[k + 1].T @ np.linalg.inv(Pp[k + 1])
        except np.linalg.LinAlgError:
            continue
        d = xs[k + 1] - xp[k + 1]
        d[2] = wrap(d[2])
        xs[k] = x[k] + C @ d
        xs[k, 2] = wrap(xs[k, 2])
    return xs
