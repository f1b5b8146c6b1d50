"""Frontier fingers: free space along beams that no return bounds, narrower than the map can
vouch for, cut back to where it is wide enough.

Outdoors, beams pass between trees, hedges, railings and parked bikes and see nothing (or
something beyond the trusted range) for metres; other scans' obstacles then clip most of such a
wedge (``mapping.evidence``), and what stays free is a comb of thin fingers, each a few beams
wide, along every path: thousands of vertices and frontier edges that bound nothing. A finger
here is a run of beams that end in unknown (no return, or a return beyond the trusted range:
``NONE``, ``FAR``, or clipped by other scans' evidence where no return lies near the end: at the
line the evidence bridges between two obstacle cells) reaching beyond its neighbours. It is cut
back to the highest level at which the beams around it, as far as they reach at least that far,
span ``width`` or more: at level ℓ a run of k beams Δβ apart spans k·Δβ·ℓ. Beams that end at a
return, or at a return other scans saw, are never cut: what bounds an obstacle stays (cutting
those too took a point off freiburg-campus's held-out endpoints explained: at the tip of such a
finger lies an obstacle no other scan's free space reaches).

The level of each beam is found greedily: the run grows from the beam one neighbour at a time,
towards the farther-reaching one (the run of each length that reaches farthest), until it spans
``width``; a run that cannot (the scan's edge, ``max_beams``) leaves its beam as it was. Arrays
in, arrays out: (S, n) rows of scans with one beam count.
"""

from __future__ import annotations

import numpy as np

from .filters import FAR, NONE

#: widest run examined, in beams: at 1° a beam, a run of 64 spans 0.4 m from 0.36 m on
MAX_BEAMS = 64


def open_ended(status: np.ndarray) -> np.ndarray:
    """Beams whose free range ends in unknown by their own status: no return, or a return beyond
    the trusted range."""
    return (status == NONE) | (status == FAR)


def finger_levels(free: np.ndarray, open_end: np.ndarray, bearings: np.ndarray, width: float,
                  max_beams: int = MAX_BEAMS) -> np.ndarray:
    """(S, n) each beam's free range with the fingers narrower than ``width`` cut back (see the
    module's docstring); ``free``, ``bearings`` (S, n) rows of scans, ``open_end`` (S, n) the beams
    whose free range ends in unknown (``open_ended``, and beams the evidence clipped where no
    return lies near their end), the only ones cut."""
    free = np.asarray(free, dtype=np.float64)
    S, n = free.shape
    out = free.copy()
    if width <= 0 or n < 2:
        return out
    step = np.abs(np.median(np.diff(bearings, axis=1), axis=1))  # (S,) the beams' spacing
    # candidates: open-ended beams too narrow alone (a plateau's inner beams too: the run decides)
    row, col = np.nonzero(open_end & (free > 0) & (free * step[:, None] < width))
    if not row.size:
        return out
    lo, hi = col.copy(), col.copy()
    level = free[row, col]
    done = np.zeros(row.size, bool)
    reached = np.zeros(row.size, bool)
    for _ in range(max_beams - 1):
        act = np.flatnonzero(~done)
        if not act.size:
            break
        r, a, b = row[act], lo[act], hi[act]
        fl = np.where(a > 0, free[r, np.maximum(a - 1, 0)], -np.inf)
        fr = np.where(b < n - 1, free[r, np.minimum(b + 1, n - 1)], -np.inf)
        go_left = fl >= fr
        nxt = np.where(go_left, fl, fr)
        stuck = ~np.isfinite(nxt)
        lo[act] = np.where(go_left & ~stuck, a - 1, a)
        hi[act] = np.where(~go_left & ~stuck, b + 1, b)
        level[act] = np.where(stuck, level[act], np.minimum(level[act], nxt))
        ok = (hi[act] - lo[act] + 1) * step[r] * level[act] >= width
        reached[act] = ok
        done[act] = ok | stuck
    cut = reached & (level < free[row, col])
    out[row[cut], col[cut]] = level[cut]
    return out
