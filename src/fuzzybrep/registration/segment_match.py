"""Scan-to-segments alignment: one scan's endpoints fitted to a set of line segments by robust
Gauss-Newton on point-to-segment distances.

``SegmentIndex`` holds the segments (a map's obstacle edges, or the edges of a map built so far)
and a KD-tree (SciPy) over points sampled densely along them, so that the segment nearest to
each of many points is one tree query plus a little arithmetic: the nearest sample names a
segment whose distance is within half the sample spacing of the nearest segment's. Segments may
carry a kind: an endpoint whose nearest segment is not one to match (a frontier, the limit of what
the map saw) is left out of the fit, as unknown, rather than pulled onto it.

``align(points, index, pose)`` minimises Σ ρ(d_i) over the sensor pose, d_i the distance from
endpoint i (sensor frame, (n, 2)) to its nearest segment: each iteration finds the nearest
segments, linearises d_i along the direction from the segment to the point (the segment's normal
in its interior: point-to-line; the direction to its end beyond it) and solves the 3 × 3 normal
equations with iteratively reweighted least squares. The weight of a residual is a triangular
membership function of it, 1 − d/w for d < w, 0 beyond: with w the map's TME it is the map's own
μ (a redescending kernel: an endpoint outside the support, a person or a door opened since, has no
say). ``w`` starts wide and halves down to ``width`` (coarse to fine), so that a start a few
decimetres and degrees off is still drawn in. An optional prior (a pose and its information
matrix, from odometry) keeps the directions the scan does not constrain (along a corridor) where
the prior puts them, which makes the result the maximum a posteriori pose; the endpoints' own
error is taken as that of the triangular function of half-width ``width`` read as a distribution
(standard deviation width/√6) for weighing them against the prior.

Nothing here knows about maps or logs: arrays in, arrays out. ``use.localise`` aligns each scan to
a fuzzy map's obstacle edges; building a map from scans aligned to the map of the scans before
them (issue 22) needs only the same call on the segments of that map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..scans.scan import wrap


#: the wide kernels of ``align`` fit at least this many endpoints (a subsample), for at most
#: this many iterations each
COARSE_POINTS = 48
KERNEL = "triangle"
_KERNELS = {
    "triangle": lambda d, w: np.maximum(1.0 - d / w, 0.0),
    "cauchy": lambda d, w: np.where(d < 2 * w, 1.0 / (1.0 + (2.0 * d / w) ** 2), 0.0),
    "gauss": lambda d, w: np.where(d < 2 * w, np.exp(-0.5 * (2.0 * d / w) ** 2), 0.0),
    "huber": lambda d, w: np.where(d < w, np.minimum(1.0, w / 3 / np.maximum(d, 1e-12)), 0.0),
}
COARSE_ITERATIONS = 3
#: where ``SegmentIndex.fit_rows``'s "nothing near" segment lies: farther than any reach
_FAR = 1e12


def sample_segments(a: np.ndarray, b: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """(samples (s, 2), segment of each (s,)): both ends of every segment a_j → b_j and enough
    points between them that none is farther than ``spacing`` from the next (all at once, no loop)."""
    a, b = np.asarray(a, np.float64).reshape(-1, 2), np.asarray(b, np.float64).reshape(-1, 2)
    d = b - a
    count = np.maximum(np.ceil(np.hypot(d[:, 0], d[:, 1]) / spacing).astype(np.int64), 1) + 1
    seg = np.repeat(np.arange(len(a)), count)
    first = np.cumsum(count) - count
    t = (np.arange(count.sum()) - np.repeat(first, count)) / np.repeat(count - 1, count)
    return a[seg] + t[:, None] * d[seg], seg


class SegmentIndex:
    """Line segments a_j → b_j ((m, 2) each) and the nearest of them to any point.

    spacing   samples along every segment at most this far apart (both ends included): the
              nearest segment's distance is found to within spacing / 2.
    kinds     (m,) small ints, optional (default 0); ``match`` says which kinds endpoints are
              fitted to (default: kind 0 only). Segments of other kinds still compete for being
              nearest: an endpoint nearest one of them is unknown, not matched.
    samples, samples_of   the samples ``sample_segments(a, b, spacing)`` gives and the segment
              of each, when the caller has them already (segments made once and moved rigidly:
              their samples move with them)
    """

    def __init__(self, a: np.ndarray, b: np.ndarray, spacing: float = 0.02, kinds: np.ndarray | None = None,
                 match: tuple[int, ...] = (0,), samples: np.ndarray | None = None, samples_of: np.ndarray | None = None):
        a = np.asarray(a, np.float64).reshape(-1, 2)
        b = np.asarray(b, np.float64).reshape(-1, 2)
        if a.shape != b.shape:
            raise ValueError(f"{len(a)} segment starts but {len(b)} ends")
        if not (math.isfinite(spacing) and spacing > 0):
            raise ValueError(f"spacing must be a positive number, got {spacing!r}")
        if not (np.isfinite(a).all() and np.isfinite(b).all()):
            raise ValueError("segment ends must be finite")
        kinds = np.zeros(len(a), np.int64) if kinds is None else np.asarray(kinds, np.int64).reshape(-1)
        if len(kinds) != len(a):
            raise ValueError(f"{len(a)} segments but {len(kinds)} kinds")
        self.a, self.b, self.kinds, self.spacing = a, b, kinds, float(spacing)
        self.matched = np.isin(kinds, np.asarray(match, np.int64))
        d = b - a
        length = np.hypot(d[:, 0], d[:, 1])
        self.length = length
        self.direction = np.divide(d, length[:, None], out=np.zeros_like(d), where=length[:, None] > 0)
        if samples is None:
            samples, seg = sample_segments(a, b, spacing)
        else:
            samples, seg = np.asarray(samples, np.float64).reshape(-1, 2), np.asarray(samples_of, np.int64).reshape(-1)
        self._finish(samples, seg)

    @classmethod
    def placed(cls, a: np.ndarray, b: np.ndarray, direction: np.ndarray, length: np.ndarray, samples: np.ndarray,
               samples_of: np.ndarray, spacing: float) -> "SegmentIndex":
        """An index of kind-0 segments whose directions, lengths and samples the caller has worked
        out already (``registration.align_scans`` moves each scan's segments rigidly once and joins the
        pieces of a local map: the checks and the per-segment arithmetic of ``__init__`` would be
        most of the index's cost, rebuilt at every scan)."""
        self = cls.__new__(cls)
        self.a, self.b, self.spacing = a, b, float(spacing)
        self.kinds = np.zeros(len(a), np.int64)
        self.matched = np.ones(len(a), bool)
        self.length, self.direction = length, direction
        self._finish(samples, samples_of)
        return self

    def _finish(self, samples: np.ndarray, seg: np.ndarray) -> None:
        self.samples = samples
        self.sample_segment = seg
        self.all_matched = bool(self.matched.all())
        # per segment (a_x, a_y, u_x, u_y, length) in one table: one gather a query instead of three;
        # and one more row, a point of a segment farther than any reach, that ``fit_rows`` names
        # for a point the tree found nothing for (the tree's "none" is the sample count)
        self._table = np.vstack((np.column_stack((self.a, self.direction, self.length)), (_FAR, _FAR, 0.0, 0.0, 0.0)))
        self._segment_of = np.append(seg, len(self.a))
        self._wall = np.append(self.matched, False)
        # an unbalanced tree builds in half the time and answers as fast for points spread like these
        self.tree = cKDTree(self.samples, balanced_tree=False, compact_nodes=False) if len(seg) else None

    def __len__(self) -> int:
        return len(self.a)

    @property
    def matched_length(self) -> float:
        """Total length of the segments endpoints are fitted to."""
        return float(self.length[self.matched].sum())

    def nearest(self, points: np.ndarray, max_distance: float = np.inf):
        """The nearest segment to each point (n, 2) within ``max_distance``.

        Returns (segment (n,) int, -1 for none within reach; distance (n,), inf for none; foot
        (n, 2), the nearest point of the segment; normal (n, 2), the unit direction from the foot
        to the point, the segment's normal when the foot is interior, so that a point on the
        segment still has one).
        """
        p = np.asarray(points, np.float64).reshape(-1, 2)
        n = len(p)
        seg = np.full(n, -1)
        dist = np.full(n, np.inf)
        foot = np.zeros((n, 2))
        normal = np.zeros((n, 2))
        idx, j, d, nx, ny, fx, fy = self.within(p, max_distance, feet=True)
        seg[idx], dist[idx] = j, d
        foot[idx, 0], foot[idx, 1], normal[idx, 0], normal[idx, 1] = fx, fy, nx, ny
        return seg, dist, foot, normal

    def fit_rows(self, p: np.ndarray, reach: float):
        """What a Gauss-Newton iteration of ``align`` needs of every point (n, 2): (the segment of
        its nearest sample within ``reach`` + spacing/2, ``len(self)`` for none (n,); the distance
        to it (n,), beyond any reach for none; normal x, y (n,)). Some distances are beyond
        ``reach`` (the caller's kernel gives those no weight: cheaper than leaving them out). The
        normal is the direction from the foot to the point, which for a foot inside the segment
        is its normal turned to the point's side (the same thing as ``nearest`` works out
        separately, up to rounding), the segment's normal for a point on it. As few array
        operations as can be: a hundred points a call, tens of thousands of calls a log."""
        if self.tree is None or len(p) == 0:
            n = len(p)
            return np.full(n, len(self.a)), np.full(n, np.inf), np.zeros(n), np.zeros(n)
        _, k = self.tree.query(p, distance_upper_bound=reach + self.spacing / 2)
        j = self._segment_of[k]
        ax, ay, ux, uy, L = self._table[j].T
        px, py = p.T
        t = np.minimum(np.maximum((px - ax) * ux + (py - ay) * uy, 0.0), L)
        ex, ey = px - (ax + t * ux), py - (ay + t * uy)
        d = np.hypot(ex, ey)
        off = d > 1e-12
        dd = np.where(off, d, 1.0)
        return j, d, np.where(off, ex / dd, -uy), np.where(off, ey / dd, ux)

    def within(self, p: np.ndarray, max_distance: float, feet: bool = False):
        """``nearest``'s work for the points (n, 2) within ``max_distance`` only, as columns: (index
        of each such point (k,), its segment (k,), distance (k,), normal x, y (k,) each[, foot x, y
        with ``feet``])."""
        if self.tree is None or len(p) == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64), *(np.zeros(0) for _ in range(5 if feet else 3))
        # a sample within max_distance + spacing/2 can name a segment within max_distance
        _, k = self.tree.query(p, distance_upper_bound=max_distance + self.spacing / 2)
        found = np.flatnonzero(k < len(self.samples))
        j = self.sample_segment[k[found]]
        ax, ay, ux, uy, L = self._table[j].T
        px, py = p[found].T
        apx, apy = px - ax, py - ay
        t = np.minimum(np.maximum(apx * ux + apy * uy, 0.0), L)  # np.clip's own overhead is most of its cost here
        qx, qy = ax + t * ux, ay + t * uy
        ex, ey = px - qx, py - qy
        d = np.hypot(ex, ey)
        # only what lies within reach is worked out further
        ok = np.flatnonzero(d <= max_distance)
        if len(ok) < len(d):
            j, ux, uy, t, L, qx, qy, ex, ey, d = (v[ok] for v in (j, ux, uy, t, L, qx, qy, ex, ey, d))
        # interior foot: the normal (-u_y, u_x), turned to the point's side; beyond an end: towards the point
        side = np.where(ex * -uy + ey * ux < 0, -1.0, 1.0)
        along = ((t > 0) & (t < L)) | (d == 0)
        dd = np.where(d > 0, d, 1.0)
        nx = np.where(along, -uy * side, ex / dd)
        ny = np.where(along, ux * side, ey / dd)
        out = found[ok], j, d, nx, ny
        return out + (qx, qy) if feet else out


@dataclass(frozen=True)
class Alignment:
    """The result of ``align``.

    pose        (3,) the sensor pose found (x, y, heading)
    covariance  (3, 3) of the pose: the inverse of (JᵀWJ / σ̂² + Λ) at the solution, marginal over
                the range offset when it was estimated; σ̂² the weighted residual variance, Λ the
                prior's information (infinite when fewer than 4 endpoints matched and there is no
                prior)
    offset      the range offset used (estimated, when ``align`` was given ``offset_prior``)
    offset_variance  its posterior variance (inf when not estimated)
    information (3, 3) what the endpoints alone say about the pose: JᵀWJ / σ̂² at the solution,
                without any prior (singular along what the scan does not constrain); a filter
                fuses the alignment with it
    matches     endpoints within ``support`` of a matched segment at the solution
    unknown     endpoints whose nearest segment is of a kind not matched (a frontier)
    points      endpoints given
    rms         root mean square distance of the matched endpoints to their segments
    mu          mean over the endpoints not unknown of 1 − d/support (0 beyond it): the mean
                membership grade of the endpoints, with ``support`` the map's TME
    iterations  Gauss-Newton iterations done
    """

    pose: np.ndarray
    covariance: np.ndarray
    offset: float
    offset_variance: float
    information: np.ndarray
    matches: int
    unknown: int
    points: int
    rms: float
    mu: float
    iterations: int

    @property
    def inlier_share(self) -> float:
        """Matched endpoints over those not unknown (0 when every endpoint is unknown)."""
        judged = self.points - self.unknown
        return self.matches / judged if judged > 0 else 0.0


def _adjugate(H: np.ndarray) -> tuple[tuple[tuple[float, ...], ...], float]:
    """(adj(H) as rows, det H) of a 3 × 3 matrix, in Python floats: np.linalg's own overhead is
    several times the arithmetic, and ``align`` solves once an iteration."""
    (a, b, c), (d, e, f), (g, h, i) = H.tolist()
    A, B, C = e * i - f * h, f * g - d * i, d * h - e * g
    adj = ((A, c * h - b * i, b * f - c * e), (B, a * i - c * g, c * d - a * f), (C, b * g - a * h, a * e - b * d))
    return adj, a * A + b * B + c * C


def _solve(H: np.ndarray, g: np.ndarray) -> np.ndarray | None:
    """The Gauss-Newton step −H⁻¹g, None when H is singular (3 × 3 by ``_adjugate``)."""
    if len(g) != 3:
        try:
            return -np.linalg.solve(H, g)
        except np.linalg.LinAlgError:
            return None
    adj, det = _adjugate(H)
    if det == 0 or not math.isfinite(det):
        return None
    r0, r1, r2 = g.tolist()
    return np.array([-(p * r0 + q * r1 + r * r2) / det for p, q, r in adj])


def _inverse(H: np.ndarray) -> np.ndarray:
    """H⁻¹ (LinAlgError when singular; 3 × 3 by ``_adjugate``)."""
    if H.shape != (3, 3):
        return np.linalg.inv(H)
    adj, det = _adjugate(H)
    if det == 0 or not math.isfinite(det):
        raise np.linalg.LinAlgError("singular matrix")
    return np.array(adj) / det


def transform(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Points (n, 2) in the frame of ``pose`` (3,), in the world frame."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    # one product with the rotation's transpose: a third of the array operations of the columns
    return points @ np.array(((c, s), (-s, c))) + np.asarray(pose[:2], np.float64)


def align(points: np.ndarray, index: SegmentIndex, pose: np.ndarray, *, width: float = 0.2, start_width: float = 0.8,
          prior: tuple[np.ndarray, np.ndarray] | None = None, offset: float = 0.0,
          offset_prior: tuple[float, float] | None = None, support: float | None = None, max_iterations: int = 30,
          tolerance: float = 1e-3, min_matches: int = 4) -> Alignment:
    """Align endpoints ``points`` (n, 2, sensor frame) to ``index``'s segments from ``pose`` (3,).

    width         the final kernel width (the map's TME, or a share of it): endpoints farther than
                  it from every matched segment have no weight; ``matches`` counts those within it.
    start_width   the first kernel width; halved each time an iteration moves less than
                  ``tolerance`` (metres; radians × 1 m for the heading), down to ``width``.
    prior         (pose (3,), information (3, 3)) or None: a Gaussian prior on the pose, in the
                  world frame (x, y, heading), added to the normal equations.
    offset        a range offset: every endpoint is moved this far along its beam (the laser's
                  systematic range error, and the map's boundary lying beyond the returns that
                  made it: both are a constant offset between the scan and the map).
    offset_prior  (mean, information) or None: estimate the offset as a fourth unknown with this
                  Gaussian prior (a scan that sees walls on one side only cannot tell it from a
                  step towards them); None: keep ``offset`` fixed.
    support       the distance within which an endpoint counts as matched in the result, and
                  over which its grade falls from 1 to 0 (default ``width``; the map's TME).
    min_matches   fewer weighted endpoints than this: the pose is left where the prior (or the
                  start) puts it.
    """
    p = np.asarray(points, np.float64).reshape(-1, 2)
    rng_ = np.hypot(p[:, 0], p[:, 1])
    beam = p / np.where(rng_ > 0, rng_, 1.0)[:, None]
    x = np.array(pose, np.float64).reshape(3)
    b = float(offset_prior[0]) if offset_prior is not None else float(offset)
    npar = 4 if offset_prior is not None else 3
    if prior is not None:
        prior_pose, info = np.asarray(prior[0], np.float64), np.asarray(prior[1], np.float64)
    w = max(start_width, width)
    inv_var = 6.0 / (width * width)  # 1/σ² of the endpoints: the triangle of half-width ``width``
    it = level_it = 0
    while it < max_iterations:
        it += 1
        level_it += 1
        # the wide kernels only bring the pose near: a subsample of the endpoints does that at
        # a fraction of the cost (each halving of the kernel takes twice as many, weighted as many)
        levels_left = max(0, math.ceil(math.log2(w / width - 1e-9))) if w > width else 0
        stride = min(1 << levels_left, max(1, len(p) // COARSE_POINTS))
        sl = slice(None, None, stride)
        ps, bs = p[sl], beam[sl]
        world = transform(ps + b * bs if b else ps, x)
        j, d, nx, ny = index.fit_rows(world, w)
        weight = _KERNELS[KERNEL](d, w)
        if KERNEL != "triangle":  # the triangle is 0 beyond w already; the others reach farther
            weight = np.where(d <= w, weight, 0.0)
        if not index.all_matched:
            weight = np.where(index._wall[j], weight, 0.0)
        if prior is None and np.count_nonzero(weight) < min_matches:
            break
        # rows of zero weight (beyond w, or nothing near) add nothing to H and g
        J = _jacobian(world, x, nx, ny, bs, npar)
        wu, du = weight * (inv_var * stride), d
        Jw = J * wu[:, None]
        H = J.T @ Jw
        g = Jw.T @ du
        if prior is not None:
            e = x - prior_pose
            e[2] = wrap(e[2])
            H[:3, :3] += info
            g[:3] += info @ e
        if npar == 4:
            H[3, 3] += offset_prior[1]
            g[3] += offset_prior[1] * (b - offset_prior[0])
        step = _solve(H, g)
        if step is None:
            break
        x = x + step[:3]
        x[2] = wrap(x[2])
        if npar == 4:
            b += float(step[3])
        small = math.hypot(step[0], step[1]) < tolerance and abs(step[2]) < tolerance
        if w <= width and small:
            break
        if w > width and (small or level_it >= COARSE_ITERATIONS):
            w = max(width, w / 2)
            level_it = 0
    return _result(p, beam, index, x, b, width, width if support is None else support, prior, offset_prior, it)


def _jacobian(world: np.ndarray, x: np.ndarray, nx: np.ndarray, ny: np.ndarray, beam: np.ndarray, npar: int) -> np.ndarray:
    """d(distance)/d(x, y, heading[, offset]) of matched endpoints, the direction (nx, ny) held."""
    arm = world - x[:2]
    cols = [nx, ny, ny * arm[:, 0] - nx * arm[:, 1]]
    if npar == 4:
        c, s = math.cos(x[2]), math.sin(x[2])
        cols.append(nx * (c * beam[:, 0] - s * beam[:, 1]) + ny * (s * beam[:, 0] + c * beam[:, 1]))
    return np.column_stack(cols)


def _result(p: np.ndarray, beam: np.ndarray, index: SegmentIndex, x: np.ndarray, b: float, width: float,
            support: float, prior, offset_prior, iterations: int) -> Alignment:
    """Matches, membership and covariance at the final pose."""
    world = transform(p + b * beam if b else p, x)
    j, d, nx, ny = index.fit_rows(world, max(width, support))
    near = d <= max(width, support)  # the points ``nearest`` finds a segment for
    wall = index._wall[j]
    matched = near & wall
    unknown = int(np.count_nonzero(near & ~wall))
    # an endpoint nothing is near is unknown too when the nearest sample at any distance is
    # a segment not matched (beyond a frontier): one more query, for the result only
    if not index.all_matched and index.tree is not None:
        far = ~near
        if far.any():
            _, k = index.tree.query(world[far])
            unknown += int(np.count_nonzero(~index.matched[index.sample_segment[k]]))
    judged = len(p) - unknown
    dm = d[matched]
    mu = float(np.maximum(1 - dm / support, 0.0).sum() / judged) if judged > 0 else 0.0
    ds = dm[dm <= support]
    n = len(ds)
    rms = math.sqrt(float(ds @ ds) / n) if n else math.inf
    npar = 4 if offset_prior is not None else 3
    H = np.zeros((npar, npar))
    inner = matched & (d < width)
    n_inner = int(np.count_nonzero(inner))
    if n_inner >= 4:
        di = d[inner]
        wt = 1 - di / width
        J = _jacobian(world[inner], x, nx[inner], ny[inner], beam[inner], npar)
        sigma2 = max(float((wt * di ** 2).sum() / max(wt.sum() - npar, 1e-9)), 1e-12)
        H = J.T @ (J * wt[:, None]) / sigma2
    data = H[:3, :3].copy()
    if prior is not None:
        H[:3, :3] += np.asarray(prior[1], np.float64)
    if npar == 4:
        H[3, 3] += offset_prior[1]
    cov = np.full((npar, npar), np.inf)
    if n_inner >= 4 or prior is not None:
        try:
            cov = _inverse(H)
        except np.linalg.LinAlgError:
            pass
    return Alignment(x, cov[:3, :3].copy(), b, float(cov[3, 3]) if npar == 4 else math.inf, data, n,
                     unknown, len(p), rms, mu, iterations)

