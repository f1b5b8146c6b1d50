"""The plain CSV scan format: one row per beam.

    # fuzzybrep scans 1
    # max_range: 8.0
    scan,time,x,y,theta,bearing,range
    0,0.0,1.5,2.0,0.0,-1.5707963,2.31
    0,0.0,1.5,2.0,0.0,-1.5533430,2.30
    ...

- ``scan`` groups the rows of one scan (rows of a scan are consecutive); ``time`` is its timestamp
  in seconds; ``x, y, theta`` its sensor pose (theta in radians); ``bearing`` the beam angle in
  radians relative to theta, increasing within a scan; ``range`` the measured distance.
- Coordinates and ranges are in metres: the map builder's settings are metric (``BuildConfig``).
- Lines starting with ``#`` are comments. ``# max_range: R`` declares the sensor's maximum: ranges
  at or above R mean "no return" (unknown, not an obstacle). Without it every range is a return.
- Optional columns ``odom_x, odom_y, odom_theta`` (all three or none) give the pose by dead
  reckoning apart from ``x, y, theta`` (``Scan.odometry``), as CARMEN's odom fields do; in a log
  ``fuzzybrep drift`` wrote, ``x, y, theta`` is the true pose and these the drifting odometry.
- The columns may come in any order; other columns are ignored. The file may be gzip-compressed.
"""

from __future__ import annotations

import io
import os
import re
from pathlib import Path

import numpy as np

from ..arrays import is_float
from ..errors import ScanFormatError
from ..formats.files import write_atomic
from .report import BadLine, DamagedStream, ReadReport, matching_lines
from .scan import Scan

COLUMNS = ("scan", "time", "x", "y", "theta", "bearing", "range")
ODOM_COLUMNS = ("odom_x", "odom_y", "odom_theta")
_MAX_RANGE = re.compile(r"#\s*max_range\s*[:=]\s*(\S+)")


#: the lines the reader looks at: not blank, and not a comment unless it may declare max_range
#: (other comments and blank lines are passed over unread, at the speed of ``re``)
_LINES = re.compile(rb"(?m)^[ \t\r\f\v]*(?:[^\s#]|#[ \t]*max_range)[^\n]*")


def _read_lines(path: Path) -> list[tuple[int, str]]:
    """(line number, text) of the lines that matter, streamed with a bounded line length and a
    guard against gzip bombs (``report.matching_lines``; a gzipped CSV was decompressed whole)."""
    try:
        return [(n, b.decode("utf-8", errors="replace")) for n, b in matching_lines(path, _LINES)]
    except DamagedStream as e:
        raise ScanFormatError(path, None, f"gzip stream {e.reason.removeprefix('file ')}") from None


def read_csv(
    path: str | os.PathLike,
    max_range: float | None = None,
    skip_bad: bool = False,
    report: ReadReport | None = None,
) -> list[Scan]:
    """Scans from a CSV scan file; errors name the file, line and column."""
    path = Path(path)
    report = report if report is not None else ReadReport()
    errors = len(report.errors)  # a report may come with earlier reads in it
    lines = _read_lines(path)
    header_at = None
    for i, (lineno, line) in enumerate(lines):
        s = line.strip()
        if s.startswith("#"):
            m = _MAX_RANGE.match(s)
            if m and max_range is None:
                if not is_float(m.group(1)) or not float(m.group(1)) > 0:
                    raise ScanFormatError(path, lineno, f"max_range {m.group(1)!r} is not a positive number")
                max_range = float(m.group(1))
            continue
        header_at = i
        break
    if header_at is None:
        raise ScanFormatError(path, None, "empty: no header line")
    header_line, header = lines[header_at]
    names = [c.strip().lower() for c in header.split(",")]
    twice = next((c for c in COLUMNS + ODOM_COLUMNS if names.count(c) > 1), None)
    if twice is not None:  # before: the first was read and the second passed over without a word
        raise ScanFormatError(path, header_line, f"header names column {twice!r} twice", twice)
    missing = [c for c in COLUMNS if c not in names]
    if missing:
        raise ScanFormatError(path, header_line, f"header lacks column(s) {', '.join(missing)}; expected {','.join(COLUMNS)}")
    odom = [c for c in ODOM_COLUMNS if c in names]
    if odom and len(odom) != len(ODOM_COLUMNS):
        raise ScanFormatError(path, header_line, f"header has {', '.join(odom)} but not "
                                                 f"{', '.join(c for c in ODOM_COLUMNS if c not in odom)}: odometry "
                                                 f"needs all of {','.join(ODOM_COLUMNS)}")
    wanted = COLUMNS + (ODOM_COLUMNS if odom else ())
    cols = [names.index(c) for c in wanted]
    data = [(n, line) for n, line in lines[header_at + 1:] if not line.lstrip().startswith("#")]
    if not data:
        raise ScanFormatError(path, header_line, "no scan rows after the header")
    table = _parse_rows(path, data, cols, wanted, len(names), skip_bad, report)
    scans = _group(path, table, max_range if max_range is not None else np.inf, skip_bad, report)
    if not scans:
        first = f" (all skipped as bad; first: {report.errors[errors].args[0]})" if len(report.errors) > errors else ""
        raise ScanFormatError(path, None, f"no usable scans{first}")
    report.scans = len(scans)
    report.max_range = max_range
    return scans


def _parse_rows(path, data: list[tuple[int, str]], cols, wanted, ncols, skip_bad, report) -> np.ndarray:
    """(m, k + 1) float array: the k wanted columns plus the 1-based file line of each row."""
    try:
        # fast path: the whole table at once; any problem falls back to row-by-row for a precise message
        arr = np.loadtxt(io.StringIO("\n".join(line for _, line in data)), delimiter=",", usecols=cols,
                         ndmin=2, dtype=np.float64)
        # loadtxt reads the chosen columns of a row with extra fields without a word: count every row's
        if arr.shape[0] == len(data) and np.isfinite(arr).all() and (arr[:, 6] >= 0).all() \
                and all(line.count(",") == ncols - 1 for _, line in data):
            return np.column_stack((arr, np.array([n for n, _ in data], np.float64)))
    except ValueError:
        pass
    rows = []
    for n, line in data:
        try:
            rows.append(_parse_row(line, cols, wanted, ncols) + [n])
        except BadLine as e:
            err = e.error(path, n)
            if not skip_bad:
                raise err from None
            report.skip(err)
    return np.array(rows, dtype=np.float64).reshape(-1, len(wanted) + 1)


def _parse_row(line: str, cols: list[int], wanted: tuple, ncols: int) -> list[float]:
    parts = line.split(",")
    if len(parts) < ncols:
        raise BadLine(None, f"truncated: {len(parts)} columns, the header has {ncols}")
    if len(parts) > ncols:
        # an extra comma (a decimal comma, say) shifts every column after it: the values would be wrong
        raise BadLine(None, f"{len(parts)} columns, but the header has {ncols} (numbers take a decimal point, "
                            f"not a comma)")
    out = []
    for name, c in zip(wanted, cols):
        tok = parts[c].strip()
        if not is_float(tok):
            raise BadLine(name, f"{tok!r} is not a number")
        v = float(tok)
        if not np.isfinite(v):
            raise BadLine(name, f"{tok!r} is not finite", True)
        if name == "range" and v < 0:
            raise BadLine(name, f"range {tok} is negative", True)
        out.append(v)
    return out


def _group(path, t: np.ndarray, max_range: float, skip_bad: bool, report: ReadReport) -> list[Scan]:
    """Rows of ``_parse_rows`` grouped into scans (the file line is the last column; with
    odometry, columns 7-9 are odom_x, odom_y, odom_theta)."""
    if len(t) == 0:
        return []
    odom = t.shape[1] == len(COLUMNS) + len(ODOM_COLUMNS) + 1
    constant = ((1, "time"), (2, "x"), (3, "y"), (4, "theta"))
    if odom:
        constant += tuple((7 + i, c) for i, c in enumerate(ODOM_COLUMNS))
    starts = np.flatnonzero(np.r_[True, t[1:, 0] != t[:-1, 0]])
    ends = np.r_[starts[1:], len(t)]
    seen: set[float] = set()
    scans = []
    for s, e in zip(starts, ends):
        rows = t[s:e]
        line0 = int(rows[0, -1])
        try:
            if rows[0, 0] in seen:
                raise BadLine("scan", f"rows of scan {rows[0, 0]:g} are not consecutive")
            seen.add(rows[0, 0])
            for j, name in constant:
                diff = np.flatnonzero(rows[:, j] != rows[0, j])
                if diff.size:
                    line0 = int(rows[diff[0], -1])
                    raise BadLine(name, f"{name} changes within scan {rows[0, 0]:g}")
            bad = np.flatnonzero(np.diff(rows[:, 5]) <= 0)
            if bad.size:
                line0 = int(rows[bad[0] + 1, -1])
                raise BadLine("bearing", f"bearings of scan {rows[0, 0]:g} must increase")
        except BadLine as e:
            err = e.error(path, line0)
            if not skip_bad:
                raise err from None
            report.skip(err)
            continue
        scans.append(Scan(rows[:, 6], rows[:, 5], rows[0, 2:5], rows[0, 1], max_range, f"{path.name}:{int(rows[0, -1])}",
                          rows[0, 7:10] if odom else None))
    return scans


def write_csv(path: str | os.PathLike, scans: list[Scan]) -> int:
    """Write scans in the CSV scan format (atomically); returns bytes written. When any scan has
    odometry (``Scan.odometry``), the odom_x, odom_y, odom_theta columns hold it (a scan without
    any: its pose)."""
    out = io.StringIO()
    out.write("# fuzzybrep scans 1\n")
    mr = {s.max_range for s in scans}
    if len(mr) > 1:
        raise ValueError("all scans of one CSV file must share max_range")
    if mr and np.isfinite(next(iter(mr))):
        out.write(f"# max_range: {float(next(iter(mr)))!r}\n")
    odom = any(s.odometry is not None for s in scans)
    out.write(",".join(COLUMNS + (ODOM_COLUMNS if odom else ())) + "\n")
    for k, s in enumerate(scans):
        # float(): under NumPy 2 the repr of a NumPy scalar is "np.float64(...)", not a number
        x, y, theta = s.pose.tolist()
        head = f"{k},{float(s.timestamp)!r},{x!r},{y!r},{theta!r},"
        tail = ""
        if odom:
            tail = "," + ",".join(repr(v) for v in (s.pose if s.odometry is None else s.odometry).tolist())
        out.writelines(f"{head}{b!r},{r!r}{tail}\n" for b, r in zip(s.bearings.tolist(), s.ranges.tolist()))
    return write_atomic(path, out.getvalue().encode())
