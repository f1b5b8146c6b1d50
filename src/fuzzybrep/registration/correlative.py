"""Correlative scan matching: the best pose in a window, searched before it is refined.

Olson, "Real-time correlative scan matching" (ICRA 2009). A local Gauss-Newton match
(``registration.segment_match.align``) converges only from a start within a few decimetres and
degrees of the truth; real odometry is not always that good (fr079's wheel odometry reports
forward motion while the robot backs up; bumps and turns on the spot on intel). So the window the
odometry's uncertainty allows is searched exhaustively first, scored on a likelihood field, and
the refinement starts from the best pose found.

``LikelihoodField`` is a grid over the local map: each cell holds exp(−d²/2σ²), d the distance
from the cell to the nearest map point (SciPy's Euclidean distance transform), and a coarse copy
whose cell (i, j) holds the largest value in the ``block`` × ``block`` cells from (i, j): its mean
over a scan's endpoints bounds from above the mean of every translation in that block (the
branch and bound of Hess et al., "Real-time loop closure in 2D LIDAR SLAM", ICRA 2016, with one
level). ``search`` scores every rotation of the window on the coarse grid, then opens blocks in
the order of their bound until no bound beats the best full-resolution score. An optional
Gaussian prior (the odometry step) is subtracted from the score, weakly: it decides only where
the scan cannot (along a bare corridor).

Arrays in, arrays out; nothing here knows about scans or maps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage


@dataclass(frozen=True)
class SearchResult:
    pose: np.ndarray  #: (3,) the best pose of the window
    score: float  #: its mean likelihood over the endpoints, in [0, 1] (without the prior)
    prior_score: float  #: the score with the prior's penalty, what was maximised
    evaluated: int  #: poses scored at full resolution


class LikelihoodField:
    """The likelihood field of map points (m, 2) at ``resolution``, σ = ``sigma`` (module
    docstring). Cells beyond the map's bounding box plus ``margin`` score 0."""

    def __init__(self, points: np.ndarray, resolution: float = 0.05, sigma: float = 0.1, block: int = 4,
                 margin: float = 0.5):
        points = np.asarray(points, np.float64).reshape(-1, 2)
        self.resolution, self.sigma, self.block = float(resolution), float(sigma), int(block)
        if not len(points):
            self.origin = np.zeros(2)
            self.fine = np.zeros((1, 1), np.float32)
            self.coarse = self.fine
            return
        pad = margin + 3 * sigma
        self.origin = points.min(axis=0) - pad
        shape = np.ceil((points.max(axis=0) + pad - self.origin) / resolution).astype(np.int64) + 1
        cells = np.floor((points - self.origin) / resolution).astype(np.int64)
        free = np.ones(tuple(shape), bool)
        free[cells[:, 0], cells[:, 1]] = False
        d = ndimage.distance_transform_edt(free) * resolution
        fine = np.exp(-0.5 * (d / sigma) ** 2).astype(np.float32)
        fine[d > 3 * sigma] = 0.0
        # a zero border: an index clipped into the grid lands on it (a point off the map scores 0)
        self.fine = np.pad(fine, 1)
        self.origin = self.origin - resolution
        # coarse[i, j] = max fine[i:i + block, j:j + block] (the block at (i, j) and the cells after it)
        self.coarse = ndimage.maximum_filter(self.fine, size=block, mode="constant", cval=0.0,
                                             origin=-(block // 2)) if block > 1 else self.fine

    def cells(self, points: np.ndarray) -> np.ndarray:
        """(..., 2) integer cells of points (..., 2) (not clipped)."""
        return np.floor((points - self.origin) / self.resolution).astype(np.int64)

    def _lookup(self, grid: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        return grid[np.clip(i, 0, grid.shape[0] - 1), np.clip(j, 0, grid.shape[1] - 1)]

    def score(self, world: np.ndarray) -> float:
        """Mean likelihood of points (n, 2) in the world frame."""
        c = self.cells(np.asarray(world, np.float64).reshape(-1, 2))
        return float(self._lookup(self.fine, c[:, 0], c[:, 1]).mean()) if len(c) else 0.0

    def search(self, points: np.ndarray, guess: np.ndarray, window: float, angle_window: float,
               angle_step: float | None = None, prior_information: np.ndarray | None = None,
               prior_weight: float = 0.02) -> SearchResult:
        """The pose within ±``window`` (metres, both axes) and ±``angle_window`` (radians) of
        ``guess`` (3,) at which the endpoints ``points`` (n, 2, sensor frame) score best.

        angle_step  default: the rotation that moves the farthest endpoint by one cell.
        prior_information  (3, 3) or None: the score is then mean likelihood − prior_weight ×
              min((p − guess)ᵀ Ω (p − guess), 25): a weak tie-breaker that costs a pose 5σ or more
              away at most 25 × prior_weight (module docstring).
        """
        pts = np.asarray(points, np.float64).reshape(-1, 2)
        guess = np.asarray(guess, np.float64)
        res, k = self.resolution, self.block
        if not len(pts):
            return SearchResult(guess.copy(), 0.0, 0.0, 0)
        if angle_step is None:
            far = max(float(np.hypot(pts[:, 0], pts[:, 1]).max()), res)
            angle_step = min(math.acos(max(-1.0, 1 - res ** 2 / (2 * far ** 2))), math.radians(2.0))
        na = int(math.ceil(angle_window / angle_step))
        dth = np.arange(-na, na + 1) * angle_step
        th = guess[2] + dth
        c, s = np.cos(th), np.sin(th)
        # every rotation's endpoints at the guess's position, as cells: (R, n, 2)
        rot = np.stack((c[:, None] * pts[:, 0] - s[:, None] * pts[:, 1],
                        s[:, None] * pts[:, 0] + c[:, None] * pts[:, 1]), axis=-1) + guess[:2]
        base = self.cells(rot)
        nt = int(math.ceil(window / res))
        # translations in whole cells, −nt .. nt, grouped into blocks of k starting at −nt
        nb = int(math.ceil((2 * nt + 1) / k))
        starts = -nt + k * np.arange(nb)
        Omega = None if prior_information is None else np.asarray(prior_information, np.float64)

        def penalty(dx, dy, da):
            if Omega is None:
                return 0.0
            m = (Omega[0, 0] * dx * dx + 2 * Omega[0, 1] * dx * dy + Omega[1, 1] * dy * dy
                 + 2 * (Omega[0, 2] * dx + Omega[1, 2] * dy) * da + Omega[2, 2] * da * da)
            return prior_weight * np.minimum(m, 25.0)

        # the coarse bound of every (rotation, block x, block y): (R, nb, nb)
        bi = base[:, None, None, :, 0] + starts[None, :, None, None]
        bj = base[:, None, None, :, 1] + starts[None, None, :, None]
        bound = self._lookup(self.coarse, bi, bj).mean(axis=-1)
        if Omega is not None:
            # the prior's smallest penalty in the block: at the guess clamped into it
            lo = starts * res
            hi = (starts + k - 1) * res
            cx = np.clip(0.0, lo, hi)
            bound = bound - penalty(cx[None, :, None], cx[None, None, :], dth[:, None, None])
        order = np.argsort(bound, axis=None)[::-1]
        best, best_raw, best_pose, evaluated = -math.inf, 0.0, guess.copy(), 0
        u = np.arange(k)
        for flat in order:
            if bound.flat[flat] <= best:
                break
            r, a, b = np.unravel_index(flat, bound.shape)
            ox = starts[a] + u
            oy = starts[b] + u
            ox, oy = ox[ox <= nt], oy[oy <= nt]
            vals = self._lookup(self.fine, base[r, None, None, :, 0] + ox[:, None, None],
                                base[r, None, None, :, 1] + oy[None, :, None]).mean(axis=-1)
            evaluated += vals.size
            total = vals - penalty(ox[:, None] * res, oy[None, :] * res, dth[r])
            at = np.unravel_index(int(np.argmax(total)), total.shape)
            if total[at] > best:
                best, best_raw = float(total[at]), float(vals[at])
                best_pose = np.array([guess[0] + ox[at[0]] * res, guess[1] + oy[at[1]] * res, th[r]])
        return SearchResult(best_pose, best_raw, best, evaluated)
