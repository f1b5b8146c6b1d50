"""The order the scans were taken in, which the evidence ranks by (newer evidence wins).

A log's timestamps give that order only when they run forward. In real logs they often do not:
every one 0 (Freiburg campus, Örebro), one rounded value for many scans, two values, a few
negative ones and then 4.29e9 (a 32-bit millisecond counter wrapping). Ranked by such times,
every scan is as old as every other, nothing is ever seen to go, and no obstacle is cleared,
silently. Scans come in a log in the order they were taken, so where the timestamps cannot give
the order, the scans' order in the sequence does: their times become 0, 1, 2, ... (one per scan),
and a one-line note says so and why.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from .scan import Scan

#: timestamps are unusable when more than this share of consecutive scans carry the same one
REPEATED = 0.1
#: a step backwards longer than this many typical steps is a clock that ran back, not a scan
#: logged out of turn
BACK_STEPS = 10


def timestamp_problem(times: Sequence[float]) -> str | None:
    """Why ``times`` (one per scan, in scan order) cannot order the scans, or None if they can.

    They can when they run forward: at most ``REPEATED`` of the steps zero (a few ties, as two
    scans logged in one clock tick, are ordered by the sequence) and as few backwards, each by
    less than ``BACK_STEPS`` typical steps (Intel's log has 4 of its 909 steps back by up to
    0.9 s, scans 3.4 s apart, logged a little out of turn: the times order them), and no single
    step longer than all the others together (a clock that jumped).
    """
    t = np.asarray(times, dtype=np.float64)
    if len(t) < 2:
        return None
    if not np.isfinite(t).all():
        return f"{int((~np.isfinite(t)).sum())} timestamps are not finite"
    step = np.diff(t)
    if np.all(t == t[0]):
        return f"every timestamp is {t[0]:g}"
    back = int((step < 0).sum())
    typical = float(np.median(step[step > 0])) if (step > 0).any() else 0.0
    if back > REPEATED * len(step) or (back and -step.min() > BACK_STEPS * typical):
        k = int(np.argmax(step < 0))
        return (f"the timestamps run backwards {back} time{'s' if back > 1 else ''} (first at scan {k + 2}: "
                f"{t[k + 1]:.10g} after {t[k]:.10g})")
    ties = int((step == 0).sum())
    if ties > REPEATED * len(step):
        return f"{len(t)} scans share {len(np.unique(t))} distinct timestamps"
    k = int(np.argmax(step))
    if len(step) > 2 and step[k] > step.sum() - step[k]:
        return (f"the timestamps jump by {step[k]:.4g} s at scan {k + 2} ({t[k]:.10g} to {t[k + 1]:.10g}), more "
                f"than all the other scans span together")
    return None


def in_scan_order(scans: Sequence[Scan], name: str = "the scans") -> tuple[list[Scan], str | None]:
    """``scans`` with times that order them: as they are if their timestamps can (note None),
    else with times 0, 1, 2, ... in sequence order and a note naming ``name`` and what was wrong."""
    why = timestamp_problem([s.timestamp for s in scans])
    if why is None:
        return list(scans), None
    note = f"{name}: {why}, so the scans are taken to come in the order they were recorded (the evidence's " \
           f"newer-wins rule needs their order)"
    return [replace(s, timestamp=float(k)) for k, s in enumerate(scans)], note
