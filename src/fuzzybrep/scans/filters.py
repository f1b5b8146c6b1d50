"""Beam classification and the spike filter, for all scans at once.

Each beam gets a status and a free range:

* RETURN: it hit something at ``range`` (below the usable maximum): free up to there;
* FAR: it hit something beyond the usable maximum (``max_usable``), where the spacing between
  beams is too coarse to trust the space between them: free up to ``max_usable``, the end is a
  frontier;
* NONE: no return (range at or above the sensor maximum): unknown, not an obstacle. Free only up
  to ``no_return_free`` (0 by default: nothing is claimed);
* CLIPPED: set where the spike filter (here) or evidence from other scans (evidence.py) shortens
  the beam.

The spike filter handles what the thesis papered over by hand (5.2). A group of beams that all
reach beyond both neighbouring beams by more than ``spike_jump``, through an opening narrower
than ``min_gap`` (the distance between the two neighbours' endpoints), has passed through glass
or a gap too narrow to be of use; its free range is cut back to the segment joining the two
neighbours' endpoints (the pane of glass, the edge of the gap), so the map gets no needle or fan
of free space. The data are never edited: only how
far each beam's free space reaches. ``min_gap`` defaults to 2·TME: a gap that narrow holds no
free space at α = 0 anyway.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..polygon import CLIPPED, FAR, NONE, RETURN
from .scan import Scan


@dataclass(frozen=True)
class BeamConfig:
    max_usable: float = 8.0  #: longest range whose free space is trusted (LMS200: 8 m in mm mode)
    no_return_free: float = 0.0  #: free range claimed along a beam with no return
    spike_width: int = 16  #: widest group of beams (in beams) examined as a possible spike
    spike_jump: float = 0.5  #: a spike reaches this much (map unit) beyond both neighbours, at least
    min_gap: float = 0.4  #: openings narrower than this (map unit) let no free space through


def classify(scan: Scan, cfg: BeamConfig = BeamConfig()) -> tuple[np.ndarray, np.ndarray]:
    """(free, status) of every beam of one scan, before any evidence from other scans."""
    return classify_all([scan], cfg)[0]


def classify_all(scans: Sequence[Scan], cfg: BeamConfig = BeamConfig()) -> list[tuple[np.ndarray, np.ndarray]]:
    """(free, status) of every beam of every scan; scans with the same beam count go together."""
    out: list = [None] * len(scans)
    groups: dict[tuple[int, bool], list[int]] = {}
    for k, s in enumerate(scans):
        groups.setdefault((len(s.ranges), s.full_circle), []).append(k)
    for (n, full), idx in groups.items():
        r = np.stack([scans[k].ranges for k in idx])
        mr = np.array([scans[k].max_range for k in idx])[:, None]
        ret = (r < mr) & (r > 0)
        status = np.where(ret, np.where(r > cfg.max_usable, FAR, RETURN), NONE).astype(np.int8)
        free = np.where(status == RETURN, r, np.where(status == FAR, cfg.max_usable, min(cfg.no_return_free, cfg.max_usable)))
        if cfg.spike_width > 0 and n >= 3:
            b = np.stack([scans[k].bearings for k in idx])
            free, status = despike(free, status, b, cfg, full)
        for j, k in enumerate(idx):
            out[k] = (free[j], status[j])
    return out


def despike(free: np.ndarray, status: np.ndarray, bearings: np.ndarray, cfg: BeamConfig, full_circle: bool = False):
    """Cut back narrow groups of beams reaching far beyond both neighbours (see module doc).

    free, status, bearings: (S, n) arrays, one row per scan. Groups of w = 1, 2, ... beams are
    examined in turn, each on the ranges the narrower groups left.
    """
    S, n = free.shape
    f = free.copy()
    st = status.copy()
    cos_b, sin_b = np.cos(bearings), np.sin(bearings)
    known = status != NONE
    for w in range(1, min(cfg.spike_width, n - 2) + 1):
        # a spike starts where the range rises by more than the jump: few places, so examine only
        # those (rows, first beam of the group)
        prev = np.roll(f, 1, axis=1)
        rows, first = np.nonzero((f > prev + cfg.spike_jump) & np.roll(known, 1, axis=1))
        if not full_circle:
            keep = (first >= 1) & (first + w <= n - 1)
            rows, first = rows[keep], first[keep]
        if rows.size == 0:
            continue
        lo, hi = (first - 1) % n, (first + w) % n
        inner = f[rows, first % n]
        for k in range(1, w):
            inner = np.minimum(inner, f[rows, (first + k) % n])
        flank = np.maximum(f[rows, lo], f[rows, hi])
        # the opening: the distance between the two neighbouring beams' endpoints
        ax, ay = f[rows, lo] * cos_b[rows, lo], f[rows, lo] * sin_b[rows, lo]
        bx, by = f[rows, hi] * cos_b[rows, hi], f[rows, hi] * sin_b[rows, hi]
        spike = known[rows, hi] & (inner > flank + cfg.spike_jump) & (np.hypot(ax - bx, ay - by) < cfg.min_gap)
        if not spike.any():
            continue
        rows, first, lo, hi, flank = rows[spike], first[spike], lo[spike], hi[spike], flank[spike]
        ax, ay = ax[spike], ay[spike]
        # the spike ends where the surface between its two neighbours lies: on the segment joining
        # their endpoints (the glass pane, the gap's edge), not at the farther neighbour's range
        ex, ey = bx[spike] - ax, by[spike] - ay
        for k in range(w):
            j = (first + k) % n
            dx, dy = cos_b[rows, j], sin_b[rows, j]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (ax * ey - ay * ex) / (dx * ey - dy * ex)
            t = np.where(np.isfinite(t) & (t > 0), t, np.minimum(f[rows, lo], f[rows, hi]))
            f[rows, j] = np.minimum(f[rows, j], np.minimum(t, flank))
            st[rows, j] = CLIPPED
    return f, st
