"""CARMEN logs: ``FLASER`` (front laser) messages, plain or gzip-compressed.

    FLASER n r_1 ... r_n  x y theta  odom_x odom_y odom_theta  timestamp host logger_timestamp

Ranges in metres; the n beams spread evenly from -90° to +90° relative to the laser heading
``theta``, both ends included; ``x y theta`` is the laser pose (``Scan.pose``) and ``odom_x odom_y
odom_theta`` the robot's pose by dead reckoning (``Scan.odometry``). In the shared SLAM-corrected
logs both are the corrected pose; in a log ``fuzzybrep drift`` wrote (``write_carmen``) the first
is the true pose and the second the drifting odometry. Other message types (``ODOM``,
``PARAM``, ``NEFF``, comments) carry no scan and are skipped. A range at or above the sensor's
maximum means "no return". CARMEN logs do not record that maximum, so by default it is taken as
the largest range in the log (81.83 m in the Intel log, 50 m in ACES): pass ``max_range`` when the
log has no no-return beams.
"""

from __future__ import annotations

import gzip
import io
import os
import re
from pathlib import Path

import numpy as np

from ..arrays import is_float
from ..errors import ScanFormatError
from ..formats.files import write_atomic
from .report import BadLine, DamagedStream, ReadReport, matching_lines
from .scan import Scan, even_bearings

SCAN_MESSAGES = ("FLASER",)


#: a line of a scan message: its name, then whitespace or the end of the line
_SCAN_LINE = re.compile(rb"(?m)^(?:" + b"|".join(re.escape(m.encode()) for m in SCAN_MESSAGES) + rb")(?![^\s])[^\n]*")


def _parse_flaser(parts: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(ranges, pose, odometry, timestamp) of one FLASER line; raises BadLine naming the field."""
    try:
        n = int(parts[1])
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
    try:
        r = np.array(parts[2 : 2 + n], dtype=np.float64)
    except ValueError:
        bad = next(i for i, t in enumerate(parts[2 : 2 + n]) if not is_float(t))
        raise BadLine(f"r_{bad + 1}", f"range {parts[2 + bad]!r} is not a number") from None
    bad = ~np.isfinite(r) | (r < 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise BadLine(f"r_{i + 1}", f"range {parts[2 + i]!r} is {'negative' if r[i] < 0 else 'not finite'}", True)
    names = ("x", "y", "theta", "odom_x", "odom_y", "odom_theta", "timestamp")
    vals = []
    for name, tok in zip(names, parts[2 + n :]):
        if not is_float(tok):
            raise BadLine(name, f"{tok!r} is not a number")
        v = float(tok)
        if not np.isfinite(v):
            raise BadLine(name, f"{tok!r} is not finite", True)
        vals.append(v)
    return r, np.array(vals[:3]), np.array(vals[3:6]), vals[6]


def read_carmen(
    path: str | os.PathLike,
    max_range: float | None = None,
    skip_bad: bool = False,
    report: ReadReport | None = None,
) -> list[Scan]:
    """All FLASER scans of a CARMEN log, in file order.

    Malformed, truncated or impossible lines (NaN or negative ranges) raise ScanFormatError naming
    the file, line and field; with ``skip_bad`` they are skipped instead and counted in ``report``.
    """
    path = Path(path)
    report = report if report is not None else ReadReport()
    skipped, errors = report.skipped, len(report.errors)  # a report may come with earlier reads in it
    rows: list[tuple[np.ndarray, np.ndarray, np.ndarray, float, int]] = []
    try:
        # streamed, with a bounded line length (report.matching_lines); other messages are passed over unread
        for lineno, line in matching_lines(path, _SCAN_LINE):
            try:
                r, pose, odom, t = _parse_flaser(line.decode("utf-8", errors="replace").split())
            except BadLine as e:
                err = e.error(path, lineno)
                if not skip_bad:
                    raise err from None
                report.skip(err)
                continue
            rows.append((r, pose, odom, t, lineno))
    except DamagedStream as err:
        # a cut-off gzip stream, or a damaged block in it: everything before the damage is kept
        # only if the caller asked to skip
        if not skip_bad:
            raise
        report.skip(err)
    if not rows:
        if report.skipped > skipped:  # every FLASER line was skipped as bad: "none in this file" would mislead
            first = f" (first: {report.errors[errors].args[0]})" if len(report.errors) > errors else ""
            raise ScanFormatError(path, None, f"no usable FLASER scans: all {report.skipped - skipped} were skipped "
                                              f"as bad{first}")
        raise ScanFormatError(path, None, "no FLASER scans in this file")
    if max_range is None:
        max_range = max(float(r.max()) for r, *_ in rows)
    scans = []
    bearings: dict[int, np.ndarray] = {}
    for r, pose, odom, t, lineno in rows:
        b = bearings.setdefault(len(r), even_bearings(len(r)))
        scans.append(Scan(r, b, pose, t, max_range, f"{path.name}:{lineno}", odom))
    report.scans = len(scans)
    report.max_range = max_range
    return scans


def write_carmen(path: str | os.PathLike, scans: list[Scan], header: str = "", host: str = "fuzzybrep") -> int:
    """Write scans as a CARMEN log of FLASER lines (atomically; gzip when the name ends in .gz);
    returns bytes written.

    ``x y theta`` is each scan's ``pose``, ``odom_x odom_y odom_theta`` its ``odometry`` (its pose
    when it has none), the timestamp its own, written twice (timestamp and logger timestamp).
    Every scan's beams must spread evenly from -90° to +90°, both ends included, as FLASER
    implies; ScanFormatError naming the file and the scan for any other, before anything is written. No-return beams are
    written as they are (the reader takes the largest range for the sensor's maximum).
    ``header``: comment lines to put first (each line gets its ``#``). Floats are written in full
    (repr), so that the log reads back bit for bit.
    """
    out = io.StringIO()
    for line in header.splitlines():
        out.write(f"# {line}\n" if line else "#\n")
    for k, s in enumerate(scans):
        n = len(s.ranges)
        expected = even_bearings(n)
        if n < 2 or not np.allclose(s.bearings, expected, rtol=0, atol=1e-9):
            raise ScanFormatError(path, None, f"cannot write scan {k + 1} ({s.source or 'no source'}) as a FLASER line: "
                                              f"its {n} beams do not spread evenly from -90° to +90°; write CSV scans "
                                              f"(.csv) instead")
        odom = s.pose if s.odometry is None else s.odometry
        t = repr(float(s.timestamp))
        nums = " ".join(repr(v) for v in (*s.ranges.tolist(), *s.pose.tolist(), *odom.tolist()))
        out.write(f"FLASER {n} {nums} {t} {host} {t}\n")
    data = out.getvalue().encode()
    if os.fspath(path).endswith(".gz"):
        data = gzip.compress(data, mtime=0)
    return write_atomic(Path(path), data)
