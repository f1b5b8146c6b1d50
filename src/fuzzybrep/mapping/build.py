"""Building a map from scans: the thesis's steps (a)-(g) of section 3.2, then chapter 4.

    beams     = classify every beam of every scan (return, far, no return; spikes cut back)
    evidence  = what all scans saw: time-stamped hits and free crossings; clip rays at obstacles
    polygons  = one scan polygon per scan (Hough or IEPF lines, vertex and edge tables)
    crisp     = union of all scan polygons, minus obstacles it swallowed: principal + holes
    kinds     = each map edge tagged obstacle (a return was seen there) or frontier

``build_map`` reads like that list; each step is a call into the module named for it.
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np
import shapely

from ..arrays import cell_count_text
from ..brep import FRONTIER, OBSTACLE, BRepMap, Ring, rings_to_shapely
from ..errors import GeometryError, ScanValueError
from ..fuzzy.membership import DEFAULT_TME_M
from ..scans.filters import CLIPPED, BeamConfig, classify_all
from ..scans.order import in_scan_order
from ..scans.scan import Scan, named
from . import evidence, union
from .evidence import EvidenceConfig, Rays
from .scan_polygon import PolygonConfig, ScanPolygon, scan_polygons

if TYPE_CHECKING:
    from ..registration.align_scans import AlignConfig, AlignResult


@dataclass(frozen=True)
class BuildConfig:
    """Every knob of the pipeline, with defaults for metric logs (metres)."""

    beams: BeamConfig = field(default_factory=BeamConfig)
    evidence: EvidenceConfig = field(default_factory=EvidenceConfig)
    polygon: PolygonConfig = field(default_factory=PolygonConfig)
    use_evidence: bool = True  #: clip rays against other scans' obstacles (truthful free space)
    min_piece_area: float = 0.05  #: detached free pieces smaller than this are noise (map unit²)
    min_hole_area: float = 0.0  #: holes smaller than this are pruned
    tme: float = DEFAULT_TME_M  #: total maximum error (map unit): the uncertainty the map carries; the thesis's, in metres
    simplify: float | None = None  #: vertex reduction tolerance; None: a quarter of TME
    presimplify: float = 0.01  #: scan polygons are simplified this much before the union (map unit)
    kind_radius: float = 0.1  #: an edge within this of a hit is an obstacle edge, else a frontier
    #: holes bounded by frontier edges alone (pockets no ray entered, no return near) and narrower
    #: than this are no map detail: the free space around them takes them in. None: TME
    pocket_width: float | None = None
    #: runs of beams ending in unknown (no return, or beyond max_usable) narrower than this where
    #: they reach beyond their neighbours are cut back to where they are this wide
    #: (``scans.fingers``): the combs of thin frontier fingers outdoors. None: 2·TME, the band's
    #: width, under which a sliver has no α = 0 inner cut; 0: off
    finger_width: float | None = None
    unit: str = "m"
    #: align every scan to the map so far from its odometry (``registration.align_scans``) and build
    #: from the aligned poses; None: the scans' poses are taken as they are
    align: "AlignConfig | None" = None

    @property
    def pocket_limit(self) -> float:
        return self.tme if self.pocket_width is None else self.pocket_width

    @property
    def finger_limit(self) -> float:
        return 2 * self.tme if self.finger_width is None else self.finger_width

    @property
    def simplify_tolerance(self) -> float:
        """Details finer than a quarter of TME are not justified by the map's uncertainty (5.3)."""
        return self.tme / 4 if self.simplify is None else self.simplify


@dataclass
class BuildResult:
    crisp: BRepMap
    scan_polygons: list[ScanPolygon]
    timings: dict[str, float]
    clipped_beams: int = 0
    beams: int = 0
    notes: list[str] = field(default_factory=list)  #: what the build decided for the user (scan order)
    alignment: "AlignResult | None" = None  #: the aligned poses and their quality, with ``BuildConfig.align``
    scans: "Sequence[Scan] | None" = None  #: the scans at the poses the map was built from

    @property
    def seconds(self) -> float:
        return sum(self.timings.values())


Progress = Callable[[str, int, int], None]
_BATCH = 1024  # scans per batch of scan polygons: large enough to amortise, small enough to report


class _Timer:
    def __init__(self):
        self.t: dict[str, float] = {}

    @contextmanager
    def __call__(self, name: str):
        t0 = time.perf_counter()
        yield
        self.t[name] = self.t.get(name, 0.0) + time.perf_counter() - t0


def build_map(scans: Sequence[Scan], config: BuildConfig = BuildConfig(), progress: Progress | None = None) -> BuildResult:
    """The crisp B-rep map of a sequence of scans at known poses (thesis 3.2 (a)-(g))."""
    if not scans:
        raise ValueError("no scans to build a map from")
    # newer evidence wins: timestamps that cannot say which is newer give way to the scans' order
    scans, order_note = in_scan_order(scans, named(scans))
    timer = _Timer()
    alignment = None
    if config.align is not None:
        from ..registration.align_scans import align_scans, with_poses

        with timer("align"):
            alignment = align_scans(scans, config.align, progress=(lambda d, t: progress("align", d, t)) if progress else None)
            scans = with_poses(scans, alignment.poses)
    with timer("beams"):
        beams = classify_all(scans, config.beams, config.polygon)
    with timer("evidence"):
        if config.use_evidence:
            rays = ray_batches(scans, beams, config.evidence)
            ev = evidence.gather(rays, config.evidence, check_extent(scans, rays, config.evidence.cell, config.unit))
            free = evidence.clip(rays, ev, config.evidence)
        else:
            ev, free = None, np.concatenate([f for f, _ in beams])
        free, status, clipped = _split_free(scans, beams, free)
        near = ev.hits_within(config.kind_radius) if ev is not None else None
        free = trim_fingers(scans, free, status, config.finger_limit, ev, near)
    with timer("scan polygons"):
        polygons = []
        for k in range(0, len(scans), _BATCH):
            sl = slice(k, k + _BATCH)
            polygons += scan_polygons(scans[sl], free[sl], status[sl], config.polygon)
            if progress:
                progress("scan polygons", len(polygons), len(scans))
    with timer("union"):
        polys = rings_to_shapely([p.ring for p in polygons])
        # a centimetre is nothing against TME, and halves what GEOS has to overlay
        geom = union.union(polys, simplify=config.presimplify)
        if ev is not None:
            stood = np.array([s.pose[:2] for s in scans])  # the robot's footprints are not carved
            geom = geom.difference(evidence.carve(geom, ev, config.evidence, stood, config.polygon.footprint))
        geom = union.clean(geom, config.min_piece_area, config.min_hole_area, config.simplify_tolerance)
        if geom.is_empty:
            raise GeometryError(f"{named(scans)} bound no free space with area above {config.min_piece_area:g} "
                                f"{config.unit}² (too few beams with a return, or max_usable "
                                f"{config.beams.max_usable:g} {config.unit} too short)")
        crisp = BRepMap.from_shapely(geom, unit=config.unit)
    with timer("edge kinds"):
        crisp = tag_edge_kinds(crisp, ev, config.kind_radius, near) if ev is not None else crisp
        crisp = fill_pockets(crisp, config.pocket_limit) if ev is not None else crisp
    return BuildResult(crisp, polygons, timer.t, clipped, int(sum(len(s.ranges) for s in scans)),
                       [order_note] if order_note else [], alignment, scans)


def rays_of(scans: Sequence[Scan], beams) -> Rays:
    """All beams of all scans as rays, in time order within each scan's own order.

    Scan.world_angles and Scan.returns, worked out for all the scans' beams at once: the evidence
    makes the rays of every batch of scans three or four times."""
    pose = np.array([s.pose for s in scans], dtype=np.float64).reshape(-1, 3)
    t = np.array([s.timestamp for s in scans], dtype=np.float64)
    per_scan = np.array([len(s.ranges) for s in scans], dtype=np.int64)
    ang = np.repeat(pose[:, 2], per_scan) + np.concatenate([s.bearings for s in scans])
    length = np.concatenate([f for f, _ in beams])
    r = np.concatenate([s.ranges for s in scans])
    hit = (r < np.repeat([s.max_range for s in scans], per_scan)) & (r > 0)
    return Rays(pose[:, 0].copy(), pose[:, 1].copy(), np.cos(ang), np.sin(ang), length, t, hit, r, per_scan)


def ray_batches(scans: Sequence[Scan], beams, cfg: evidence.EvidenceConfig) -> evidence.RayBatches:
    """The rays of consecutive scans, about ``cfg.chunk`` samples of them a batch (a scan is never
    split), each batch made by ``rays_of`` when the evidence asks for it."""
    samples = np.array([evidence.ray_samples(f, cfg.step).sum() for f, _ in beams])
    bounds = [lo for lo, _ in evidence.chunk_bounds(samples, cfg.chunk)] + [len(scans)]

    def make(i: int) -> Rays:
        return rays_of(scans[bounds[i] : bounds[i + 1]], beams[bounds[i] : bounds[i + 1]])

    times = np.array([s.timestamp for s in scans], dtype=np.float64)
    return evidence.RayBatches(make, len(bounds) - 1, times)


#: a log whose returns' median range is farther than this is not in metres (``check_extent``)
MAX_MEDIAN_RANGE = 200.0


def check_extent(scans: Sequence[Scan], rays: "Rays | evidence.RayBatches", cell: float, unit: str = "m"):
    """The evidence grid's frame (``evidence.grid_frame``) over ``rays``, for ``evidence.gather``.

    ScanValueError naming the scan (and the beam) that lies farthest out when the grid would hold
    more than evidence.MAX_CELLS cells or evidence.MAX_SIDE a side (farthest from the median scan position), or reach beyond
    evidence.MAX_CELLS_FROM_ZERO cells (farthest from (0, 0)): a corrupt range or pose otherwise
    ended in NumPy failing to allocate terabytes, or an IndexError."""
    frame = origin, nx, ny = evidence.grid_frame(rays, cell)
    reach = max(np.abs(origin).max(), abs(origin[0] + nx * cell), abs(origin[1] + ny * cell))
    if nx * ny > evidence.MAX_CELLS or max(nx, ny) > evidence.MAX_SIDE:
        centre, where = np.median([s.pose[:2] for s in scans], axis=0), "the median scan position"
        why = f"an evidence grid of about {cell_count_text(nx)} × {cell_count_text(ny)} cells at {cell:g} {unit} " \
              f"(limit {evidence.MAX_CELLS}, {evidence.MAX_SIDE} a side) would hold it"
    elif reach > evidence.MAX_CELLS_FROM_ZERO * cell:
        centre, where = np.zeros(2), "(0, 0)"
        why = f"a float places a {cell:g} {unit} cell of the evidence grid only within " \
              f"±{evidence.MAX_CELLS_FROM_ZERO * cell:.3g} {unit} of (0, 0)"
    else:
        ranges = np.concatenate([s.ranges[s.returns] for s in scans]) if scans else np.zeros(0)
        median = float(np.median(ranges)) if len(ranges) else 0.0
        if median <= MAX_MEDIAN_RANGE or unit != "m":
            return frame
        # no 2-D laser's returns lie hundreds of metres off in the middle: a log in millimetres
        # (whose frame the limits above no longer catch: a site kilometres across is legal)
        raise ScanValueError(named(scans), None, f"the median range of the returns is {median:.4g} {unit}, over "
                                                 f"{MAX_MEDIAN_RANGE:g} {unit}: are the ranges corrupt, or the log not in metres?")
    what, d, source = farthest_out(scans, centre)
    # a log in millimetres lands here too (every setting of the build is metric): say so
    raise ScanValueError(source, None, f"{what} lies {d:.3g} {unit} from {where}: {why}; is the range or the pose corrupt, "
                                       f"or the log not in metres?")


def farthest_out(scans: Sequence[Scan], centre) -> tuple[str, float, str]:
    """What of the scans lies farthest from ``centre``, for a message on a map or grid too large to
    hold: (the scan's position or one beam's return, its distance, the scan's source). A corrupt
    range or pose is usually that one thing."""
    best = (-1.0, 0, None, -1.0)
    for k, s in enumerate(scans):
        d_pose = float(np.hypot(*(s.pose[:2] - centre)))
        d_hit = np.hypot(*(s.endpoints()[s.returns] - centre).T)
        i = int(np.argmax(d_hit)) if len(d_hit) else None
        d = max(d_pose, float(d_hit[i]) if i is not None else -1.0)
        # a tie (two scans, or the median halfway between two: -1e308 in scan 2 put both 5e307
        # from it, and scan 1 was blamed) goes to the one farther from (0, 0), where a corrupt
        # number lands; ties are within a relative 1e-9
        from_zero = float(np.hypot(*s.pose[:2]))
        if d > best[0] * (1 + 1e-9) or (d >= best[0] * (1 - 1e-9) and from_zero > best[3]):
            # the scan itself lies far out, not just what one beam saw
            beam = None if i is None or d_pose >= d_hit[i] / 2 else int(np.flatnonzero(s.returns)[i])
            best = (d, k, beam, from_zero)
    d, k, beam, _ = best
    s = scans[k]
    what = f"the scan's position ({s.pose[0]:g}, {s.pose[1]:g})" if beam is None else f"beam {beam + 1}'s return"
    return what, d, s.source or f"scan {k}"


def _split_free(scans, beams, free: np.ndarray):
    """Per-scan free ranges and statuses after clipping; beams shortened by evidence are CLIPPED."""
    out_f, out_s, clipped, i = [], [], 0, 0
    for s, (f0, st0) in zip(scans, beams):
        n = len(s.ranges)
        f = free[i : i + n]
        cut = f < f0 - 1e-9
        st = np.where(cut, CLIPPED, st0).astype(st0.dtype)
        clipped += int(cut.sum())
        out_f.append(f)
        out_s.append(st)
        i += n
    return out_f, out_s, clipped


def trim_fingers(scans, free: list, status: list, width: float, ev: "evidence.Evidence | None" = None,
                 near: np.ndarray | None = None) -> list:
    """Per scan, the free ranges with frontier fingers narrower than ``width`` cut back
    (``scans.fingers``); scans with one beam count go together. With the evidence and its cells
    near a hit (``near``), a beam the evidence clipped counts as ending in unknown where no hit
    lies near its end."""
    if width <= 0:
        return free
    from ..scans.fingers import finger_levels, open_ended

    out = list(free)
    groups: dict[int, list[int]] = {}
    for k, s in enumerate(scans):
        groups.setdefault(len(s.ranges), []).append(k)
    for idx in groups.values():
        f, st = np.stack([free[k] for k in idx]), np.stack([status[k] for k in idx])
        b = np.stack([scans[k].bearings for k in idx])
        open_end = open_ended(st)
        if ev is not None and near is not None:
            r, c = np.nonzero(st == CLIPPED)  # a beam's own return is a hit at its end: never open
            pose = np.array([scans[k].pose for k in idx], dtype=np.float64)[r]
            ang = pose[:, 2] + b[r, c]
            end = pose[:, :2] + f[r, c, None] * np.column_stack((np.cos(ang), np.sin(ang)))
            open_end[r, c] = ~near[ev.cell_index(end[:, 0], end[:, 1])]
        levels = finger_levels(f, open_end, b, width)
        for j, k in enumerate(idx):
            out[k] = levels[j]
    return out


def tag_edge_kinds(crisp: BRepMap, ev: evidence.Evidence, radius: float, near: np.ndarray | None = None) -> BRepMap:
    """Obstacle where a return was seen along the edge, frontier where none was (issue: kinds).

    An edge is an obstacle edge if at least two of three points along it (quarter, middle,
    three quarters) lie within ``radius`` of a hit.
    """
    rings = crisp.rings
    v = np.vstack([r.vertices for r in rings])
    w = np.vstack([np.roll(r.vertices, -1, axis=0) for r in rings])
    near = ev.hits_within(radius) if near is None else near
    votes = np.zeros(len(v), np.int64)
    for q in (0.25, 0.5, 0.75):
        p = v + q * (w - v)
        votes += near[ev.cell_index(p[:, 0], p[:, 1])]
    kinds = np.where(votes >= 2, OBSTACLE, FRONTIER).astype(np.uint8)
    out, i = [], 0
    for r in rings:
        out.append(Ring(r.vertices, kinds[i : i + len(r)], r.fm))
        i += len(r)
    return crisp.with_rings(out)


def fill_pockets(crisp: BRepMap, width: float) -> BRepMap:
    """The map without its unknown pockets narrower than ``width``: holes whose every edge is a
    frontier (no return within ``kind_radius`` of it: nothing was seen there, it is only where
    no ray went) and that a disc of diameter ``width`` does not fit in.

    Outdoors they are most of the map's holes: the thin shadows between rays that passed trees,
    railings, parked bikes (908 of Freiburg campus's 4389 holes). Narrower than the map's
    uncertainty, they are no detail the map can vouch for either way; what bounds an obstacle
    (an obstacle edge) is never taken away.
    """
    if width <= 0:
        return crisp
    regions = []
    for region in crisp.regions:
        holes = region.holes
        unknown = np.array([bool((h.kinds == FRONTIER).all()) for h in holes], bool)
        if unknown.any():
            idx = np.flatnonzero(unknown)
            polys = rings_to_shapely([holes[i] for i in idx])
            narrow = shapely.is_empty(shapely.buffer(polys, -width / 2, quad_segs=2))
            drop = set(idx[narrow].tolist())
            holes = tuple(h for i, h in enumerate(holes) if i not in drop)
        regions.append(replace(region, holes=holes))
    return BRepMap(tuple(regions), crisp.unit)
