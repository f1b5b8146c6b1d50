"""The pose a map uses for each scan of a simulated run: dead reckoning, re-localised, or true.

The thesis sizes its membership functions with TME = laser error + odometry error, the odometry
error being UMBmark's figure for one 4 m square (Appendix I; 184.13 mm). That bounds a pose error
only while the robot has driven about one square since it last knew where it was; after the 136 m
route, dead reckoning with Table I.2's robot is metres off (docs/simulator.md). So the thesis's
assumption holds only if the robot re-localises now and then. The demo's default model:

    relocalised  the robot knows its pose when it leaves a stop (an operator puts it on the
                 programmed route's mark, as the thesis's robot started from "Home"); the pose of
                 both scans at the next stop is that fix plus what the odometry measured since:
                 one 5 m leg, its turns, and the 180° turn between the two scans. The error of
                 each scan is the odometry error of one leg, shorter than one UMBmark square.
    odometry     pure dead reckoning from home (``SimRun.scans``' own poses).
    true         the true poses: no pose error at all (isolates the mapping pipeline).

``pose_errors`` and ``point_errors`` measure what each model really gives, against the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scans.scan import Scan, compose, relative, wrap
from .simulate import SimRun

MODELS = ("relocalised", "odometry", "true")
__all__ = ["MODELS", "compose", "relative", "departures", "relocalised_poses", "scan_poses", "with_poses",
           "PoseErrors", "pose_errors"]


def departures(run: SimRun) -> np.ndarray:
    """(k,) index into ``run.true_path`` of the pose in which the robot leaves each stop.

    At a stop the robot scans (pose i), turns 180° left and scans (i + 1), turns back (i + 2),
    then drives on (docs/simulator.md). Pose i is found as the path pose equal to the first scan's
    true pose, searching forward from the previous stop.
    """
    path, front = run.true_path, run.true_poses[::2]
    out, lo = [], 0
    for x, y, th in front:
        hit = np.flatnonzero((path[lo:, 0] == x) & (path[lo:, 1] == y) & (wrap(path[lo:, 2]) == th))
        if len(hit) == 0:
            raise ValueError("the run's scan poses are not on its true path")
        i = lo + int(hit[0])
        out.append(i + 2)
        lo = i + 1
    return np.minimum(np.array(out), len(path) - 1)


def relocalised_poses(run: SimRun) -> np.ndarray:
    """(S, 3) pose of every scan when the robot re-localises as it leaves each stop.

    Scans at stop k get the true departure pose of stop k − 1 composed with the odometry's own
    motion since then; at the first stop the fix is the start, which the odometry shares.
    """
    dep = departures(run)
    fix = np.repeat(np.r_[0, dep[:-1]], 2)[: len(run.scans)]
    odo = run.odometry_poses
    return compose(run.true_path[fix], relative(run.odometry_path[fix], odo))


def scan_poses(run: SimRun, model: str) -> np.ndarray:
    """(S, 3) pose of every scan under one of ``MODELS``."""
    if model == "relocalised":
        return relocalised_poses(run)
    if model == "odometry":
        return run.odometry_poses
    if model == "true":
        return run.true_poses.copy()
    raise ValueError(f"pose model must be one of {', '.join(MODELS)}, got {model!r}")


def with_poses(scans: list[Scan], poses: np.ndarray) -> list[Scan]:
    """The scans, each at the given pose instead of its own."""
    return [Scan(s.ranges, s.bearings, p, s.timestamp, s.max_range, s.source, s.odometry) for s, p in zip(scans, poses)]


@dataclass(frozen=True)
class PoseErrors:
    """How far the poses a map uses are from the truth (metres, degrees).

    position     (S,) distance between each scan's pose and its true pose.
    heading      (S,) heading error, degrees, signed.
    point        every return's displacement caused by its scan's pose error: where the map puts
                 the point minus where it truly is (the laser's own error not included).
    """

    position: np.ndarray
    heading: np.ndarray
    point: np.ndarray

    def summary(self, odometry_error: float, tme: float) -> dict:
        """Max and mean of each, and the share of returns the odometry error and TME cover."""
        p, h, q = self.position, np.abs(self.heading), self.point
        return {
            "position_error_m": {"max": float(p.max()), "mean": float(p.mean())},
            "heading_error_deg": {"max": float(h.max()), "mean": float(h.mean())},
            "point_error_m": {"max": float(q.max()), "p99": float(np.percentile(q, 99)), "mean": float(q.mean()),
                              "returns": int(q.size)},
            "position_error_within_odometry_error": bool(p.max() <= odometry_error),
            "returns_within_odometry_error": float(np.mean(q <= odometry_error)),
            "returns_within_tme": float(np.mean(q <= tme)),
        }


def pose_errors(scans: list[Scan], poses: np.ndarray, true_poses: np.ndarray) -> PoseErrors:
    """Position, heading and per-return point errors of ``poses`` against ``true_poses`` (S, 3)."""
    poses, true_poses = np.asarray(poses, np.float64), np.asarray(true_poses, np.float64)
    position = np.hypot(*(poses[:, :2] - true_poses[:, :2]).T)
    heading = np.degrees(wrap(poses[:, 2] - true_poses[:, 2]))
    r = np.concatenate([s.ranges[s.returns] for s in scans])
    b = np.concatenate([s.bearings[s.returns] for s in scans])
    k = np.repeat(np.arange(len(scans)), [int(s.returns.sum()) for s in scans])

    def world(p):
        a = p[k, 2] + b
        return p[k, :2] + r[:, None] * np.column_stack((np.cos(a), np.sin(a)))

    point = np.hypot(*(world(poses) - world(true_poses)).T)
    return PoseErrors(position, heading, point)
