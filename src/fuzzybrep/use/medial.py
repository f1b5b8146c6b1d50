"""The medial axis of a polygonal region: the generalised Voronoi diagram of its boundary.

Every point of the medial axis is the centre of a disc inscribed in the region that touches the
boundary in two or more places, so a route along it keeps as far from the boundary as the region
allows (the GVD of thesis 2.2.3; its graph of meet points and end points is the GVG).

It is approximated from the Voronoi diagram of points spread along the boundary every
``spacing`` (``scipy.spatial.Voronoi``): the Voronoi edges between points of two different
stretches of boundary, kept where they lie inside the region, converge on the medial axis as the
spacing shrinks (points on one stretch only make the short edges at right angles to it, which
are dropped). Arrays in, arrays out; nothing here knows about maps or paths.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from scipy.spatial import Voronoi

from .visibility import boundary_edges


@dataclass(frozen=True, eq=False)
class MedialAxis:
    """A graph approximating the medial axis of a region.

    nodes  (k, 2) Voronoi vertices inside the region
    edges  (e, 2) node indices of Voronoi edges inside the region
    """

    nodes: np.ndarray
    edges: np.ndarray

    @classmethod
    def of(cls, region: shapely.Geometry, spacing: float) -> "MedialAxis":
        if not spacing > 0:
            raise ValueError(f"spacing must be positive, got {spacing!r}")
        rings = shapely.get_rings(shapely.get_parts(region))
        coords, ring = shapely.get_coordinates(shapely.segmentize(rings, spacing), return_index=True)
        # drop each ring's closing point, then points repeated where two rings touch
        last = np.r_[ring[1:] != ring[:-1], True]
        coords, ring = coords[~last], ring[~last]
        size = np.bincount(ring, minlength=len(rings))
        pos = np.arange(len(ring)) - np.repeat(np.cumsum(size) - size, size)[: len(ring)]
        _, first = np.unique(coords[:, 0] + 1j * coords[:, 1], return_index=True)
        first.sort()
        sites, ring, pos = coords[first], ring[first], pos[first]
        if len(sites) < 4:
            return cls(np.zeros((0, 2)), np.zeros((0, 2), np.int64))
        # evenly spaced points along straight walls are as degenerate as input gets (many on a
        # line, four on a circle) and make Qhull crawl; a jitter of 1e-3 spacing, the same on
        # every run, takes that away and moves the axis by no more
        jitter = np.random.default_rng(0).uniform(-1e-3 * spacing, 1e-3 * spacing, sites.shape)
        vor = Voronoi(sites + jitter)
        rv = np.asarray(vor.ridge_vertices, dtype=np.int64).reshape(-1, 2)
        rp = np.asarray(vor.ridge_points, dtype=np.int64)
        a, b = rp[:, 0], rp[:, 1]
        gap = np.abs(pos[a] - pos[b])
        gap = np.minimum(gap, size[ring[a]] - gap)
        # neighbours along one ring only make the short edges across that stretch of boundary
        keep = (rv >= 0).all(axis=1) & ((ring[a] != ring[b]) | (gap > 1))
        v = vor.vertices
        inside = shapely.contains_xy(region, v[:, 0], v[:, 1])
        keep &= inside[rv[:, 0]] & inside[rv[:, 1]]
        rv = rv[keep]
        boundary = shapely.linestrings(np.stack(boundary_edges(region), axis=1))
        hits = shapely.STRtree(boundary).query(shapely.linestrings(v[rv]), predicate="intersects")[0]
        rv = np.delete(rv, np.unique(hits), axis=0)
        used, edges = np.unique(rv, return_inverse=True)
        return cls(v[used], edges.reshape(-1, 2))

    @property
    def lengths(self) -> np.ndarray:
        d = self.nodes[self.edges[:, 1]] - self.nodes[self.edges[:, 0]]
        return np.hypot(d[:, 0], d[:, 1])

