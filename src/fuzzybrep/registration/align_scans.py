"""Poses from drifting odometry: every scan aligned to the map of the scans before it, and the
drift left over closed at every loop (issue 22).

Only the odometry's relative motion between consecutive scans is used, never a pose the log
may hold from someone else's SLAM: the first scan sits at its odometry pose and every later one
starts at its predecessor's aligned pose moved by the odometry step.

Front end (``align_scans``, scan by scan):

* the *local map* is the surface the last ``window`` key scans saw: each key scan's returns,
  joined beam to beam into polylines wherever consecutive returns lie close enough to be one
  surface (a jump in range is a gap, not a wall). A scan becomes a key scan once the robot has
  moved ``key_distance`` or turned ``key_turn`` since the last one, so that a robot standing
  still does not fill the window with copies of one view;
* each scan's returns are aligned to those polylines by ``registration.segment_match.align`` (robust Gauss-Newton
  on point-to-segment distances, coarse to fine), with the odometry step as a Gaussian prior
  (``OdometryNoise``): where a corridor leaves a direction unconstrained, the odometry says where
  the scan lies along it.

Back end (loop closure, ``registration.pose_graph``): every ``loop_every`` metres of travel the scan is
also aligned to the key scans around the nearest place passed more than ``loop_travel`` metres
ago (within what the drift since can explain of the scan's current estimate, ``_try_loop``); a match that explains most of the
scan (``loop_inliers``) and fixes its heading and at least one direction of its position adds a loop edge to the pose graph
whose other edges are the consecutive scans' relative poses; at the end every key scan is
matched again to the places it passed twice (``_refine``) and to its neighbours in time on both
sides (``_refine_local``). The graph is solved (SciPy sparse
least squares, a robust kernel on the loop edges) whenever a new loop edge disagrees with the
trajectory by more than ``loop_reoptimise`` metres, and once at the end; the local map then
follows the corrected poses.

Honesty: each scan gets a quality (``ScanQuality``): the share of its returns the map explains,
and the standard deviation of its position along the direction the match constrained least (a
corridor's length); ``AlignResult.poor`` lists the scans below ``poor_inliers`` or above
``poor_sigma``, and the build's summary says how many there were.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from ..errors import AlignmentError
from ..scans.scan import Scan, compose, named, relative, wrap
from . import pose_graph
from .calibrate_odometry import OdometryCalibration
from .check import AlignmentCheck, check_alignment
from .config import POSE_FLOOR, AlignConfig, OdometryNoise  # noqa: F401 (OdometryNoise: the API)
from .correlative import LikelihoodField
from .loop_closure import _refine, _refine_local, _try_loop
from .segment_match import align
from .surfaces import _edge_information, _sigma, _subsample, _Surfaces, _well_fixed, likelihood_of


@dataclass
class ScanQuality:
    """Per scan: ``inliers`` the share of its returns within the kernel of the map's surfaces
    (1 for the first scan), ``sigma`` the largest positional standard deviation of the match
    (metres; the odometry prior included, so a degenerate corridor shows as the odometry's
    uncertainty), ``matches`` the returns matched."""

    inliers: np.ndarray
    sigma: np.ndarray
    matches: np.ndarray


@dataclass
class AlignResult:
    poses: np.ndarray  #: (S, 3) aligned sensor poses
    quality: ScanQuality
    loops: int  #: loop edges in the pose graph
    optimisations: int
    config: AlignConfig
    #: the odometry's systematic error as learnt (``registration.calibrate_odometry``; None when not learnt)
    calibration: OdometryCalibration | None = None
    #: the aligned poses checked against the scans (``registration.check``; None: not checked)
    check: AlignmentCheck | None = None
    #: per loop edge, its disagreement with the solved poses in its own standard deviations
    loop_chi: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def poor(self) -> np.ndarray:
        """Indices of the scans whose alignment is poor (``AlignConfig.poor_*``)."""
        q, c = self.quality, self.config
        return np.flatnonzero((q.inliers < c.poor_inliers) | (q.sigma > c.poor_sigma))

    def metadata(self) -> dict:
        """What the map file keeps of the alignment (``metadata["alignment"]``)."""
        q = self.quality
        out = {"method": "scan-to-map alignment from odometry, pose-graph loop closure",
               "loops": int(self.loops), "poor_scans": int(len(self.poor())),
               "inliers": np.round(q.inliers, 4).tolist(), "sigma": np.round(q.sigma, 4).tolist()}
        if self.check is not None:
            out["check"] = self.check.metadata()
        if len(self.loop_chi):
            out["loop_residuals"] = {"edges": int(len(self.loop_chi)), "median_sigma": round(float(np.median(self.loop_chi)), 3),
                                     "beyond_3_sigma": round(float((self.loop_chi > 3).mean()), 4)}
        if self.calibration is not None:
            kappa, c = self.calibration.kappa_c
            out["odometry_error"] = {"distance": round(self.calibration.a, 5), "heading_deg_per_m": round(math.degrees(kappa), 4),
                                     "turn": round(c, 5), "stretches": self.calibration.steps}
        return out


def odometry_of(scans: Sequence[Scan]) -> np.ndarray:
    """(S, 3): each scan's odometry pose, its ``pose`` where the log records only one (a ROS bag
    without a map frame, a CSV log without odometry columns: that pose is the odometry)."""
    if all(s.odometry is not None for s in scans):
        return np.array([s.odometry for s in scans], np.float64).reshape(-1, 3)
    return np.array([s.pose for s in scans], np.float64).reshape(-1, 3)


def with_poses(scans: Sequence[Scan], poses: np.ndarray) -> list[Scan]:
    """The scans at ``poses`` (S, 3), their odometry kept."""
    return [Scan(s.ranges, s.bearings, p, s.timestamp, s.max_range, s.source, s.odometry) for s, p in zip(scans, poses)]


def pose_error(result: "AlignResult", share: float = 0.9) -> float:
    """The aligned poses' own error, for widening TME (``fuzzybrep build --align --widen-tme``):
    the ``share`` quantile of the per-scan σ, at least the 2 cm floor of ``_edge_information``
    (what a match moves from the shared logs' corrected poses, median)."""
    s = result.quality.sigma[np.isfinite(result.quality.sigma)]
    return max(float(np.quantile(s, share)) if len(s) else 0.0, POSE_FLOOR)


Progress = Callable[[int, int], None]


def align_scans(scans: Sequence[Scan], config: AlignConfig = AlignConfig(), odometry: np.ndarray | None = None,
                progress: Progress | None = None) -> AlignResult:
    """Aligned sensor poses (S, 3) of ``scans`` from their odometry (``odometry_of`` unless
    given), checked against the scans (``registration.check``): module docstring.

    Every scan is aligned, however little the robot moved: aligning only the scans it moved a few
    centimetres to reach made the benchmark's logs worse (docs/slam.md)."""
    cfg = config
    odo = odometry_of(scans) if odometry is None else np.asarray(odometry, np.float64).reshape(-1, 3)
    n = len(scans)
    if len(odo) != n:
        raise ValueError(f"{n} scans but {len(odo)} odometry poses")
    if n == 0:
        return AlignResult(np.zeros((0, 3)), ScanQuality(np.zeros(0), np.zeros(0), np.zeros(0, np.int64)), 0, 0, cfg)
    result = _align(scans, cfg, odo, progress)
    result.check = check_alignment(scans, result.poses) if cfg.check or cfg.strict else None
    if cfg.strict and not result.check.ok:  # before a map is built from poses known to be wrong
        raise AlignmentError(f"{named(scans)}: {result.check.describe(scans)} (strict: no map made)")
    return result


def _align(scans: Sequence[Scan], cfg: AlignConfig, odo: np.ndarray, progress: Progress | None) -> AlignResult:
    """``align_scans`` before the check: the front end, the loops and the refinement."""
    n = len(scans)
    poses = np.zeros((n, 3))
    surf = _Surfaces(scans, cfg)
    steps = relative(odo[:-1], odo[1:])
    inliers, sigma, matches = np.ones(n), np.zeros(n), np.zeros(n, np.int64)
    poses[0] = odo[0]
    keys = [0]
    travel = np.zeros(n)
    # the pose graph: consecutive edges (k - 1 → k) and loop edges (j → k)
    ei, ej, ez, einfo, robust = [], [], [], [], []
    loops = optimisations = 0
    last_try = last_loop = 0.0
    index, index_keys = None, None
    backwards = False  # the odometry reports the robot's travel reversed (``_direction``)
    recent: list = []
    calibration = OdometryCalibration()
    fixed = 0  # the last scan a calibration stretch begins at (the first scan is where it is)
    for k in range(1, n):
        step = steps[k - 1]
        travel[k] = travel[k - 1] + math.hypot(step[0], step[1])
        if backwards:
            step = np.array([-step[0], -step[1], step[2]])
        if cfg.calibrate:
            step = calibration.correct(step)
        guess = compose(poses[k - 1], step)
        prior_info = cfg.odometry.information(step, poses[k - 1, 2])
        pts = _subsample(surf.points[k], cfg.max_points)
        window = tuple(keys[-cfg.window:])
        if window != index_keys:
            index, index_keys = surf.index(window, poses), window
        if len(index) and len(pts) >= 4:
            res = align(pts, index, guess, width=cfg.width, start_width=cfg.start_width, prior=(guess, prior_info),
                        max_iterations=cfg.iterations)
            if cfg.search_sigmas and res.inlier_share < cfg.search_below:
                # the odometry's guess was not good enough a start: search its window, refine from
                # the best pose found, keep whichever explains more of the scan
                field_ = likelihood_of(index, cfg.search_resolution, cfg.search_sigma)
                start = _search(field_, pts, guess, prior_info, cfg)
                alt = align(pts, index, start, width=cfg.width, start_width=cfg.start_width, prior=(start, prior_info),
                            max_iterations=cfg.iterations)
                if alt.inlier_share > res.inlier_share + cfg.search_gain:
                    res = alt
            poses[k] = res.pose
            inliers[k], sigma[k], matches[k] = res.inlier_share, _sigma(res.covariance), res.matches
            cov = res.covariance
            if cfg.calibrate and res.inlier_share >= cfg.loop_inliers and _well_fixed(res.information, cfg):
                f = fixed
                if f is None or travel[k] - travel[f] >= cfg.calibrate_stretch:
                    if f is not None:
                        calibration.learn(relative(odo[f], odo[k]), relative(poses[f], poses[k]), travel[k] - travel[f],
                                          float(steps[f:k, 2].sum()))
                    fixed = k
        else:
            poses[k], inliers[k], matches[k] = guess, 0.0, 0
            cov = np.linalg.inv(prior_info)
            sigma[k] = _sigma(cov)
        moved = relative(poses[k - 1], poses[k])
        if cfg.direction_check:
            fixed_along = bool(matches[k]) and _fixed_along(res.information, poses[k - 1, 2], cfg)
            recent = recent[-cfg.direction_steps + 1:] + [(steps[k - 1, 0], moved[0], fixed_along)]
            flip = _direction(recent, cfg)
            if abs(steps[k - 1, 0]) < cfg.direction_stop and abs(steps[k - 1, 2]) < cfg.direction_stop_turn:
                flip = False  # a robot that stopped starts again the way its odometry says
            if flip is not None and flip != backwards:
                backwards, fixed = flip, None  # no calibration stretch across a reversal
        ei.append(k - 1)
        ej.append(k)
        ez.append(moved)
        einfo.append(_edge_information(cov, poses[k - 1, 2]))
        robust.append(False)
        last = poses[keys[-1]]
        if math.hypot(*(poses[k, :2] - last[:2])) >= cfg.key_distance or abs(wrap(poses[k, 2] - last[2])) >= cfg.key_turn:
            keys.append(k)
        if cfg.loop_closure and travel[k] - last_try >= cfg.loop_every and len(pts) >= 20:
            last_try = travel[k]
            closed = _try_loop(k, pts, poses, keys, travel, surf, cfg, travel[k] - last_loop)
            if closed is not None:
                j, pose_k, cov_k = closed
                ei.append(j)
                ej.append(k)
                ez.append(relative(poses[j], pose_k))
                einfo.append(_edge_information(cov_k, poses[j, 2], information=True))
                robust.append(True)
                loops += 1
                last_loop = travel[k]
                if math.hypot(*(pose_k[:2] - poses[k, :2])) > cfg.loop_reoptimise:
                    poses[: k + 1] = pose_graph.solve(poses[: k + 1], np.array(ei), np.array(ej), np.array(ez),
                                                      np.array(einfo), np.array(robust),
                                                      iterations=cfg.loop_solve_iterations)
                    optimisations += 1
                    index_keys = None  # the local map follows the corrected poses
        if progress and (k % 50 == 0 or k == n - 1):
            progress(k + 1, n)
    if loops:
        poses = pose_graph.solve(poses, np.array(ei), np.array(ej), np.array(ez), np.array(einfo), np.array(robust))
        optimisations += 1
    edges = (ei, ej, ez, einfo, robust)
    for _ in range(cfg.refine if loops else 0):
        added = _refine(poses, keys, travel, surf, cfg, edges)
        local = _refine_local(poses, keys, travel, surf, cfg, edges) if cfg.refine_local else 0
        if not added + local:
            break
        loops += added  # the local edges tie a scan to its own stretch: not loops
        poses = pose_graph.solve(poses, *(np.array(e) for e in edges))
        optimisations += 1
    result = AlignResult(poses, ScanQuality(inliers, sigma, matches), loops, optimisations, cfg,
                         calibration if cfg.calibrate else None)
    r = np.asarray(robust, bool)
    if r.any():
        # how far each loop edge is from the solved poses, in its own standard deviations
        e = pose_graph.residuals(poses, np.asarray(ei)[r], np.asarray(ej)[r], np.asarray(ez)[r])
        result.loop_chi = np.sqrt(np.einsum("ea,eab,eb->e", e, np.asarray(einfo)[r], e))
    return result


def _direction(recent: list, cfg: AlignConfig) -> bool | None:
    """Whether the odometry reports the robot's travel reversed (True), the right way (False), or
    the scans cannot tell (None), from ``recent``: the last steps' (odometry forward travel,
    aligned forward travel, whether the match fixed the travel to ``direction_sigma``). It can tell
    when each of the last ``direction_steps`` was fixed, the odometry's steps all went one way by at
    least ``direction_min``, and the aligned steps all went the same way as them (False) or all
    the other way (True), by at least a third of them.

    Odometry that loses the sign of the robot's velocity is not hypothetical: the benchmark's fr079
    log, as rebuilt from its bag, advances the robot's x, y along its heading while its ODOM lines'
    own velocity is −0.5 m/s and the scans show it backing up a corridor for 3 m. No window a drift
    model allows covers that (0.2 m off every 0.1 m step), and along a corridor the scan cannot
    correct it; the last steps whose match could tell can. Several steps that agree, not one:
    intel's repeated timestamps make single odometry steps jump back and forth by decimetres."""
    last = recent[-cfg.direction_steps:]
    if len(last) < cfg.direction_steps or not all(r[2] for r in last):
        return None
    odo = np.array([r[0] for r in last])
    ali = np.array([r[1] for r in last])
    if not (np.all(odo >= cfg.direction_min) or np.all(odo <= -cfg.direction_min)):
        return None
    if np.all(ali * np.sign(odo) >= np.abs(odo) / 3):
        return False
    if np.all(-ali * np.sign(odo) >= np.abs(odo) / 3):
        return True
    return None


def _fixed_along(information: np.ndarray, heading: float, cfg: AlignConfig) -> bool:
    """Whether a match's ``information`` fixes the robot's position along its heading (the
    direction it drives) to ``direction_sigma``."""
    w = np.array([math.cos(heading), math.sin(heading)])
    return bool(np.isfinite(information).all() and w @ information[:2, :2] @ w >= cfg.direction_sigma ** -2)


def _search(field_: LikelihoodField, pts: np.ndarray, guess: np.ndarray, prior_info: np.ndarray,
            cfg: AlignConfig) -> np.ndarray:
    """The start of a scan's match: the best pose of the correlative search in the window the
    odometry step's uncertainty allows (``AlignConfig.search_*``)."""
    sx = 1 / math.sqrt(prior_info[0, 0])
    st = 1 / math.sqrt(prior_info[2, 2])
    w = min(max(cfg.search_sigmas * sx, cfg.search_window), cfg.search_max)
    wa = min(max(cfg.search_sigmas * st, cfg.search_angle), cfg.search_max_angle)
    found = field_.search(_subsample(pts, cfg.search_points), guess, w, wa, prior_information=prior_info,
                          prior_weight=cfg.search_prior)
    return found.pose
