"""Synthetic scans of known worlds, for tests: exact ranges by ray casting, optional noise."""

from __future__ import annotations

import numpy as np
import shapely

from fuzzybrep.scans.scan import Scan, even_bearings
from fuzzybrep.sim.simulate import cast_rays
from fuzzybrep.sim.world import World


def scan_of(free: shapely.Polygon, pose, n: int = 181, fov: float = np.pi, max_range: float = 8.0,
            sigma: float = 0.0, seed: int = 0, t: float = 0.0, bearings=None) -> Scan:
    """A scan of the world ``free`` (a Polygon whose boundary is the walls) from ``pose``.

    Beams that see nothing within max_range return max_range ("no return").
    """
    world = World(free)
    b = even_bearings(n, fov) if bearings is None else np.asarray(bearings)
    pose = np.asarray(pose, dtype=np.float64)
    r, _ = cast_rays(world, np.repeat(pose[None, :2], len(b), axis=0), pose[2] + b, max_range)
    if sigma:
        r = r + np.random.default_rng(seed).normal(0, sigma, len(r))
    r = np.where(np.isfinite(r), np.maximum(r, 0.0), max_range)
    return Scan(np.minimum(r, max_range), b, pose, t, max_range)


def room(w: float = 6.0, h: float = 4.0) -> shapely.Polygon:
    return shapely.box(0, 0, w, h)


def l_room() -> shapely.Polygon:
    """An L-shaped room: a reflex corner at (4, 2)."""
    return shapely.Polygon([(0, 0), (8, 0), (8, 2), (4, 2), (4, 6), (0, 6)])
