"""Evidence across scans: where the laser saw obstacles, and which rays must stop short of them.

A union of scan polygons is optimistic: one wrong free region (a ray through glass, a person who
walked away, two passes along a thin wall whose poses disagree by a few centimetres) stays free
for ever. So before any scan polygon is built, every beam's free range is checked against what
all scans saw:

1. every return is a *hit* in a fine grid (cell ``cell``), with the time it was seen;
2. every ray *crosses* the cells it passed through, well short of its own end;
3. a cell is *occupied* if it was hit and was not cleared afterwards: an obstacle seen at one time
   and later crossed by at least ``clear_crossings`` rays (and by more rays than it had hits)
   after the last hit anywhere in its 3 x 3 neighbourhood is gone (a person who walked away, a
   door opened). The neighbourhood keeps a chair leg that rays graze through pose noise from
   being cleared. With ``clear`` off (a static world) every cell ever hit stays occupied;
4. each beam's free range is clipped at the first occupied cell along it that lies more than
   ``own_margin`` in front of its own end (or off its own surface: ``own_incidence``). Evidence must be of standing to stop a ray: a cell hit
   fewer than ``solid_hits`` times and by less than ``block_ratio`` of the rays that crossed it
   is noise at the edge of something (a mixed pixel, pose jitter, a passing leg) and stops none.
   Among evidence of standing the newest wins, both ways (thesis 6.2, future work 2): an
   obstacle put down later stops the older rays that crossed its place. A beam with no return
   that claims free space (``no_return_free``) is weaker still: nothing answered it, so it may
   have passed through glass between sparse returns. It also stops where it crosses the line
   between two occupied cells less than ``no_return_bridge`` apart (``bridged``);
5. after the union, occupied cells hit ``carve_hits`` times or more that the free space still
   swallowed (a thin wall seen from both sides, whose two sides' free space meets through pose
   error) are cut back out (``carve``); with ``carve_close`` the gaps between them are closed.

The grid is scaffolding: it is dropped once the free ranges are known, and the map stays a B-rep.
It is stored only where rays pass (``cells.Cells``), and counted cell by cell where samples fall,
so that its memory and time follow the area the scans saw, not the bounding box of their returns.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Callable

import numpy as np
import shapely

from .bridge import segment_cells
from .cells import TILE, Cells
from .own_surface import own_margins


@dataclass(frozen=True)
class EvidenceConfig:
    cell: float = 0.05  #: grid cell size (map unit)
    step: float = 0.05  #: sampling step along rays
    cross_margin: float = 0.15  #: a ray crosses cells only this far short of its end
    #: evidence closer than this to a beam's own end is its own surface; measured across the
    #: surface when ``own_incidence`` < 90°: own_margin / sin β along a beam meeting it at
    #: incidence β ≥ own_incidence (``own_surface.own_margins``)
    own_margin: float = 0.15
    #: 90° (the default): the margin is along the beam, whatever the incidence. 10° with a
    #: margin of 0.12 m lets grazing beams reach the wall they ended on (Freiburg campus's held-out
    #: explained 92.7 → 93.8 %), but another pass's copy of the wall a few centimetres off is then
    #: deep in the free space and carved out as hundreds of small holes (Freiburg 079: 12418 →
    #: 19133 vertices, the compact map under 20× the grid), so it is not the default yet
    own_incidence: float = float(np.pi / 2)
    clear_crossings: int = 3  #: crossings after the last hit needed to clear an obstacle
    clear: bool = True  #: allow later free rays to clear obstacles (dynamic environments)
    solid_hits: int = 3  #: a cell hit this often blocks rays whatever crossed it
    carve_hits: int = 3  #: occupied cells hit this often are cut out of the free space if deep inside it
    carve_depth: float = 0.10  #: how deep inside the free space a cell must lie to be cut out
    #: gaps up to twice this between carved cells are closed (one wall, one hole). Off: on Freiburg
    #: 079 it made ghost walls of other passes' wall copies (localisation 0.035 -> 0.062 m RMSE)
    carve_close: float = 0.0
    block_ratio: float = 0.05  #: a cell hit fewer times blocks only if hits >= block_ratio x its crossings
    no_return_bridge: float = 1.0  #: a beam with no return also stops between occupied cells closer than this
    chunk: int = 250_000  #: samples per chunk: bounds the memory each of the two threads takes (no faster when larger)
    cache: int = 16_000_000  #: ray samples that could stop their ray kept between the two passes, at most


@dataclass
class Evidence:
    """Hit counts and the final occupied state of every stored cell (``cells``: where each cell
    of the frame is stored; None: all of them, row by row)."""

    origin: np.ndarray  # (2,) world position of cell (0, 0)'s corner
    cell: float
    shape: tuple[int, int]  # (ny, nx)
    hits: np.ndarray  # (cells.size,) int32 number of returns per cell
    occupied: np.ndarray  # (cells.size,) bool
    samples: list | None = None  # per batch and chunk of ``gather``, its samples that could stop a
    # ray (or the chunk's range to sample again), for ``clip`` to reuse (then dropped)
    claims: bool = False  # some beam with no return claims free space (``no_return_free``)
    # blocks of ``claim_block`` cells a side that a claiming beam samples (``bridged`` looks only there)
    claimed: np.ndarray | None = None
    claim_block: int = 1
    cells: Cells | None = None

    def __post_init__(self) -> None:
        if self.cells is None:
            self.cells = Cells(tuple(self.shape))

    def cell_index(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        ny, nx = self.shape
        ix = np.clip(((x - self.origin[0]) / self.cell).astype(np.int64), 0, nx - 1)
        iy = np.clip(((y - self.origin[1]) / self.cell).astype(np.int64), 0, ny - 1)
        return self.cells.index(ix, iy)

    def hits_within(self, radius: float) -> np.ndarray:
        """(cells.size,) bool: a hit lies within about ``radius`` of the cell (± one cell)."""
        k = max(1, int(np.ceil(radius / self.cell)))
        hit = np.flatnonzero(self.hits > 0)
        out = np.zeros(len(self.hits), bool)
        for near, _ in self.cells.around(hit, [(dx, dy) for dx in range(-k, k + 1) for dy in range(-k, k + 1)]):
            out[near] = True
        if self.cells.tiles is not None:
            out[: TILE * TILE] = False  # the scratch tile
        return out


@dataclass(frozen=True)
class Rays:
    """Every beam of every scan as a ray: origin, direction, length to sample, time, hit flag.

    The rays of one scan share its origin and time, so those are held once per scan, the scan's
    ``per_scan`` rays following one another (None: every ray its own origin), and spread to the
    rays only where a step needs them: held per ray, they were 41 MB of Freiburg's peak.
    """

    origin_x: np.ndarray
    origin_y: np.ndarray
    cos: np.ndarray
    sin: np.ndarray
    length: np.ndarray  # free range to examine
    origin_time: np.ndarray
    hit: np.ndarray  # bool: the beam ended on an obstacle at ``hit_range``
    hit_range: np.ndarray
    per_scan: np.ndarray | None = None  # rays of each origin, in order

    def spread(self, a: np.ndarray) -> np.ndarray:
        """A value per origin (scan) as one per ray."""
        return a if self.per_scan is None else np.repeat(a, self.per_scan)

    @property
    def ox(self) -> np.ndarray:
        return self.spread(self.origin_x)

    @property
    def oy(self) -> np.ndarray:
        return self.spread(self.origin_y)

    @property
    def time(self) -> np.ndarray:
        return self.spread(self.origin_time)

    @property
    def hx(self) -> np.ndarray:
        return self.ox[self.hit] + self.hit_range[self.hit] * self.cos[self.hit]

    @property
    def hy(self) -> np.ndarray:
        return self.oy[self.hit] + self.hit_range[self.hit] * self.sin[self.hit]


@dataclass(frozen=True)
class RayBatches:
    """Rays in consecutive batches, each made when it is asked for (``make(i)``), so that the
    steps below hold the rays of a batch or two at a time. All of a long log's rays at once take
    some 70 bytes a ray in them (120 MB on Freiburg's 1.7 M), and grow with the log, where the
    evidence grid grows only with the place. ``times``: the time of every origin, batch after
    batch, as the batches' ``origin_time`` give them (their order ranks the evidence)."""

    make: Callable[[int], Rays]
    count: int
    times: np.ndarray

    def __len__(self) -> int:
        return self.count

    def __getitem__(self, i: int) -> Rays:
        if not 0 <= i < self.count:
            raise IndexError(i)
        return self.make(i)

    def __iter__(self):
        return map(self.make, range(self.count))


def batched(rays: "Rays | RayBatches") -> RayBatches:
    """Rays held all at once as one batch; batches as they are."""
    return rays if isinstance(rays, RayBatches) else RayBatches(lambda i: rays, 1, rays.origin_time)


def carve(free, ev: Evidence, cfg: EvidenceConfig = EvidenceConfig(), stood=None, footprint: float = 0.0):
    """The obstacle cells the free space swallowed: occupied, hit ``carve_hits`` times or more, and
    more than ``carve_depth`` inside it (a cell-sized box each, united).

    A thin wall seen from both sides ends every ray at its own face, so no ray is clipped, yet the
    free space of the two sides meets (or overlaps by the pose error) and the wall is gone from the
    union. Cutting these cells back out keeps every obstacle seen solidly as a boundary. Cells
    within ``footprint`` of where the robot ``stood`` ((k, 2) positions) are not: the robot was
    there, so what other scans saw there came or went (a person walking beside it).
    """
    cand = np.flatnonzero(ev.occupied & (ev.hits >= cfg.carve_hits))
    if cand.size == 0 or free.is_empty:
        return shapely.GeometryCollection()
    ix, iy = ev.cells.xy(cand)
    row = np.lexsort((ix, iy))  # row by row, as the cells lie in the frame: the union's vertices start alike
    ix, iy = ix[row], iy[row]
    cx = ev.origin[0] + (ix + 0.5) * ev.cell
    cy = ev.origin[1] + (iy + 0.5) * ev.cell
    if stood is not None and footprint > 0 and len(stood):
        away = ~within(np.asarray(stood, np.float64).reshape(-1, 2), cx, cy, footprint)
        cx, cy = cx[away], cy[away]
    shapely.prepare(free)
    deep = shapely.contains_xy(free, cx, cy)
    r = cfg.carve_depth
    for dx, dy in ((r, 0), (-r, 0), (0, r), (0, -r)):
        deep[deep] = shapely.contains_xy(free, cx[deep] + dx, cy[deep] + dy)
    h = ev.cell / 2
    cells = shapely.union_all(shapely.box(cx[deep] - h, cy[deep] - h, cx[deep] + h, cy[deep] + h))
    if not cfg.carve_close:
        return cells
    # one wall, one hole: the carved cells of a thin wall lie in a broken chain (only its cells
    # deep in the free space are cut), which united cell by cell made a string of 5 cm boxes,
    # each its own hole of three or four vertices after the vertex reduction (most of Intel's
    # holes). Closing the gaps of up to 2 · carve_close between them (a morphological closing:
    # grow, unite, shrink back) gives each wall one thin hole; what it adds lies between cells
    # of one wall, narrower than a door by far
    c = cfg.carve_close
    return shapely.buffer(shapely.buffer(cells, c, join_style="mitre", quad_segs=1), -c, join_style="mitre", quad_segs=1)


def within(points: np.ndarray, x: np.ndarray, y: np.ndarray, radius: float) -> np.ndarray:
    """(len(x),) bool: (x, y) lies less than ``radius`` from one of ``points`` ((k, 2)).

    An STRtree over the points (GEOS, loaded already) picks the pairs within the radius, and the
    distance of each decides. scipy's KD-tree did this before: importing scipy.spatial alone took
    0.2 s and 38 MB, more than this whole step on a small log."""
    out = np.zeros(len(x), bool)
    if not len(x) or not len(points):
        return out
    q, p = shapely.STRtree(shapely.points(points)).query(shapely.points(x, y), predicate="dwithin", distance=radius)
    near = np.hypot(x[q] - points[p, 0], y[q] - points[p, 1]) < radius
    out[q[near]] = True
    return out


def _grid_rays(rays: Rays, ev: "Evidence", step: float):
    """Every ray in grid units (float32): origin and the offset of one sampling step."""
    f32 = np.float32
    gx = rays.spread(((rays.origin_x - ev.origin[0]) / ev.cell).astype(f32))
    gy = rays.spread(((rays.origin_y - ev.origin[1]) / ev.cell).astype(f32))
    return gx, gy, (rays.cos * step / ev.cell).astype(f32), (rays.sin * step / ev.cell).astype(f32)


def _sample_counts(length: np.ndarray, step: float) -> np.ndarray:
    """Samples of every ray: one every ``step`` up to ``length``."""
    return np.ceil(np.maximum(length, 0.0) / step).astype(np.int64)


def _samples_short_of(x: np.ndarray, step: float, count: np.ndarray) -> np.ndarray:
    """Per ray, how many of its ``count`` samples k lie short of x (k * step < x), as int32.

    k * step grows with k, so they are the first ones, and a comparison of k with this count
    takes the place of one in floating point; ceil(x / step) is off by one at most.
    """
    n = np.clip(np.ceil(x / step), 0, count).astype(np.int64)
    n -= (n > 0) & ((n - 1) * step >= x)
    n += (n < count) & (n * step < x)
    return n.astype(np.int32)


def _sample_cells(g, cells: Cells, count: np.ndarray, lo: int, hi: int):
    """The cell of every sample along rays lo..hi (``count`` samples each, see _sample_counts).

    Returns ray index, step index and cell index of every sample (ragged, flattened). The grid
    covers every ray's whole length, so no sample needs clamping. Each ray's values are spread to
    its samples by np.repeat, which streams, where indexing by ray would gather.
    """
    gx, gy, dx, dy = g
    n = count[lo:hi]
    ray = np.repeat(np.arange(lo, hi, dtype=np.int32), n)
    k = np.arange(len(ray), dtype=np.int32) - np.repeat((np.cumsum(n) - n).astype(np.int32), n)
    kf = k.astype(np.float32)
    cx = (np.repeat(gx[lo:hi], n) + kf * np.repeat(dx[lo:hi], n)).astype(np.int32)
    cy = (np.repeat(gy[lo:hi], n) + kf * np.repeat(dy[lo:hi], n)).astype(np.int32)
    return ray, k, cells.index(cx, cy)


def _cells_of(g, cells: Cells, ray: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The cells of samples (ray, k): the same arithmetic as _sample_cells, so the same cells."""
    gx, gy, dx, dy = g
    kf = k.astype(np.float32)
    cx = (gx[ray] + kf * dx[ray]).astype(np.int32)
    cy = (gy[ray] + kf * dy[ray]).astype(np.int32)
    return cells.index(cx, cy)


def ray_samples(length: np.ndarray, step: float) -> np.ndarray:
    """What sampling rays of these lengths costs, ray by ray: their samples, and one for the ray."""
    return np.ceil(np.maximum(length, 0) / step) + 1


def chunk_bounds(samples: np.ndarray, size: int):
    """Index ranges [lo, hi) of consecutive items (rays, or scans) of about ``size`` samples each
    (``samples``: per item): a range runs up to and with the item that crosses a multiple of size."""
    cum = np.cumsum(samples)
    bounds = np.searchsorted(cum, np.arange(size, cum[-1] + size, size)) if len(cum) else []
    lo = 0
    for b in list(bounds) + [len(samples)]:
        hi = min(int(b) + 1, len(samples))
        if hi > lo:
            yield lo, hi
            lo = hi


def _chunks(length: np.ndarray, cfg: EvidenceConfig):
    """Ray index ranges whose samples fit in one chunk."""
    return chunk_bounds(ray_samples(length, cfg.step), cfg.chunk)


def _counted(c: np.ndarray) -> tuple[int | np.ndarray, np.ndarray]:
    """How often each cell occurs in ``c``, in the work of its samples: counts over the span from
    the smallest cell to the largest, as (the first cell, counts), where that span is not much
    wider than the samples (a few scans' cells lie mostly near one another); else the distinct
    cells and their counts, by sorting (a place seen again later, stored far from where it was
    first seen). ``_add`` adds either to a grid."""
    if not len(c):
        return 0, np.zeros(0, np.int32)
    first = int(c.min())
    span = int(c.max()) - first + 1
    if span <= 4 * len(c) + 65536:
        return first, np.bincount(c - first, minlength=span).astype(np.int32)
    cell, n = np.unique(c, return_counts=True)
    return cell, n.astype(np.int32)


def _add(grid: np.ndarray, counted) -> None:
    """``_counted``'s counts added to ``grid``."""
    where, n = counted
    if isinstance(where, np.ndarray):
        grid[where] += n
    else:
        grid[where : where + len(n)] += n


def _parallel(fn, jobs):
    """fn of every job, in order, run on the machine's cores (NumPy releases the GIL on large
    arrays). A generator: each result is taken as it comes, so a caller that folds them up holds
    a few at a time, not all (gather's per-chunk counts are two grids each: 38 chunks on Freiburg)."""
    jobs = list(jobs)
    if len(jobs) < 2:
        yield from map(fn, jobs)
        return
    with ThreadPoolExecutor(min(len(jobs), os.cpu_count() or 1)) as ex:
        yield from ex.map(fn, jobs)


#: the frame's cells at most, and MAX_SIDE a side: only tiles rays pass are stored (``cells``), the
#: frame costs a table of tiles (84 MB at the limit), so this only names a corrupt pose (2^36: 13 km
#: across at 5 cm; freiburg-campus 37.5 M, a 300 m loop with drift 45 M: the old limit was 40 M)
MAX_CELLS = 1 << 36
MAX_SIDE = 1 << 19
#: coordinates at most this many cells from (0, 0): a float holds 1 part in 2**52, so beyond it
#: resolves a coordinate to worse than 1/64 of a cell (at 1e15 m no free space was left; at 1e300
#: samples fell outside the grid, an IndexError); 3.5e12 m for 5 cm cells
MAX_CELLS_FROM_ZERO = 2.0**46


def grid_frame(rays: "Rays | RayBatches", cell: float) -> tuple[np.ndarray, float, float]:
    """(origin, nx, ny) of the grid that holds every hit, ray origin and ray end, with a margin.
    nx and ny are floats, so that a grid too large to hold can be measured."""
    lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
    for b in batched(rays):
        xs = np.concatenate((b.hx, b.origin_x, b.ox + b.length * b.cos))
        ys = np.concatenate((b.hy, b.origin_y, b.oy + b.length * b.sin))
        if len(xs):
            lo = np.minimum(lo, (xs.min(), ys.min()))
            hi = np.maximum(hi, (xs.max(), ys.max()))
    origin = lo - 2 * cell
    with np.errstate(over="ignore", invalid="ignore"):  # a grid too large to hold measures inf: check_extent says so
        return origin, np.floor((hi[0] - origin[0]) / cell) + 3, np.floor((hi[1] - origin[1]) / cell) + 3


def time_ranks(t: np.ndarray) -> np.ndarray:
    """(n,) int32: 1 for the earliest time, one more for each later distinct time."""
    if len(t) and np.all(t[1:] >= t[:-1]):  # a log's scans come in time order: no sort needed
        return np.cumsum(np.r_[True, t[1:] > t[:-1]], dtype=np.int32)
    return (np.unique(t, return_inverse=True)[1].reshape(-1) + 1).astype(np.int32)


def _claims(b: Rays) -> np.ndarray:
    """No-return beams that claim free space (``no_return_free``)."""
    return ~b.hit & (b.length > 0)


def gather(rays: "Rays | RayBatches", cfg: EvidenceConfig = EvidenceConfig(), frame=None) -> Evidence:
    """Hits and the time-aware occupied state of every cell (steps 1-3 above). A grid over more
    than MAX_CELLS, or reaching beyond MAX_CELLS_FROM_ZERO, is the caller's to refuse first
    (``build.check_extent``, which names the scan, and gives its ``frame``: ``grid_frame``'s
    answer, worked out here if not given). Batches are made once for the hits and once for the
    crossings; ``clip`` makes them once more."""
    batches = batched(rays)
    origin, nx, ny = grid_frame(batches, cfg.cell) if frame is None else frame
    nx, ny = int(nx), int(ny)
    cells = Cells.where_rays_pass((ny, nx), batches, origin, cfg.cell)
    ev = Evidence(origin, cfg.cell, (ny, nx), np.zeros(0, np.int32), np.zeros(0, bool), cells=cells)
    size = cells.size

    # times as ranks (int32, 0 = never): only their order counts, and a grid of them is half
    # the memory of float64 times (the evidence grid is this stage's peak: 1.3 M cells on ACES)
    ranks = time_ranks(batches.times)
    first_origin = [0]  # of every batch, in ``ranks``
    hits = np.zeros(size, np.int32)
    last_hit = np.zeros(size, np.int32) if cfg.clear else None
    total, longest, ev.claims = 0, 0, False
    for b in batches:
        hc = ev.cell_index(b.hx, b.hy)
        stored = hc >= (TILE * TILE)  # the rest lies far from every ray (the scratch tile)
        _add(hits, _counted(hc[stored]))
        rank = b.spread(ranks[first_origin[-1] : first_origin[-1] + len(b.origin_time)])
        first_origin.append(first_origin[-1] + len(b.origin_time))
        if last_hit is not None:
            np.maximum.at(last_hit, hc[stored], rank[b.hit][stored])
        count = _sample_counts(b.length, cfg.step)
        total, longest = total + int(count.sum()), max(longest, int(count.max(initial=0)))
        ev.claims |= bool(_claims(b).any())
    ev.hits = hits
    if not cfg.clear:
        ev.occupied = hits > 0
        return ev

    # only a cell that was hit can turn out occupied, so what clears it is counted only there:
    # per hit cell (``hit``; ``slot``: each cell's place in it, -1 for a cell never hit), not per
    # cell of the grid (Freiburg 079: 52 k hit cells of 348 k stored, ACES 31 k of 1.25 M),
    # which took four grids of int32 and a count over each chunk's span of cells
    hit = np.flatnonzero(hits)
    n_hit = len(hit)
    slot = np.full(size, -1, np.int32)
    slot[hit] = np.arange(n_hit, dtype=np.int32)
    # the newest hit anywhere next to a hit cell: a ray grazing a chair leg through pose noise is
    # not evidence that the leg has gone; and the hits next to it (3 x 3 neighbourhoods)
    last_near = np.zeros(n_hit, np.int32)
    hits_near = np.zeros(n_hit, np.int32)
    last_of_hit, hits_of_hit = last_hit[hit], hits[hit]
    del last_hit
    for near, src in cells.around(hit, [(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]):
        # one offset at a time: the neighbours it gives are distinct, so plain indexing adds
        j = slot[near]
        on = j >= 0
        j, src = j[on], src[on]
        last_near[j] = np.maximum(last_near[j], last_of_hit[src])
        hits_near[j] += hits_of_hit[src]

    # sample every ray once, to its full length: the crossings use the part short of its end, and
    # clip (step 4) all of it. Only a hit cell can turn out occupied, so clip needs just the
    # samples in hit cells, and all of those of no-return beams (a bridge crosses empty cells):
    # a small part of them, kept in memory when they fit in a chunk's share of ``cfg.cache``
    total = max(total, 1)
    k_type = np.int16 if longest <= np.iinfo(np.int16).max else np.int32

    def crossings(i):
        b = batches[i]
        g = _grid_rays(b, ev, cfg.step)
        count = _sample_counts(b.length, cfg.step)
        short = _samples_short_of(b.length - cfg.cross_margin, cfg.step, count)
        rank = b.spread(ranks[first_origin[i] : first_origin[i + 1]])
        claims = _claims(b) if ev.claims else None
        # a ray of a batch by its index in the batch: two bytes in a batch of up to 65536 rays
        r_type = np.uint16 if len(b.length) <= 1 << 16 else np.int32
        counts = np.zeros(2 * n_hit, np.int64)  # per hit cell: crossings, and those newer than the hits near it
        kept, claimed = [], []
        for lo, hi in _chunks(b.length, cfg):
            ray, k, c = _sample_cells(g, cells, count, lo, hi)
            if claims is not None:
                # per sample by repeating per ray, which streams, where indexing by ray gathers
                claiming = np.repeat(claims[lo:hi], count[lo:hi])
                claimed.append(_blocks(ev, c[claiming]))
            s_ = slot[c]
            in_hit = s_ >= 0
            crossing = np.flatnonzero(in_hit & (k < np.repeat(short[lo:hi], count[lo:hi])))
            r_, c_ = ray[crossing], s_[crossing]  # c_: the hit cell's slot
            # one crossing per ray and cell (a ray's samples in a cell follow one another: a
            # cell is convex); for clearing, only crossings newer than the nearby hits
            first_in_cell = np.ones(len(c_), bool)
            np.not_equal(c_[1:], c_[:-1], out=first_in_cell[1:])
            first_in_cell[1:] |= r_[1:] != r_[:-1]
            j = c_[first_in_cell]
            newer = rank[r_[first_in_cell]] > last_near[j]
            counts += np.bincount(2 * j + newer, minlength=2 * n_hit)
            stop = np.flatnonzero(in_hit if claims is None else in_hit | claiming)
            if len(stop) > cfg.cache * len(ray) / total:
                kept.append((lo, hi))
            else:
                # the cells are worked out again when needed: kept, they were a third of the cache
                kept.append(((lo, hi), ray[stop].astype(r_type), k[stop].astype(k_type)))
        return counts, kept, claimed

    crossed = np.zeros(n_hit, np.int64)
    after_near = np.zeros(n_hit, np.int64)
    ev.samples = []
    ev.claim_block = max(1, int(np.ceil(cfg.no_return_bridge / cfg.cell)))
    claimed = []
    for counts, kept, blocks in _parallel(crossings, range(len(batches))):
        crossed += counts[0::2]
        crossed += counts[1::2]
        after_near += counts[1::2]
        ev.samples.append(kept)
        claimed += blocks
    ev.claimed = np.unique(np.concatenate(claimed)) if claimed else None
    cleared = (after_near >= cfg.clear_crossings) & (after_near > hits_near)
    # a cell hit once or twice but crossed by many times more rays is noise at the edge of
    # something (a mixed pixel, pose jitter, a leg passing), not evidence of standing
    solid = (hits_of_hit >= cfg.solid_hits) | (hits_of_hit >= cfg.block_ratio * crossed)
    ev.occupied = np.zeros(size, bool)
    ev.occupied[hit] = ~cleared & solid
    return ev


def _blocks(ev: Evidence, c: np.ndarray) -> np.ndarray:
    """The blocks (``claim_block`` cells a side, keyed as one int64) that cells ``c`` lie in."""
    ix, iy = ev.cells.xy(c)
    b = ev.claim_block
    key = (iy // b) * (1 << 31) + ix // b
    # a ray's samples run through a block one after another: the repeats go before the sort
    return np.unique(key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key)


def bridged(ev: Evidence, span: float) -> np.ndarray:
    """(cells.size,) bool: occupied, or on the segment between two occupied cells ``span`` or less apart.

    Step 4's evidence for beams with no return. Glass answers a beam now and then, so its
    returns, even from many scans, are points with gaps, and a beam through a gap sees nothing
    within range; joining every two obstacle cells no farther apart than ``span`` (a door's width:
    the spike filter's ``min_gap``) turns the points back into the pane.

    The pairs are taken one displacement (dx, dy) at a time: a real log has millions of them
    (6.5 M on Freiburg, 134 M cells on their segments), which all at once took 2 GB on ACES and
    several on Freiburg; one displacement at a time holds at most one pair per occupied cell.
    A segment's cells are the rounded points at every half cell along its longer axis.

    Only segments that a claiming beam can cross count: both their ends lie within ``span`` of a
    cell such a beam sampled, so within one block (``claim_block`` cells, at least ``span``) of its
    block (``Evidence.claimed``). Indoors few beams claim (Intel: 2.5 % of its beams return
    nothing), and the bridge over all occupied cells was nine tenths of the evidence step.
    """
    ny, nx = ev.shape
    occ = np.flatnonzero(ev.occupied)
    out = ev.occupied.copy()
    if len(occ) < 2:
        return out
    if ev.claimed is not None and span <= ev.claim_block * ev.cell:
        b = ev.claim_block
        ox, oy = ev.cells.xy(occ)
        near = np.zeros(len(occ), bool)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                key = (oy // b + dy) * (1 << 31) + ox // b + dx
                near |= np.isin(key, ev.claimed, assume_unique=False)
        occ = occ[near]
        if len(occ) < 2:
            return out
    kx, ky = segment_cells(*ev.cells.xy(occ), span / ev.cell)
    inside = (kx >= 0) & (kx < nx) & (ky < ny)
    out[ev.cells.index(kx[inside], ky[inside])] = True
    return out


def clip(rays: "Rays | RayBatches", ev: Evidence, cfg: EvidenceConfig = EvidenceConfig()) -> np.ndarray:
    """Each ray's free range, stopped at the first occupied cell in front of its own end (step 4),
    for all rays of all batches in order."""
    batches = batched(rays)
    wide = bridged(ev, cfg.no_return_bridge) if cfg.no_return_bridge > 0 and ev.claims else None
    samples = ev.samples
    ev.samples = None  # used once: give the memory back

    def clipped(i):
        b = batches[i]
        out = b.length.copy()
        g = _grid_rays(b, ev, cfg.step)
        count = _sample_counts(b.length, cfg.step)
        # evidence at the beam's own end is its own return, not a conflict
        own_end = np.where(b.hit, b.hit_range, np.inf) - own_margins(b, cfg.own_margin, cfg.own_incidence)
        for chunk in samples[i] if samples is not None else _chunks(b.length, cfg):
            if len(chunk) == 3:  # kept by gather: the samples that could stop their rays
                _, ray, k = chunk
                c = _cells_of(g, ev.cells, ray, k)
            else:
                ray, k, c = _sample_cells(g, ev.cells, count, *chunk)
            d = k * cfg.step
            occ = ev.occupied[c] if wide is None else np.where(b.hit[ray], ev.occupied[c], wide[c])
            occ &= d < own_end[ray]
            r, dd = ray[occ], d[occ]
            # samples come ray by ray in order of distance: the first of each ray is the nearest
            first = np.flatnonzero(np.r_[True, r[1:] != r[:-1]]) if len(r) else np.zeros(0, np.int64)
            r, dd = r[first], dd[first]
            # a return stops short of the evidence it conflicts with; a no-return beam reaches
            # the surface the bridge stands for
            out[r] = np.minimum(out[r], np.maximum(np.where(b.hit[r], dd - cfg.step, dd), 0.0))
        return out

    parts = list(_parallel(clipped, range(len(batches))))
    return np.concatenate(parts) if parts else np.zeros(0)
