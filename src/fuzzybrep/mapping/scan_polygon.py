"""Scan polygons: the free space each scan saw, as vertex and edge tables (thesis 3.2.1).

Lines are extracted from runs of consecutive returns (no depth jump between them) and ordered by
the scan index of their points; consecutive lines meet at a vertex (thesis 3.2.1.2). Between runs
the boundary follows the rays: where the range jumps, the wedge between the two beams is free
only up to the nearer range, so an occluding object, a doorway or a no-return gap never fans out
into free space the scan did not see. An isolated long beam (a spike through glass) thereby adds
nothing.

Every vertex lies on a beam's ray or, for a corner, between the rays of its two lines, in order
of bearing: each polygon is star-shaped around its sensor and so always simple. A 180° scan
includes the sensor as its apex; a 360° scan does not.

All scans are processed together: their beams are laid end to end in flat arrays, every vertex
gets a sort key (its beam's position plus a fraction for its place on that beam), and one sort
puts every polygon's vertices in order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..arrays import spans
from ..brep import FRONTIER, OBSTACLE, Ring
from ..scans.filters import CLIPPED, NONE, RETURN, DepthJump, depth_continuous
from ..scans.scan import Scan
from .lines import LineConfig, Lines, extract, intersect, tolerance

# where on its beam a vertex sits, as a fraction added to the beam's position: the boundary
# reaches the beam (A), starts a line (S), has a single point (P), ends a line (E), leaves (C)
_A, _S, _P, _E, _C = 0.1, 0.3, 0.5, 0.7, 0.9
_APEX, _CORNER = -0.05, -0.5  # before the scan's first beam; between a beam and the previous one


@dataclass(frozen=True)
class PolygonConfig:
    lines: LineConfig = field(default_factory=LineConfig)
    jump_angle: float = DepthJump.jump_angle  #: λ of the adaptive depth-jump test (Borges & Aldon)
    jump_floor: float = DepthJump.jump_floor  #: depth-jump allowance added to the geometric one (3σ of range noise)
    #: lines meeting at less than this get no shared vertex (15° left 10-15° bends 4-5 cm off their
    #: walls; a far-off intersection of near-parallel lines fails the nearness tests anyway)
    corner_angle: float = np.radians(5.0)
    corner_bridge: int = 2  #: stray single points between two lines that a corner may replace
    clearance: float = 0.05  #: free range kept along unknown beams (the sensor's own body)
    #: the robot's footprint, a disc of this radius about the laser (map unit; 0: none): where the
    #: robot stood is free by fact, not by beams. Behind the laser, outside its field of view, the
    #: disc is free; in front, every beam is free up to the disc or its own return if nearer
    footprint: float = 0.3


@dataclass(frozen=True)
class ScanPolygon:
    """A scan polygon in world coordinates, with the lines it was built from (sensor frame)."""

    ring: Ring
    lines: Lines


def scan_polygon(scan: Scan, free: np.ndarray, status: np.ndarray, cfg: PolygonConfig = PolygonConfig()) -> ScanPolygon:
    """The scan polygon of one scan given each beam's free range and status (see scan_polygons)."""
    return scan_polygons([scan], [free], [status], cfg)[0]


def scan_polygons(
    scans: Sequence[Scan], free: Sequence[np.ndarray], status: Sequence[np.ndarray], cfg: PolygonConfig = PolygonConfig()
) -> list[ScanPolygon]:
    """The scan polygon of every scan.

    free   per scan, (n,) how far each beam's ray is free (the range for a return; less where
           evidence or a filter shortened it; the usable maximum for a far beam; nothing for no
           return: ``clearance`` is kept so that every polygon has area). Every beam is free at least
           up to the robot's ``footprint`` or its own return, whichever is nearer.
    status per scan, (n,) RETURN, CLIPPED, FAR or NONE. Lines are fitted to RETURN beams only.
    """
    B = _Beams(scans, free, status, cfg)
    lines = extract(B.pts, B.f, B.runs, cfg.lines)
    keys, xy, kinds = B.vertices(lines)
    o = np.argsort(keys, kind="stable")
    keys, xy, kinds = keys[o], xy[o], kinds[o]
    scan_of = np.searchsorted(B.offsets, np.floor(keys - _APEX), side="right") - 1
    # drop repeated vertices (zero-length edges) within each ring; the later one's edge is kept
    bounds = np.searchsorted(scan_of, np.arange(len(scans) + 1))
    nxt = np.arange(len(keys)) + 1
    ends = bounds[1:] - 1
    nxt[ends] = bounds[:-1]
    keep = np.any(np.abs(xy - xy[np.minimum(nxt, len(xy) - 1)]) > 1e-12, axis=1)
    # to world coordinates
    pose = B.poses[scan_of]
    ct, st = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    world = np.column_stack((pose[:, 0] + ct * xy[:, 0] - st * xy[:, 1], pose[:, 1] + st * xy[:, 0] + ct * xy[:, 1]))
    # each scan's share of the vertices and lines, its lines counted from its own first beam:
    # worked out for all scans at once, so that the loop only cuts slices
    world, kinds = world[keep], kinds[keep]
    bounds = np.r_[0, np.cumsum(keep)][bounds]
    line_bounds = np.searchsorted(lines.start, B.offsets)
    first = np.repeat(B.offsets[:-1], np.diff(line_bounds))
    start, stop = lines.start - first, lines.stop - first
    out = []
    for k in range(len(scans)):
        v, w = bounds[k], bounds[k + 1]
        lo, hi = line_bounds[k], line_bounds[k + 1]
        own = Lines(start[lo:hi], stop[lo:hi], lines.theta[lo:hi], lines.rho[lo:hi])
        out.append(ScanPolygon(Ring(world[v:w], kinds[v:w]), own))
    return out


class _Beams:
    """The beams of all scans end to end, with wedges, staircase ranges and runs."""

    def __init__(self, scans: Sequence[Scan], free, status, cfg: PolygonConfig):
        self.cfg = cfg
        counts = np.array([len(s.bearings) for s in scans], np.int64)
        self.offsets = np.concatenate(([0], np.cumsum(counts)))
        self.poses = np.array([s.pose for s in scans]).reshape(-1, 3)
        self.full = np.array([s.full_circle for s in scans], bool)
        n = int(self.offsets[-1])
        beta = np.concatenate([s.bearings for s in scans])
        f = np.maximum(np.concatenate([np.asarray(x, np.float64) for x in free]), cfg.clearance)
        if cfg.footprint > 0:
            # the robot stood here: nothing was within its footprint but what its own laser saw
            r = np.concatenate([s.ranges for s in scans])
            own = np.where((r > 0) & (r < np.repeat([s.max_range for s in scans], counts)), r, np.inf)
            f = np.maximum(f, np.minimum(cfg.footprint, own))
        st = np.concatenate([np.asarray(x) for x in status]).astype(np.int8)
        sid = np.repeat(np.arange(len(scans)), counts)
        first, last = self.offsets[:-1], self.offsets[1:] - 1
        is_first = np.zeros(n, bool)
        is_first[first] = True
        is_last = np.zeros(n, bool)
        is_last[last] = True
        # next and previous beam of the same scan (a 360° scan wraps around)
        nxt = np.arange(n) + 1
        nxt[last] = np.where(self.full, first, last)
        prv = np.arange(n) - 1
        prv[first] = np.where(self.full, last, first)
        half_end = is_last & ~self.full[sid]

        dbeta = beta[nxt] - beta
        dbeta[last] += 2 * np.pi
        typical = np.where(counts > 1, (beta[last] - beta[first]) / np.maximum(counts - 1, 1), np.pi)[sid]
        known = st != NONE
        # beams farther apart than the jump angle tell nothing about the surface between them
        cont = (depth_continuous(f, f[nxt], dbeta, cfg) & (dbeta < 2.5 * typical) & (dbeta < cfg.jump_angle)
                & known & known[nxt] & ~half_end)

        # a 360° scan starts right after a break, so that no run of beams wraps around
        for k in np.flatnonzero(self.full):
            sl = slice(first[k], last[k] + 1)
            c = cont[sl]
            if c.all():
                continue
            r = int(np.argmin(c)) + 1
            b = beta[sl]
            beta[sl] = np.concatenate((b[r:], b[:r] + 2 * np.pi))
            for arr in (f, st, cont):
                arr[sl] = np.roll(arr[sl], -r)
        self.beta, self.f, self.st, self.cont, self.sid = beta, f, st, cont, sid
        self.is_first, self.half_end = is_first, half_end
        self.cos_b, self.sin_b = np.cos(beta), np.sin(beta)
        self.pts = np.column_stack((f * self.cos_b, f * self.sin_b))

        # staircase: a wedge is free up to both its beams' ranges if continuous, else the nearer
        low = np.minimum(f, f[nxt])
        left = np.where(cont, f, low)  # range of wedge i on beam i
        right = np.where(cont, f[nxt], low)  # range of wedge i on beam i+1
        self.a = right[prv]  # range at which the boundary reaches beam i from the previous wedge
        self.c = left.copy()  # range at which it leaves beam i into the next wedge
        half_start = is_first & ~self.full[sid]
        # the fan's two edge rays lead back to the apex: nothing beyond the outer wedges counts,
        # else the boundary would run out along the ray and back over itself
        self.a[half_start] = self.c[half_start]
        self.c[half_end] = self.a[half_end]
        seen = (st == RETURN) | (st == CLIPPED)
        self.wedge_kind = np.where(cont & seen & seen[nxt], OBSTACLE, FRONTIER).astype(np.uint8)

        # runs: consecutive returns on one surface (never across scans: cont is False there or
        # the run would start at a scan's first beam)
        ret = st == RETURN
        joined = ret & ret[prv] & cont[prv] & ~is_first
        starts = np.flatnonzero(ret & ~joined)
        ends_ = np.flatnonzero(ret & ~np.r_[joined[1:], False]) + 1
        self.runs = np.column_stack((starts, ends_)).astype(np.int64)
        self.tol = tolerance(f, cfg.lines)

    def vertices(self, lines: Lines):
        """Every vertex of every polygon: sort keys, sensor-frame coordinates, outgoing edge kinds."""
        keys, xs, ys, ks = [], [], [], []

        def add(key, x, y, kind):
            key = np.atleast_1d(np.asarray(key, np.float64))
            keys.append(key)
            xs.append(np.broadcast_to(x, key.shape))
            ys.append(np.broadcast_to(y, key.shape))
            ks.append(np.broadcast_to(np.asarray(kind, np.uint8), key.shape))

        def on_beam(key_frac, i, r, kind):
            add(i + key_frac, r * self.cos_b[i], r * self.sin_b[i], kind)

        eps = 1e-9
        half = np.flatnonzero(~self.full)
        self._behind(add, half)
        runs = self.runs
        long_run = runs[:, 1] - runs[:, 0] >= 2
        in_long = np.zeros(len(self.f), bool)
        lr = runs[long_run]
        in_long[spans(lr[:, 0], lr[:, 1] - lr[:, 0])] = True
        a, c, f, wk = self.a, self.c, self.f, self.wedge_kind
        # beams outside runs: where the boundary reaches the beam (a) and where it leaves it (c)
        b = np.flatnonzero(~in_long)
        step = b[np.abs(a[b] - c[b]) > eps]
        on_beam(_A, step, a[step], FRONTIER)
        on_beam(_C, b, c[b], wk[b])
        # runs: the staircase steps at their two ends, then their lines
        rs, re_ = lr[:, 0], lr[:, 1] - 1
        s_in = rs[a[rs] < f[rs] - eps]
        on_beam(_A, s_in, a[s_in], FRONTIER)
        out = c[re_] < f[re_] - eps
        on_beam(_C, re_[out], c[re_[out]], wk[re_[out]])
        last_kind = np.where(out, FRONTIER, wk[re_]).astype(np.uint8)
        if len(lines) and len(lr):
            self._line_vertices(add, lines, lr, last_kind)
        return np.concatenate(keys), np.column_stack((np.concatenate(xs), np.concatenate(ys))), np.concatenate(ks)

    def _behind(self, add, half: np.ndarray) -> None:
        """What closes a fan that is no full turn: the apex (the sensor itself), or with a
        ``footprint`` an arc of it behind the sensor, from the last beam's bearing round to the
        first's, a chord at most every 15°, all frontier (the robot's body, not seen)."""
        r = self.cfg.footprint
        if r <= 0 or not len(half):
            add(self.offsets[half] + _APEX, 0.0, 0.0, FRONTIER)
            return
        first, last = self.offsets[half], self.offsets[half + 1] - 1
        gap = self.beta[first] + 2 * np.pi - self.beta[last]
        k = np.maximum(2, np.ceil(gap / np.radians(15.0)).astype(np.int64) + 1)  # points on the arc, ends included
        j = np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)
        frac = j / np.repeat(k - 1, k)
        ang = np.repeat(self.beta[last], k) + frac * np.repeat(gap, k)
        # keys in [offset + _APEX, offset): after the previous scan's vertices, before the first beam's
        add(np.repeat(first, k) + _APEX + 0.04 * frac, r * np.cos(ang), r * np.sin(ang), FRONTIER)

    def _line_vertices(self, add, lines: Lines, runs: np.ndarray, last_kind: np.ndarray):
        """Each line's ends on its first and last beam, and corners where consecutive lines meet.

        Consecutive lines of one run share a corner vertex at their intersection (thesis
        3.2.1.2) when they meet at a real angle, between their middle beams, and close to their
        end points or to where the beam at the corner's bearing hit; otherwise each keeps its
        own end and a short edge joins them. Up to
        ``corner_bridge`` stray points between two lines (the beams right at a corner often fit
        neither) give way to the corner.
        """
        beta, pts, tol = self.beta, self.pts, self.tol
        run_of = np.searchsorted(runs[:, 0], lines.start, side="right") - 1
        inside = (run_of >= 0) & (lines.start < runs[np.maximum(run_of, 0), 1])
        start, stop, th, rh, run_of = lines.start[inside], lines.stop[inside], lines.theta[inside], lines.rho[inside], run_of[inside]
        is_line = np.isfinite(th)
        sx, sy = self._ray_points(th, rh, start)
        ex, ey = self._ray_points(th, rh, stop - 1)
        n = len(start)
        corner = np.zeros(n, bool)  # line k ends at a corner shared with a later line
        begins_at_corner = np.zeros(n, bool)
        dropped = np.zeros(n, bool)  # stray single points a corner replaces
        single = ~is_line
        for gap in range(1, self.cfg.corner_bridge + 2):
            # line k and line k + gap of one run, with only single points between them
            k = np.arange(n - gap)
            ok = is_line[k] & is_line[k + gap] & (run_of[k] == run_of[k + gap]) & ~corner[k] & ~begins_at_corner[k + gap]
            for m in range(1, gap):
                ok &= single[k + m]
            k = k[ok]
            if k.size == 0:
                continue
            x, y = intersect(th[k], rh[k], th[k + gap], rh[k + gap], self.cfg.corner_angle)
            i, j = stop[k] - 1, start[k + gap]  # last beam of the first line, first of the second
            with np.errstate(invalid="ignore"):
                bx = np.arctan2(y, x)
                bx = bx + 2 * np.pi * np.round((beta[j] - bx) / (2 * np.pi))
                near = np.maximum(4 * tol[j], 2 * np.hypot(*(pts[j] - pts[i]).T))
                # anywhere between the middle beams of the two lines: noise, and the merge of
                # stray points within the loose tolerance, may hand a few beams of one wall to
                # the other's line (at 0.25° several). A line's corner at its start stays before
                # its middle beam and the one at its end after it: the order holds.
                lo, hi = (start[k] + stop[k] - 1) // 2, (start[k + gap] + stop[k + gap] - 1) // 2
                near_ends = (np.hypot(x - pts[j, 0], y - pts[j, 1]) <= near) & (np.hypot(x - pts[i, 0], y - pts[i, 1]) <= near)
                good = (np.isfinite(x) & (bx >= beta[lo]) & (bx <= beta[hi])
                        & (near_ends | self._on_surface(x, y, bx, lo, hi)))
            k, x, y, j = k[good], x[good], y[good], j[good]
            corner[k] = True
            begins_at_corner[k + gap] = True
            for m in range(1, gap):
                dropped[k + m] = True
            add(j + _CORNER, x, y, OBSTACLE)
        # the last line of each run hands over to the staircase or the next wedge
        last = np.r_[run_of[1:] != run_of[:-1], True]
        end_kind = np.full(len(start), OBSTACLE, np.uint8)
        end_kind[last] = last_kind[run_of[last]]
        keep = single & ~dropped
        add(start[keep] + _P, sx[keep], sy[keep], end_kind[keep])
        s_ok = is_line & ~begins_at_corner
        add(start[s_ok] + _S, sx[s_ok], sy[s_ok], OBSTACLE)
        e_ok = is_line & ~corner
        add(stop[e_ok] - 1 + _E, ex[e_ok], ey[e_ok], end_kind[e_ok])

    def _on_surface(self, x, y, bx, lo, hi):
        """Is (x, y), at bearing bx between beams lo and hi of one run, where the scan saw a surface?

        The beam nearest to bx in bearing must have hit within twice the local beam spacing
        of it (or 4 × the line tolerance). This finds a corner whose lines took a few beams of
        each other's wall, so that neither line ends near it.
        """
        beta, pts, tol = self.beta, self.pts, self.tol
        lo0, hi0 = lo, hi
        ok = np.isfinite(bx)
        bx = np.where(ok, bx, beta[lo])
        while np.any(hi - lo > 1):  # bisection: beta[lo] <= bx <= beta[hi]
            m = (lo + hi) // 2
            up = beta[m] <= bx
            lo, hi = np.where(up, m, lo), np.where(up, hi, m)
        c = np.where(bx - beta[lo] <= beta[hi] - bx, lo, hi)
        # the local spacing of the hits, from the beams either side (within the two lines)
        before, after = np.maximum(c - 1, lo0), np.minimum(c + 1, hi0)
        spacing = np.maximum(np.hypot(*(pts[c] - pts[before]).T), np.hypot(*(pts[after] - pts[c]).T))
        near = np.maximum(4 * tol[c], 2 * spacing)
        return ok & (np.hypot(x - pts[c, 0], y - pts[c, 1]) <= near)

    def _ray_points(self, theta, rho, i):
        """Where each line crosses beam i's ray; the beam's own point if that is far off."""
        cos_b, sin_b, f, tol = self.cos_b, self.sin_b, self.f, self.tol
        with np.errstate(divide="ignore", invalid="ignore"):
            den = cos_b[i] * np.cos(theta) + sin_b[i] * np.sin(theta)
            t = rho / den
            bad = ~((np.abs(den) > 1e-6) & (t > 0) & (np.abs(t - f[i]) <= 3 * tol[i]))
        t = np.where(bad, f[i], t)
        return t * cos_b[i], t * sin_b[i]
