"""Ground truth for simulated runs: how a map's geometry compares with the world it was built in.

Pure geometry: walls and regions are shapely geometries in the world's unit (metres). A map
enters as its crisp free space, its support band (outer(0) minus inner(0)) and its safe inner
region (inner(0)); the world as ``World``; what the robot could see as its true sensor poses and
the laser. Section 5.3's claim, "the support (μ = 0) of boundaries of the fuzzy B-rep map ...
enclosed the floor plan boundary", becomes ``support_coverage`` = 1 and ``unsafe_wall_length`` = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from .simulate import Laser, World, cast_rays


def seen_walls(world: World, poses: np.ndarray, laser: Laser | None = None, glass: str = "opaque") -> shapely.MultiLineString:
    """The wall the robot saw: pieces of wall between two neighbouring beams of one scan that both
    hit the same wall segment within range (noise-free beams from the true sensor poses (S, 3)).

    glass: "opaque" counts glass as a wall the beams stop at (so a map that looked through it
    misses it); "transparent" lets every beam through glass, which is then never seen.
    """
    if glass not in ("opaque", "transparent"):
        raise ValueError(f"glass must be opaque or transparent, got {glass!r}")
    laser = laser or Laser()
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    n = laser.n_beams
    origins = np.repeat(poses[:, :2], n, axis=0)
    angles = (poses[:, 2:3] + laser.bearings).ravel()
    t, idx = cast_rays(world, origins, angles, laser.max_range,
                       glass_pass=1.0 if glass == "transparent" else 0.0, rng=np.random.default_rng(0))
    hits = origins + np.where(np.isfinite(t), t, 0.0)[:, None] * np.column_stack((np.cos(angles), np.sin(angles)))
    seg = world.segments
    safe = np.maximum(idx, 0)
    p, e = seg[safe, :2], seg[safe, 2:] - seg[safe, :2]
    u = np.clip(np.sum((hits - p) * e, axis=1) / np.sum(e * e, axis=1), 0.0, 1.0)  # position along the segment
    idx, u = idx.reshape(-1, n), u.reshape(-1, n)
    pair = (idx[:, :-1] == idx[:, 1:]) & (idx[:, :-1] >= 0)
    ids = idx[:, :-1][pair]
    lo = np.minimum(u[:, :-1][pair], u[:, 1:][pair])
    hi = np.maximum(u[:, :-1][pair], u[:, 1:][pair])
    ids, lo, hi = _merge_intervals(ids, lo, hi)
    keep = hi > lo
    ids, lo, hi = ids[keep], lo[keep], hi[keep]
    p, e = seg[ids, :2], seg[ids, 2:] - seg[ids, :2]
    a, b = p + lo[:, None] * e, p + hi[:, None] * e
    return shapely.MultiLineString(list(np.stack((a, b), axis=1))) if len(ids) else shapely.MultiLineString()


def _merge_intervals(ids: np.ndarray, lo: np.ndarray, hi: np.ndarray):
    """Union of intervals [lo, hi] ⊂ [0, 1] on each segment id: one interval per connected piece."""
    if len(ids) == 0:
        return ids, lo, hi
    order = np.lexsort((lo, ids))
    ids, lo, hi = ids[order], lo[order], hi[order]
    # offsetting by 2·id keeps the running maximum from leaking from one segment into the next;
    # the offset costs a few bits, hence the tolerance for intervals that just touch
    reach = np.maximum.accumulate(hi + 2.0 * ids) - 2.0 * ids
    start = np.ones(len(ids), dtype=bool)
    start[1:] = (ids[1:] != ids[:-1]) | (lo[1:] > reach[:-1] + 1e-9)
    first = np.flatnonzero(start)
    return ids[first], lo[first], np.maximum.reduceat(hi, first)


def length_inside(lines, region) -> float:
    """Length of ``lines`` in the interior of ``region`` (lying along its boundary does not count)."""
    inside = shapely.intersection(lines, region)
    return float(inside.length - shapely.intersection(inside, shapely.boundary(region)).length)


def fraction_inside(lines, region) -> float:
    """Fraction of the length of ``lines`` in ``region``, boundary included; NaN for no length."""
    total = shapely.length(lines)
    return float(shapely.intersection(lines, region).length / total) if total > 0 else math.nan


def fraction_within(lines, truth, distance: float) -> float:
    """Fraction of the length of ``lines`` no farther than ``distance`` from ``truth``; NaN for no length."""
    total = shapely.length(lines)
    if total == 0:
        return math.nan
    return float(shapely.intersection(lines, shapely.buffer(truth, distance)).length / total)


def hausdorff(a, b, step: float = 0.02) -> float:
    """Hausdorff distance between two geometries, from points every ``step`` along both.

    GEOS's own measures only vertices; densifying makes the result exact to within step/2.
    """
    if shapely.is_empty(a) or shapely.is_empty(b):
        return math.inf
    pa = shapely.points(shapely.get_coordinates(shapely.segmentize(a, step)))
    pb = shapely.points(shapely.get_coordinates(shapely.segmentize(b, step)))
    shapely.prepare(a)
    shapely.prepare(b)
    return float(max(shapely.distance(pa, b).max(), shapely.distance(pb, a).max()))


@dataclass(frozen=True)
class TruthScore:
    """How a map's geometry compares with the simulated world (lengths in metres).

    seen_wall_length     length of wall the robot saw (``seen_walls``).
    support_coverage     fraction of it inside the support band (thesis 5.3: should be 1).
    unsafe_wall_length   length of any true wall inside the safe inner region (must be 0).
    boundary_within_tme  fraction of the crisp boundary within TME of a true wall.
    hausdorff            Hausdorff distance between the crisp boundary and the seen walls.
    """

    seen_wall_length: float
    support_coverage: float
    unsafe_wall_length: float
    boundary_within_tme: float
    hausdorff: float


def score(world: World, true_poses: np.ndarray, crisp_free, support_band, safe_inner, tme: float,
          laser: Laser | None = None) -> TruthScore:
    """Score a map against the world: crisp_free, support_band and safe_inner are shapely
    (Multi)Polygons in metres, tme in metres (the thesis's 199.13 mm is 0.19913)."""
    return score_cuts(world, seen_walls(world, true_poses, laser), crisp_free, [(support_band, safe_inner)], tme)[0]


def score_cuts(world: World, seen, crisp_free, cuts, tme: float) -> list[TruthScore]:
    """``score`` for several cuts of one map, each a (support_band, safe_inner) pair, given its
    seen walls (``seen_walls``): what depends on the crisp boundary alone (boundary_within_tme,
    hausdorff) is computed once for all of them."""
    boundary = shapely.boundary(crisp_free)
    within = fraction_within(boundary, world.walls, tme)
    h = hausdorff(boundary, seen)
    return [TruthScore(
        seen_wall_length=float(seen.length),
        support_coverage=fraction_inside(seen, support_band),
        unsafe_wall_length=length_inside(world.walls, safe_inner),
        boundary_within_tme=within,
        hausdorff=h,
    ) for support_band, safe_inner in cuts]
