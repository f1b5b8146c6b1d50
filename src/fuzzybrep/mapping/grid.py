"""Occupancy-grid mapping: the baseline the thesis argues against (thesis 2.2: Elfes; Thrun).

The plane is cut into square cells; each cell holds the log-odds ``l = log(p / (1 - p))`` that it
is occupied, 0 (p = 0.5) before anything is seen. Every beam applies the inverse sensor model:

* every cell the beam passes through before its return gets ``l_free`` (the beam went through);
* the cell holding the return gets ``l_occ`` (something reflected it);
* a beam whose return lies beyond ``max_usable`` marks free space up to ``max_usable`` and no hit
  (the thesis does not trust the space between 1°-apart beams that far out);
* a beam with no return (range at or above the scan's ``max_range``) marks nothing: it is evidence
  of nothing. ``no_return_free`` > 0 claims free space that far along it instead.

Updates are independent, so the map is the sum of all of them (Bayes' rule in log-odds form,
Thrun, Burgard and Fox 2005, 9.2), clamped to ``clamp`` so that no cell becomes so certain that
it can never change. The sum is clamped once at the end (batch mapping of a static world): this is
what sequential clamping gives unless a cell hits a bound and later turns the other way.

The cells a beam passes through are found exactly (the cells of Amanatides and Woo's traversal,
1987) for all beams at once: a beam from cell (ix0, iy0) to cell (ix1, iy1) lies in |ix1 - ix0| + 1
columns, in each a run of cells from the row where it entered the column to the row where it left;
where it crosses the vertical cell boundaries is computed, and its horizontal crossings are where
the runs end, so a beam's cells form an unbroken chain even within rounding of a cell corner. Flat
beams are taken row by row instead. Each run adds one to its cells through a difference array, so
no (beam, cell) pair is counted twice, nothing is sorted, and the work grows with the runs (about a
quarter of the cells at 5 cm), not with the cells.
"""

from __future__ import annotations

import math
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..arrays import cell_count_text, cells_area
from ..formats.rosmap import FREE_THRESH, MAX_CELLS, OCCUPIED_THRESH
from ..scans.scan import Scan


def logit(p: float) -> float:
    """Log-odds of a probability."""
    return math.log(p / (1.0 - p))


#: OctoMap's published sensor model (Hornung et al. 2013): hit 0.7, miss 0.4, clamped to 0.12..0.97
L_OCC = logit(0.7)
L_FREE = logit(0.4)
CLAMP = (logit(0.12), logit(0.97))

#: cell states in the nav_msgs/OccupancyGrid convention (what ``trinary`` returns)
UNKNOWN, FREE, OCCUPIED = -1, 0, 100

_CHUNK = 1 << 19  # cell runs per batch (a few scans): amortises the per-step NumPy calls, shares the cores
_ONE = np.int32(1)  # not 1: np.add.at on int32 with a Python int takes a path 25 times slower


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """Log-odds occupancy of square cells.

    logodds  (ny, nx) float32; row iy covers y in [origin_y + iy·res, origin_y + (iy+1)·res), so row 0
             is the BOTTOM of the map (a ROS image is the other way up: see ``rosmap``).
    origin   (2,) world x, y of the lower-left corner of cell (0, 0).
    resolution  cell side (map unit).
    free_thresh, occupied_thresh  probabilities below / above which a cell is free / occupied.
    """

    logodds: np.ndarray
    origin: np.ndarray
    resolution: float
    free_thresh: float = FREE_THRESH
    occupied_thresh: float = OCCUPIED_THRESH

    def __post_init__(self) -> None:
        lo = np.asarray(self.logodds, dtype=np.float32)
        if lo.ndim != 2:
            raise ValueError(f"logodds must be a 2-D array, got shape {lo.shape}")
        object.__setattr__(self, "logodds", lo)
        object.__setattr__(self, "origin", np.asarray(self.origin, dtype=np.float64).reshape(2))
        if not self.resolution > 0:
            raise ValueError(f"resolution must be positive, got {self.resolution!r}")
        if not 0 < self.free_thresh < self.occupied_thresh < 1:
            raise ValueError(f"need 0 < free_thresh ({self.free_thresh}) < occupied_thresh ({self.occupied_thresh}) < 1")

    # ------------------------------------------------------------------ size
    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx)."""
        return self.logodds.shape  # type: ignore[return-value]

    @property
    def cells(self) -> int:
        return int(self.logodds.size)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) of the whole grid, for plotting."""
        ny, nx = self.shape
        x0, y0 = self.origin
        return x0, x0 + nx * self.resolution, y0, y0 + ny * self.resolution

    def nbytes(self, bytes_per_cell: int = 4) -> int:
        """Memory of the map at ``bytes_per_cell`` (the thesis counts 4 per cell; a PGM stores 1)."""
        return self.cells * int(bytes_per_cell)

    # ------------------------------------------------------------------ states
    def probability(self) -> np.ndarray:
        """(ny, nx) probability that each cell is occupied."""
        return 1.0 / (1.0 + np.exp(-self.logodds.astype(np.float64)))

    def free(self) -> np.ndarray:
        """(ny, nx) bool: p < free_thresh."""
        return self.logodds < logit(self.free_thresh)

    def occupied(self) -> np.ndarray:
        """(ny, nx) bool: p > occupied_thresh."""
        return self.logodds > logit(self.occupied_thresh)

    def unknown(self) -> np.ndarray:
        """(ny, nx) bool: neither free nor occupied (never seen, or seen both ways)."""
        return ~(self.free() | self.occupied())

    def trinary(self) -> np.ndarray:
        """(ny, nx) int8: OCCUPIED (100), FREE (0) or UNKNOWN (-1), as nav_msgs/OccupancyGrid."""
        out = np.full(self.shape, UNKNOWN, np.int8)
        out[self.free()] = FREE
        out[self.occupied()] = OCCUPIED
        return out

    def free_area(self) -> float:
        """Area of the free cells (map unit²)."""
        return cells_area(int(np.count_nonzero(self.free())), self.resolution)

    # ------------------------------------------------------------------ queries at world points
    def cell_index(self, x, y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(iy, ix, inside) of world points; iy, ix are clipped into the grid where not inside."""
        ny, nx = self.shape
        fx = np.floor((np.asarray(x, np.float64) - self.origin[0]) / self.resolution)
        fy = np.floor((np.asarray(y, np.float64) - self.origin[1]) / self.resolution)
        inside = (fx >= 0) & (fx < nx) & (fy >= 0) & (fy < ny)
        return np.clip(fy, 0, ny - 1).astype(np.intp), np.clip(fx, 0, nx - 1).astype(np.intp), inside

    def probability_at(self, x, y) -> np.ndarray:
        """Occupancy probability at world points; 0.5 (nothing known) outside the grid."""
        iy, ix, inside = self.cell_index(x, y)
        lo = np.where(inside, self.logodds[iy, ix], 0.0)
        return 1.0 / (1.0 + np.exp(-lo))

    def state_at(self, x, y) -> np.ndarray:
        """OCCUPIED, FREE or UNKNOWN at world points (UNKNOWN outside the grid)."""
        iy, ix, inside = self.cell_index(x, y)
        return np.where(inside, self.trinary()[iy, ix], UNKNOWN).astype(np.int8)


# ---------------------------------------------------------------------- building


@dataclass(frozen=True)
class Beams:
    """Every beam of every scan as a segment to trace: origin, direction, length, hit at the end."""

    ox: np.ndarray
    oy: np.ndarray
    cos: np.ndarray
    sin: np.ndarray
    length: np.ndarray
    hit: np.ndarray  # bool: the cell at the end gets l_occ

    @property
    def ex(self) -> np.ndarray:
        return self.ox + self.length * self.cos

    @property
    def ey(self) -> np.ndarray:
        return self.oy + self.length * self.sin


def beams_of(scans: Sequence[Scan], max_usable: float = 8.0, no_return_free: float = 0.0) -> Beams:
    """The inverse sensor model's segments (see module doc); beams that mark nothing are dropped."""
    n = np.fromiter((len(s.ranges) for s in scans), np.int64, len(scans))
    poses = np.array([s.pose for s in scans]).reshape(-1, 3)
    r = np.concatenate([s.ranges for s in scans]) if len(scans) else np.zeros(0)
    ret = np.concatenate([s.returns for s in scans]) if len(scans) else np.zeros(0, bool)
    ang = np.repeat(poses[:, 2], n) + (np.concatenate([s.bearings for s in scans]) if len(scans) else 0.0)
    hit = ret & (r <= max_usable)
    length = np.where(ret, np.minimum(r, max_usable), min(no_return_free, max_usable))
    keep = hit | (length > 0)
    return Beams(np.repeat(poses[:, 0], n)[keep], np.repeat(poses[:, 1], n)[keep], np.cos(ang[keep]),
                 np.sin(ang[keep]), length[keep], hit[keep])


def occupancy_grid(
    scans: Sequence[Scan],
    resolution: float = 0.05,
    l_occ: float = L_OCC,
    l_free: float = L_FREE,
    clamp: tuple[float, float] = CLAMP,
    max_usable: float = 8.0,
    no_return_free: float = 0.0,
    free_thresh: float = FREE_THRESH,
    occupied_thresh: float = OCCUPIED_THRESH,
    workers: int | None = None,
) -> OccupancyGrid:
    """The log-odds occupancy grid of scans at known poses (inverse sensor model: module doc).

    The grid just covers every traced beam, with one spare cell on each side; its origin is a
    multiple of ``resolution``, so grids of different logs line up.
    """
    if not resolution > 0:
        raise ValueError(f"resolution must be positive, got {resolution!r}")
    if not max_usable > 0:
        raise ValueError(f"max_usable must be positive, got {max_usable!r}")
    if not clamp[0] <= 0 <= clamp[1]:
        raise ValueError(f"clamp {clamp} must contain 0 (the prior)")
    if not (l_occ > 0 and l_free < 0):
        raise ValueError(f"need l_occ > 0 and l_free < 0, got {l_occ} and {l_free}")
    b = beams_of(scans, max_usable, no_return_free)
    if len(b.length) == 0:
        raise ValueError("no beam marks anything: every beam has no return (try no_return_free > 0)")
    ex, ey = b.ex, b.ey
    i0, j0, nx, ny = lattice(min(b.ox.min(), ex.min()), min(b.oy.min(), ey.min()),
                             max(b.ox.max(), ex.max()), max(b.oy.max(), ey.max()), resolution)
    if nx * ny > MAX_CELLS:
        raise ValueError(f"a grid of {cell_count_text(nx)} × {cell_count_text(ny)} cells at resolution {resolution:g} is too large "
                         f"(limit {MAX_CELLS} cells): give a coarser resolution")
    nx, ny = int(nx), int(ny)
    ou, ov = b.ox / resolution - i0, b.oy / resolution - j0
    eu, ev = ex / resolution - i0, ey / resolution - j0

    passes = traverse_counts(ou, ov, eu, ev, b.cos, b.sin, nx, ny, workers)
    end = np.floor(ev[b.hit]).astype(np.int64) * nx + np.floor(eu[b.hit]).astype(np.int64)
    hits = np.bincount(end, minlength=nx * ny)
    # every hit beam passed through its own end cell once: that pass is the hit, not free space
    free = np.maximum(passes - hits, 0)
    lo = (hits * l_occ + free * l_free).clip(clamp[0], clamp[1]).astype(np.float32).reshape(ny, nx)
    return OccupancyGrid(lo, np.array([i0 * resolution, j0 * resolution]), float(resolution), free_thresh,
                         occupied_thresh)


def lattice(xmin: float, ymin: float, xmax: float, ymax: float, resolution: float) -> tuple[float, float, float, float]:
    """The grid over the box: its first cell's indices (i0, j0) and its size (nx, ny) in cells.

    Cell k spans [k, k+1) * resolution in world coordinates, so the origin is on the lattice and
    grids of different logs line up; one spare cell on each side. Grows with the box, so a box
    holding every beam bounds the grid before the beams are traced (``commands.grid``)."""
    # NumPy's floor, not math's: a resolution fine enough to overflow gives an infinite size to
    # refuse, which the caller does in one line (NumPy's warning about it came first)
    with np.errstate(over="ignore", invalid="ignore"):
        i0, j0 = np.floor(np.divide((xmin, ymin), resolution)) - 1
        nx, ny = np.floor(np.divide((xmax, ymax), resolution)) - (i0, j0) + 2
    return float(i0), float(j0), float(nx), float(ny)


def traverse_counts(ou, ov, eu, ev, du, dv, nx: int, ny: int, workers: int | None = None) -> np.ndarray:
    """(nx*ny,) how many segments pass through each cell, start and end cells included.

    Segments are given in cell units (cell (i, j) spans [i, i+1) x [j, j+1)): start (ou, ov), end
    (eu, ev), unit direction (du, dv). Every segment lies inside the grid.

    A segment's cells are runs (``cell_runs``): of a column for a steep segment, of a row for a
    flat one. A run adds one to a line's cells lo..hi, which is +1 at lo and -1 after hi in a
    difference array whose cumulative sum along the line is the count: the work grows with the
    number of runs, not of cells.
    """
    ix0, iy0 = np.floor(ou).astype(np.int64), np.floor(ov).astype(np.int64)
    ix1, iy1 = np.floor(eu).astype(np.int64), np.floor(ev).astype(np.int64)
    nv, nh = np.abs(ix1 - ix0), np.abs(iy1 - iy0)
    steep = nh > nv
    per = np.minimum(nv, nh) + 1  # runs of each segment
    cum = np.cumsum(per)
    cuts = np.searchsorted(cum, np.arange(_CHUNK, cum[-1], _CHUNK), side="right") if len(cum) else []
    bounds = np.unique(np.r_[0, cuts, len(per)])
    seg = (ou, ov, du, dv, ix0, iy0, ix1, iy1)

    size = nx * (ny + 1) + ny * (nx + 1)
    totals: list[np.ndarray] = []  # one difference array per thread
    mine = threading.local()

    def count(k: int) -> None:
        lo, hi = bounds[k], bounds[k + 1]
        x, y = (np.flatnonzero(part) + lo for part in (steep[lo:hi], ~steep[lo:hi]))
        ou, ov, du, dv, ix0, iy0, ix1, iy1 = ((a[x], a[y]) for a in seg)
        if not hasattr(mine, "total"):
            mine.total = np.zeros(size, np.int32)  # half the memory of int64; a count is at most the beams
            totals.append(mine.total)
        # steep: runs of a column, in a difference array of (nx, ny + 1); flat: of a row, (ny, nx + 1)
        steep_runs = cell_runs(ou[0], ov[0], du[0], dv[0], ix0[0], iy0[0], ix1[0], iy1[0], xy=True)
        flat_runs = cell_runs(ov[1], ou[1], dv[1], du[1], iy0[1], ix0[1], iy1[1], ix1[1], xy=False)
        for (line, first, last), width, offset in ((steep_runs, ny + 1, 0), (flat_runs, nx + 1, nx * (ny + 1))):
            line *= width
            line += offset
            np.add.at(mine.total, line + first, _ONE)
            np.subtract.at(mine.total, line + last + 1, _ONE)

    jobs = range(len(bounds) - 1)
    workers = workers or min(os.cpu_count() or 1, 8)
    # the elementwise NumPy work releases the GIL, so threads share the cores without copying
    with ThreadPoolExecutor(max(1, min(workers, len(jobs)))) as ex:
        for _ in ex.map(count, jobs):
            pass
    total = totals[0] if totals else np.zeros(size, np.int32)
    for t in totals[1:]:
        total += t
    # in place: the grid-sized arrays are what a large map's memory goes to
    cols = total[: nx * (ny + 1)].reshape(nx, ny + 1)
    rows = total[nx * (ny + 1) :].reshape(ny, nx + 1)
    np.cumsum(cols, axis=1, out=cols)
    np.cumsum(rows, axis=1, out=rows)
    passes = rows[:, :nx].astype(np.int64)
    passes += cols[:, :ny].T
    return passes.ravel()


def cell_runs(u, v, du, dv, i0, j0, i1, j1, xy: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The cells segments pass through, as runs: (i, lo, hi) for the cells (i, lo..hi), each cell
    of a segment in one run.

    In cell units, in the frame (u, v) = (x, y) if ``xy``, else (y, x); so a run is part of a column
    (x, y) or of a row (y, x). A segment starts at (u, v) in cell (i0, j0), ends in cell (i1, j1),
    with unit direction (du, dv); it lies in the lines i0, i0 ± 1, ..., i1, one run each, from the
    v-cell where it entered the line to the v-cell where it left. The runs of one segment form a
    4-connected chain from its start cell to its end cell: where it crosses a line u = integer is
    computed, where it crosses a line v = integer is where the run ends, so the two cannot
    disagree. Fastest with the frame in which segments cross few lines u = integer (steep ones in
    (x, y)). Where a segment passes exactly through a cell corner it crosses the horizontal
    boundary first, so the corner gives two distinct cells, not one twice.
    """
    # Computing the crossings of the lines v = integer apart, from where they lie, is the textbook
    # way, but within rounding of a corner the two can disagree on which came first and claim the
    # corner cell twice or not at all (a segment starting 1.4e-14 from a corner did)
    n = np.abs(i1 - i0)
    order = np.argsort(-n, kind="stable")  # the segments still crossing at step m are a prefix
    u, v, du, dv, i0, j0, i1, j1, n = (a[order] for a in (u, v, du, dv, i0, j0, i1, j1, n))
    m = len(n)
    active = np.searchsorted(-n, -np.arange(1, (n[0] if m else 0) + 1), side="right")  # crossing >= k + 1
    size = np.r_[m, active]  # runs in block k: segments crossing >= k lines u = integer
    start = np.r_[0, np.cumsum(size)]
    line, lo, hi = (np.empty(start[-1], np.int64) for _ in range(3))
    si = np.where(du >= 0, 1, -1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # du = 0 only where n = 0
        t1 = (i0 + (si > 0) - u) / du  # where along the segment the first crossing lies
        v1 = v + t1 * dv
        dvdu = np.abs(dv / du)  # how far v moves per line
    # the (k+1)-th crossing enters line i0 + (k+1)·si at u = that line (moving up u) or that line + 1
    # (moving down u); its v-cell is where the segment is then. Exactly on a line v = integer the
    # horizontal crossing comes first: in (x, y) the row after it, ceil(v) - 1 = -floor(-v) - 1
    # going down, where floor() alone would go the wrong way; in (y, x) the column before it
    flip = (dv < 0) if xy else (dv > 0)
    sg = np.where(flip, -1.0, 1.0)
    off = np.where(flip, -1.0, 0.0)
    w1 = sg * v1
    ws = sg * np.sign(dv) * dvdu
    jlo, jhi = np.minimum(j0, j1), np.maximum(j0, j1)
    # bounds of floor(w) that keep the run within the segment's own cells despite rounding
    wlo = np.where(flip, -jhi - 1, jlo).astype(np.float64)
    whi = np.where(flip, -jlo - 1, jhi).astype(np.float64)
    lo[:m] = j0  # the first runs start in the start cells
    w = np.empty(active[0] if len(active) else 0)
    # in block k the first a = active[k] segments leave their line (none in the last block)
    for k, (c, a) in enumerate(zip(size, np.r_[active, 0])):
        b = start[k]
        np.multiply(si[:c], k, out=line[b : b + c])
        line[b : b + c] += i0[:c]
        np.multiply(ws[:a], k, out=w[:a])
        w[:a] += w1[:a]
        np.floor(w[:a], out=w[:a])
        np.fmax(w[:a], wlo[:a], out=w[:a])  # fmax, not maximum: a NaN from a degenerate segment becomes a bound
        np.fmin(w[:a], whi[:a], out=w[:a])
        w[:a] *= sg[:a]
        w[:a] += off[:a]
        hi[b : b + a] = w[:a]  # where they leave it, the run ends
        lo[start[k + 1] : start[k + 1] + a] = hi[b : b + a]  # and the next one starts in that cell
        hi[b + a : b + c] = j1[a:c]  # the others end here, in their end cells
    return line, np.minimum(lo, hi), np.maximum(lo, hi)
