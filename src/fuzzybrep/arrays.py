"""Small helpers shared by the stages and the formats: spans of indices, cell counts for messages,
number tokens."""

from __future__ import annotations

import numpy as np


def spans(start: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Concatenated ranges start[k] .. start[k] + count[k] - 1, without a Python loop."""
    count = np.asarray(count, np.int64)
    return np.repeat(start, count) + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)


def cell_count_text(n: float) -> str:
    """A grid's cells along a side, for a message: every digit while it is readable, else three
    (an absurd resolution made a count of 300 digits)."""
    return f"{n:.0f}" if n < 1e12 else f"{n:.3g}"


def cells_area(n: int, resolution: float) -> float:
    """Area of n cells. n·r·r, not n·r**2: a float's ** raises OverflowError (--resolution 1e300)
    where * gives inf; and no cells have no area, not NaN (0·inf)."""
    return n * resolution * resolution if n else 0.0


def is_float(tok: str) -> bool:
    """A number as a log or a CSV file writes one. Python's float() also takes digits grouped by
    underscores ("1_0" is 10), which no writer of numbers means: refused."""
    if "_" in tok:
        return False
    try:
        float(tok)
        return True
    except ValueError:
        return False
