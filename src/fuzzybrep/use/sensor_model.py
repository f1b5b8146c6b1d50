"""The laser's sensor model, read off a fuzzy B-rep map: where a return may lie, and how likely a
scan is from a pose.

A return comes from a wall: the map's obstacle edges, each with its membership function
(Table 4.2) saying how far from the crisp edge the wall may really be. So the grade of an
endpoint is μ of its signed distance to the nearest obstacle edge (1 on the crisp edge, 0 beyond
the support ±TME): the Extension principle's μ (``fuzzy.exact``) restricted to the edges a laser
can see. Two kinds of evidence are not walls and are kept apart:

- frontier edges (the limit of what the map saw: no return, the usable range, the side of a ray
  past an occluder): an endpoint whose nearest edge is a frontier lies where the map does not
  know anything, so it says nothing for or against a pose (``UNKNOWN``);
- beams with no return: nothing was seen along them, which the map builder takes as unknown,
  not free; they are not endpoints and are left out.

Nearest edges come from ``align.SegmentIndex``: a KD-tree over points sampled every 2 cm along
every edge (obstacle and frontier), so no grid of the map is ever made; memory grows with the
boundary's length, not the map's area. The free space (for a global search's prior) is the crisp
map's, through Shapely.
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from ..brep import FRONTIER, OBSTACLE, BRepMap
from ..scans.scan import Scan
from ..fuzzy.membership import MembershipTable
from ..registration.segment_match import SegmentIndex

#: spacing of the samples along the edges (m): nearest-edge distances are exact to half of it
SAMPLE_SPACING = 0.02
#: an endpoint's grade when it lies beyond a frontier: neither a wall nor a contradiction
UNKNOWN = -1.0
#: endpoints × poses from which ``log_likelihood`` queries the KD-tree on every core (the same
#: results; threads pay only for a global search's large draws)
PARALLEL_QUERY = 100_000


def map_edges(crisp: BRepMap) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every edge of every ring: starts (m, 2), ends (m, 2), kinds (m,) and the FM index of its
    first vertex (m,). The free space lies on the left of every edge (``brep``)."""
    rings = crisp.rings
    if not rings:
        z = np.zeros((0, 2))
        return z, z, np.zeros(0, np.int64), np.zeros(0, np.int64)
    a = np.vstack([r.vertices for r in rings])
    b = np.vstack([np.roll(r.vertices, -1, axis=0) for r in rings])
    kinds = np.concatenate([r.kinds for r in rings]).astype(np.int64)
    fm = np.concatenate([r.fm for r in rings]).astype(np.int64)
    return a, b, kinds, fm


def sensor_points(scan: Scan) -> np.ndarray:
    """(n, 2) the endpoints of a scan's returns in the sensor frame (no-return beams left out)."""
    r = scan.returns
    return np.column_stack((scan.ranges[r] * np.cos(scan.bearings[r]), scan.ranges[r] * np.sin(scan.bearings[r])))


class SensorModel:
    """A fuzzy map as a laser's sensor model (module docstring).

    crisp, table   the map's crisp rings and its membership-function table (``FuzzyBRepMap.crisp``
                   and ``.table``; a map file's, without the sweep, is enough).
    spacing        samples along the edges (map unit).

    ``tme``: the widest support of the obstacle edges' membership functions, the distance within
    which an endpoint counts as on a wall.
    """

    def __init__(self, crisp: BRepMap, table: MembershipTable, spacing: float = SAMPLE_SPACING):
        a, b, kinds, fm = map_edges(crisp)
        obstacle = kinds == OBSTACLE
        if not obstacle.any():
            raise ValueError("the map has no obstacle edges: there is no wall a laser return could be matched to")
        self.crisp, self.table = crisp, table
        self.index = SegmentIndex(a, b, spacing, kinds, match=(int(OBSTACLE),))
        self.fm = fm
        used = np.unique(fm[obstacle])
        self.tme = float(max(max(table[int(k)].support_in, table[int(k)].support_out) for k in used))
        self._kind_of_sample = kinds[self.index.sample_segment]
        self._free = None

    @classmethod
    def from_map(cls, fuzzy_map, spacing: float = SAMPLE_SPACING) -> "SensorModel":
        """The sensor model of a ``FuzzyBRepMap``."""
        return cls(fuzzy_map.crisp, fuzzy_map.table, spacing)

    # -- grades ----------------------------------------------------------------------------

    def membership(self, points: np.ndarray) -> np.ndarray:
        """(n,) μ of each endpoint (n, 2) by its nearest obstacle edge's membership function;
        ``UNKNOWN`` (−1) where the nearest edge is a frontier."""
        p = np.asarray(points, np.float64).reshape(-1, 2)
        seg, d, foot, _ = self.index.nearest(p, self.tme)
        mu = np.zeros(len(p))
        found = seg >= 0
        on_wall = found & self.index.matched[np.maximum(seg, 0)]
        if on_wall.any():
            j = seg[on_wall]
            u = self.index.direction[j]
            e = p[on_wall] - foot[on_wall]
            free_side = e[:, 0] * -u[:, 1] + e[:, 1] * u[:, 0] >= 0  # left of the edge: free space
            # the membership function's x: negative IN (into the edge's own ring), which is the
            # free side for a principal polygon (counter-clockwise) and the obstacle for a hole;
            # for the symmetric triangle the side does not matter
            x = np.where(free_side, -d[on_wall], d[on_wall])
            ring_is_shell = self._shell_edge[j]
            x = np.where(ring_is_shell, x, -x)
            vals = np.zeros(len(j))
            fm = self.fm[j]
            for k in np.unique(fm):
                sel = fm == k
                vals[sel] = self.table[int(k)].mu(x[sel])
            mu[on_wall] = vals
        far = ~found
        if far.any():
            # nothing within TME: unknown if a frontier is the nearest edge at any distance
            _, k = self.index.tree.query(p[far])
            mu[np.flatnonzero(far)[self._kind_of_sample[k] == FRONTIER]] = UNKNOWN
        mu[found & ~on_wall] = UNKNOWN
        return mu

    @property
    def _shell_edge(self) -> np.ndarray:
        if not hasattr(self, "_shell"):
            flags = [j == 0 for region in self.crisp.regions for j in range(1 + len(region.holes))]
            sizes = [len(r) for r in self.crisp.rings]
            self._shell = np.repeat(np.array(flags, bool), sizes)
        return self._shell

    # -- the likelihood of a scan, for many poses at once ---------------------------------

    def log_likelihood(self, poses: np.ndarray, points: np.ndarray, sigma: float, z_rand: float = 0.05,
                       chunk: int = 1 << 20) -> np.ndarray:
        """(P,) log-likelihood of endpoints ``points`` (B, 2, sensor frame) from each of ``poses``
        (P, 3): the sum over endpoints of log(z_rand + (1 − z_rand) exp(−d²/2σ²)), d the distance
        to the nearest obstacle edge (its nearest sample's: exact to spacing/2). An endpoint
        nearest a frontier scores as one σ from a wall (unknown: neither a hit nor a miss); one
        with nothing within 3σ as a miss. Vectorised over poses × endpoints, in chunks of
        ``chunk`` endpoints."""
        poses = np.asarray(poses, np.float64).reshape(-1, 3)
        pts = np.asarray(points, np.float64).reshape(-1, 2)
        out = np.zeros(len(poses))
        if len(pts) == 0 or len(poses) == 0:
            return out
        hit = np.log(z_rand + (1 - z_rand) * np.exp(-0.5 * (np.arange(0, 3.0001, 0.001) ** 2)))
        miss, unknown = math.log(z_rand), math.log(z_rand + (1 - z_rand) * math.exp(-0.5))
        rows = max(1, chunk // len(pts))
        reach = 3 * sigma
        for lo in range(0, len(poses), rows):
            P = poses[lo:lo + rows]
            c, s = np.cos(P[:, 2])[:, None], np.sin(P[:, 2])[:, None]
            wx = P[:, 0:1] + c * pts[:, 0] - s * pts[:, 1]
            wy = P[:, 1:2] + s * pts[:, 0] + c * pts[:, 1]
            # a global search's draw (10⁵ particles × 60 endpoints) is most of its cost: the query
            # runs on every core then; a local search's few thousand points do not pay for threads
            d, k = self.index.tree.query(np.column_stack((wx.ravel(), wy.ravel())), distance_upper_bound=reach,
                                         workers=-1 if wx.size >= PARALLEL_QUERY else 1)
            found = k < len(self.index.samples)
            ll = np.full(d.shape, miss)
            kind = self._kind_of_sample[np.where(found, k, 0)]
            wall = found & (kind == OBSTACLE)
            ll[wall] = hit[np.minimum((d[wall] / sigma * 1000).astype(np.int64), len(hit) - 1)]
            ll[found & (kind != OBSTACLE)] = unknown
            out[lo:lo + rows] = ll.reshape(len(P), len(pts)).sum(axis=1)
        return out

    # -- the prior of a global search --------------------------------------------------------

    @property
    def free_space(self) -> shapely.Geometry:
        """The crisp map's free space, prepared."""
        if self._free is None:
            self._free = self.crisp.to_shapely()
            shapely.prepare(self._free)
        return self._free

    def sample_free(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """(n, 2) points drawn uniformly from the free space (rejection from its bounding box)."""
        free = self.free_space
        x0, y0, x1, y1 = free.bounds
        share = max(free.area / max((x1 - x0) * (y1 - y0), 1e-300), 1e-6)
        out, have = [], 0
        while have < n:
            m = int(min(max(2 * (n - have) / share, 1024), 4_000_000))
            q = np.column_stack((rng.uniform(x0, x1, m), rng.uniform(y0, y1, m)))
            q = q[shapely.contains_xy(free, q[:, 0], q[:, 1])]
            out.append(q)
            have += len(q)
        return np.vstack(out)[:n]
