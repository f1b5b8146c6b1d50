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
* each scan's returns are aligned to those polylines by ``use.align.align`` (robust Gauss-Newton
  on point-to-segment distances, coarse to fine), with the odometry step as a Gaussian prior
  (``OdometryNoise``): where a corridor leaves a direction unconstrained, the odometry says where
  the scan lies along it.

Back end (loop closure, ``mapping.pose_graph``): every ``loop_every`` metres of travel the scan is
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

from ..scans.scan import Scan, compose, relative, wrap
from ..use.align import SegmentIndex, align, sample_segments, transform
from . import pose_graph
from .calibrate_odometry import OdometryCalibration


#: the floor under a match's standard deviation (``_edge_information``): metres, radians
POSE_FLOOR = 0.02
HEADING_FLOOR = math.radians(0.5)


@dataclass(frozen=True)
class OdometryNoise:
    """How far the odometry's step between two scans may be off, one standard deviation:
    ``distance`` × the distance driven + ``floor`` in position, ``turn`` × the turn +
    ``heading_per_m`` × the distance + ``heading_floor`` in heading (radians). The defaults are
    twice the benchmark's systematic drift (5 % and 2°/m), so that a badly calibrated robot is
    still inside the prior."""

    distance: float = 0.10
    floor: float = 0.02
    turn: float = 0.05
    heading_per_m: float = math.radians(4.0)
    heading_floor: float = math.radians(1.0)

    def information(self, step: np.ndarray, heading: float) -> np.ndarray:
        """(3, 3) information of an odometry step (3,) in the world frame at ``heading``
        (isotropic in position, so the frame does not matter)."""
        d = math.hypot(step[0], step[1])
        sp = self.distance * d + self.floor
        st = self.turn * abs(step[2]) + self.heading_per_m * d + self.heading_floor
        return np.diag([1 / sp ** 2, 1 / sp ** 2, 1 / st ** 2])


@dataclass(frozen=True)
class AlignConfig:
    """Knobs of ``align_scans`` (metres and radians; module docstring)."""

    window: int = 16  #: key scans in the local map
    key_distance: float = 0.5
    key_turn: float = math.radians(10.0)
    max_range: float = 15.0  #: returns farther than this are not aligned nor mapped (too sparse)
    max_points: int = 100  #: returns aligned per scan, evenly subsampled
    join: float = 0.05  #: consecutive returns closer than join + 3 × beam spacing × range are one surface
    width: float = 0.10  #: final kernel width of the match
    start_width: float = 0.3
    spacing: float = 0.05  #: SegmentIndex sample spacing
    iterations: int = 20  #: Gauss-Newton iterations of a scan's match at most
    loop_iterations: int = 30  #: ... of a loop match
    odometry: OdometryNoise = field(default_factory=OdometryNoise)
    #: learn the odometry's systematic error from the well-matched steps and take it out of the
    #: next steps (``mapping.calibrate_odometry``)
    calibrate: bool = True
    calibrate_sigma: float = 0.02  #: a stretch teaches it between scans whose match alone fixes them this well (m), every way
    calibrate_stretch: float = 3.0  #: ... at least this far apart (m of odometry travel)
    loop_closure: bool = True
    loop_every: float = 2.0  #: try a loop closure every this many metres of travel
    loop_travel: float = 8.0  #: a place passed at least this much travel ago is a loop candidate
    loop_radius: float = 0.5  #: ... when within this distance of the scan's estimate (and more: ``_try_loop``)
    loop_window: int = 4  #: key scans either side of the candidate in the loop's local map
    loop_growth: float = 0.05  #: ... plus this share of the travel since (``_try_loop``)
    loop_max_radius: float = 10.0
    #: the match may move the scan at most loop_radius + this share of the travel since: a front
    #: end that drifts more than this loses that loop, one that slides along a corridor whose
    #: doors repeat is not believed
    loop_slide: float = 0.025
    #: an old place is a candidate this much farther than the drift reaches: the other side of a
    #: corridor, or a room seen from its door, is the same place (the match's own correction
    #: must still lie within the drift's reach)
    loop_view: float = 2.0
    loop_start_width: float = 1.6
    loop_inliers: float = 0.75  #: share of the scan the old place must explain
    loop_sigma: float = 0.05  #: and its position known this well across the corridor at least (m)
    loop_heading_sigma: float = math.radians(1.0)  #: and its heading this well
    loop_reoptimise: float = 0.20
    #: Gauss-Newton iterations of that solve at most: it moves the local map near the loop's
    #: correction, the solves at the end converge (most of the pose graph's cost on intel)
    loop_solve_iterations: int = 5
    #: a loop match must be unique (``_rival``): along the direction it constrains least, profiled
    #: every loop_probe metres, no other pose farther than loop_unique may explain nearly as
    #: much of the scan (loop_rival of its mean membership): a corridor whose doors repeat has one
    loop_probe: float = 0.1
    loop_unique: float = 0.25
    loop_rival: float = 0.95
    probe_iterations: int = 12  #: Gauss-Newton iterations of a probe at most (it need only show where it goes)
    refine: int = 1  #: passes of ``_refine`` after the online pass (0: none)
    refine_radius: float = 3.0  #: a key scan this near, passed at least loop_travel ago (or later), is matched
    refine_move: float = 0.3  #: a refinement match moving a scan farther than this is not believed
    refine_every: float = 1.0  #: a key scan is matched again once per this much travel
    #: ... and to the key scans around it in time, at least this many key scans either side (0:
    #: not): the front end matched it to the scans before it only (``_refine_local``)
    refine_local: int = 4
    refine_local_every: float = 1.0  #: ... once per this much travel
    poor_inliers: float = 0.5
    poor_sigma: float = 0.10


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
    #: the odometry's systematic error as learnt (``mapping.calibrate_odometry``; None when not learnt)
    calibration: OdometryCalibration | None = None

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


def scan_points(scan: Scan, max_range: float) -> tuple[np.ndarray, np.ndarray]:
    """(points (n, 2) in the sensor frame, joinable (n - 1,) bool) of a scan's returns within
    ``max_range``: joinable[i] says points i and i + 1 are consecutive beams."""
    r, b = scan.ranges, scan.bearings
    ok = scan.returns & (r <= max_range)
    idx = np.flatnonzero(ok)
    pts = np.column_stack((r[idx] * np.cos(b[idx]), r[idx] * np.sin(b[idx])))
    return pts, np.diff(idx) == 1


def surface_segments(points: np.ndarray, joinable: np.ndarray, beam_step: float, join: float) -> tuple[np.ndarray, np.ndarray]:
    """(a, b) segments joining consecutive returns that lie on one surface: closer than join + 3 ×
    beam_step × range (a surface seen at a grazing angle still joins; a jump in range does not)."""
    if len(points) < 2:
        return np.zeros((0, 2)), np.zeros((0, 2))
    a, b = points[:-1], points[1:]
    gap = np.hypot(*(b - a).T)
    reach = join + 3 * beam_step * np.minimum(np.hypot(*a.T), np.hypot(*b.T))
    keep = joinable & (gap <= reach)
    return a[keep], b[keep]


class _Surfaces:
    """Every scan's surface segments in its own frame, made once, placed at a pose on demand.

    A scan's placed segments (ends, directions, lengths, samples) are kept for the pose they were
    placed at: the front end's local map changes by one key scan at a time and the loop closure
    and the refinement ask for the same places again, so only a scan whose pose has changed (the
    pose graph moved it) is placed again; an index is made of the pieces as they are."""

    def __init__(self, scans: Sequence[Scan], cfg: AlignConfig):
        self.points, self.segments = [], []
        for s in scans:
            p, j = scan_points(s, cfg.max_range)
            step = float(np.median(np.diff(s.bearings))) if len(s.bearings) > 1 else 0.0
            self.points.append(p)
            sa, sb = surface_segments(p, j, step, cfg.join)
            self.segments.append((sa, sb, *sample_segments(sa, sb, cfg.spacing)))
        self.spacing = cfg.spacing
        self._placed: dict[int, tuple] = {}
        self._kept: dict[str, tuple] = {}

    def placed(self, k: int, pose: np.ndarray) -> tuple:
        """Scan k's (a, b, direction, length, samples, samples_of) at ``pose``, world frame."""
        key = (float(pose[0]), float(pose[1]), float(pose[2]))
        hit = self._placed.get(k)
        if hit is not None and hit[0] == key:
            return hit[1]
        sa, sb, samples, of = self.segments[k]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        R = np.array([[c, s], [-s, c]])
        a, b = sa @ R + pose[:2], sb @ R + pose[:2]
        d = b - a
        length = np.hypot(d[:, 0], d[:, 1])
        u = np.divide(d, length[:, None], out=np.zeros_like(d), where=length[:, None] > 0)
        out = (a, b, u, length, samples @ R + pose[:2], of)
        self._placed[k] = (key, out)
        return out

    def index(self, which: Sequence[int], poses: np.ndarray, keep: str | None = None) -> SegmentIndex:
        """The segments (and their samples: a rigid motion moves them too) of scans ``which`` at
        ``poses``. ``keep``: the index is kept under that name and given again while the same
        scans are asked for at the same poses (a KD-tree's making is most of an index's cost)."""
        if keep is not None:
            sig = (tuple(which), poses[list(which)].tobytes())
            kept = self._kept.get(keep)
            if kept is not None and kept[0] == sig:
                return kept[1]
            index = self.index(which, poses)
            self._kept[keep] = (sig, index)
            return index
        parts = [self.placed(k, poses[k]) for k in which]
        if not parts:
            return SegmentIndex(np.zeros((0, 2)), np.zeros((0, 2)), self.spacing)
        a, b, u, length, samples = (np.concatenate([p[i] for p in parts]) for i in range(5))
        offsets = np.cumsum([0] + [len(p[3]) for p in parts[:-1]])
        of = np.concatenate([p[5] + o for p, o in zip(parts, offsets)])
        return SegmentIndex.placed(a, b, u, length, samples, of, self.spacing)


def _subsample(p: np.ndarray, n: int) -> np.ndarray:
    return p if len(p) <= n else p[np.linspace(0, len(p) - 1, n).round().astype(np.int64)]


def _sigma(cov: np.ndarray) -> float:
    c = cov[:2, :2]
    if not np.isfinite(c).all():
        return math.inf
    return float(math.sqrt(max(np.linalg.eigvalsh(c).max(), 0.0)))


def _well_fixed(information: np.ndarray, cfg: AlignConfig) -> bool:
    """Whether a match's own information (no prior) fixes the scan's position to ``calibrate_sigma``
    in every direction and its heading to ``loop_heading_sigma``: not a corridor."""
    if not np.isfinite(information).all():
        return False
    return (np.linalg.eigvalsh(information[:2, :2]).min() >= cfg.calibrate_sigma ** -2
            and information[2, 2] >= cfg.loop_heading_sigma ** -2)


def _edge_information(cov: np.ndarray, heading: float, information: bool = False) -> np.ndarray:
    """Information of a relative pose measured by a match with covariance ``cov`` (world frame),
    in the frame of the pose it is measured from (``heading``). A floor of 2 cm and 0.5° (what a
    match moves from the corrected poses of the shared logs, median) keeps an overconfident match
    (its covariance says millimetres: hundreds of returns on one wall) from outweighing
    everything else, and a chain of consecutive edges from holding out against a loop."""
    c, s = math.cos(heading), math.sin(heading)
    R = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    floor = np.diag([POSE_FLOOR ** 2, POSE_FLOOR ** 2, HEADING_FLOOR ** 2])
    if information:  # ``cov`` is an information matrix, possibly singular: (Ω⁻¹ + F)⁻¹ = Ω (I + F Ω)⁻¹
        omega = R @ cov @ R.T
        out = omega @ np.linalg.inv(np.eye(3) + floor @ omega)
        return (out + out.T) / 2 + np.eye(3) * 1e-9
    cov = np.where(np.isfinite(cov), cov, 0.0)
    return np.linalg.inv(R @ cov @ R.T + floor)


Progress = Callable[[int, int], None]


def align_scans(scans: Sequence[Scan], config: AlignConfig = AlignConfig(), odometry: np.ndarray | None = None,
                progress: Progress | None = None) -> AlignResult:
    """Aligned sensor poses (S, 3) of ``scans`` from their odometry (``odometry_of`` unless
    given): module docstring."""
    cfg = config
    odo = odometry_of(scans) if odometry is None else np.asarray(odometry, np.float64).reshape(-1, 3)
    n = len(scans)
    if len(odo) != n:
        raise ValueError(f"{n} scans but {len(odo)} odometry poses")
    poses = np.zeros((n, 3))
    if n == 0:
        return AlignResult(poses, ScanQuality(np.zeros(0), np.zeros(0), np.zeros(0, np.int64)), 0, 0, cfg)
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
    calibration = OdometryCalibration()
    fixed = 0  # the last scan a calibration stretch begins at (the first scan is where it is)
    for k in range(1, n):
        step = steps[k - 1]
        travel[k] = travel[k - 1] + math.hypot(step[0], step[1])
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
        ei.append(k - 1)
        ej.append(k)
        ez.append(relative(poses[k - 1], poses[k]))
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
    return AlignResult(poses, ScanQuality(inliers, sigma, matches), loops, optimisations, cfg,
                       calibration if cfg.calibrate else None)


def _refine(poses: np.ndarray, keys: list[int], travel: np.ndarray, surf: _Surfaces, cfg: AlignConfig,
            edges: tuple[list, ...]) -> int:
    """Once the loops have pulled the trajectory together, every key scan is matched again to the
    key scans near it from another time (at least ``loop_travel`` before or after it), from its
    corrected pose: the online pass closed a loop every ``loop_every`` metres where the drift still
    let it; now every place seen twice ties its two visits together. Each match that explains the
    scan (the loop's tests) and moves it less than ``refine_move`` adds a robust edge. Returns the
    number of edges added to ``edges`` (ei, ej, ez, einfo, robust lists, extended in place)."""
    keys_a = np.asarray(keys)
    added = 0
    last = -math.inf
    for c, k in enumerate(keys_a):
        if travel[k] - last < cfg.refine_every:
            continue
        other = np.flatnonzero(np.abs(travel[keys_a] - travel[k]) >= cfg.loop_travel)
        if not len(other):
            continue
        d = np.hypot(*(poses[keys_a[other], :2] - poses[k, :2]).T)
        if d.min() > cfg.refine_radius:
            continue
        ci = int(other[np.argmin(d)])
        j = int(keys_a[ci])
        pts = _subsample(surf.points[k], cfg.max_points)
        if len(pts) < 20:
            continue
        near = keys_a[slice(*_around(ci, cfg.loop_window))]
        near = near[np.abs(travel[near] - travel[k]) >= cfg.loop_travel]
        index = surf.index(near.tolist(), poses, keep="refine")
        if not len(index):
            continue
        last = travel[k]
        res = align(pts, index, poses[k], width=cfg.width, start_width=2 * cfg.width, max_iterations=cfg.iterations)
        info = res.information
        if res.inlier_share < cfg.loop_inliers or not np.isfinite(info).all():
            continue
        if np.linalg.eigvalsh(info[:2, :2]).max() < cfg.loop_sigma ** -2 or info[2, 2] < cfg.loop_heading_sigma ** -2:
            continue
        added += _add_refined(edges, j, int(k), poses, res, cfg)
    return added


def _add_refined(edges: tuple[list, ...], j: int, k: int, poses: np.ndarray, res, cfg: AlignConfig) -> int:
    """A refinement's robust edge from key scan j to scan k at its matched pose ``res``, unless the
    match moved k farther than ``refine_move`` from its corrected pose. 1 if added, else 0."""
    if math.hypot(*(res.pose[:2] - poses[k, :2])) > cfg.refine_move:
        return 0
    ei, ej, ez, einfo, robust = edges
    ei.append(j)
    ej.append(k)
    ez.append(relative(poses[j], res.pose))
    einfo.append(_edge_information(res.information, poses[j, 2], information=True))
    robust.append(True)
    return 1


def _refine_local(poses: np.ndarray, keys: list[int], travel: np.ndarray, surf: _Surfaces, cfg: AlignConfig,
                  edges: tuple[list, ...]) -> int:
    """Every key scan (once per ``refine_local_every``) matched again, from its corrected pose, to the
    key scans around it in time, itself left out: those of the other parity in a block reaching at
    least ``refine_local`` key scans either side (one map serves every key scan of one parity in
    the block). The front end matched each scan to the scans before it only, each match a few
    centimetres and tenths of a degree off (``benchmarks/align_limits.py``): chained along a
    corridor seen once, that is the error left between the loops. Tied to both sides of its
    stretch, the pose graph averages the one-sided errors. The edge is from the map's key scan
    nearest to it; the tests are the refinement's but for heading and across-corridor (its own
    neighbours are the same corridor; a match that says little gets little information).
    Returns the edges added."""
    keys_a = np.asarray(keys)
    added = 0
    last = -math.inf
    W = cfg.refine_local
    for c, k in enumerate(keys_a):
        if travel[k] - last < cfg.refine_local_every or c == 0:
            continue
        pts = _subsample(surf.points[k], cfg.max_points)
        if len(pts) < 20:
            continue
        # the key scans of the other parity in a block of 4W around c's block of 2W: at least W
        # either side of c, without c, and the same for every key of that parity in the block (one
        # KD-tree for W matches, not one each: the trees were half of this pass's cost)
        first = (c // (2 * W)) * (2 * W)
        lo = max(0, first - W)
        near = [int(keys_a[i]) for i in range(lo, min(len(keys_a), first + 3 * W)) if i % 2 != c % 2]
        if not near:
            continue
        index = surf.index(near, poses, keep=f"local{c % 2}")
        last = travel[k]
        # from the corrected pose the scan lies within centimetres of its neighbours: the final
        # kernel from the start, and few iterations (this pass is about a tenth of the alignment's CPU time on intel)
        res = align(pts, index, poses[k], width=cfg.width, start_width=cfg.width, max_iterations=cfg.probe_iterations)
        info = res.information
        if res.inlier_share < cfg.loop_inliers or not np.isfinite(info).all():
            continue
        d = np.hypot(*(poses[near, :2] - poses[k, :2]).T)
        added += _add_refined(edges, near[int(np.argmin(d))], int(k), poses, res, cfg)
    return added


def _around(c: int, window: int) -> tuple[int, int]:
    """The slice of key scans around key c in a loop's or a refinement's local map: at least
    ``window`` either side, in blocks of ``window`` that neighbouring candidates share (the same
    key scans at the same poses: the same index, made once)."""
    first = (c // window) * window
    return max(0, first - window), first + 2 * window + 1


def _try_loop(k: int, pts: np.ndarray, poses: np.ndarray, keys: list[int], travel: np.ndarray, surf: _Surfaces,
              cfg: AlignConfig, since_loop: float):
    """(j, pose, covariance) of a loop match of scan k to the key scans around an old place, or None.

    The place is searched for, and the match accepted, only within what the drift since then
    can explain: ``loop_radius`` + ``loop_growth`` × the travel since that place or since the last
    loop closed, whichever is less (at most ``loop_max_radius``). A corridor matched one door
    along, or another corridor like it, lies farther than that."""
    keys_a = np.asarray(keys)
    old = keys_a[(travel[keys_a] <= travel[k] - cfg.loop_travel)]
    if not len(old):
        return None
    d = np.hypot(*(poses[old, :2] - poses[k, :2]).T)
    reach = np.minimum(cfg.loop_radius + cfg.loop_growth * np.minimum(travel[k] - travel[old], since_loop),
                       cfg.loop_max_radius)
    inside = d <= reach + cfg.loop_view
    if not inside.any():
        return None
    c = int(np.argmin(np.where(inside, d, np.inf)))
    j = int(old[c])
    radius = min(cfg.loop_radius + cfg.loop_slide * min(travel[k] - travel[j], since_loop), cfg.loop_max_radius)
    index = surf.index(old[slice(*_around(c, cfg.loop_window))].tolist(), poses, keep="loop")
    if not len(index):
        return None
    res = align(pts, index, poses[k], width=cfg.width, start_width=max(cfg.loop_start_width, d.min() / 2),
                max_iterations=cfg.loop_iterations)
    # what the match says, and only that: a corridor fixes the scan across it and its heading,
    # not along it, and the edge's information says so (singular along the corridor), rather than
    # the loop being dropped or trusted where it knows nothing
    info = res.information
    if res.inlier_share < cfg.loop_inliers or not np.isfinite(info).all():
        return None
    ev = np.linalg.eigvalsh(info[:2, :2])
    if ev.max() < cfg.loop_sigma ** -2 or info[2, 2] < cfg.loop_heading_sigma ** -2:
        return None
    if math.hypot(*(res.pose[:2] - poses[k, :2])) > radius:  # it slid into another corridor
        return None
    u = _rival(pts, index, res, poses[k], radius, cfg)
    if u is not None:  # it knows across the corridor, not which bay along it: singular along it
        M = np.eye(3)
        M[:2, :2] -= np.outer(u, u)
        info = M @ info @ M
    return j, res.pose, info


def _rival(pts: np.ndarray, index: SegmentIndex, res, estimate: np.ndarray, radius: float, cfg: AlignConfig):
    """The direction (2,) along which the loop match ``res`` has a rival, or None: a pose farther
    than ``loop_unique`` along the direction the match constrains least, within ``radius`` of the
    scan's ``estimate``, that explains nearly as much of the scan (``loop_rival`` × its mean
    membership). A corridor whose doors or pillars repeat matches one bay along almost as well as
    in the right one; its information says metres, not decimetres, only when the corridor is bare,
    so the rival is looked for, not inferred: the scan's mean membership (kernel twice the
    match's width) is profiled every ``loop_probe`` metres along that direction, all offsets in one
    tree query, and each local maximum that comes near the match's is aligned from there."""
    _, vec = np.linalg.eigh(res.information[:2, :2])
    u = vec[:, 0]  # the least constrained direction
    reach = radius + math.hypot(*(res.pose[:2] - estimate[:2]))
    offsets = np.arange(-reach, reach + cfg.loop_probe / 2, cfg.loop_probe)
    offsets = np.append(offsets[np.abs(offsets) > cfg.loop_unique], 0.0)
    w = 2 * cfg.width
    base = transform(pts, res.pose)
    world = (base[None, :, :] + offsets[:, None, None] * u[None, None, :]).reshape(-1, 2)
    _, d, _, _ = index.nearest(world, w)
    grade = np.clip(1 - d / w, 0, None).reshape(len(offsets), -1).mean(axis=1)
    mu0, grade, offsets = grade[-1], grade[:-1], offsets[:-1]
    padded = np.r_[-np.inf, grade, -np.inf]
    peak = (grade >= padded[:-2]) & (grade >= padded[2:]) & (grade >= cfg.loop_rival * mu0)
    for o in offsets[peak][np.argsort(-grade[peak])][:4]:
        start = res.pose + np.r_[o * u, 0.0]
        alt = align(pts, index, start, width=cfg.width, start_width=w, max_iterations=cfg.probe_iterations)
        if (math.hypot(*(alt.pose[:2] - res.pose[:2])) > cfg.loop_unique and alt.mu >= cfg.loop_rival * res.mu
                and math.hypot(*(alt.pose[:2] - estimate[:2])) <= radius):
            return u
    return None
