"""Reading scans from any supported file, and the report of what was read or skipped."""

from __future__ import annotations

import gzip
import os
import zlib
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ScanFormatError, ScanValueError


@dataclass
class ReadReport:
    """What a reader did: scans read, lines skipped (only with skip_bad) and why."""

    scans: int = 0
    skipped: int = 0
    errors: list[ScanFormatError] = field(default_factory=list)
    max_range: float | None = None
    consolidated: int = 0  # pairs of 180° scans merged into 360° scans
    notes: list[str] = field(default_factory=list)  # choices a reader made for the user (topics, pose source)

    def skip(self, err: ScanFormatError) -> None:
        self.skipped += 1
        if len(self.errors) < 20:  # enough to show the user what kind of damage it is
            self.errors.append(err)

    def summary(self) -> str:
        s = f"{self.scans} scans"
        if self.skipped:
            s += f", {self.skipped} bad lines skipped (first: {self.errors[0]})"
        return s


class BadLine(Exception):
    """A line a reader cannot use: the field it failed on and why (internal to readers)."""

    def __init__(self, field: str | None, message: str, impossible_value: bool = False):
        super().__init__(message)
        self.field, self.message, self.impossible_value = field, message, impossible_value

    def error(self, path, line: int) -> ScanFormatError:
        cls = ScanValueError if self.impossible_value else ScanFormatError
        return cls(path, line, self.message, self.field)


def is_float(tok: str) -> bool:
    try:
        float(tok)
        return True
    except ValueError:
        return False


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


def first_bytes(path: Path, size: int = 65536) -> bytes:
    """The first bytes of a file, gunzipped if it is gzip; b"" if it cannot be read (the reader says why)."""
    try:
        with open(path, "rb") as f:
            head = f.read(size)
        if head[:2] == b"\x1f\x8b":
            with gzip.open(path, "rb") as f:
                head = f.read(size)
        return head
    except (OSError, EOFError, zlib.error):
        return b""


def read_scans(path: str | os.PathLike, fmt: str | None = None, report: ReadReport | None = None, **kw):
    """Scans from a CARMEN log, a CSV scan file or a ROS bag (format from the name, else from the
    first bytes, unless given)."""
    fmt = fmt or detect_format(path)
    if not Path(path).exists():
        raise ScanFormatError(path, None, "no such file")
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
