"""Is the alignment right? The aligned poses checked against the scans themselves.

A pose graph can converge to a map that is wrong (a loop closed in the wrong corridor, a front
end that lost its way where the odometry failed): its own residuals then say little, since the
edges that would object were outvoted. The scans cannot be outvoted. Where the robot passes a
place again, a return of one pass must not lie in space another pass saw through: a beam of scan
j that reached beyond the point (by more than ``margin``) says the point is free. A right map
has a few such returns (people, doors that opened or closed between passes, glass); a wrong
one has walls across the other passes' free space.

``check_alignment(scans, poses)`` takes every ``every``-th scan, pairs it with the scans of
other passes (at least ``min_gap`` scans away in time) whose poses lie within ``radius``, and
counts its returns within ``max_range`` that fall inside their free space. A scan is
*contradicted* when more than ``share`` of its returns do; a *failed span* is a run of checked
scans at least ``span`` long (in checked scans) where most are contradicted, allowing short gaps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.spatial import cKDTree

from ..scans.scan import Scan, wrap


@dataclass(frozen=True)
class CheckConfig:
    every: int = 5  #: check every this many scans
    radius: float = 3.0  #: other passes' scans whose poses lie this near (m)
    min_gap: int = 100  #: ... at least this many scans away
    neighbours: int = 4  #: at most this many of them
    max_range: float = 10.0  #: returns checked, and the other scans' beams trusted, to this range
    margin: float = 0.3  #: a return is in another scan's free space when its beam reached this much farther
    #: a scan with more of its returns so is contradicted: people and doors that moved between
    #: passes make 15 % common even at the corrected poses (fhw's crowd, intel), a third rare
    share: float = 0.35
    span: int = 5  #: a failed span has at least this many contradicted checked scans
    gap: int = 2  #: ... with at most this many uncontradicted ones between
    #: the check fails when more than this share of the checked scans are contradicted: at the
    #: corrected poses of the shared logs 0-2.1 % are (fhw's crowd the most), with poses
    #: --align got right on the raw logs 0.2-0.5 %; poses the benchmark's relations show wrong
    #: (0.25-2 m mean error) 6-18 %
    fail_share: float = 0.04


@dataclass
class AlignmentCheck:
    checked: np.ndarray  #: (C,) scan indices checked (those with another pass near)
    contradicted: np.ndarray  #: (C,) share of each one's returns inside other passes' free space
    spans: list[tuple[int, int]]  #: failed spans, first and last scan index
    config: CheckConfig

    @property
    def bad_share(self) -> float:
        """The share of the checked scans that are contradicted."""
        return float((self.contradicted > self.config.share).mean()) if len(self.contradicted) else 0.0

    @property
    def ok(self) -> bool:
        return self.bad_share <= self.config.fail_share

    def metadata(self) -> dict:
        return {"ok": self.ok, "checked": int(len(self.checked)), "contradicted": round(self.bad_share, 4),
                "median_share": round(self.median(), 4), "spans": [list(s) for s in self.spans]}

    def median(self) -> float:
        return float(np.median(self.contradicted)) if len(self.contradicted) else 0.0

    def describe(self, scans: Sequence[Scan] | None = None) -> str:
        """One line: the check's verdict, naming the spans that failed."""
        n = len(self.checked)
        bad = int((self.contradicted > self.config.share).sum())

        def name(k: int) -> str:
            if scans is not None and scans[k].source:
                return scans[k].source
            return f"scan {k + 1}"

        where = "; ".join(f"{name(a)} to {name(b)}" for a, b in self.spans[:5])
        more = f" and {len(self.spans) - 5} more" if len(self.spans) > 5 else ""
        if self.ok:
            local = f"; the passes disagree locally (doors, people, or a pose) at {where}{more}" if self.spans else ""
            return (f"alignment check passed: {bad} of {n} scans where the robot came back "
                    f"({100 * self.bad_share:.1f} %, at most {100 * self.config.fail_share:g} %) put over "
                    f"{100 * self.config.share:.0f} % of their returns in space another pass saw free{local}")
        return (f"alignment check FAILED: {bad} of {n} scans where the robot came back ({100 * self.bad_share:.1f} %, "
                f"at most {100 * self.config.fail_share:g} %) put over {100 * self.config.share:.0f} % of their returns "
                f"in space another pass saw free" + (f", in {len(self.spans)} span(s): {where}{more}" if self.spans else "")
                + "; the map is wrong there")


def _polar(scan: Scan, max_range: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(bearings (n,), ranges (n,), bearing step) of a scan's beams, a beam with no return reaching
    max_range (it saw nothing that near)."""
    r = np.where(scan.returns, np.minimum(scan.ranges, max_range), max_range)
    step = float(np.median(np.diff(scan.bearings))) if len(scan.bearings) > 1 else 0.0
    return scan.bearings, r, step


def check_alignment(scans: Sequence[Scan], poses: np.ndarray, config: CheckConfig = CheckConfig()) -> AlignmentCheck:
    """The check of the module docstring on ``poses`` (S, 3) of ``scans``."""
    cfg = config
    poses = np.asarray(poses, np.float64).reshape(-1, 3)
    n = len(scans)
    sel = np.arange(0, n, max(cfg.every, 1))
    tree = cKDTree(poses[sel, :2]) if len(sel) else None
    checked, shares = [], []
    polar: dict[int, tuple] = {}  # a scan is the other pass of several checked scans: its beams once
    for k in sel:
        s = scans[k]
        ok = s.returns & (s.ranges <= cfg.max_range)
        if ok.sum() < 10 or tree is None:
            continue
        near = sel[tree.query_ball_point(poses[k, :2], cfg.radius)]
        near = near[np.abs(near - k) >= cfg.min_gap]
        if not len(near):
            continue
        near = near[np.argsort(np.hypot(*(poses[near, :2] - poses[k, :2]).T))][: cfg.neighbours]
        c, si = math.cos(poses[k, 2]), math.sin(poses[k, 2])
        r, b = s.ranges[ok], s.bearings[ok]
        lx, ly = r * np.cos(b), r * np.sin(b)
        world = np.column_stack((poses[k, 0] + c * lx - si * ly, poses[k, 1] + si * lx + c * ly))
        seen_through = np.zeros(len(world), bool)
        for j in near:
            o = scans[j]
            d = world - poses[j, :2]
            rng = np.hypot(d[:, 0], d[:, 1])
            bearing = wrap(np.arctan2(d[:, 1], d[:, 0]) - poses[j, 2])
            if j not in polar:
                polar[j] = _polar(o, cfg.max_range)
            bj, rj, step = polar[j]
            if len(bj) < 2:
                continue
            idx = np.rint((bearing - bj[0]) / step).astype(np.int64)
            inside = (idx >= 0) & (idx < len(bj)) & (rng < cfg.max_range - cfg.margin)
            # the beam and both neighbours must reach beyond the point: a return on the edge of an
            # obstacle another beam grazed is not a contradiction
            lo = np.clip(idx - 1, 0, len(bj) - 1)
            hi = np.clip(idx + 1, 0, len(bj) - 1)
            mid = np.clip(idx, 0, len(bj) - 1)
            reach = np.minimum(np.minimum(rj[lo], rj[mid]), rj[hi])
            seen_through |= inside & (reach > rng + cfg.margin)
        checked.append(int(k))
        shares.append(float(seen_through.mean()))
    checked_a, shares_a = np.array(checked, np.int64), np.array(shares)
    return AlignmentCheck(checked_a, shares_a, _spans(checked_a, shares_a > cfg.share, cfg), cfg)


def _spans(checked: np.ndarray, bad: np.ndarray, cfg: CheckConfig) -> list[tuple[int, int]]:
    """Runs of at least ``span`` contradicted checked scans, bridging at most ``gap`` good ones."""
    spans, start, count, good_run, last_bad = [], None, 0, 0, None
    for c, b in zip(checked, bad):
        if b:
            if start is None:
                start, count = c, 0
            count += 1
            good_run, last_bad = 0, c
        elif start is not None:
            good_run += 1
            if good_run > cfg.gap:
                if count >= cfg.span:
                    spans.append((int(start), int(last_bad)))
                start, count = None, 0
    if start is not None and count >= cfg.span:
        spans.append((int(start), int(last_bad)))
    return spans
