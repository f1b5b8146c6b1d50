"""Point lists: the x, y points of a CSV file (``membership --points``)."""

from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path

import numpy as np

from ..arrays import is_float
from ..errors import MapFileError
from .files import read_limited


def read_points(path: str | os.PathLike, limit: int | None = None) -> np.ndarray:
    """(m, 2) points from a CSV file: two columns x, y (more are ignored), header optional; at
    least one point. A header naming columns x and y says where they are (``id,x,y``).

    MapFileError naming the file (and line) for anything wrong: unreadable, more than ``limit``
    bytes (None: files.MAX_INPUT_BYTES; read with a bound, since a device or FIFO has no size to
    check first), not UTF-8, a field longer than the csv module reads (128 kB), a header naming x
    or y twice, or a row that is not two finite numbers."""
    path = Path(path)
    raw = read_limited(path, limit, "a point list")
    try:
        text = raw.decode("utf-8-sig")  # -sig: a spreadsheet's byte-order mark
    except UnicodeDecodeError as e:
        raise MapFileError(path, f"cannot read: {e}") from None
    reader = csv.reader(io.StringIO(text, newline=""))
    pts = []
    first = True
    ix, iy = 0, 1
    while True:
        try:
            row = next(reader)
        except StopIteration:
            break
        except csv.Error as e:  # a field over csv.field_size_limit(), a NUL byte
            raise MapFileError(path, f"line {reader.line_num}: not CSV ({e})") from None
        line = reader.line_num
        cells = [c.strip() for c in row]
        if not cells or not any(cells) or cells[0].startswith("#"):
            continue
        header, first = first, False
        if header and not any(is_float(c) for c in cells[:2]):  # a header line such as "x,y"
            names = [c.lower() for c in cells]
            if "x" in names and "y" in names:  # "id,x,y" or "y,x": read by name, not by place
                if names.count("x") > 1 or names.count("y") > 1:
                    twice = "x" if names.count("x") > 1 else "y"
                    raise MapFileError(path, f"line {line}: the header names column {twice!r} twice")
                ix, iy = names.index("x"), names.index("y")
            continue
        if len(cells) <= max(ix, iy):
            raise MapFileError(path, f"line {line}: expected x,y, got {_short(','.join(cells))!r}")
        if not (is_float(cells[ix]) and is_float(cells[iy])):
            raise MapFileError(path, f"line {line}: x,y must be numbers, got {_short(cells[ix])!r}, "
                                     f"{_short(cells[iy])!r}")
        x, y = float(cells[ix]), float(cells[iy])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise MapFileError(path, f"line {line}: x,y must be finite")
        pts.append((x, y))
    if not pts:  # an empty query is a mistake (a wrong file), not a question with no answers
        raise MapFileError(path, "no x,y points in the file")
    return np.array(pts, dtype=np.float64)


def _short(text: str, n: int = 40) -> str:
    """What an error quotes of a field: at most ``n`` characters (a field may be 100 kB)."""
    return text if len(text) <= n else text[:n] + "..."


__all__ = ["read_points"]
