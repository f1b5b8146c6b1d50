"""Per-scan beam classification and the spike filter.

Each beam gets a status and a free range:

* RETURN: it hit something at ``range`` (below the usable maximum): free up to there;
* FAR: it hit something beyond the usable maximum (``max_usable``), where 1° between beams is
  too coarse to trust the space between them: free up to ``max_usable``, the end is a frontier;
* NONE: no return (range at or above the sensor maximum): unknown, not an obstacle. Free only up
  to ``no_return_free`` (0 by default: nothing is claimed);
* CLIPPED: set later where evidence from other scans or the spike filter shortens the beam.

The spike filter handles what the thesis papered over by hand (5.2): a narrow group of beams
(at most ``spike_width``) reaching much farther than the beams on both sides has passed through
glass or a gap too narrow to matter. Its free range is cut back to the longer of its two
neighbours, so the map gets no needle of free space, never by editing the data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..polygon import CLIPPED, FAR, NONE, RETURN
from .scan import Scan


@dataclass(frozen=True)
class BeamConfig:
    max_usable: float = 8.0  #: longest range whose free space is trusted (LMS200: 8 m in mm mode)
    no_return_free: float = 0.0  #: free range claimed along a beam with no return
    spike_width: int = 3  #: widest group of beams (in beams) treated as a spike
    spike_jump: float = 0.5  #: a spike reaches this much (map unit) beyond both neighbours, at least


def classify(scan: Scan, cfg: BeamConfig = BeamConfig()) -> tuple[np.ndarray, np.ndarray]:
    """(free, status) of every beam of a scan, before any evidence from other scans."""
    r = scan.ranges
    ret = scan.returns
    status = np.where(ret, np.where(r > cfg.max_usable, FAR, RETURN), NONE).astype(np.int8)
    free = np.where(status == RETURN, r, np.where(status == FAR, cfg.max_usable, min(cfg.no_return_free, cfg.max_usable)))
    if cfg.spike_width > 0:
        free, status = despike(free, status, cfg.spike_width, cfg.spike_jump, scan.full_circle)
    return free, status


def despike(free: np.ndarray, status: np.ndarray, width: int, jump: float, full_circle: bool = False):
    """Cut back narrow groups of beams that reach far beyond both neighbours (see module doc)."""
    n = len(free)
    f = free.copy()
    st = status.copy()
    if n < 3:
        return f, st
    # try every group width w: beams i..i+w-1 all longer than both flanking beams by `jump`
    for w in range(1, width + 1):
        idx = np.arange(n) if full_circle else np.arange(1, n - w)
        lo = (idx - 1) % n
        hi = (idx + w) % n
        inner = np.stack([f[(idx + k) % n] for k in range(w)])
        flank = np.maximum(f[lo], f[hi])
        known = (status[lo] != NONE) & (status[hi] != NONE)
        spike = known & (inner.min(axis=0) > flank + jump)
        for k in range(w):
            j = (idx[spike] + k) % n
            f[j] = np.minimum(f[j], flank[spike])
            st[j] = CLIPPED
    return f, st
