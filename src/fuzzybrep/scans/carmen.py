"""CARMEN logs: ``FLASER``, ``ROBOTLASER1`` and ``RAWLASER1`` scans and ``ODOM`` odometry, plain or
gzip-compressed (one message a line; ``scans.carmen_lines`` parses each).

    FLASER n r_1 ... r_n  x y theta  odom_x odom_y odom_theta  timestamp host logger_timestamp

Ranges in metres; the n beams spread evenly from -90° to +90° relative to the laser heading
``theta``, both ends included; ``x y theta`` is the laser pose (``Scan.pose``) and ``odom_x odom_y
odom_theta`` the robot's pose by dead reckoning (``Scan.odometry``). In the shared SLAM-corrected
logs both are the corrected pose; in a log ``fuzzybrep drift`` wrote (``write_carmen``) the first
is the true pose and the second the drifting odometry.

    ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range accuracy
        remission_mode num_readings r_1 ... r_n num_remissions m_1 ... m_k laser_pose_x laser_pose_y
        laser_pose_theta robot_pose_x robot_pose_y robot_pose_theta laser_tv laser_rv
        forward_safety_dist side_safety_dist turn_axis timestamp hostname logger_timestamp

Newer CARMEN's laser message with its pose: the beams lie at ``start_angle + i·angular_resolution``
(spread evenly over ``field_of_view`` when the steps make it, see ``carmen_lines``), a range at or
above ``maximum_range`` is no return, and ``Scan.pose`` is the laser pose. CARMEN's robot module
writes both poses from odometry (interpolated at the laser's time), the laser pose being the robot
pose moved by the laser's offset on the robot; a corrected log (a SLAM tool's output) has both
corrected. So ``Scan.odometry`` is the laser pose too: the sensor's pose by dead reckoning, in
the sensor's frame as ``Scan.pose`` is (the robot pose would add the offset's lever arm to every
turn). Remissions are read past.

    RAWLASER1 (the same fields up to the remissions) timestamp hostname logger_timestamp
    ODOM x y theta tv rv accel timestamp hostname logger_timestamp

A RAWLASER1 scan has no pose of its own: it is placed at the odometry, the ODOM stream
interpolated at the scan's timestamp (x and y linearly, theta unwrapped), held at the stream's
first or last pose for a scan at most ODOM_GAP seconds outside it. CARMEN records the laser's
offset on the robot only in PARAM lines, which are not read: such a scan's pose is the robot's.
FLASER and ROBOTLASER1 always carry their odometry, so ODOM lines are read only for RAWLASER1
scans (and a damaged ODOM line is an error only then).

One message type gives the scans, since a logger writes each scan under several (newer CARMEN
writes RAWLASER1 and ROBOTLASER1 of every scan; converters add FLASER): of FLASER and ROBOTLASER1,
the one with more scans (the complete stream, where a logger wrote the other for part of the run
only), ROBOTLASER1 if as many (it records its own beam geometry and maximum range, which FLASER
leaves to convention); RAWLASER1 only when neither is there. ``ReadReport.notes`` says which was
chosen. Other message types (``PARAM``, ``NEFF``, ``ROBOTLASER2``, comments) carry no scan of the
front laser and are passed over.

CARMEN's FLASER does not record the laser's maximum, so by default it is taken as the largest
range in the log (81.83 m in the Intel log, 50 m in ACES): pass ``max_range`` when the log has no
no-return beams (``max_range`` also overrides ROBOTLASER1's and RAWLASER1's ``maximum_range``; a
``maximum_range`` of 0 or less means not recorded, and the largest range is taken for it too).
"""

from __future__ import annotations

import gzip
import io
import os
import re
from array import array
from pathlib import Path

import numpy as np

from ..errors import ScanFormatError
from ..formats.files import write_atomic
from .carmen_lines import parse_flaser, parse_laser1, parse_odom
from .report import BadLine, DamagedStream, ReadReport, matching_lines
from .scan import Scan, even_bearings

SCAN_MESSAGES = ("FLASER", "ROBOTLASER1", "RAWLASER1")
#: how far (seconds) a RAWLASER1 scan may lie before the first or after the last ODOM message and
#: still be placed (at that message's pose): a logger starts its streams a few messages apart
ODOM_GAP = 1.0

#: a line of a scan message or of ODOM: its name, then whitespace or the end of the line
_SCAN_LINE = re.compile(rb"(?m)^(?:" + b"|".join(re.escape(m.encode()) for m in (*SCAN_MESSAGES, "ODOM"))
                        + rb")(?![^\s])[^\n]*")


class _Lines:
    """What a pass over a log found: the scans of each message type, as (ranges, bearings or None,
    maximum_range or None, pose or None, odometry or None, timestamp, line), and the ODOM stream.
    Once a scan with a pose (FLASER, ROBOTLASER1) is met, RAWLASER1 scans and ODOM lines can no
    longer be chosen: they are counted, not kept, so that memory does not grow with them."""

    def __init__(self):
        self.rows: dict[str, list] = {k: [] for k in SCAN_MESSAGES}
        self.count = dict.fromkeys(SCAN_MESSAGES, 0)
        self.bad = dict.fromkeys(SCAN_MESSAGES, 0)
        self.odom = array("d")  # x, y, theta, timestamp of each ODOM line
        self.odom_errors: list[ScanFormatError] = []  # the first 20 (judged only if the scans need ODOM)
        self.odom_bad = 0

    def read(self, path: Path, skip_bad: bool, report: ReadReport) -> None:
        # streamed, with a bounded line length (report.matching_lines); other messages are passed over unread
        for lineno, line in matching_lines(path, _SCAN_LINE):
            parts = line.decode("utf-8", errors="replace").split()
            kind = parts[0]
            posed = self.count["FLASER"] or self.count["ROBOTLASER1"]
            if kind == "ODOM" and posed:
                continue
            try:
                if kind == "ODOM":
                    self.odom.extend(parse_odom(parts))
                    continue
                if kind == "FLASER":
                    r, pose, odom, t = parse_flaser(parts)
                    row = (r, None, None, pose, odom, t, lineno)
                else:
                    r, b, top, pose, t = parse_laser1(parts)
                    row = (r, b, top, pose, pose, t, lineno)
                self.count[kind] += 1
                if kind != "RAWLASER1":
                    self.rows[kind].append(row)
                    self.rows["RAWLASER1"].clear()
                    self.odom = array("d")
                elif not posed:
                    self.rows[kind].append(row)
            except BadLine as e:
                err = e.error(path, lineno)
                if kind == "ODOM":
                    self.odom_bad += 1
                    if len(self.odom_errors) < 20:
                        self.odom_errors.append(err)
                    continue
                if not skip_bad:
                    raise err from None
                report.skip(err)
                self.bad[kind] += 1

    def choose(self) -> str | None:
        """The message type whose scans are read (the module's docstring says why), None if none."""
        posed = [k for k in ("ROBOTLASER1", "FLASER") if self.rows[k]]
        if posed:
            return max(posed, key=lambda k: self.count[k])  # the first of equals: ROBOTLASER1
        return "RAWLASER1" if self.rows["RAWLASER1"] else None

    def place(self, path: Path, skip_bad: bool, report: ReadReport) -> list:
        """The RAWLASER1 rows with their pose and odometry: the ODOM stream at their timestamps."""
        if self.odom_bad:
            if not skip_bad:
                raise self.odom_errors[0]
            for err in self.odom_errors:
                report.skip(err)
            report.skipped += self.odom_bad - len(self.odom_errors)
        if not self.odom:
            raise ScanFormatError(path, None, f"the {len(self.rows['RAWLASER1'])} RAWLASER1 scans carry no pose, and "
                                              f"the log has no {'usable ' if self.odom_bad else ''}ODOM line to place "
                                              f"them by (FLASER and ROBOTLASER1 lines carry theirs)")
        o = np.frombuffer(self.odom, dtype=np.float64).reshape(-1, 4)
        o = o[np.argsort(o[:, 3], kind="stable")]
        t, theta = o[:, 3], np.unwrap(o[:, 2])
        rows = []
        for r, b, top, _, _, ts, lineno in self.rows["RAWLASER1"]:
            if not t[0] - ODOM_GAP <= ts <= t[-1] + ODOM_GAP:
                side = f"{t[0] - ts:.6g} s before the first" if ts < t[0] else f"{ts - t[-1]:.6g} s after the last"
                err = ScanFormatError(path, lineno, f"{ts!r} is {side} ODOM message: no odometry to place the "
                                                    f"scan by (at most {ODOM_GAP:g} s outside the stream)", "timestamp")
                if not skip_bad:
                    raise err
                report.skip(err)
                continue
            th = float(np.interp(ts, t, theta))
            pose = np.array([np.interp(ts, t, o[:, 0]), np.interp(ts, t, o[:, 1]), np.arctan2(np.sin(th), np.cos(th))])
            rows.append((r, b, top, pose, pose, ts, lineno))
        return rows


def read_carmen(
    path: str | os.PathLike,
    max_range: float | None = None,
    skip_bad: bool = False,
    report: ReadReport | None = None,
) -> list[Scan]:
    """The scans of a CARMEN log (FLASER, ROBOTLASER1 or RAWLASER1 placed by ODOM: see the module's
    docstring), in file order.

    Malformed, truncated or impossible lines (NaN or negative ranges) raise ScanFormatError naming
    the file, line and field; with ``skip_bad`` they are skipped instead and counted in ``report``.
    """
    path = Path(path)
    report = report if report is not None else ReadReport()
    skipped, errors = report.skipped, len(report.errors)  # a report may come with earlier reads in it
    found = _Lines()
    try:
        found.read(path, skip_bad, report)
    except DamagedStream as err:
        # a cut-off gzip stream, or a damaged block in it: everything before the damage is kept
        # only if the caller asked to skip
        if not skip_bad:
            raise
        report.skip(err)
    kind = found.choose()
    rows = [] if kind is None else found.place(path, skip_bad, report) if kind == "RAWLASER1" else found.rows[kind]
    if not rows:
        if report.skipped > skipped:  # every scan line was skipped as bad: "none in this file" would mislead
            first = f" (first: {report.errors[errors].args[0]})" if len(report.errors) > errors else ""
            kinds = (" or ".join(k for k in SCAN_MESSAGES if found.bad[k] or k == kind)
                     or "FLASER, ROBOTLASER1 or RAWLASER1")
            raise ScanFormatError(path, None, f"no usable {kinds} scans: all {report.skipped - skipped} were skipped "
                                              f"as bad{first}")
        raise ScanFormatError(path, None, "no FLASER, ROBOTLASER1 or RAWLASER1 scans in this file")
    others = [f"{found.count[k]} {k}" for k in SCAN_MESSAGES if k != kind and found.count[k]]
    if others:
        report.notes.append(f"read the {found.count[kind]} {kind} scans, not the {' and '.join(others)} ones "
                            f"(one message type per log: of FLASER and ROBOTLASER1 the one with more scans)")
    largest = max(float(r.max()) for r, *_ in rows)
    if max_range is None and kind != "FLASER" and any(top <= 0 for _, _, top, *_ in rows):
        report.notes.append(f"{kind} lines with no maximum_range (0): the log's largest range, {largest:g}, is "
                            f"taken for it")
    scans = []
    bearings: dict[int | bytes, np.ndarray] = {}
    for r, b, top, pose, odom, t, lineno in rows:
        if b is None:
            b = bearings.setdefault(len(r), even_bearings(len(r)))
        else:  # one array for every scan of the same geometry
            b = bearings.setdefault(b.tobytes(), b)
        mr = max_range if max_range is not None else top if top is not None and top > 0 else largest
        scans.append(Scan(r, b, pose, t, mr, f"{path.name}:{lineno}", odom))
    report.scans = len(scans)
    report.max_range = max_range if max_range is not None else max(s.max_range for s in scans)
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
