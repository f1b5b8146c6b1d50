"""What every reader shares: the report of what was read or skipped, the error a bad line
raises inside a reader, and a look at a file's first bytes."""

from __future__ import annotations

import gzip
import re
import zlib
from collections.abc import Iterator
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


# ---------------------------------------------------------------------------- streaming text logs

#: the longest line a text log may have: a FLASER line of 181 beams is 1.5 kB, a spinning
#: lidar's scan tens of kB; a line of NUL bytes in a gzip bomb grew until MemoryError at 4.3 GB
MAX_LINE_BYTES = 8 * 2**20
#: a gzip log may expand at most this many times (checked once past GZIP_RATIO_FROM bytes): the
#: shared logs expand 3 to 6 times, a gzip bomb about 1000 (4 MB to 4 GiB)
MAX_GZIP_RATIO = 100
GZIP_RATIO_FROM = 16 * 2**20
_CHUNK = 2**20


class DamagedStream(ScanFormatError):
    """A gzip log cut off or damaged in the middle: what came before it can be kept (--skip-bad)."""


def matching_lines(path: str | Path, pattern: re.Pattern[bytes]) -> Iterator[tuple[int, bytes]]:
    """(1-based line number, line without its newline) of every line of a text log, plain or
    gzip, that ``pattern`` (multi-line mode, anchored at ``^``) matches from its start, read a
    chunk at a time: the memory held is a chunk and a line, whatever the file's size, and lines
    that do not match are passed over at the speed of ``re`` (4 GiB of blank lines ran for over
    five minutes one line at a time).

    ScanFormatError naming the line for a line longer than MAX_LINE_BYTES, and the file for a gzip
    stream that expands more than MAX_GZIP_RATIO times; DamagedStream (naming the line the damage
    is in) for a gzip stream cut off or corrupt."""
    path = Path(path)
    try:
        raw = open(path, "rb")
    except OSError as e:
        raise ScanFormatError(path, None, f"cannot open: {e.strerror or e}") from None
    with raw:
        gz = raw.read(2) == b"\x1f\x8b"
        raw.seek(0)
        # read1: what one read of the compressed stream gives, so that the lines before damage
        # are yielded before the damage is met (read() of a chunk would lose them with it)
        read = gzip.GzipFile(fileobj=raw, mode="rb").read1 if gz else raw.read
        line, carry, out, first = 1, b"", 0, True  # line: the number of carry's line
        while True:
            try:
                chunk = read(_CHUNK)
            except (EOFError, OSError, zlib.error) as e:  # zlib.error: a damaged block, no OSError
                raise DamagedStream(path, line, f"file is truncated or corrupt ({e})") from None
            out += len(chunk)
            if gz and out > GZIP_RATIO_FROM and out > MAX_GZIP_RATIO * raw.tell():
                raise ScanFormatError(path, None, f"the gzip stream expands more than {MAX_GZIP_RATIO} times "
                                                  f"({out // 2**20} MiB from {raw.tell() / 2**20:.1f} MiB): refused "
                                                  f"as a gzip bomb (logs expand a few times)")
            data = carry + chunk
            if first:  # a spreadsheet's "CSV UTF-8" starts with a byte-order mark
                data, first = data.removeprefix(b"\xef\xbb\xbf"), False
            end = len(data) if not chunk else data.rfind(b"\n") + 1
            block, carry = data[:end], data[end:]
            if len(carry) > MAX_LINE_BYTES:
                raise ScanFormatError(path, line + block.count(b"\n"), f"line is longer than {MAX_LINE_BYTES} bytes, the "
                                                                       f"most a line of a log may be")
            at = 0
            for m in pattern.finditer(block):
                line += block.count(b"\n", at, m.start())
                at = m.start()
                text = m.group()
                if len(text) > MAX_LINE_BYTES:
                    raise ScanFormatError(path, line, f"line is longer than {MAX_LINE_BYTES} bytes, the most a line "
                                                      f"of a log may be")
                yield line, text.rstrip(b"\r")
            line += block.count(b"\n", at)
            if not chunk:
                return
