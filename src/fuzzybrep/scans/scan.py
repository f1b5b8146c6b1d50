"""The scan: ranges and bearings of one laser sweep taken at a known sensor pose (thesis 3.2, step a)."""

from __future__ import annotations

import math

from dataclasses import dataclass, field

import numpy as np

from ..errors import ScanValueError


@dataclass(frozen=True, eq=False)
class Scan:
    """One laser scan at a known pose.

    ranges    (n,) distances along each beam, in the map's unit (metres for real logs).
    bearings  (n,) beam angles in radians relative to the sensor heading, strictly increasing
              (counter-clockwise), spanning at most one full turn.
    pose      (3,) sensor pose x, y, heading (radians) in the world frame.
    timestamp seconds; decides which evidence is newer when scans disagree.
    max_range a range at or above this means "no return": the beam saw nothing (unknown),
              not an obstacle.
    source    where the scan came from ("file:line"), for messages.
    odometry  (3,) or None: the sensor pose by dead reckoning, when the log records it apart from
              ``pose`` (CARMEN's odom_x odom_y odom_theta, the CSV format's odom_x, odom_y,
              odom_theta columns). In a log ``fuzzybrep drift`` wrote, ``pose`` is the true pose
              and ``odometry`` the drifting one; None: the log has one pose only.
    """

    ranges: np.ndarray
    bearings: np.ndarray
    pose: np.ndarray
    timestamp: float = 0.0
    max_range: float = np.inf
    source: str = ""
    odometry: np.ndarray | None = None
    _full: bool = field(default=False, repr=False, init=False)

    def __post_init__(self) -> None:
        r = np.ascontiguousarray(self.ranges, dtype=np.float64)
        b = np.ascontiguousarray(self.bearings, dtype=np.float64)
        p = np.ascontiguousarray(self.pose, dtype=np.float64)
        object.__setattr__(self, "ranges", r)
        object.__setattr__(self, "bearings", b)
        object.__setattr__(self, "pose", p)
        where = self.source or "scan"
        if r.ndim != 1 or b.shape != r.shape:
            raise ScanValueError(where, None, f"{r.size} ranges but {b.size} bearings")
        if p.shape != (3,):
            raise ScanValueError(where, None, f"pose must be (x, y, heading), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ScanValueError(where, None, f"pose is not finite: {p.tolist()}")
        if self.odometry is not None:
            o = np.ascontiguousarray(self.odometry, dtype=np.float64)
            object.__setattr__(self, "odometry", o)
            if o.shape != (3,):
                raise ScanValueError(where, None, f"odometry must be (x, y, heading), got {o.shape}")
            if not np.all(np.isfinite(o)):
                raise ScanValueError(where, None, f"odometry is not finite: {o.tolist()}")
        if r.size == 0:  # nothing to map, and every step after would reduce an empty array
            raise ScanValueError(where, None, "a scan needs at least one beam")
        if not np.isfinite(self.timestamp):  # it orders the evidence: NaN is neither older nor newer
            raise ScanValueError(where, None, f"timestamp {self.timestamp!r} is not finite")
        if not self.max_range > 0:  # NaN would make every beam "no return"
            raise ScanValueError(where, None, f"max_range {self.max_range!r} must be positive (inf: every range is "
                                              f"a return)")
        bad = ~np.isfinite(r) | (r < 0)
        if bad.any():
            i = int(np.argmax(bad))
            raise ScanValueError(where, None, f"beam {i} has range {float(r[i])!r} (NaN, infinite or negative)")
        if not np.isfinite(b).all():  # NaN compares false: the checks below would pass it
            i = int(np.argmax(~np.isfinite(b)))
            raise ScanValueError(where, None, f"beam {i} has bearing {float(b[i])!r} (not finite)")
        if r.size >= 2 and np.any(np.diff(b) <= 0):
            raise ScanValueError(where, None, "bearings must increase strictly")
        if r.size and b[-1] - b[0] >= 2 * np.pi:
            raise ScanValueError(where, None, "bearings span a full turn or more")
        full = b.size >= 3 and bool(b[-1] - b[0] + 1.5 * np.median(np.diff(b)) >= 2 * np.pi)
        object.__setattr__(self, "_full", full)

    @property
    def returns(self) -> np.ndarray:
        """(n,) bool: the beam hit something (range below max_range and above zero)."""
        return (self.ranges < self.max_range) & (self.ranges > 0)

    @property
    def full_circle(self) -> bool:
        """True when the beams cover the whole turn (a consolidated 360° scan, thesis 5.2)."""
        return self._full

    def world_angles(self) -> np.ndarray:
        return self.pose[2] + self.bearings

    def endpoints(self) -> np.ndarray:
        """(n, 2) world coordinates of every beam's endpoint (no-return beams included)."""
        a = self.world_angles()
        return np.column_stack((self.pose[0] + self.ranges * np.cos(a), self.pose[1] + self.ranges * np.sin(a)))


def wrap(angle):
    """Angles into [-π, π). One angle (a float, NumPy's included) in Python floats: the same value
    (% is the floored modulo in both), without NumPy's per-call overhead, which the scan matcher
    paid twice an iteration."""
    if isinstance(angle, float):
        return np.float64((angle + math.pi) % (2 * math.pi) - math.pi)
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Poses a ⊕ b, both (n, 3) (or (3,)): b expressed in a's frame, returned in the world frame."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if a.ndim == 1 and b.ndim == 1:
        return compose(a[None], b[None])[0]
    a, b = np.broadcast_arrays(np.atleast_2d(a), np.atleast_2d(b))
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack((a[:, 0] + c * b[:, 0] - s * b[:, 1], a[:, 1] + s * b[:, 0] + c * b[:, 1],
                            wrap(a[:, 2] + b[:, 2])))


def relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Poses a⁻¹ ⊕ b, both (n, 3) (or (3,)): where b is seen from a."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if a.ndim == 1 and b.ndim == 1:
        return relative(a[None], b[None])[0]
    a, b = np.broadcast_arrays(np.atleast_2d(a), np.atleast_2d(b))
    d = b[:, :2] - a[:, :2]
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack((c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], wrap(b[:, 2] - a[:, 2])))


def decompose(steps: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rot1, trans, rot2), each (m,), of relative motions (m, 3): turn on the spot by rot1, drive
    trans straight (negative: backwards), turn by rot2, as a differential drive would. A step
    whose direction lies behind the robot is driven backwards, so that no step turns by more
    than it must."""
    steps = np.asarray(steps, np.float64).reshape(-1, 3)
    dx, dy, dth = steps[:, 0], steps[:, 1], steps[:, 2]
    trans = np.hypot(dx, dy)
    phi = np.where(trans > 0, np.arctan2(dy, dx), 0.0)
    back = np.abs(phi) > np.pi / 2
    rot1 = np.where(back, wrap(phi + np.pi), phi)
    trans = np.where(back, -trans, trans)
    return rot1, trans, wrap(dth - rot1)


def recompose(rot1: np.ndarray, trans: np.ndarray, rot2: np.ndarray) -> np.ndarray:
    """(m, 3) relative motions of turn rot1, straight trans, turn rot2 (``decompose``'s inverse)."""
    return np.column_stack((trans * np.cos(rot1), trans * np.sin(rot1), rot1 + rot2))


def even_bearings(n: int, fov: float = np.pi) -> np.ndarray:
    """n beams spread evenly over the field of view, both ends included (CARMEN's convention)."""
    return np.linspace(-fov / 2, fov / 2, n)


def named(scans) -> str:
    """The scans for a message, by where they came from ("file:line"): which log a failure is about."""
    a, b = scans[0].source or "scan 1", scans[-1].source or f"scan {len(scans)}"
    return f"the 1 scan {a}" if len(scans) == 1 else f"the {len(scans)} scans {a} to {b}"
