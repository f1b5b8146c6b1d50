"""Line extraction from one scan's points, lines ordered by the scan index of their points.

Two extractors share one output (``Lines``):

* ``hough_lines``: the thesis's Hough transform (3.2.1.1). The accumulator holds
  ρ_j(θ) = x_j cos θ + y_j sin θ for θ on a grid over [0°, 180°) (Table 3.3). Starting from an
  anchor point a (the first point not yet on a line), point j lies on a line with a if
  |ρ_j(θ) − ρ_a(θ)| ≤ τ for some θ of the grid, where τ is about 1% of the anchor's ρ (never
  below a noise floor); the line is the longest run of consecutive points sharing one θ. If no
  line of ``min_points`` is found the tolerance is relaxed (doubled, then doubled again).
  Scanning the accumulator column by column is exact but slow; the same answer comes in closed
  form: point j is within τ of the anchor's line at θ exactly when θ lies within
  asin(τ / |p_j − p_a|) of the normal direction of p_a→p_j, so a run of points shares a θ when
  the intersection of their intervals holds a grid angle. That is evaluated for every anchor at
  once with cumulative max/min; ``hough_accumulator`` keeps the explicit table for checking.
* ``iepf_lines``: iterative end-point fit (split at the farthest point until every point is
  within τ of its chord): what most practitioners use, and the comparison the Hough must stand.

Either way single points left next to a line and within its tolerance join it (the merge step
of split-and-merge: the beams right at a corner often fit neither wall at first), and each line
is refitted by total least squares on its points, so its accuracy does not depend on the θ grid
step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arrays import spans


@dataclass(frozen=True)
class LineConfig:
    method: str = "hough"  #: "hough" or "iepf"
    theta_step: float = 1.0  #: Hough θ grid step, degrees
    tol_rel: float = 0.01  #: tolerance as a fraction of range ("about 1% of ρ")
    tol_min: float = 0.03  #: noise floor of the tolerance (map unit)
    relax: tuple[float, ...] = (1.0, 2.0, 4.0)  #: tolerance factors tried in turn
    min_points: int = 4  #: points for a line; fewer stay as single vertices
    window: int = 16  #: points examined at once from an anchor (longer lines are then extended)

    def __post_init__(self):
        if self.method not in ("hough", "iepf"):
            raise ValueError(f"line extraction method must be 'hough' or 'iepf', not {self.method!r}")
        if not 0 < self.theta_step <= 45:
            raise ValueError(f"theta_step must be in (0, 45] degrees, got {self.theta_step}")
        if self.tol_min <= 0 or self.tol_rel < 0:
            raise ValueError("tolerances must be positive")
        if self.min_points < 3:
            raise ValueError("min_points must be at least 3")


@dataclass(frozen=True)
class Lines:
    """Lines of one scan in scan order: points start[k]..stop[k]-1 lie on line k.

    theta, rho: normal form x cos θ + y sin θ = ρ with θ in [0, π) (total least squares fit);
    NaN for single points that belong to no line.
    """

    start: np.ndarray
    stop: np.ndarray
    theta: np.ndarray
    rho: np.ndarray

    def __len__(self) -> int:
        return len(self.start)

    @property
    def is_line(self) -> np.ndarray:
        return np.isfinite(self.theta)


def hough_accumulator(points: np.ndarray, theta_step: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """θ grid (radians) and the accumulator ρ_j(θ) for every point and θ (Table 3.3)."""
    theta = np.radians(np.arange(0.0, 180.0, theta_step))
    p = np.asarray(points, dtype=np.float64)
    return theta, p[:, :1] * np.cos(theta) + p[:, 1:2] * np.sin(theta)


def tolerance(ranges: np.ndarray, cfg: LineConfig) -> np.ndarray:
    return np.maximum(cfg.tol_rel * ranges, cfg.tol_min)


def anchored_runs(points: np.ndarray, run_stop: np.ndarray, tol: np.ndarray, theta_step: float, window: int,
                  anchors: np.ndarray | None = None):
    """For each anchor a: how many consecutive points from a share one grid θ, and that θ.

    Returns (length, theta) per anchor (all points unless ``anchors`` is given); length counts
    the anchor itself and is at most ``window``.
    """
    a = np.arange(len(points)) if anchors is None else np.asarray(anchors)
    n = len(a)
    step = np.radians(theta_step)
    j = a[:, None] + np.arange(1, window)[None, :]
    valid = j < run_stop[a][:, None]
    j = np.minimum(j, len(points) - 1)
    dx = points[j, 0] - points[a, None, 0]
    dy = points[j, 1] - points[a, None, 1]
    d = np.hypot(dx, dy)
    psi = np.arctan2(dy, dx) + np.pi / 2  # normal direction of the line anchor -> p_j
    ta = tol[a][:, None]
    with np.errstate(divide="ignore"):
        half = np.arcsin(np.minimum(ta / d, 1.0))
    # unwrap every interval (they live modulo π) next to a reference: the first point far enough
    # from the anchor to constrain θ
    far = (d > 2 * ta) & valid
    ref = psi[np.arange(n), np.argmax(far, axis=1)]
    psi = ref[:, None] + (psi - ref[:, None] + np.pi / 2) % np.pi - np.pi / 2
    lo = np.maximum.accumulate(np.where(valid, psi - half, np.inf), axis=1)
    hi = np.minimum.accumulate(np.where(valid, psi + half, -np.inf), axis=1)
    eps = 1e-9
    k_lo, k_hi = np.ceil(lo / step - eps), np.floor(hi / step + eps)
    ok = k_lo <= k_hi
    count = np.where(ok.all(axis=1), ok.shape[1], np.argmin(ok, axis=1))
    last = np.maximum(count - 1, 0)
    rows = np.arange(n)
    l_lo, l_hi = lo[rows, last], hi[rows, last]
    with np.errstate(invalid="ignore"):
        kmid = np.clip(np.round((l_lo + l_hi) / 2 / step), k_lo[rows, last], k_hi[rows, last])
    theta = np.where(count > 0, kmid * step, np.nan) % np.pi
    return 1 + count, theta


def hough_lines(points: np.ndarray, ranges: np.ndarray, runs: np.ndarray, cfg: LineConfig = LineConfig(),
                run_stop: np.ndarray | None = None) -> Lines:
    """Lines by the anchored Hough transform (see module doc), for every run at once.

    points (n, 2), ranges (n,), runs (k, 2): [start, stop) index ranges of consecutive points
    that may share a line (no depth jump or gap between them). Points may belong to many scans:
    lines never cross a run's ends. Each run is a chain: its first line starts at its first
    point, every next line at the first point after the previous one. All runs advance together,
    one line per step. run_stop: ``run_ends(runs, n)`` if the caller has it already.
    """
    n = len(points)
    runs = np.asarray(runs, np.int64).reshape(-1, 2)
    if n == 0 or len(runs) == 0:
        return _empty()
    if run_stop is None:
        run_stop = run_ends(runs, n)
    tol0 = tolerance(ranges, cfg)
    window = int(max(2, min(cfg.window, np.max(runs[:, 1] - runs[:, 0]))))
    cursor, end = runs[:, 0].copy(), runs[:, 1]
    out_start, out_stop = [], []
    active = np.flatnonzero(cursor < end)
    while active.size:
        a, e = cursor[active], end[active]
        length = np.ones(len(a), np.int64)
        factor = np.zeros(len(a))
        pending = e - a >= cfg.min_points
        for f in cfg.relax:  # "relaxed when no line is found"
            idx = np.flatnonzero(pending)
            if idx.size == 0:
                break
            L, _ = anchored_runs(points, run_stop, tol0 * f, cfg.theta_step, window, a[idx])
            take = L >= cfg.min_points
            length[idx[take]], factor[idx[take]] = L[take], f
            pending[idx[take]] = False
        length = np.minimum(length, e - a)
        for i in np.flatnonzero((length == window) & (a + length < e)):
            # a long wall: keep growing the line along its refitted direction
            length[i] = _extend(points, int(a[i]), int(a[i] + length[i]), int(e[i]), tol0[a[i]] * factor[i])
        length = np.where(length >= cfg.min_points, length, 1)
        out_start.append(a)
        out_stop.append(a + length)
        cursor[active] = a + length
        active = active[cursor[active] < end[active]]
    start = np.concatenate(out_start)
    stop = np.concatenate(out_stop)
    order = np.argsort(start, kind="stable")
    return fit_lines(points, start[order], stop[order], cfg.min_points)


def _extend(points: np.ndarray, a: int, b: int, e: int, tol: float) -> int:
    """Grow a line [a, b) along a long wall: refit, then take the following points within tol."""
    while b < e:
        p = points[a:b]
        c = np.add.reduce(p, axis=0) / (b - a)  # p.mean(axis=0) without its wrapper: run very often
        d = p - c
        # total least squares: the normal is the direction of least spread
        phi = 0.5 * np.arctan2(2 * np.dot(d[:, 0], d[:, 1]), np.dot(d[:, 0], d[:, 0]) - np.dot(d[:, 1], d[:, 1]))
        nx, ny = -np.sin(phi), np.cos(phi)
        dist = np.abs((points[b:e, 0] - c[0]) * nx + (points[b:e, 1] - c[1]) * ny)
        off = dist > tol
        first = int(off.argmax())
        grow = first if off[first] else e - b
        if grow == 0:
            break
        b += grow
    return b - a


def iepf_lines(points: np.ndarray, ranges: np.ndarray, runs: np.ndarray, cfg: LineConfig = LineConfig()) -> Lines:
    """Lines by iterative end-point fit: split every segment at its farthest point from the chord
    until all points are within tolerance. All segments of all runs are split level by level."""
    runs = np.asarray(runs, np.int64).reshape(-1, 2)
    if len(points) == 0 or len(runs) == 0:
        return _empty()
    tol = tolerance(ranges, cfg) * cfg.relax[0]
    seg_s, seg_e = runs[:, 0].copy(), runs[:, 1].copy()
    done_s, done_e = [], []
    while len(seg_s):
        short = seg_e - seg_s <= 2
        done_s.append(seg_s[short])
        done_e.append(seg_e[short])
        seg_s, seg_e = seg_s[~short], seg_e[~short]
        if not len(seg_s):
            break
        inner = seg_e - seg_s - 2  # points strictly between the chord's ends
        sid = np.repeat(np.arange(len(seg_s)), inner)
        j = spans(seg_s + 1, inner)
        p0, p1 = points[seg_s[sid]], points[seg_e[sid] - 1]
        u = p1 - p0
        q = points[j] - p0
        norm = np.hypot(u[:, 0], u[:, 1])
        cross = np.abs(q[:, 0] * u[:, 1] - q[:, 1] * u[:, 0])
        dist = np.where(norm > 0, cross / np.where(norm > 0, norm, 1), np.hypot(q[:, 0], q[:, 1]))
        ratio = dist / tol[j]
        # the farthest point of every segment: sort by (segment, -ratio), take each group's first
        o = np.lexsort((-ratio, sid))
        first = o[np.r_[0, np.cumsum(inner)[:-1]]]
        split = ratio[first] > 1.0
        cut = j[first] + 1  # the farthest point ends the first piece
        done_s.append(seg_s[~split])
        done_e.append(seg_e[~split])
        seg_s, seg_e = np.concatenate((seg_s[split], cut[split])), np.concatenate((cut[split], seg_e[split]))
    start, stop = np.concatenate(done_s), np.concatenate(done_e)
    # pieces too short for a line fall apart into single points
    short = (stop - start) < cfg.min_points
    if short.any():
        singles = spans(start[short], stop[short] - start[short])
        start = np.concatenate((start[~short], singles))
        stop = np.concatenate((stop[~short], singles + 1))
    order = np.argsort(start, kind="stable")
    return fit_lines(points, start[order], stop[order], cfg.min_points)


def absorb_strays(points: np.ndarray, lines: Lines, tol: np.ndarray, run_end: np.ndarray, passes: int = 3) -> Lines:
    """Single points next to a line, within its tolerance, join it (the merge of split-and-merge).

    Near a corner the few beams that fit neither wall at the extraction tolerance are often
    within tolerance of the refitted line; letting them join keeps corners sharp. A point joins
    the nearer of its neighbouring lines of the same run; one point per line end per pass.
    """
    start, stop = lines.start.copy(), lines.stop.copy()
    theta, rho = lines.theta.copy(), lines.rho.copy()
    for _ in range(passes):
        is_line = np.isfinite(theta)
        single = np.flatnonzero(~is_line)
        if single.size == 0:
            break
        p = points[start[single]]
        best = np.full(single.size, np.inf)
        target = np.full(single.size, -1)
        for side in (-1, 1):
            nb = single + side
            ok = (nb >= 0) & (nb < len(start))
            nb = np.where(ok, nb, 0)
            ok &= is_line[nb] & (run_end[start[nb]] == run_end[start[single]])
            d = np.abs(p[:, 0] * np.cos(theta[nb]) + p[:, 1] * np.sin(theta[nb]) - rho[nb])
            take = ok & (d <= tol[start[single]]) & (d < best)
            best[take], target[take] = d[take], nb[take]
        move = target >= 0
        # one point per line end per pass: points are ordered, so keep the first claim on each end
        key = target * 2 + (single > target)
        _, first = np.unique(np.where(move, key, -1), return_index=True)
        claim = np.zeros(single.size, bool)
        claim[first] = True
        move &= claim
        if not move.any():
            break
        s_, t_ = single[move], target[move]
        before = s_ < t_
        start[t_[before]] = start[s_[before]]
        stop[t_[~before]] = stop[s_[~before]]
        keep = np.ones(len(start), bool)
        keep[s_] = False
        start, stop, theta, rho = start[keep], stop[keep], theta[keep], rho[keep]
    return Lines(start, stop, theta, rho)


def fit_lines(points: np.ndarray, start: np.ndarray, stop: np.ndarray, min_points: int = 2) -> Lines:
    """Total-least-squares normal form of every [start, stop) group; NaN for smaller groups."""
    m_int = (stop - start).astype(np.int64)
    owner = np.repeat(np.arange(len(start)), m_int)
    idx = spans(start, m_int)
    # moments about each line's own first point: no cancellation however many scans are stacked
    x = points[idx, 0] - points[start, 0][owner]
    y = points[idx, 1] - points[start, 1][owner]
    m = m_int.astype(np.float64)
    k = len(start)
    mx = np.bincount(owner, x, k) / m
    my = np.bincount(owner, y, k) / m
    cxx = np.bincount(owner, x * x, k) / m - mx * mx
    cxy = np.bincount(owner, x * y, k) / m - mx * my
    cyy = np.bincount(owner, y * y, k) / m - my * my
    mx, my = mx + points[start, 0], my + points[start, 1]
    theta = 0.5 * np.arctan2(2 * cxy, cxx - cyy) + np.pi / 2  # normal = direction + 90°
    rho = mx * np.cos(theta) + my * np.sin(theta)
    flip = rho < 0
    theta = np.where(flip, theta + np.pi, theta) % (2 * np.pi)
    rho = np.abs(rho)
    # Hough convention: θ in [0, π) with signed ρ
    back = theta >= np.pi
    theta = np.where(back, theta - np.pi, theta)
    rho = np.where(back, -rho, rho)
    single = (stop - start) < min_points
    theta[single] = np.nan
    rho[single] = np.nan
    return Lines(start, stop, theta, rho)


def intersect(theta1, rho1, theta2, rho2, min_angle: float = 0.0):
    """Intersection of lines x cos θ + y sin θ = ρ, the thesis's equation (3) of 3.2.1.2.

    With A y + B x + C = 0 and D y + E x + F = 0 (A = sin θ1, B = cos θ1, C = -ρ1, ...):
    x = (CD - AF) / (AE - BD). The special cases: AE = BD (parallel lines, no vertex: NaN, also
    when the lines meet at less than ``min_angle``), and a vertical first line (A = sin θ1 = 0),
    where y comes from the second line.
    """
    A, B, C = np.sin(theta1), np.cos(theta1), -np.asarray(rho1, dtype=np.float64)
    D, E, F = np.sin(theta2), np.cos(theta2), -np.asarray(rho2, dtype=np.float64)
    den = A * E - B * D
    parallel = np.abs(den) <= max(np.sin(min_angle), 1e-12)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (C * D - A * F) / den
        use_first = np.abs(A) >= np.abs(D)
        y = np.where(use_first, (-B * x - C) / A, (-E * x - F) / D)
    x = np.where(parallel, np.nan, x)
    y = np.where(parallel, np.nan, y)
    return x, y


def extract(points: np.ndarray, ranges: np.ndarray, runs: np.ndarray, cfg: LineConfig = LineConfig()) -> Lines:
    """Lines by the configured method, stray points absorbed, every line refitted."""
    runs = np.asarray(runs, np.int64).reshape(-1, 2)
    # the Hough's anchors and the stray points' merge both stop at a run's end: found once here
    run_end = run_ends(runs, len(points))
    if cfg.method == "hough":
        lines = hough_lines(points, ranges, runs, cfg, run_end)
    else:
        lines = iepf_lines(points, ranges, runs, cfg)
    if len(lines) == 0:
        return lines
    loose = tolerance(ranges, cfg) * cfg.relax[-1]
    lines = absorb_strays(points, lines, loose, run_end)
    lines = fit_lines(points, lines.start, lines.stop, cfg.min_points)
    return demote_misfits(points, lines, loose, cfg.min_points)


def demote_misfits(points: np.ndarray, lines: Lines, tol: np.ndarray, min_points: int) -> Lines:
    """Lines whose refitted line misses one of their own points by more than tol fall apart
    into single points: a line must fit what it claims to represent."""
    m = lines.stop - lines.start
    idx = spans(lines.start, m)
    owner = np.repeat(np.arange(len(m)), m)
    th, rh = lines.theta[owner], lines.rho[owner]
    resid = np.abs(points[idx, 0] * np.cos(th) + points[idx, 1] * np.sin(th) - rh)
    bad_pt = np.isfinite(th) & (resid > tol[idx])
    bad = np.bincount(owner[bad_pt], minlength=len(m)) > 0
    if not bad.any():
        return lines
    singles = spans(lines.start[bad], m[bad])
    start = np.concatenate((lines.start[~bad], singles))
    order = np.argsort(start, kind="stable")
    stop = np.concatenate((lines.stop[~bad], singles + 1))[order]
    start = start[order]
    return fit_lines(points, start, stop, min_points)


def run_ends(runs: np.ndarray, n: int) -> np.ndarray:
    """For each of n points, the stop of the run [start, stop) that holds it (0 outside runs)."""
    count = runs[:, 1] - runs[:, 0]
    out = np.zeros(n, np.int64)
    out[spans(runs[:, 0], count)] = np.repeat(runs[:, 1], count)
    return out


def _empty() -> Lines:
    z = np.zeros(0, np.int64)
    return Lines(z, z, np.zeros(0), np.zeros(0))
