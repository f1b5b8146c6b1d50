"""What every reader shares: the report of what was read or skipped, the error a bad line
raises inside a reader, and a look at a file's first bytes."""

from __future__ import annotations

import gzip
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
