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

The spike filter handles what the thesis papered over by hand (5.2). A group of beams between a
depth jump away from the sensor and a jump back, all reaching more than ``spike_jump`` beyond
the segment joining the two near endpoints, where those endpoints are less than ``min_gap``
apart, has passed through glass, a doorway or a gap: the space behind was seen only as a fan of
rays through the opening. Its free
range is cut back to the segment joining the two neighbours' endpoints (the pane, the doorway),
so the map gets no needle or fan of free space; a room is mapped from inside, or from where its
opening looks wider than ``min_gap`` (1 m: a door). The data are never edited: only how far each
beam's free space reaches.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..arrays import spans
from .scan import Scan

#: beam status
RETURN, CLIPPED, FAR, NONE = 0, 1, 2, 3


@dataclass(frozen=True)
class DepthJump:
    """The adaptive breakpoint test's parameters, shared by the spike filter and the scan polygons
    (``mapping.scan_polygon.PolygonConfig`` carries the same two fields)."""

    jump_angle: float = np.radians(10.0)  #: λ of the adaptive depth-jump test (Borges & Aldon)
    jump_floor: float = 0.05  #: depth-jump allowance added to the geometric one (3σ of range noise)


def depth_continuous(f0: np.ndarray, f1: np.ndarray, dbeta: np.ndarray, cfg: DepthJump) -> np.ndarray:
    """True where neighbouring beams (ranges f0, f1, dbeta apart) see one surface.

    The adaptive breakpoint test: the largest range change a surface at incidence angle
    ``jump_angle`` can make over one beam step, plus the noise floor.
    """
    r = np.minimum(f0, f1)
    limit = r * np.sin(dbeta) / np.sin(np.maximum(cfg.jump_angle - dbeta, 1e-6)) + cfg.jump_floor
    return np.abs(f0 - f1) <= limit


@dataclass(frozen=True)
class BeamConfig:
    max_usable: float = 8.0  #: longest range whose free space is trusted (LMS200: 8 m in mm mode)
    no_return_free: float = 0.0  #: free range claimed along a beam with no return
    #: a beam with no return claims free space up to the segment joining the endpoints of the
    #: nearest beams either side that saw something (``chord_claims``)
    no_return_chord: bool = True
    #: no chord claim reaches farther than this share of the sensor's maximum range: near it, a
    #: beam with no return may have just missed the surface its neighbours hit, and there the
    #: pose's angular error (2° is 0.28 m at 8 m) puts such claims through walls
    chord_reach: float = 0.5
    spike_width: int = 180  #: widest opening examined, in beams (a bound on work only)
    spike_jump: float = 0.5  #: beams through an opening reach at least this far (map unit) beyond it
    min_gap: float = 1.0  #: openings narrower than this (map unit: a door) let no free space through
    max_pairs: int = 6  #: jumps back tried for each jump away


def classify(scan: Scan, cfg: BeamConfig = BeamConfig(),
             polygon: DepthJump = DepthJump()) -> tuple[np.ndarray, np.ndarray]:
    """(free, status) of every beam of one scan, before any evidence from other scans."""
    return classify_all([scan], cfg, polygon)[0]


_ROWS = 512  # scans filtered together (classify_all)


def classify_all(scans: Sequence[Scan], cfg: BeamConfig = BeamConfig(),
                 polygon: DepthJump = DepthJump()) -> list[tuple[np.ndarray, np.ndarray]]:
    """(free, status) of every beam of every scan; scans with the same beam count go together.

    polygon: the depth-jump test's parameters (``DepthJump``, or the scan polygons' configuration,
    whose test the spike filter shares).
    """
    out: list = [None] * len(scans)
    groups: dict[tuple[int, bool], list[int]] = {}
    for k, s in enumerate(scans):
        groups.setdefault((len(s.ranges), s.full_circle), []).append(k)
    # rows of at most _ROWS scans: the spike filter's temporaries are some ten times the ranges
    # (182 MB for Freiburg's 4791 scans at once), and rows are filtered each on its own
    parts = [(full, idx[lo : lo + _ROWS]) for (_, full), idx in groups.items() for lo in range(0, len(idx), _ROWS)]
    for full, idx in parts:
        n = len(scans[idx[0]].ranges)
        r = np.stack([scans[k].ranges for k in idx])
        mr = np.array([scans[k].max_range for k in idx])[:, None]
        ret = (r < mr) & (r > 0)
        status = np.where(ret, np.where(r > cfg.max_usable, FAR, RETURN), NONE).astype(np.int8)
        free = np.where(status == RETURN, r, np.where(status == FAR, cfg.max_usable, min(cfg.no_return_free, cfg.max_usable)))
        b = np.stack([scans[k].bearings for k in idx])
        if cfg.spike_width > 0 and n >= 3:
            free, status = despike(free, status, b, cfg, full, polygon)
        if cfg.no_return_chord:
            reach = np.minimum(cfg.chord_reach * mr, cfg.max_usable)
            free = np.where(status == NONE, np.maximum(free, np.minimum(chord_claims(free, status, b, full), reach)),
                            free)
        for j, k in enumerate(idx):
            out[k] = (free[j], status[j])
    return out


def chord_claims(free: np.ndarray, status: np.ndarray, bearings: np.ndarray, full_circle: bool = False) -> np.ndarray:
    """(S, n) how far each beam with no return may claim free space: up to the segment joining
    the ends of the nearest beams on either side that saw something (a return, a far return, or
    a beam the spike filter cut back to an opening), 0 where one side has none (the edges of a
    fan) or the segment is not in front of the beam (the two lie half a turn or more apart).

    Nothing answered such a beam within the sensor's range: the sky outdoors, an open plaza, a
    pane of glass. Claiming its whole range would fan free space out through glass; claiming
    nothing leaves a wedge of unknown with its tip at the robot, along every path the robot
    drove outdoors (a quarter of Freiburg campus's beams return nothing). Its neighbours saw
    the space up to their ends free, and the segment between those ends is as far as the beam
    itself can be vouched for by them: up to the pane between two returns off its frame, up to
    the line between two trees. The wider the gap, the nearer the segment passes the sensor, and
    a gap of half a turn claims nothing. The claims are checked against every other scan's
    evidence like any beam's (``mapping.evidence``: they stop at obstacles other scans saw, and
    at the line between two obstacle cells less than ``no_return_bridge`` apart).
    """
    S, n = free.shape
    anchor = status != NONE
    f, b = free, bearings
    if full_circle:  # the neighbours of a 360° scan's first beams may be its last ones, a turn back
        f = np.concatenate((free, free, free), axis=1)
        b = np.concatenate((bearings - 2 * np.pi, bearings, bearings + 2 * np.pi), axis=1)
        anchor = np.concatenate((anchor, anchor, anchor), axis=1)
    m = f.shape[1]
    idx = np.broadcast_to(np.arange(m), (S, m))
    prev = np.maximum.accumulate(np.where(anchor, idx, -1), axis=1)
    nxt = np.minimum.accumulate(np.where(anchor, idx, m)[:, ::-1], axis=1)[:, ::-1]
    ok = ~anchor & (prev >= 0) & (nxt < m)
    rows = np.broadcast_to(np.arange(S)[:, None], (S, m))
    p, q = np.where(ok, prev, 0), np.where(ok, nxt, 0)
    fl, fr, bl, br = f[rows, p], f[rows, q], b[rows, p], b[rows, q]
    span = br - bl
    with np.errstate(divide="ignore", invalid="ignore"):
        # the segment from (fl, bl) to (fr, br) in polar form, at bearing b
        den = fl * np.sin(b - bl) + fr * np.sin(br - b)
        r = fl * fr * np.sin(span) / den
    claim = np.where(ok & (span < np.pi) & (den > 0) & np.isfinite(r), np.minimum(r, np.minimum(fl, fr)), 0.0)
    return claim[:, n:2 * n] if full_circle else claim


def despike(free: np.ndarray, status: np.ndarray, bearings: np.ndarray, cfg: BeamConfig, full_circle: bool = False,
            polygon: DepthJump = DepthJump()):
    """Cut back the beams that passed through a narrow opening (see the module doc).

    free, status, bearings: (S, n) arrays, one row per scan. With ``full_circle`` (360° scans) the
    last beam neighbours the first, so an opening may straddle the seam: the first beams are
    appended once more, a full turn on, and what is cut there folds back onto them.
    """
    n = free.shape[1]
    if not full_circle:
        return _despike(free, status, bearings, cfg, polygon)
    m = min(cfg.spike_width + 1, n)  # an opening of spike_width beams and its far flank
    f, st = _despike(np.concatenate((free, free[:, :m]), axis=1), np.concatenate((status, status[:, :m]), axis=1),
                     np.concatenate((bearings, bearings[:, :m] + 2 * np.pi), axis=1), cfg, polygon)
    out_f, out_st = f[:, :n].copy(), st[:, :n].copy()
    wrapped = f[:, n:] < out_f[:, :m]
    out_f[:, :m] = np.where(wrapped, f[:, n:], out_f[:, :m])
    out_st[:, :m] = np.where(wrapped, st[:, n:], out_st[:, :m])
    return out_f, out_st


def _despike(free: np.ndarray, status: np.ndarray, bearings: np.ndarray, cfg: BeamConfig,
             polygon: DepthJump):
    """The spike filter on rows of beams in order, the first and last without neighbours.

    free, status, bearings: (S, n) arrays, one row per scan. An opening runs from a depth jump
    away from the sensor (beam lo near, lo + 1 far) to a later jump back (hi - 1 far, hi near),
    the same test that splits scan polygons (with ``polygon``, their configuration). It is narrow
    if lo's and hi's endpoints are less than ``min_gap`` apart and every beam between reaches at
    least ``spike_jump`` beyond the segment joining them; such beams are cut back to that segment.
    Up to ``max_pairs`` jumps back are tried for each jump away, the nearest first; openings wider
    than ``spike_width`` beams are not examined.
    """
    S, n = free.shape
    f = free.copy()
    st = status.copy()
    known = status != NONE
    cos_b, sin_b = np.cos(bearings), np.sin(bearings)
    x, y = f * cos_b, f * sin_b
    db = np.diff(bearings, axis=1)
    # the flanks must be returns (they bound the opening); the beams through it are any that claim
    # free space, a no-return beam with ``no_return_free`` included
    reach = f > 0
    cont = depth_continuous(f[:, :-1], f[:, 1:], db, polygon) & reach[:, :-1] & reach[:, 1:]
    away = ~cont & known[:, :-1] & reach[:, 1:] & (f[:, 1:] > f[:, :-1])  # lo = i, first beam of the group i + 1
    back = ~cont & reach[:, :-1] & known[:, 1:] & (f[:, :-1] > f[:, 1:])  # hi = j + 1, last beam of the group j
    ra, ia = np.nonzero(away)
    rb, jb = np.nonzero(back)
    if ra.size == 0 or rb.size == 0:
        return f, st
    key_b = rb * (n + 1) + jb
    start_b = np.searchsorted(key_b, ra * (n + 1) + ia + 1)
    done = np.zeros(ra.size, bool)
    cut_rows, cut_cols, cut_t = [], [], []
    for k in range(cfg.max_pairs):
        c = np.flatnonzero(~done & (start_b + k < key_b.size))
        if c.size == 0:
            break
        q = start_b[c] + k
        same = rb[q] == ra[c]
        c, q = c[same], q[same]
        lo, hi = ia[c], jb[q] + 1
        w = hi - lo - 1
        ok = (w >= 1) & (w <= cfg.spike_width)
        row = ra[c]
        ax, ay, bx, by = x[row, lo], y[row, lo], x[row, hi], y[row, hi]
        ok &= np.hypot(ax - bx, ay - by) < cfg.min_gap
        # lo to hi must turn less than half a circle: an opening is seen from one side of it. Edges
        # opposite each other (standing in a doorway) put the sensor on the segment, where the test
        # below would decide on rounding noise; wider openings always have beams with t < 0.
        ok &= ax * by - ay * bx > 1e-9 * np.hypot(ax, ay) * np.hypot(bx, by)
        c, row, lo, w, ax, ay, bx, by = c[ok], row[ok], lo[ok], w[ok], ax[ok], ay[ok], bx[ok], by[ok]
        if c.size == 0:
            continue
        # every beam between must reach beyond the segment lo-hi by spike_jump
        owner = np.repeat(np.arange(c.size), w)
        cols = spans(lo + 1, w)
        rr = row[owner]
        ex, ey = (bx - ax)[owner], (by - ay)[owner]
        dx, dy = cos_b[rr, cols], sin_b[rr, cols]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (ax[owner] * ey - ay[owner] * ex) / (dx * ey - dy * ex)
        beyond = np.isfinite(t) & (t > 0) & (f[rr, cols] > t + cfg.spike_jump)
        all_beyond = np.bincount(owner, ~beyond, c.size) == 0
        keep = all_beyond[owner]
        cut_rows.append(rr[keep])
        cut_cols.append(cols[keep])
        cut_t.append(t[keep])
        done[c[all_beyond]] = True
    if cut_rows:
        rr, cc, tt = np.concatenate(cut_rows), np.concatenate(cut_cols), np.concatenate(cut_t)
        np.minimum.at(f, (rr, cc), tt)
        st[rr, cc] = CLIPPED
    return f, st
