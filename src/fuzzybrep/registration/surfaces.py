"""The local map of ``registration.align_scans``: every scan's returns joined into surface segments
in its own frame, placed in the world at a pose on demand, and indexed (``segment_match.SegmentIndex``)."""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..scans.scan import Scan
from .config import HEADING_FLOOR, POSE_FLOOR, AlignConfig
from .correlative import LikelihoodField
from .segment_match import SegmentIndex, sample_segments


def scan_points(scan: Scan, max_range: float) -> tuple[np.ndarray, np.ndarray]:
    """(points (n, 2) in the sensor frame, joinable (n - 1,) bool) of a scan's returns within
    ``max_range``: joinable[i] says points i and i + 1 are consecutive beams."""
    r, b = scan.ranges, scan.bearings
    ok = scan.returns & (r <= max_range)
    idx = np.flatnonzero(ok)
    pts = np.column_stack((r[idx] * np.cos(b[idx]), r[idx] * np.sin(b[idx])))
    return pts, np.diff(idx) == 1


def surface_segments(points: np.ndarray, joinable: np.ndarray, beam_step: float, join: float) -> tuple[np.ndarray, np.ndarray]:
    """(a, b) segments joining consecutive returns that lie on one surface: closer than join + 3 ×
    beam_step × range (a surface seen at a grazing angle still joins; a jump in range does not)."""
    if len(points) < 2:
        return np.zeros((0, 2)), np.zeros((0, 2))
    a, b = points[:-1], points[1:]
    gap = np.hypot(*(b - a).T)
    reach = join + 3 * beam_step * np.minimum(np.hypot(*a.T), np.hypot(*b.T))
    keep = joinable & (gap <= reach)
    return a[keep], b[keep]


class _Lazy:
    """A read-only sequence whose item k is ``make(k)``, made on first access and kept."""

    def __init__(self, make, n: int):
        self._make, self._n, self._made = make, n, {}

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, k: int):
        if k < 0:
            k += self._n
        if not 0 <= k < self._n:
            raise IndexError(k)
        got = self._made.get(k)
        if got is None:
            got = self._made[k] = self._make(k)
        return got


class _Surfaces:
    """Every scan's surface segments in its own frame, made once, placed at a pose on demand.

    A scan's placed segments (ends, directions, lengths, samples) are kept for the pose they were
    placed at: the front end's local map changes by one key scan at a time and the loop closure
    and the refinement ask for the same places again, so only a scan whose pose has changed (the
    pose graph moved it) is placed again; an index is made of the pieces as they are."""

    def __init__(self, scans: Sequence[Scan], cfg: AlignConfig):
        self.points, self._joinable, self._steps = [], [], []
        for s in scans:
            p, j = scan_points(s, cfg.max_range)
            if len(p) < cfg.sparse_share * len(s.ranges) and cfg.far_range > cfg.max_range:
                # outdoors most beams see nothing near (sky, open plazas; buildings 20 m and more
                # away): what lies within max_range is too little to match (freiburg-campus with
                # the benchmark's drift: 13.7 m RMSE at 15 m, 1.7 m with 30 m). Indoors no scan of the
                # shared logs has so few returns near, so their alignment is unchanged
                p, j = scan_points(s, cfg.far_range)
            self.points.append(p)
            self._joinable.append(j)
            self._steps.append(float(np.median(np.diff(s.bearings))) if len(s.bearings) > 1 else 0.0)
        self.join, self.spacing = cfg.join, cfg.spacing
        # a scan's surfaces are made when it is first placed: only key scans are (one in ten at a
        # laser's full rate), and making every scan's was a tenth of the alignment's time on aces
        self.segments = _Lazy(self._segments_of, len(self.points))
        self._placed: dict[int, tuple] = {}
        self._kept: dict[str, tuple] = {}

    def _segments_of(self, k: int) -> tuple:
        sa, sb = surface_segments(self.points[k], self._joinable[k], self._steps[k], self.join)
        return (sa, sb, *sample_segments(sa, sb, self.spacing))

    def placed(self, k: int, pose: np.ndarray) -> tuple:
        """Scan k's (a, b, direction, length, samples, samples_of) at ``pose``, world frame."""
        key = (float(pose[0]), float(pose[1]), float(pose[2]))
        hit = self._placed.get(k)
        if hit is not None and hit[0] == key:
            return hit[1]
        sa, sb, samples, of = self.segments[k]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        R = np.array([[c, s], [-s, c]])
        a, b = sa @ R + pose[:2], sb @ R + pose[:2]
        d = b - a
        length = np.hypot(d[:, 0], d[:, 1])
        u = np.divide(d, length[:, None], out=np.zeros_like(d), where=length[:, None] > 0)
        out = (a, b, u, length, samples @ R + pose[:2], of)
        self._placed[k] = (key, out)
        return out

    def index(self, which: Sequence[int], poses: np.ndarray, keep: str | None = None) -> SegmentIndex:
        """The segments (and their samples: a rigid motion moves them too) of scans ``which`` at
        ``poses``. ``keep``: the index is kept under that name and given again while the same
        scans are asked for at the same poses (a KD-tree's making is most of an index's cost)."""
        if keep is not None:
            sig = (tuple(which), poses[list(which)].tobytes())
            kept = self._kept.get(keep)
            if kept is not None and kept[0] == sig:
                return kept[1]
            index = self.index(which, poses)
            self._kept[keep] = (sig, index)
            return index
        parts = [self.placed(k, poses[k]) for k in which]
        if not parts:
            return SegmentIndex(np.zeros((0, 2)), np.zeros((0, 2)), self.spacing)
        a, b, u, length, samples = (np.concatenate([p[i] for p in parts]) for i in range(5))
        offsets = np.cumsum([0] + [len(p[3]) for p in parts[:-1]])
        of = np.concatenate([p[5] + o for p, o in zip(parts, offsets)])
        return SegmentIndex.placed(a, b, u, length, samples, of, self.spacing)


def _subsample(p: np.ndarray, n: int) -> np.ndarray:
    return p if len(p) <= n else p[np.linspace(0, len(p) - 1, n).round().astype(np.int64)]


def _sigma(cov: np.ndarray) -> float:
    c = cov[:2, :2]
    if not np.isfinite(c).all():
        return math.inf
    return float(math.sqrt(max(np.linalg.eigvalsh(c).max(), 0.0)))


def _well_fixed(information: np.ndarray, cfg: AlignConfig) -> bool:
    """Whether a match's own information (no prior) fixes the scan's position to ``calibrate_sigma``
    in every direction and its heading to ``loop_heading_sigma``: not a corridor."""
    if not np.isfinite(information).all():
        return False
    return (np.linalg.eigvalsh(information[:2, :2]).min() >= cfg.calibrate_sigma ** -2
            and information[2, 2] >= cfg.loop_heading_sigma ** -2)


def _edge_information(cov: np.ndarray, heading: float, information: bool = False) -> np.ndarray:
    """Information of a relative pose measured by a match with covariance ``cov`` (world frame),
    in the frame of the pose it is measured from (``heading``). A floor of 2 cm and 0.5° (what a
    match moves from the corrected poses of the shared logs, median) keeps an overconfident match
    (its covariance says millimetres: hundreds of returns on one wall) from outweighing
    everything else, and a chain of consecutive edges from holding out against a loop."""
    c, s = math.cos(heading), math.sin(heading)
    R = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    floor = np.diag([POSE_FLOOR ** 2, POSE_FLOOR ** 2, HEADING_FLOOR ** 2])
    if information:  # ``cov`` is an information matrix, possibly singular: (Ω⁻¹ + F)⁻¹ = Ω (I + F Ω)⁻¹
        omega = R @ cov @ R.T
        out = omega @ np.linalg.inv(np.eye(3) + floor @ omega)
        return (out + out.T) / 2 + np.eye(3) * 1e-9
    cov = np.where(np.isfinite(cov), cov, 0.0)
    return np.linalg.inv(R @ cov @ R.T + floor)


def likelihood_of(index: SegmentIndex, resolution: float, sigma: float) -> LikelihoodField:
    """The likelihood field of a local map's samples (``correlative``), made when first asked for
    and kept with the index: an index lives as long as its key scans stay where they are, and most
    indices are never searched."""
    kept = index.__dict__.setdefault("_likelihood", {})
    key = (resolution, sigma)
    if key not in kept:
        kept[key] = LikelihoodField(index.samples, resolution, sigma)
    return kept[key]
