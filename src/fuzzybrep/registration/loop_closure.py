"""Loop closure and refinement of ``registration.align_scans``: a scan matched to the key scans
around a place passed long ago (``_try_loop``, checked for a rival along a corridor, ``_rival``),
and, once the loops have pulled the trajectory together, every key scan matched again to the
places it passed twice (``_refine``) and to its neighbours in time on both sides (``_refine_local``)."""

from __future__ import annotations

import math

import numpy as np

from ..scans.scan import relative
from .config import AlignConfig
from .segment_match import SegmentIndex, align, transform
from .surfaces import _edge_information, _subsample, _Surfaces, likelihood_of


def _refine(poses: np.ndarray, keys: list[int], travel: np.ndarray, surf: _Surfaces, cfg: AlignConfig,
            edges: tuple[list, ...]) -> int:
    """Once the loops have pulled the trajectory together, every key scan is matched again to the
    key scans near it from another time (at least ``loop_travel`` before or after it), from its
    corrected pose: the online pass closed a loop every ``loop_every`` metres where the drift still
    let it; now every place seen twice ties its two visits together. Each match that explains the
    scan (the loop's tests) and moves it less than ``refine_move`` adds a robust edge. Returns the
    number of edges added to ``edges`` (ei, ej, ez, einfo, robust lists, extended in place)."""
    keys_a = np.asarray(keys)
    added = 0
    last = -math.inf
    for c, k in enumerate(keys_a):
        if travel[k] - last < cfg.refine_every:
            continue
        other = np.flatnonzero(np.abs(travel[keys_a] - travel[k]) >= cfg.loop_travel)
        if not len(other):
            continue
        d = np.hypot(*(poses[keys_a[other], :2] - poses[k, :2]).T)
        if d.min() > cfg.refine_radius:
            continue
        ci = int(other[np.argmin(d)])
        j = int(keys_a[ci])
        pts = _subsample(surf.points[k], cfg.max_points)
        if len(pts) < 20:
            continue
        near = keys_a[slice(*_around(ci, cfg.loop_window))]
        near = near[np.abs(travel[near] - travel[k]) >= cfg.loop_travel]
        index = surf.index(near.tolist(), poses, keep="refine")
        if not len(index):
            continue
        last = travel[k]
        res = align(pts, index, poses[k], width=cfg.width, start_width=2 * cfg.width, max_iterations=cfg.iterations)
        info = res.information
        if res.inlier_share < cfg.loop_inliers or not np.isfinite(info).all():
            continue
        if np.linalg.eigvalsh(info[:2, :2]).max() < cfg.loop_sigma ** -2 or info[2, 2] < cfg.loop_heading_sigma ** -2:
            continue
        added += _add_refined(edges, j, int(k), poses, res, cfg)
    return added


def _add_refined(edges: tuple[list, ...], j: int, k: int, poses: np.ndarray, res, cfg: AlignConfig) -> int:
    """A refinement's robust edge from key scan j to scan k at its matched pose ``res``, unless the
    match moved k farther than ``refine_move`` from its corrected pose. 1 if added, else 0."""
    if math.hypot(*(res.pose[:2] - poses[k, :2])) > cfg.refine_move:
        return 0
    ei, ej, ez, einfo, robust = edges
    ei.append(j)
    ej.append(k)
    ez.append(relative(poses[j], res.pose))
    einfo.append(_edge_information(res.information, poses[j, 2], information=True))
    robust.append(True)
    return 1


def _refine_local(poses: np.ndarray, keys: list[int], travel: np.ndarray, surf: _Surfaces, cfg: AlignConfig,
                  edges: tuple[list, ...]) -> int:
    """Every key scan (once per ``refine_local_every``) matched again, from its corrected pose, to the
    key scans around it in time, itself left out: those of the other parity in a block reaching at
    least ``refine_local`` key scans either side (one map serves every key scan of one parity in
    the block). The front end matched each scan to the scans before it only, each match a few
    centimetres and tenths of a degree off (``benchmarks/align_limits.py``): chained along a
    corridor seen once, that is the error left between the loops. Tied to both sides of its
    stretch, the pose graph averages the one-sided errors. The edge is from the map's key scan
    nearest to it; the tests are the refinement's but for heading and across-corridor (its own
    neighbours are the same corridor; a match that says little gets little information).
    Returns the edges added."""
    keys_a = np.asarray(keys)
    added = 0
    last = -math.inf
    W = cfg.refine_local
    for c, k in enumerate(keys_a):
        if travel[k] - last < cfg.refine_local_every or c == 0:
            continue
        pts = _subsample(surf.points[k], cfg.max_points)
        if len(pts) < 20:
            continue
        # the key scans of the other parity in a block of 4W around c's block of 2W: at least W
        # either side of c, without c, and the same for every key of that parity in the block (one
        # KD-tree for W matches, not one each: the trees were half of this pass's cost)
        first = (c // (2 * W)) * (2 * W)
        lo = max(0, first - W)
        near = [int(keys_a[i]) for i in range(lo, min(len(keys_a), first + 3 * W)) if i % 2 != c % 2]
        if not near:
            continue
        index = surf.index(near, poses, keep=f"local{c % 2}")
        last = travel[k]
        # from the corrected pose the scan lies within centimetres of its neighbours: the final
        # kernel from the start, and few iterations (this pass is about a tenth of the alignment's CPU time on intel)
        res = align(pts, index, poses[k], width=cfg.width, start_width=cfg.width, max_iterations=cfg.probe_iterations)
        info = res.information
        if res.inlier_share < cfg.loop_inliers or not np.isfinite(info).all():
            continue
        d = np.hypot(*(poses[near, :2] - poses[k, :2]).T)
        added += _add_refined(edges, near[int(np.argmin(d))], int(k), poses, res, cfg)
    return added


def _around(c: int, window: int) -> tuple[int, int]:
    """The slice of key scans around key c in a loop's or a refinement's local map: at least
    ``window`` either side, in blocks of ``window`` that neighbouring candidates share (the same
    key scans at the same poses: the same index, made once)."""
    first = (c // window) * window
    return max(0, first - window), first + 2 * window + 1


def _try_loop(k: int, pts: np.ndarray, poses: np.ndarray, keys: list[int], travel: np.ndarray, surf: _Surfaces,
              cfg: AlignConfig, since_loop: float):
    """(j, pose, covariance) of a loop match of scan k to the key scans around an old place, or None.

    The place is searched for, and the match accepted, only within what the drift since then
    can explain: ``loop_radius`` + ``loop_growth`` × the travel since that place or since the last
    loop closed, whichever is less (at most ``loop_max_radius``). A corridor matched one door
    along, or another corridor like it, lies farther than that."""
    keys_a = np.asarray(keys)
    old = keys_a[(travel[keys_a] <= travel[k] - cfg.loop_travel)]
    if not len(old):
        return None
    d = np.hypot(*(poses[old, :2] - poses[k, :2]).T)
    reach = np.minimum(cfg.loop_radius + cfg.loop_growth * np.minimum(travel[k] - travel[old], since_loop),
                       cfg.loop_max_radius)
    inside = d <= reach + cfg.loop_view
    if not inside.any():
        return None
    c = int(np.argmin(np.where(inside, d, np.inf)))
    j = int(old[c])
    radius = min(cfg.loop_radius + cfg.loop_slide * min(travel[k] - travel[j], since_loop), cfg.loop_max_radius)
    index = surf.index(old[slice(*_around(c, cfg.loop_window))].tolist(), poses, keep="loop")
    if not len(index):
        return None
    start, start_width = poses[k], max(cfg.loop_start_width, d.min() / 2)
    if cfg.loop_search:
        # search the window the drift allows before refining (Olson; Cartographer's constraint
        # builder): the Gauss-Newton match from the current estimate is drawn in from a metre or
        # two, the heading's drift since the place is often more (degrees over tens of metres)
        field_ = likelihood_of(index, cfg.loop_search_resolution, cfg.search_sigma * 2)
        since = min(travel[k] - travel[j], since_loop)
        angle = min(cfg.search_angle + cfg.loop_search_turn * since, cfg.search_max_angle)
        found = field_.search(_subsample(pts, cfg.search_points), poses[k], radius, angle)
        start, start_width = found.pose, 2 * cfg.loop_search_resolution
    res = align(pts, index, start, width=cfg.width, start_width=start_width, max_iterations=cfg.loop_iterations)
    # what the match says, and only that: a corridor fixes the scan across it and its heading,
    # not along it, and the edge's information says so (singular along the corridor), rather than
    # the loop being dropped or trusted where it knows nothing
    info = res.information
    if res.inlier_share < cfg.loop_inliers or not np.isfinite(info).all():
        return None
    ev = np.linalg.eigvalsh(info[:2, :2])
    if ev.max() < cfg.loop_sigma ** -2 or info[2, 2] < cfg.loop_heading_sigma ** -2:
        return None
    if math.hypot(*(res.pose[:2] - poses[k, :2])) > radius:  # it slid into another corridor
        return None
    u = _rival(pts, index, res, poses[k], radius, cfg)
    if u is not None:  # it knows across the corridor, not which bay along it: singular along it
        M = np.eye(3)
        M[:2, :2] -= np.outer(u, u)
        info = M @ info @ M
    return j, res.pose, info


def _rival(pts: np.ndarray, index: SegmentIndex, res, estimate: np.ndarray, radius: float, cfg: AlignConfig):
    """The direction (2,) along which the loop match ``res`` has a rival, or None: a pose farther
    than ``loop_unique`` along the direction the match constrains least, within ``radius`` of the
    scan's ``estimate``, that explains nearly as much of the scan (``loop_rival`` × its mean
    membership). A corridor whose doors or pillars repeat matches one bay along almost as well as
    in the right one; its information says metres, not decimetres, only when the corridor is bare,
    so the rival is looked for, not inferred: the scan's mean membership (kernel twice the
    match's width) is profiled every ``loop_probe`` metres along that direction, all offsets in one
    tree query, and each local maximum that comes near the match's is aligned from there."""
    _, vec = np.linalg.eigh(res.information[:2, :2])
    u = vec[:, 0]  # the least constrained direction
    reach = radius + math.hypot(*(res.pose[:2] - estimate[:2]))
    offsets = np.arange(-reach, reach + cfg.loop_probe / 2, cfg.loop_probe)
    offsets = np.append(offsets[np.abs(offsets) > cfg.loop_unique], 0.0)
    w = 2 * cfg.width
    base = transform(pts, res.pose)
    world = (base[None, :, :] + offsets[:, None, None] * u[None, None, :]).reshape(-1, 2)
    _, d, _, _ = index.nearest(world, w)
    grade = np.clip(1 - d / w, 0, None).reshape(len(offsets), -1).mean(axis=1)
    mu0, grade, offsets = grade[-1], grade[:-1], offsets[:-1]
    padded = np.r_[-np.inf, grade, -np.inf]
    peak = (grade >= padded[:-2]) & (grade >= padded[2:]) & (grade >= cfg.loop_rival * mu0)
    for o in offsets[peak][np.argsort(-grade[peak])][:4]:
        start = res.pose + np.r_[o * u, 0.0]
        alt = align(pts, index, start, width=cfg.width, start_width=w, max_iterations=cfg.probe_iterations)
        if (math.hypot(*(alt.pose[:2] - res.pose[:2])) > cfg.loop_unique and alt.mu >= cfg.loop_rival * res.mu
                and math.hypot(*(alt.pose[:2] - estimate[:2])) <= radius):
            return u
    return None
