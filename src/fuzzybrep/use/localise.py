"""Localisation on a fuzzy B-rep map: where was the robot at every scan of a log?

``localise(fuzzy_map, scans, odometry)`` returns a ``Track``: one pose per scan, in scan order,
in the map's frame, each with a confidence. The map is the sensor model (``sensor_model``): an
endpoint's grade is μ of its distance to the nearest obstacle edge under the edge's own
membership function; frontier edges and beams with no return are unknown, not walls.

Pose tracking (the default; from ``start``, by default the log's first pose): each scan's pose
is predicted from the previous one by the odometry's relative motion, then found by aligning the
scan's endpoints to the map's obstacle edges (``align``: robust Gauss-Newton, point-to-segment,
the prediction as a prior that holds what the scan cannot see, along a corridor). The laser's
range offset against the map (its systematic error, the union's boundary lying beyond the
returns) is estimated on the way, as a fourth unknown whose prior is what the scans before
said. A result that lost most of the map's agreement (the mean grade fell below
``CONFIG.keep`` of the recent scans'), or that moved implausibly far from the prediction, is
checked against a second alignment from the prediction with the narrow kernel and a local
search (``mcl.local_search``); if none agrees with the map, the scan keeps the prediction (dead
reckoning) and is marked lost.

Global localisation (``global_search=True``; no start): Monte Carlo localisation (``mcl``) with
particles spread over the map's free space, until one cluster holds the weight and a scan
aligned from it agrees with the map; tracking takes over from there. Until then the poses are
the particles' best estimate, with confidence 0, and ``Track.converged_at`` says at which scan it
converged (None: it did not).

Why matching for tracking and particles only for the global search: measured on the shared logs
(docs/localise.md), aligning to the edges is both more accurate and faster than a particle filter
on the same sensor model; a particle filter is what finds a pose with no start.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..scans.scan import Scan, compose, relative
from .sensor_model import UNKNOWN, SensorModel, sensor_points
from .tracking import LOST, TRACKED, Tracker, rts_smooth

#: ``Track.status`` of a pose: aligned to the map (TRACKED); predicted, because no alignment
#: agreed with the map (LOST); before global localisation converged (SEARCHING)
SEARCHING = 2
STATUS_NAMES = {TRACKED: "tracked", LOST: "lost", SEARCHING: "searching"}


@dataclass(frozen=True)
class LocaliseConfig:
    """Settings of ``localise``; lengths in the map's unit (defaults for metres).

    kernel          the final kernel width of the alignment to the map, as a share of its TME
                    (0.75: on freiburg-079's odd scans the heading RMSE is 1.02° at 0.5, 0.91°
                    at 0.75, 0.89° at 1; intel, aces, fhw, orebro within 1 mm and 0.05° of
                    each other; freiburg-campus 74.6 %, 75.5 % and 42 % of poses within TME)
    start_kernel    the widest first kernel (the prediction's own uncertainty sets it below this)
    trans_per_m, trans_floor          the wheel odometry's noise: σ of the position, per metre
                                      moved and at least
    heading_per_m, heading_per_rad, heading_floor   σ of its heading (radians): per metre moved,
                                      per radian turned, and at least
    odometry_sigma, odometry_heading, odometry_turn, odometry_floor, odometry_heading_floor
                    the calibrated odometry's random error: σ² of the position grows by
                    odometry_sigma² per metre, of the heading by odometry_heading² per metre and
                    odometry_turn² per radian turned, from floors of the two last
    match_sigma, match_heading   the best a scan aligned to the map is taken to be (σ)
    offset_sigma    prior σ of the range offset before any scan (0: not estimated); offset_limit
                    its bound
    keep            an alignment whose mean grade is below this share of the recent scans'
                    median is checked again (recovery)
    max_mahalanobis an alignment farther than this from the prediction (in σ) is checked again
    beams           endpoints a particle is weighed with (a subsample of the scan's returns)
    tolerance       an alignment stops when an iteration moves less than this
    smooth          run the RTS smoother over the filter (False: the online filter's poses)
    update_distance, update_turn   global search: a scan whose odometry moved less than this
                    (map unit) and turned less than this (radians) since the last filter update
                    does not update the filter (ROS 1 amcl's update_min_d 0.2 m and update_min_a π/6)
    max_updates     global search: filter updates without converging before it gives up
                    (``LocalisationError``)
    """

    kernel: float = 0.75
    start_kernel: float = 0.8
    trans_per_m: float = 0.1
    trans_floor: float = 0.02
    heading_per_m: float = math.radians(5.0)
    heading_per_rad: float = 0.05
    heading_floor: float = math.radians(1.0)
    odometry_sigma: float = 0.03
    odometry_heading: float = math.radians(1.0)
    odometry_turn: float = math.radians(1.5)
    odometry_floor: float = 0.005
    odometry_heading_floor: float = math.radians(0.2)
    match_sigma: float = 0.05
    match_heading: float = math.radians(0.5)
    offset: float = 0.0
    offset_sigma: float = 0.01
    offset_limit: float = 0.05
    keep: float = 0.6
    max_mahalanobis: float = 5.0
    beams: int = 60
    tolerance: float = 1e-3
    smooth: bool = True
    update_distance: float = 0.2
    update_turn: float = math.pi / 6
    max_updates: int = 100


CONFIG = LocaliseConfig()


@dataclass(frozen=True, eq=False)
class Track:
    """Where the robot was at every scan (``localise``).

    times       (S,) the scans' timestamps
    poses       (S, 3) x, y, heading (radians) of the sensor, in the map's frame
    confidence  (S,) the mean membership grade of the scan's endpoints at the pose, under the
                map's own membership functions (1: every endpoint on a crisp edge; 0: none within
                the support), endpoints beyond a frontier left out; 0 before global localisation
                converged
    status      (S,) TRACKED, LOST or SEARCHING (``STATUS_NAMES``)
    converged_at  the scan at which global localisation converged (0 when tracking from a start;
                None when it never did)
    offset      the range offset estimated between the laser and the map
    search_updates  the global search's filter updates (0 without it)
    notes       what the user should know, one line each
    """

    times: np.ndarray
    poses: np.ndarray
    confidence: np.ndarray
    status: np.ndarray
    converged_at: int | None
    offset: float = 0.0
    notes: tuple[str, ...] = ()
    search_updates: int = 0

    def __len__(self) -> int:
        return len(self.poses)

    def csv_text(self) -> str:
        """The track as CSV: header time,x,y,theta,confidence,status, one row per scan in scan
        order; theta in radians, status a word of ``STATUS_NAMES``; floats in full (repr), so that
        it reads back exactly."""
        rows = ["time,x,y,theta,confidence,status"]
        for t, (x, y, th), c, st in zip(self.times.tolist(), self.poses.tolist(), self.confidence.tolist(),
                                        self.status.tolist()):
            rows.append(f"{t!r},{x!r},{y!r},{th!r},{c!r},{STATUS_NAMES[st]}")
        return "\n".join(rows) + "\n"

    def write_csv(self, path: str | os.PathLike) -> int:
        """Write ``csv_text`` atomically; returns bytes written."""
        from ..formats.files import write_atomic

        return write_atomic(path, self.csv_text().encode())


def laser_odometry(scans: list[Scan], odometry: np.ndarray | None = None) -> np.ndarray:
    """(S, 3) the laser's pose by odometry for every scan: ``odometry`` if given, else each scan's
    ``odometry`` (the log's dead reckoning), else its ``pose``. A log's odometry is the robot's:
    the laser's mount on it is taken from the first scan (where the odometry and the laser pose
    of a log both start), and carried to every scan."""
    if odometry is not None:
        odo = np.asarray(odometry, np.float64).reshape(-1, 3)
        if len(odo) != len(scans):
            raise ValueError(f"{len(odo)} odometry poses for {len(scans)} scans")
        if not np.isfinite(odo).all():
            raise ValueError(f"odometry pose {int(np.argmax(~np.isfinite(odo).all(axis=1))) + 1} is not finite")
        return odo
    if scans and all(s.odometry is not None for s in scans):
        odo = np.array([s.odometry for s in scans])
        mount = relative(odo[0], scans[0].pose)
        return compose(odo, np.broadcast_to(mount, odo.shape))
    return np.array([s.pose for s in scans]).reshape(-1, 3)


def localise(fuzzy_map, scans: list[Scan], odometry: np.ndarray | None = None, *, start=None,
             global_search: bool = False, config: LocaliseConfig | None = None, seed: int | None = 0,
             progress=None) -> Track:
    """The pose of every scan on ``fuzzy_map`` (a ``FuzzyBRepMap``, or a ``SensorModel`` of one).

    odometry       (S, 3) the laser's pose by odometry per scan (only its relative motions are
                   used); default ``laser_odometry(scans)``: the log's odometry, else its poses.
    start          (3,) the first scan's pose; default the log's first pose. Ignored with
                   ``global_search``.
    global_search  no start: Monte Carlo localisation over the map's free space first; it updates
                   only after the robot moved (``config.update_distance``, ``update_turn``) and
                   raises ``LocalisationError`` after ``config.max_updates`` updates without
                   converging.
    seed           for the particles and the local searches (equal seeds, equal tracks).
    progress       called as progress(done, total) after every scan.
    """
    cfg = config or CONFIG
    model = fuzzy_map if isinstance(fuzzy_map, SensorModel) else SensorModel.from_map(fuzzy_map)
    S = len(scans)
    if S == 0:
        raise ValueError("no scans to localise")
    odo = laser_odometry(scans, odometry)
    rng = np.random.default_rng(seed)
    times = np.array([s.timestamp for s in scans])
    status = np.full(S, TRACKED, np.uint8)
    X, P, Xp, Pp, F = np.zeros((S, 3)), np.zeros((S, 3, 3)), np.zeros((S, 3)), np.zeros((S, 3, 3)), np.zeros((S, 3, 3))
    notes: list[str] = []
    tracker = Tracker(model, cfg, rng)
    k0 = updates = 0
    if global_search:
        from .mcl import global_localise

        k0, first, guesses, updates = global_localise(model, scans, odo, cfg, rng, tracker, progress)
        X[:k0] = guesses
        status[:k0] = SEARCHING
        if first is None:
            notes.append(f"global localisation did not converge in {S} scans: every pose is the particles' best "
                         f"guess, with confidence 0")
            return Track(times, X, np.zeros(S), status, None, tracker.offset, tuple(notes), updates)
        notes.append(f"global localisation converged at scan {k0 + 1} of {S}, after {updates} filter updates")
        x0 = first.pose
        P0 = np.linalg.inv(first.information + 1e-9 * np.eye(3)) + np.diag([cfg.match_sigma, cfg.match_sigma,
                                                                             cfg.match_heading]) ** 2
    else:
        x0 = np.array(scans[0].pose if start is None else start, np.float64).reshape(3)
        if not np.isfinite(x0).all():
            raise ValueError(f"start pose {x0.tolist()} is not finite")
        P0 = np.diag([cfg.trans_floor, cfg.trans_floor, cfg.heading_floor]) ** 2
    tracker.begin(x0, P0)
    if not global_search:  # the first scan: aligned from the start, which it refines
        _, status[k0] = tracker.update(sensor_points(scans[k0]), x0, P0)
    else:
        tracker.last_fix = x0
    X[k0], P[k0], Xp[k0], Pp[k0], F[k0] = tracker.x, tracker.P, x0, P0, np.eye(3)
    if progress is not None:
        progress(k0 + 1, S)
    for k in range(k0 + 1, S):
        wheel = relative(odo[k - 1], odo[k])
        step, cov = tracker.motion(wheel)
        xp, ppk, Fk = tracker.predict(step, cov)
        _, status[k] = tracker.update(sensor_points(scans[k]), xp, ppk, wheel)
        X[k], P[k], Xp[k], Pp[k], F[k] = tracker.x, tracker.P, xp, ppk, Fk
        if progress is not None:
            progress(k + 1, S)
    poses = X.copy()
    if cfg.smooth:
        poses[k0:] = rts_smooth(X[k0:], P[k0:], Xp[k0:], Pp[k0:], F[k0:])
    conf = np.zeros(S)
    conf[k0:] = grades(model, scans[k0:], poses[k0:], tracker.offset)
    lost = int((status == LOST).sum())
    if lost:
        notes.append(f"{lost} of {S} scans agreed with no alignment to the map and kept the predicted pose "
                     f"(status lost)")
    return Track(times, poses, conf, status, k0, tracker.offset, tuple(notes), updates)


def grades(model: SensorModel, scans: list[Scan], poses: np.ndarray, offset: float = 0.0) -> np.ndarray:
    """(S,) the mean membership grade of each scan's endpoints at its pose (one query for all
    scans): 1 when every endpoint lies on a crisp obstacle edge, 0 when none is within the
    support; endpoints beyond a frontier left out."""
    pts = [sensor_points(s) for s in scans]
    n = np.array([len(p) for p in pts])
    if n.sum() == 0:
        return np.zeros(len(scans))
    k = np.repeat(np.arange(len(scans)), n)
    p = np.vstack(pts)
    p = p + offset * p / np.maximum(np.hypot(p[:, 0], p[:, 1]), 1e-12)[:, None]
    c, s = np.cos(poses[k, 2]), np.sin(poses[k, 2])
    world = np.column_stack((poses[k, 0] + c * p[:, 0] - s * p[:, 1], poses[k, 1] + s * p[:, 0] + c * p[:, 1]))
    mu = model.membership(world)
    known = mu != UNKNOWN
    total = np.bincount(k[known], mu[known], len(scans))
    count = np.bincount(k[known], minlength=len(scans))
    return np.divide(total, count, out=np.zeros(len(scans)), where=count > 0)
