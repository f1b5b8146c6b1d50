"""Judging a map against laser endpoints: is each endpoint where the map says a boundary may be?

For a set of scans (the held-out ones, or all of them) every endpoint with a return closer than
``max_range`` is put in one of three classes against the map's fuzzy boundary:

* explained: inside the support band (between the inner and outer polygon at α = 0);
* violation: inside the safe inner region at α = 0, where the map promises free space with
  full confidence: an obstacle where the map says there is none;
* beyond: outside the outer polygon at α = 0, past everything the map knows.

``holdout`` builds the map from all scans but every K-th and scores the held-out ones: the map
must predict scans it has not seen. Two diagnostics say what the violations are: those on small
isolated objects (legs, people, poles, judged from the held-out scan alone), and those where no
kept scan saw any return within TME, which no map of the kept scans could know (a person who
passed by between two kept scans). A third says which violations the map is right about: those
that came and went, where beams of kept scans passed more than TME beyond the endpoint both
before and after the held-out scan saw something there. The rest (``violations_rest``) is what
a better map of the kept scans could have avoided, or something kept scans saw stand and then
saw through (the map keeps the newest evidence). For the endpoints beyond the map, ``beyond_seen``
says which a kept scan saw a return within TME of: what a map of the kept scans could have
explained (the rest no map of them could, short of inventing a surface).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import shapely

from ..errors import ScanValueError
from ..mapping.scan_polygon import PolygonConfig
from ..scans.filters import classify_all, depth_continuous
from ..scans.order import in_scan_order
from ..scans.scan import Scan, named

#: ``seen_free`` looks at about this many (scan, point) pairs at a time, about 120 bytes each at
#: its peak (30 MB); 4 000 000 took 430 MB, and more time, not less
_PAIRS = 250_000


@dataclass(frozen=True)
class EndpointScore:
    endpoints: int
    explained: float
    violations: float
    beyond: float
    #: per point: inside the safe inner region (a violation); None when there are no points
    violated: np.ndarray | None = field(default=None, repr=False, compare=False)
    #: per point: outside the outer polygon (beyond the map); None when there are no points
    outside: np.ndarray | None = field(default=None, repr=False, compare=False)

    def as_dict(self) -> dict:
        return {"endpoints": self.endpoints, "explained": self.explained, "violations": self.violations, "beyond": self.beyond}


def scored(scan: Scan, max_range: float) -> np.ndarray:
    """(n,) bool: the beams whose endpoints are scored, returns closer than max_range."""
    return scan.returns & (scan.ranges < max_range)


def endpoints(scans: Sequence[Scan], max_range: float = 5.0) -> np.ndarray:
    """(m, 2) world coordinates of every return closer than max_range."""
    pts = [s.endpoints()[scored(s, max_range)] for s in scans]
    return np.vstack(pts) if pts else np.zeros((0, 2))


def small_objects(scans: Sequence[Scan], max_range: float = 5.0, max_extent: float = 0.5,
                  polygon: PolygonConfig = PolygonConfig()) -> np.ndarray:
    """For every endpoint ``endpoints`` returns: does it lie on a small isolated object?

    A run of beams on one surface (no depth jump between neighbours, as scan polygons split
    them) less than ``max_extent`` across and nearer than the beams on both sides: a leg, a
    pole, a person. Judged from the scan alone, so it says what kind of thing was seen, not
    whether the map knew it. polygon: the scan polygons' configuration (its depth-jump test).
    """
    out = []
    for s in scans:
        r, ret, b = s.ranges, s.returns, s.bearings
        n = len(r)
        cont = depth_continuous(r[:-1], r[1:], np.diff(b), polygon) & ret[:-1] & ret[1:]  # beam i and i + 1
        k = 0  # the beam the segments are counted from
        if s.full_circle:
            # a 360° scan has no ends: count from a depth jump, so the seam splits no surface
            seam = depth_continuous(r[-1:], r[:1], b[:1] + 2 * np.pi - b[-1:], polygon) & ret[-1:] & ret[:1]
            ring = np.concatenate((cont, seam))  # beam i and i + 1 mod n
            if ring.all():  # one surface all round
                out.append(np.zeros(int(scored(s, max_range).sum()), bool))
                continue
            k = (int(np.argmin(ring)) + 1) % n
            cont, r, ret = np.roll(ring, -k)[:-1], np.roll(r, -k), np.roll(ret, -k)
        seg = np.concatenate(([0], np.cumsum(~cont)))  # segment id of every beam
        first = np.flatnonzero(np.r_[True, seg[1:] != seg[:-1]])
        last = np.r_[first[1:] - 1, n - 1]
        e = np.roll(s.endpoints(), -k, axis=0)
        extent = np.hypot(*(e[last] - e[first]).T)
        # the beam before a segment and after it (a 360° scan wraps round; a 180° one has none)
        prev = np.where(first > 0, first - 1, n - 1 if s.full_circle else -1)
        nxt = np.where(last < n - 1, last + 1, 0 if s.full_circle else -1)
        before = np.where((prev >= 0) & ret[prev], r[prev], np.inf)
        after = np.where((nxt >= 0) & ret[nxt], r[nxt], np.inf)
        small = (extent < max_extent) & (before > r[first]) & (after > r[last]) & (last - first + 1 < n)
        small = np.roll(small[seg], k)
        out.append(small[scored(s, max_range)])
    return np.concatenate(out) if out else np.zeros(0, bool)


def seen_near(points: np.ndarray, scans: Sequence[Scan], distance: float) -> np.ndarray:
    """Per point: did any of ``scans`` see a return within ``distance`` of it?

    For a held-out endpoint in the safe region this separates what the map could have known
    (another scan saw something there) from what no scan but its own ever saw (a person passing).
    """
    from scipy.spatial import cKDTree

    seen = endpoints(scans, np.inf) if len(points) else np.zeros((0, 2))
    if len(seen) == 0:
        return np.zeros(len(points), bool)
    return cKDTree(seen).query(points, distance_upper_bound=distance)[0] <= distance


def seen_free(points: np.ndarray, times: np.ndarray, scans: Sequence[Scan], free: Sequence[np.ndarray],
              margin: float) -> tuple[np.ndarray, np.ndarray]:
    """Per point, (before, after): did a scan earlier / later than the point's time see it free?

    A scan sees a point free when the point lies within half a beam spacing (the median) of the
    beam on either side of it (on the beam, for a scan of one) and that beam's free range
    (``free``: per scan, as the map used it, e.g. after the spike filter) reaches ``margin`` or
    more beyond it. Seen free both before and after, an endpoint is something that came and
    went: a person walking by, a door that opened and closed.
    """
    before = np.zeros(len(points), bool)
    after = np.zeros(len(points), bool)
    if not len(points):
        return before, after
    groups: dict[bytes, list[int]] = {}  # scans with the same beams are looked at together
    for k, s in enumerate(scans):
        if len(s.bearings):
            groups.setdefault(s.bearings.tobytes(), []).append(k)
    chunk = max(1, _PAIRS // len(points))  # scans at a time
    for idx in groups.values():
        b = scans[idx[0]].bearings
        n = len(b)
        half = 0.5 * float(np.median(np.diff(b))) if n > 1 else 0.0
        turn = np.append(b, b[0] + 2 * np.pi)
        for lo in range(0, len(idx), chunk):
            part = idx[lo : lo + chunk]
            pose = np.stack([scans[k].pose for k in part])
            f = np.stack([free[k] for k in part])
            dx = points[None, :, 0] - pose[:, None, 0]
            dy = points[None, :, 1] - pose[:, None, 1]
            dist = np.hypot(dx, dy)
            # only the (scan, point) pairs within reach of the scan's longest beam
            si, pi = np.nonzero(dist + margin <= f.max(axis=1)[:, None])
            dist = dist[si, pi]
            # bearing of each point in its scan's frame, in [b0, b0 + 2π), and the beam on either
            # side of it (a point half way between two is as near to both); above the last beam
            # the one on the other side is the first, a turn on (a 360° scan's seam)
            rel = (np.arctan2(dy[si, pi], dx[si, pi]) - pose[si, 2] - b[0]) % (2 * np.pi) + b[0]
            above = np.searchsorted(turn, rel)
            below = np.maximum(above - 1, 0)
            reach = dist + margin
            passed = np.zeros(len(si), bool)
            for j, off in ((below, rel - turn[below]), (above, turn[above] - rel)):
                passed |= (off <= half) & (f[si, j % n] >= reach)
            t = np.array([scans[k].timestamp for k in part])[si]
            before[pi[passed & (t < times[pi])]] = True
            after[pi[passed & (t > times[pi])]] = True
    return before, after


def seen_through(points: np.ndarray, scans: Sequence[Scan], free: Sequence[np.ndarray], margin: float) -> np.ndarray:
    """Per point: did a beam of ``scans`` pass it by more than ``margin`` (``seen_free`` at any
    time, ``free`` the scans' free ranges as ``spike_free`` gives them)? An obstacle there that
    none of them saw within ``margin`` was not there for them: a map true to those scans calls
    the place free."""
    before, _ = seen_free(points, np.full(len(points), np.inf), scans, free, margin)
    return before


def spike_free(scans: Sequence[Scan], config) -> list[np.ndarray]:
    """Every scan's free ranges as the map uses them before evidence (``config``'s spike filter)."""
    return [f for f, _ in classify_all(scans, config.beams, config.polygon)]


def came_and_went(points: np.ndarray, times: np.ndarray, scans: Sequence[Scan], config, margin: float,
                  free: Sequence[np.ndarray] | None = None) -> np.ndarray:
    """Per point: seen free by ``scans`` both before and after its time (``seen_free``), with the
    free ranges the map uses (``config``'s spike filter), beams passing ``margin`` or more beyond.

    For points of the scans themselves (a map judged on its own endpoints) the point's own scan
    counts neither way: it is neither before nor after its own time.
    """
    free = spike_free(scans, config) if free is None else free  # (``free``: already worked out)
    before, after = seen_free(points, times, scans, free, margin)
    return before & after


def endpoint_times(scans: Sequence[Scan], max_range: float = 5.0) -> np.ndarray:
    """The time stamp of every endpoint ``endpoints`` returns, in the same order."""
    return np.repeat([s.timestamp for s in scans], [int(scored(s, max_range).sum()) for s in scans])


def score(points: np.ndarray, safe, outer) -> EndpointScore:
    """Classify points against the safe inner region and the outer polygon at α = 0."""
    shapely.prepare(safe)
    shapely.prepare(outer)
    n = len(points)
    if n == 0:
        return EndpointScore(0, float("nan"), float("nan"), float("nan"))
    inside_safe = shapely.contains_xy(safe, points[:, 0], points[:, 1])
    inside_outer = shapely.intersects_xy(outer, points[:, 0], points[:, 1])
    v = float(inside_safe.mean())
    b = float((~inside_outer).mean())
    return EndpointScore(n, 1.0 - v - b, v, b, inside_safe, ~inside_outer)


def band_by_buffer(free, tme_in: float, tme_out: float | None = None):
    """(safe, outer) of a crisp free-space geometry by exact offsetting (Extension principle).

    safe = free space shrunk by tme_in; outer = free space grown by tme_out.
    """
    tme_out = tme_in if tme_out is None else tme_out
    return shapely.buffer(free, -tme_in), shapely.buffer(free, tme_out)


def holdout_split(scans: Sequence[Scan], k: int) -> tuple[list[Scan], list[Scan]]:
    """(map scans, held-out scans): every k-th scan (k = 2: every second) is held out."""
    if k < 2:
        raise ValueError(f"holdout K must be at least 2, got {k}")
    held = list(scans[k - 1 :: k])
    kept = [s for i, s in enumerate(scans) if (i + 1) % k != 0]
    return kept, held


def ordinal(k: int) -> str:
    """"second", "third", "4th", "21st": how every k-th scan is named in messages."""
    if k in (2, 3):
        return "second" if k == 2 else "third"
    return f"{k}{'th' if 10 <= k % 100 <= 20 else {1: 'st', 2: 'nd', 3: 'rd'}.get(k % 10, 'th')}"


@dataclass
class Evaluation:
    """``fuzzybrep evaluate``: a map built without every K-th scan, judged on those scans."""

    holdout: int
    scans_used: int
    scans_held_out: int
    exact: EndpointScore  # against the Extension-principle band (exact ±TME offsets)
    violations_on_small_objects: float  # share of held-out endpoints: exact violations on legs, people, poles
    #: share of held-out endpoints: exact violations with no return of any kept scan within TME.
    #: No map of the kept scans could avoid these without inventing an obstacle nobody saw.
    violations_unseen: float
    #: share of held-out endpoints: exact violations that came and went, seen free by kept scans
    #: (beams passing more than TME beyond) both before and after: the map is right to call them free
    violations_came_and_went: float
    #: share of held-out endpoints: exact violations neither unseen nor come and gone: a kept scan
    #: saw a return within TME, and the map promises free space (wrongly, or it was seen to go)
    violations_rest: float
    safe: EndpointScore  # against the default (safe) α-cut's band
    thesis: EndpointScore  # against the thesis's sweep band
    free_iou: float  # crisp free space vs the occupancy grid's free cells
    map_bytes_compact: int
    map_bytes_thesis: int
    grid_bytes: int  # the 5 cm (or given) grid, 4 bytes a cell as in Table 5.3
    grid_cells: int
    resolution: float
    seconds: float
    notes: list = field(default_factory=list)  #: what the evaluation decided (the scans' order)
    #: share of the held-out scans' sensor positions inside the crisp free space (the robot's own track)
    held_poses_free: float = math.nan
    #: share of held-out endpoints: unseen violations (``violations_unseen``) that a kept beam
    #: passed more than TME beyond: free for every map true to the kept scans, whatever its method
    violations_seen_through: float = math.nan
    #: share of held-out endpoints: beyond the exact band's outer polygon although a kept scan saw
    #: a return within TME of them: what a map of the kept scans could have explained (a room seen
    #: through a door the spike filter cut back, a surface behind the first one others saw)
    beyond_seen: float = math.nan

    def as_dict(self) -> dict:
        """The JSON form. An undefined IoU (NaN: no free space in either at the cell centres) is
        None, JSON's null: json.dumps would write NaN, which is not JSON."""
        d = {k: None if isinstance(v, float) and math.isnan(v) else v
             for k, v in self.__dict__.items() if not isinstance(v, EndpointScore)}
        d["exact"], d["safe"], d["thesis"] = self.exact.as_dict(), self.safe.as_dict(), self.thesis.as_dict()
        return d


def free_space_iou(free, grid) -> float:
    """Intersection over union of a map's free space and a grid's free cells (cell centres)."""
    ny, nx = grid.shape
    x0, y0 = grid.origin
    r = grid.resolution
    cx = x0 + (np.arange(nx) + 0.5) * r
    cy = y0 + (np.arange(ny) + 0.5) * r
    X, Y = np.meshgrid(cx, cy)
    shapely.prepare(free)
    in_map = shapely.contains_xy(free, X.ravel(), Y.ravel()).reshape(ny, nx)
    in_grid = grid.free()
    union = np.logical_or(in_map, in_grid).sum()
    return float(np.logical_and(in_map, in_grid).sum() / union) if union else float("nan")


#: what ``evaluate_log`` does, in order: the steps its ``progress`` is told of
EVALUATION_STEPS = ("building the map from the kept scans", "fuzzifying it", "scoring the held-out endpoints",
                    "small isolated objects", "returns no kept scan saw", "what came and went",
                    "the occupancy grid of the kept scans")


def evaluate_log(scans: Sequence[Scan], holdout: int = 2, config=None, tme: float | None = None,
                 resolution: float = 0.05, max_range: float = 5.0, progress=None) -> Evaluation:
    """Build from all scans but every ``holdout``-th and score the held-out ones (see module doc).

    The band is the map's support at α = 0: the exact one (the Extension principle), the
    default safe α-cut's (which holds the exact one) and the thesis's sweep approximation, all
    from the same fuzzy map. ScanValueError, before any map
    is built, if no held-out endpoint is left to score (every rate would be 0/0).
    """
    import time

    from ..fuzzy.map import fuzzify
    from ..fuzzy.memory import compact_bytes, memory_table
    from ..mapping.build import BuildConfig, build_map
    from ..mapping.grid import occupancy_grid

    config = config or BuildConfig()
    tme = config.tme if tme is None else tme
    t0 = time.perf_counter()
    # came and went, like the evidence, needs the order the scans were taken in (``scans.order``)
    scans, order_note = in_scan_order(scans, named(scans))
    kept, held = holdout_split(scans, holdout)
    if not held:
        raise ScanValueError(None, None, f"{len(scans)} scan(s): holding out every {ordinal(holdout)} leaves none to "
                                         f"score" + (f"; give --holdout 2 to {len(scans)}" if len(scans) >= 2 else ""))
    pts = endpoints(held, max_range)
    if not len(pts):
        raise ScanValueError(None, None, f"no held-out scan has a return within {max_range:g} m: nothing to score")
    step = iter(EVALUATION_STEPS)
    tell = (lambda: progress(next(step))) if progress else (lambda: None)  # noqa: E731
    tell()
    crisp = build_map(kept, config).crisp
    tell()
    fz = fuzzify(crisp, tme=tme)
    tell()
    scores = {}
    for method in ("exact", "safe", "thesis"):
        cut = fz.alpha_cut(0.0, method)
        scores[method] = score(pts, cut.inner, cut.outer)
    viol = scores["exact"].violated
    tell()
    on_small = float((viol & small_objects(held, max_range, polygon=config.polygon)).mean())
    tell()
    # asked of the violations and the endpoints beyond the map only, in one look-up
    outside = scores["exact"].outside
    seen = np.zeros(len(pts), bool)
    seen[viol | outside] = seen_near(pts[viol | outside], kept, tme)
    unseen = ~seen[viol]
    beyond_seen = seen & outside
    tell()
    kept_free = spike_free(kept, config)  # came and went and seen through ask the same beams
    went = came_and_went(pts[viol], endpoint_times(held, max_range)[viol], kept, config, tme, kept_free)
    through = seen_through(pts[viol][unseen], kept, kept_free, tme)
    share = lambda v: float(v.sum() / len(pts))  # noqa: E731  (of all held-out endpoints)
    tell()
    grid = occupancy_grid(kept, resolution, max_usable=config.beams.max_usable)
    free = crisp.to_shapely()
    iou = free_space_iou(free, grid)
    xy = np.array([s.pose[:2] for s in held])
    poses_free = float(shapely.contains_xy(free, xy[:, 0], xy[:, 1]).mean())
    thesis = memory_table(crisp.n_vertices, crisp.n_vertices, 0.0, cells=())[0].bytes  # Table 5.3's accounting
    return Evaluation(holdout, len(kept), len(held), scores["exact"], on_small, share(unseen), share(went),
                      share(~unseen & ~went), scores["safe"], scores["thesis"], iou, compact_bytes(fz), thesis,
                      grid.nbytes(4), grid.cells, resolution, time.perf_counter() - t0,
                      [order_note] if order_note else [], poses_free, share(through), share(beyond_seen))
