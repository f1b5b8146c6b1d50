"""The CARMEN messages fuzzybrep reads, one line each: ``FLASER``, ``ROBOTLASER1``, ``RAWLASER1``
and ``ODOM`` (``scans.carmen`` reads a log of them). Each parser takes a line's fields and returns
numbers, or raises BadLine naming the field, with CARMEN's own names for the fields."""

from __future__ import annotations

import math

import numpy as np

from ..arrays import is_float
from .report import BadLine

#: numbers after the remissions: ROBOTLASER1's laser pose, robot pose, tv rv forward_safety_dist
#: side_safety_dist turn_axis and timestamp; RAWLASER1's timestamp only
_TAILS = {
    "ROBOTLASER1": ("laser_pose_x", "laser_pose_y", "laser_pose_theta", "robot_pose_x", "robot_pose_y",
                    "robot_pose_theta", "laser_tv", "laser_rv", "forward_safety_dist", "side_safety_dist",
                    "turn_axis", "timestamp"),
    "RAWLASER1": ("timestamp",),
}
_CONFIG = ("laser_type", "start_angle", "field_of_view", "angular_resolution", "maximum_range", "accuracy",
           "remission_mode", "num_readings")
_ODOM = ("x", "y", "theta", "tv", "rv", "accel", "timestamp")


def _number(tok: str, name: str, finite: bool = True) -> float:
    if not is_float(tok):
        raise BadLine(name, f"{tok!r} is not a number")
    v = float(tok)
    if finite and not math.isfinite(v):
        raise BadLine(name, f"{tok!r} is not finite", True)
    return v


def _integer(tok: str) -> int:
    """int(tok), but not of digits grouped by underscores (int() reads "1_0" as 10): ValueError."""
    if "_" in tok:
        raise ValueError(tok)
    return int(tok)


def _count(parts: list[str], i: int, name: str, least: int) -> int:
    tok = parts[i] if i < len(parts) else ""
    try:
        n = _integer(tok)
    except ValueError:
        raise BadLine(name, f"{tok!r} is not an integer") from None
    if n < least:
        raise BadLine(name, f"{n} must be at least {least}")
    return n


def _ranges(parts: list[str], at: int, n: int, name: str) -> np.ndarray:
    """n ranges from parts[at]: finite and not negative (fields named name_1 ... name_n)."""
    try:
        if "_" in "".join(parts[at : at + n]):  # NumPy, as float(), reads "1_0" as 10
            raise ValueError("underscore")
        r = np.array(parts[at : at + n], dtype=np.float64)
    except ValueError:
        bad = next(i for i, t in enumerate(parts[at : at + n]) if not is_float(t))
        raise BadLine(f"{name}_{bad + 1}", f"range {parts[at + bad]!r} is not a number") from None
    bad = ~np.isfinite(r) | (r < 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise BadLine(f"{name}_{i + 1}", f"range {parts[at + i]!r} is {'negative' if r[i] < 0 else 'not finite'}", True)
    return r


def parse_flaser(parts: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(ranges, pose, odometry, timestamp) of one FLASER line; raises BadLine naming the field."""
    try:
        n = _integer(parts[1])
    except (IndexError, ValueError):
        raise BadLine("n", f"beam count {parts[1] if len(parts) > 1 else ''!r} is not an integer") from None
    if n <= 0:
        raise BadLine("n", f"beam count {n} must be positive")
    need = 2 + n + 7
    if len(parts) < need:
        raise BadLine(None, f"truncated: {len(parts)} fields, a FLASER line with {n} beams needs at least {need}")
    # the ranges are not delimited: only the field count (7 numbers after them, then host and
    # logger timestamp, which old logs lack) shows a beam count that disagrees with the ranges,
    # which would otherwise shift ranges into the pose or the pose into the ranges
    if len(parts) == need + 1 and not is_float(parts[need]):
        # the host is there but not the logger timestamp after it: a line cut short (the last
        # line of a log that was still being written), not a wrong beam count
        raise BadLine(None, f"truncated: {len(parts)} fields, ending at the host {parts[need]!r}; a FLASER line "
                            f"with {n} beams has {need + 2}, the logger timestamp last")
    if len(parts) not in (need, need + 2):
        raise BadLine("n", f"beam count {n} does not match the line's {len(parts)} fields (a FLASER line with {n} "
                           f"beams has {need + 2}, or {need} without host and logger timestamp)")
    if len(parts) == need + 2 and is_float(parts[need]):
        raise BadLine("n", f"beam count {n} does not match the line: where the host should follow {n} ranges, the "
                           f"pose and the timestamp, there is the number {parts[need]!r}")
    r = _ranges(parts, 2, n, "r")
    names = ("x", "y", "theta", "odom_x", "odom_y", "odom_theta", "timestamp")
    vals = [_number(tok, name) for name, tok in zip(names, parts[2 + n :])]
    return r, np.array(vals[:3]), np.array(vals[3:6]), vals[6]


def _bearings(start: float, fov: float, res: float, n: int) -> np.ndarray:
    """The beams' bearings of a laser message: start_angle + i·angular_resolution (CARMEN's rule);
    where the n − 1 steps make the field of view, within the six decimals CARMEN writes both
    with, the beams spread evenly over it, both ends included (the field of view has the more
    digits: 180 steps of 0.008727 fall 0.1 mrad short of 3.141593)."""
    if not res > 0:
        raise BadLine("angular_resolution", f"{res!r} must be positive", True)
    if not fov >= 0:
        raise BadLine("field_of_view", f"{fov!r} must not be negative", True)
    span = (n - 1) * res
    tol = 1e-6 * n + 1e-9
    if span > fov + 0.5 * res + tol:
        raise BadLine("angular_resolution", f"{n} readings {res!r} rad apart span {span:.6g} rad, more than the "
                                            f"field of view {fov!r} rad")
    b = np.linspace(start, start + fov, n) if n > 1 and abs(span - fov) <= tol else start + res * np.arange(n)
    if n > 1 and b[-1] - b[0] >= 2 * np.pi:
        raise BadLine("field_of_view", f"{n} readings over {b[-1] - b[0]:.6g} rad span a full turn or more")
    return b


def parse_laser1(parts: list[str]) -> tuple[np.ndarray, np.ndarray, float, np.ndarray | None, float]:
    """(ranges, bearings, maximum_range, laser pose or None, timestamp) of a ROBOTLASER1 or
    RAWLASER1 line (RAWLASER1 has no pose); raises BadLine naming the field."""
    kind = parts[0]
    tail = _TAILS[kind]
    if len(parts) < 9:
        raise BadLine(None, f"truncated: {len(parts)} fields, a {kind} line has at least {10 + len(tail)}")
    n = _count(parts, 8, "num_readings", 1)
    vals = {}
    for i, name in enumerate(_CONFIG[:-1], 1):
        if name in ("laser_type", "remission_mode"):
            _count(parts, i, name, -2**31)
        else:
            vals[name] = _number(parts[i], name)
    at = 9 + n  # num_remissions
    if len(parts) <= at:
        raise BadLine(None, f"truncated: {len(parts)} fields, a {kind} line with {n} readings has at least "
                            f"{at + 1 + len(tail)}")
    try:
        m = _count(parts, at, "num_remissions", 0)
    except BadLine as e:  # the field after the ranges: num_readings may be what is wrong
        raise BadLine(e.field, f"{e.message} (is num_readings {n} the number of ranges?)") from None
    need = at + 1 + m + len(tail)
    what = f"a {kind} line with {n} readings and {m} remissions"
    if len(parts) == need and not is_float(parts[need - 2]) and is_float(parts[need - 1]):
        # host and logger timestamp where the tail's last two numbers should be: counts off by two
        raise BadLine("num_readings", f"num_readings {n} and num_remissions {m} do not match the line: where the "
                                      f"timestamp should end it, there is the host {parts[need - 2]!r}")
    if len(parts) < need:
        raise BadLine(None, f"truncated: {len(parts)} fields, {what} needs at least {need}")
    if len(parts) == need + 1 and not is_float(parts[need]):
        raise BadLine(None, f"truncated: {len(parts)} fields, ending at the host {parts[need]!r}; {what} has "
                            f"{need + 2}, the logger timestamp last")
    if len(parts) not in (need, need + 2) or (len(parts) == need + 2 and is_float(parts[need])):
        raise BadLine("num_readings", f"num_readings {n} and num_remissions {m} do not match the line's "
                                      f"{len(parts)} fields ({what} has {need + 2}, or {need} without host and "
                                      f"logger timestamp)")
    r = _ranges(parts, 9, n, "range")
    for j in range(m):
        _number(parts[at + 1 + j], f"remission_{j + 1}", finite=False)
    t = [_number(tok, name) for name, tok in zip(tail, parts[at + 1 + m :])]
    b = _bearings(vals["start_angle"], vals["field_of_view"], vals["angular_resolution"], n)
    return r, b, vals["maximum_range"], (np.array(t[:3]) if kind == "ROBOTLASER1" else None), t[-1]


def parse_odom(parts: list[str]) -> tuple[float, float, float, float]:
    """(x, y, theta, timestamp) of an ODOM line (``ODOM x y theta tv rv accel timestamp host
    logger_timestamp``, host and logger timestamp optional); raises BadLine naming the field."""
    if len(parts) not in (8, 10) or (len(parts) == 10 and is_float(parts[8])):
        raise BadLine(None, f"{len(parts)} fields: an ODOM line has 10 (ODOM x y theta tv rv accel timestamp host "
                            f"logger_timestamp), or 8 without host and logger timestamp")
    v = [_number(tok, name) for name, tok in zip(_ODOM, parts[1:8])]
    return v[0], v[1], v[2], v[6]
