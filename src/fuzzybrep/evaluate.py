"""Judging a map against laser endpoints: is each endpoint where the map says a boundary may be?

For a set of scans (the held-out ones, or all of them) every endpoint with a return closer than
``max_range`` is put in one of three classes against the map's fuzzy boundary:

* explained: inside the support band (between the inner and outer polygon at α = 0);
* violation: inside the safe inner region at α = 0, where the map promises free space with
  full confidence: an obstacle where the map says there is none;
* beyond: outside the outer polygon at α = 0, past everything the map knows.

``holdout`` builds the map from all scans but every K-th and scores the held-out ones: the map
must predict scans it has not seen.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import shapely

from .scans.scan import Scan


@dataclass(frozen=True)
class EndpointScore:
    endpoints: int
    explained: float
    violations: float
    beyond: float

    def as_dict(self) -> dict:
        return {"endpoints": self.endpoints, "explained": self.explained, "violations": self.violations, "beyond": self.beyond}


def endpoints(scans: Sequence[Scan], max_range: float = 5.0) -> np.ndarray:
    """(m, 2) world coordinates of every return closer than max_range."""
    pts = [s.endpoints()[s.returns & (s.ranges < max_range)] for s in scans]
    return np.vstack(pts) if pts else np.zeros((0, 2))


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
    return EndpointScore(n, 1.0 - v - b, v, b)


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
