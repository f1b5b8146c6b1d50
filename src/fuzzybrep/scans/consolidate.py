"""Consolidation of two 180° scans taken at one spot, headings 0° and 180°, into one 360° scan.

The LMS200 sees 180°; the thesis turns the robot in place and scans again so that each local scan
covers the whole turn (thesis 5.2).
"""

from __future__ import annotations

import numpy as np

from ..errors import ScanValueError
from .scan import Scan, wrap


def can_consolidate(a: Scan, b: Scan, position_tol: float, heading_tol: float) -> bool:
    """True if b was taken at a's spot looking the other way."""
    return bool(
        np.hypot(*(b.pose[:2] - a.pose[:2])) <= position_tol
        and abs(abs(wrap(b.pose[2] - a.pose[2])) - np.pi) <= heading_tol
        and not a.full_circle
        and not b.full_circle
    )


def consolidate(a: Scan, b: Scan, position_tol: float = np.inf, heading_tol: float = np.radians(10)) -> Scan:
    """One 360° scan in a's frame from a and b (b taken at a's spot, heading turned by about 180°).

    b's beams are expressed relative to a's heading; where the two fields of view overlap
    (the beams at ±90° are seen by both) a's beams are kept.
    """
    if not can_consolidate(a, b, position_tol, heading_tol):
        raise ScanValueError(
            b.source or "scan", None,
            f"cannot consolidate with {a.source or 'the previous scan'}: scans must share a spot and face opposite ways "
            f"(moved {np.hypot(*(b.pose[:2] - a.pose[:2])):.3g}, turned {np.degrees(wrap(b.pose[2] - a.pose[2])):.1f}°)",
        )
    turn = wrap(b.pose[2] - a.pose[2]) % (2 * np.pi)
    bb = b.bearings + turn
    step = float(np.median(np.diff(a.bearings)))
    lo, hi = a.bearings[0], a.bearings[-1]
    # keep b's beams strictly beyond a's field of view, and short of a full turn
    keep = (bb > hi + step / 2) & (bb < lo + 2 * np.pi - step / 2)
    # b's ranges are measured from b's position; the consolidation assumes one spot (thesis 5.2)
    return Scan(
        np.concatenate((a.ranges, b.ranges[keep])),
        np.concatenate((a.bearings, bb[keep])),
        a.pose,
        a.timestamp,
        min(a.max_range, b.max_range),
        a.source,
        a.odometry,
    )


def consolidate_pairs(
    scans: list[Scan], position_tol: float = 0.05, heading_tol: float = np.radians(10)
) -> tuple[list[Scan], int]:
    """Merge every consecutive pair taken at one spot with opposite headings; others pass through.

    Returns the new list and the number of pairs merged.
    """
    out, i, merged = [], 0, 0
    while i < len(scans):
        if i + 1 < len(scans) and can_consolidate(scans[i], scans[i + 1], position_tol, heading_tol):
            out.append(consolidate(scans[i], scans[i + 1], position_tol, heading_tol))
            i += 2
            merged += 1
        else:
            out.append(scans[i])
            i += 1
    return out, merged
