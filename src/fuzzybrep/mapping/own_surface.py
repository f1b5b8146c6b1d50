"""A beam's own surface: how far in front of its return the cells it ends on reach along it.

The evidence (``evidence.clip``) stops a beam at the first occupied cell in front of its own end;
the cells of the surface it ended on are not in front of it. How far back along the beam they
reach depends on the angle at which the beam meets the surface.
"""

from __future__ import annotations

import numpy as np

from ..scans.filters import DepthJump, depth_continuous


def own_margins(b, margin: float, incidence: float, jump=None) -> np.ndarray:
    """How far in front of its own end each ray's own surface reaches along it: ``margin`` across
    the surface, so margin / sin β along a beam meeting it at incidence β ≥ ``incidence``.

    A wall is a band of hit cells some centimetres thick (range noise, pose error between passes,
    the cells themselves), which a beam meeting it at incidence β runs through for margin / sin β
    before its own end. With a margin fixed along the beam, the wall's own cells stopped such
    beams short, and along a wall the robot drove beside (freiburg-campus) the free space came
    out as a comb of teeth 0.2-0.6 m short of the wall: held-out returns on the wall lay beyond
    the map. β comes from the beam's neighbours in its scan that see the same surface (the
    adaptive depth-jump test), the steeper of the two sides (the shorter margin); a beam with no
    such neighbour keeps ``margin``. What stands off the surface by more than ``margin`` still
    stops the beam: within margin / sin β of its end a beam is never farther than margin from
    the line its returns lie on."""
    jump = jump or DepthJump()
    n = len(b.length)
    out = np.full(n, margin)
    if n < 2 or incidence >= np.pi / 2:
        return out
    r = np.where(b.hit, b.hit_range, np.nan)
    ox, oy = b.ox, b.oy
    px, py = ox + r * b.cos, oy + r * b.sin
    # ray i and i + 1 are neighbours in one scan: one origin and time (rays held one by one
    # carry no per_scan), and not across per_scan's boundaries
    t = b.time
    same = (ox[:-1] == ox[1:]) & (oy[:-1] == oy[1:]) & (t[:-1] == t[1:])
    if b.per_scan is not None:
        last = np.cumsum(b.per_scan)[:-1] - 1  # each scan's last ray (a scan of no rays has none)
        same[last[(last >= 0) & (last < n - 1)]] = False
    step = np.abs(np.arcsin(np.clip(b.cos[:-1] * b.sin[1:] - b.sin[:-1] * b.cos[1:], -1, 1)))
    ok = same & b.hit[:-1] & b.hit[1:]
    ok[ok] = depth_continuous(r[:-1][ok], r[1:][ok], step[ok], jump)
    tx, ty = px[1:] - px[:-1], py[1:] - py[:-1]
    length = np.hypot(tx, ty)
    ok &= length > 0
    # sin β of the chord to the next return, seen from ray i and from ray i + 1
    sin_here = np.zeros(n - 1)
    sin_next = np.zeros(n - 1)
    sin_here[ok] = np.abs(b.cos[:-1][ok] * ty[ok] - b.sin[:-1][ok] * tx[ok]) / length[ok]
    sin_next[ok] = np.abs(b.cos[1:][ok] * ty[ok] - b.sin[1:][ok] * tx[ok]) / length[ok]
    best = np.full(n, -1.0)
    best[:-1] = np.where(ok, sin_here, -1.0)
    best[1:] = np.maximum(best[1:], np.where(ok, sin_next, -1.0))
    has = best >= 0
    out[has] = margin / np.maximum(best[has], np.sin(incidence))
    return out
