"""Reading scans from any supported file, and the report of what was read or skipped."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import ScanFormatError
from .report import ReadReport, first_bytes


def detect_format(path: str | os.PathLike) -> str:
    """'csv', 'rosbag' or 'carmen', from the name and the first bytes."""
    p = Path(path)
    name = p.name.lower()
    # metadata.yaml: the file that makes a ROS 2 bag's folder a bag (`ros2 bag info` prints it)
    if p.is_dir() or name.endswith((".bag", ".db3", ".mcap")) or name == "metadata.yaml":
        return "rosbag"
    if name.endswith((".csv", ".csv.gz")):
        return "csv"
    # any other name: the first bytes (run.bag.active, as rosbag record leaves a cut-off bag;
    # scans.txt; a CSV gzipped as run.gz)
    head = first_bytes(p)
    if head.startswith(b"#ROSBAG V"):
        return "rosbag"
    for line in head.decode("utf-8-sig", errors="replace").splitlines():
        line = line.strip()
        if line and not line.startswith("#"):  # the first line that is not a comment: a CSV header?
            return "csv" if {"scan", "bearing", "range"} <= {c.strip().lower() for c in line.split(",")} else "carmen"
    return "carmen"


def read_scans(path: str | os.PathLike, fmt: str | None = None, report: ReadReport | None = None, **kw):
    """Scans from a CARMEN log, a CSV scan file or a ROS bag (format from the name, else from the
    first bytes, unless given)."""
    fmt = fmt or detect_format(path)
    if not Path(path).exists():
        raise ScanFormatError(path, None, "no such file")
    if fmt != "rosbag" and Path(path).suffix.lower() == ".npz" and first_bytes(Path(path))[:2] == b"PK":
        # before: read as a CARMEN log, "no FLASER line" or worse
        raise ScanFormatError(path, None, "a NumPy archive, such as `fuzzybrep simulate --out RUN.npz` writes "
                                          "(scans, odometry and true poses): logs are read as CARMEN, CSV scans or "
                                          "ROS bags; write the scans with `fuzzybrep simulate --out SCANS.csv`")
    if fmt == "carmen":
        from .carmen import read_carmen

        return read_carmen(path, report=report, **kw)
    if fmt == "csv":
        from .csvscans import read_csv

        return read_csv(path, report=report, **kw)
    if fmt == "rosbag":
        from .rosbag import read_rosbag

        return read_rosbag(path, report=report, **kw)
    raise ScanFormatError(path, None, f"unknown scan format {fmt!r} (carmen, csv or rosbag)")
