"""A fuzzy B-rep map on a grid of square cells: free, occupied and unknown kept apart, μ per cell.

Every raster fuzzybrep writes (the ROS map_server pair, the Nav2 map and masks, the OccupancyGrid
of a ROS 2 bag, the Foxglove grid) comes from ``membership_raster``. A cell is classed by its
centre, by what the laser saw and nothing more, as ``fuzzybrep grid`` classes its cells:

- **free**: in the crisp free space (the scans' rays passed there);
- **occupied**: outside the crisp free space, within the obstacle side of the support band of an
  obstacle edge (``occupied_region``). The laser saw that surface, and by the membership function
  the true surface lies within the band: so the band behind an obstacle edge is occupied. A hole
  thinner than the band (a chair leg, a pillar) is occupied through and through;
- **unknown**: everything else. That is the inside of a hole farther than the band from its
  obstacle edges (a block the robot drove round, seen only from outside), every cell beyond a
  frontier edge (nothing was seen there; a pocket bounded by frontier edges only is all
  unknown), and the outside of the map.

Before, every hole was painted occupied through: on belgioioso none of the 24,781 hole cells
farther than 0.5 m from any obstacle edge was unknown, and a planner took unexplored blocks for
walls. The band's depth is the membership function's support on the obstacle side of the edge
(the outer support for the principal polygon's edges, the inner one for a hole's), edge by edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from scipy import ndimage

from ..arrays import cell_count_text, cells_area
from ..brep import FRONTIER
from .rosmap import MAX_CELLS

# ROS grey levels (docs/export.md). map_server reads v as the occupancy probability p = (255 − v)/255
# and, in trinary mode, p < free_thresh as free and p > occupied_thresh as occupied. With
# map_saver's thresholds every level below keeps its class, so a stock map_server sees free,
# occupied and unknown exactly where the raster has them, and the shade within a class is μ.
#: free cell deep in free space (μ = 0); FREE_GREY − FREE_STEPS = 206 is free next to the boundary
FREE_GREY = 254
FREE_STEPS = 48
#: map_saver's unknown
UNKNOWN_GREY = 205
#: occupied cell at the far edge of the band (μ = 0); OCCUPIED_STEPS = 88 is occupied next to the boundary
OCCUPIED_GREY = 0
OCCUPIED_STEPS = 88
#: arcs of the occupied band's round joins: segments per quarter circle (a cell is far coarser)
BAND_QUAD_SEGS = 8
#: the union of many buffers: GEOS's disjoint-subset union (3.12 on) where it has it
_union_all = shapely.disjoint_subset_union_all if shapely.geos_version >= (3, 12, 0) else shapely.union_all


def obstacle_depths(fuzzy) -> np.ndarray:
    """(n,) per stacked edge (``fuzzy.stack`` order): how deep its band reaches on the obstacle
    side, the larger of its two vertices' supports on that side (OUT of the principal polygon, IN of
    a hole); 0 for a frontier edge."""
    s = fuzzy.stack
    fm, nxt, shell = s["fm"], s["next"], s["shell"]
    top = max(k for k, _ in fuzzy.table) + 1
    s_in, s_out = np.zeros(top), np.zeros(top)
    for k, f in fuzzy.table:
        s_in[k], s_out[k] = f.support_in, f.support_out
    depth = np.where(shell, np.maximum(s_out[fm], s_out[fm[nxt]]), np.maximum(s_in[fm], s_in[fm[nxt]]))
    kinds = np.concatenate([r.kinds for r in fuzzy.crisp.rings])
    return np.where(kinds == FRONTIER, 0.0, depth)


def occupied_region(fuzzy, quad_segs: int = BAND_QUAD_SEGS) -> shapely.Geometry:
    """The occupied part of the map: the obstacle edges buffered by their depth (``obstacle_depths``)
    minus the crisp free space.

    Consecutive obstacle edges of one depth form a chain, buffered with round joins and flat caps:
    flat where a chain meets a frontier edge, so that the band does not spill round the corner into
    the unseen space beyond the frontier; where two chains meet otherwise (a change of depth, the
    ring's first vertex) a disc of the smaller depth closes the wedge flat caps would leave. Every
    chain is buffered alone (one vectorised call) and the buffers united once, as the exact α-cut
    does (a MultiLineString's buffer nodes every curve together: 10 s on Freiburg 079, 1 s so).
    """
    s = fuzzy.stack
    V, nxt, start = s["V"], s["next"], s["start"]
    n = len(V)
    depth = obstacle_depths(fuzzy)
    obst = depth > 0
    prev = np.empty(n, np.int64)
    prev[nxt] = np.arange(n)
    first = np.zeros(n, bool)
    first[start] = True
    begins = obst & (first | ~obst[prev] | (depth != depth[prev]))
    e = np.flatnonzero(obst)
    if not len(e):
        return shapely.Polygon()
    chain = np.cumsum(begins)[e] - 1
    last = np.r_[chain[1:] != chain[:-1], True]
    # a chain's points: the start of each of its edges, then the end of its last edge
    pts = np.concatenate((V[e], V[nxt[e[last]]]))
    order = np.argsort(np.concatenate((2 * e, 2 * e[last] + 1)), kind="stable")
    ids = np.concatenate((chain, chain[last]))[order]
    lines = shapely.linestrings(pts[order], indices=ids)
    widths = depth[e[np.r_[True, chain[1:] != chain[:-1]]]]
    bands = shapely.buffer(lines, widths, cap_style="flat", join_style="round", quad_segs=quad_segs)
    joint = begins & obst[prev]
    discs = shapely.buffer(shapely.points(V[joint]), np.minimum(depth[joint], depth[prev][joint]), quad_segs=quad_segs)
    band = _union_all(np.concatenate((bands, discs)))
    return shapely.difference(band, fuzzy.crisp_geometry)


@dataclass(frozen=True, eq=False)
class MembershipRaster:
    """The map on a grid of square cells.

    image       (h, w) uint8 grey levels of the ROS map_server pair (``export.grey_levels``), row 0
                at the TOP (as an image stores it)
    mu          (h, w) μ of the fuzzy boundary at each cell centre, row 0 at the top
    free        (h, w) bool: cell centre in the crisp free space
    occupied    (h, w) bool: cell centre in ``occupied_region``
    resolution  cell side, in the map's unit
    origin      (x, y) of the lower-left corner of the lower-left cell
    method      how μ was evaluated (``FuzzyBRepMap.membership``)
    """

    image: np.ndarray
    mu: np.ndarray
    free: np.ndarray
    occupied: np.ndarray
    resolution: float
    origin: tuple[float, float]
    method: str
    unit: str = "m"

    @property
    def shape(self) -> tuple[int, int]:
        return self.image.shape  # type: ignore[return-value]

    @property
    def unknown(self) -> np.ndarray:
        """(h, w) bool: neither free nor occupied."""
        return ~(self.free | self.occupied)

    def free_area(self) -> float:
        return cells_area(int(self.free.sum()), self.resolution)

    def occupied_area(self) -> float:
        return cells_area(int(self.occupied.sum()), self.resolution)

    def unknown_area(self) -> float:
        return cells_area(int(self.unknown.sum()), self.resolution)

    def extent(self) -> shapely.Geometry:
        """The grid's box, in the map's unit."""
        h, w = self.shape
        x0, y0 = self.origin
        return shapely.box(x0, y0, x0 + w * self.resolution, y0 + h * self.resolution)


def grey_levels(mu: np.ndarray, free: np.ndarray, occupied: np.ndarray) -> np.ndarray:
    """The encoding of docs/export.md: μ and the cell's class to a grey level (uint8)."""
    img = np.full(np.shape(mu), UNKNOWN_GREY, np.uint8)
    m = np.clip(mu, 0.0, 1.0)
    img[free] = (FREE_GREY - np.rint(FREE_STEPS * m[free])).astype(np.uint8)
    img[occupied] = (OCCUPIED_GREY + np.rint(OCCUPIED_STEPS * m[occupied])).astype(np.uint8)
    return img


def mu_from_grey(image: np.ndarray) -> np.ndarray:
    """μ read back from the grey levels (to 1/48 in free cells, 1/88 in occupied ones; NaN unknown)."""
    v = np.asarray(image, dtype=np.float64)
    mu = np.full(v.shape, np.nan)
    free = v > UNKNOWN_GREY
    occ = v <= OCCUPIED_GREY + OCCUPIED_STEPS
    mu[free] = (FREE_GREY - np.minimum(v[free], FREE_GREY)) / FREE_STEPS
    mu[occ] = (v[occ] - OCCUPIED_GREY) / OCCUPIED_STEPS
    return mu


def _segments(crisp) -> tuple[np.ndarray, np.ndarray]:
    """(a, b) of every crisp edge: (m, 2), (m, 2)."""
    rings = crisp.rings
    a = np.vstack([r.vertices for r in rings])
    b = np.vstack([np.roll(r.vertices, -1, axis=0) for r in rings])
    return a, b


def _boundary_cells(a: np.ndarray, b: np.ndarray, origin, resolution: float, shape) -> np.ndarray:
    """(h, w) bool, row 0 at the bottom: cells the crisp boundary passes through.

    Every edge is sampled at half a cell, so no cell it crosses is missed by more than a corner
    clip, which the caller's margin of one cell absorbs.
    """
    length = np.hypot(*(b - a).T)
    n = np.maximum(np.ceil(length / (0.5 * resolution)).astype(np.int64), 1) + 1
    seg = np.repeat(np.arange(len(a)), n)
    t = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n - 1, n)
    p = a[seg] + t[:, None] * (b - a)[seg]
    i = np.clip(((p[:, 0] - origin[0]) / resolution).astype(np.int64), 0, shape[1] - 1)
    j = np.clip(((p[:, 1] - origin[1]) / resolution).astype(np.int64), 0, shape[0] - 1)
    mask = np.zeros(shape, bool)
    mask[j, i] = True
    return mask


def membership_raster(fuzzy, resolution: float = 0.05, method: str = "safe") -> MembershipRaster:
    """Rasterise a fuzzy B-rep map at cell centres: classes from the crisp map and its obstacle
    band (module doc), μ from the fuzzy map.

    Inside/outside is one vectorised ``shapely.contains_xy`` over all cell centres; the occupied
    band and μ (``fuzzy.membership(points, method)``) are evaluated only at cells within the support
    of the boundary, found with a distance transform of the cells the boundary crosses. The grid
    covers the map's bounding box grown by the outer support and a cell, on a lattice of
    ``resolution`` (so that rasters of one building line up cell for cell).
    """
    if not (isinstance(resolution, (int, float)) and math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution must be a positive number, got {resolution!r}")
    crisp = fuzzy.crisp
    table = fuzzy.table
    # the safe method's fans and stadium caps circumscribe their arcs: their corners reach further
    wider = fuzzy.safe["reach"] if method == "safe" else 1.0
    reach_out = max(f.support_out for _, f in table) * wider
    reach = max(reach_out, max(f.support_in for _, f in table) * wider)
    x0, y0, x1, y1 = fuzzy.crisp_geometry.bounds
    pad = reach_out + resolution
    # rounded so that the YAML reads -23.45, not -23.450000000000003
    ox = round(math.floor((x0 - pad) / resolution) * resolution, 9)
    oy = round(math.floor((y0 - pad) / resolution) * resolution, 9)
    w = math.ceil((x1 + pad - ox) / resolution)
    h = math.ceil((y1 + pad - oy) / resolution)
    if w * h > MAX_CELLS:
        raise ValueError(f"a grid of {cell_count_text(w)} × {cell_count_text(h)} cells at {resolution:g} {crisp.unit} is too large "
                         f"(limit {MAX_CELLS} cells): give a coarser resolution")
    cx = ox + (np.arange(w) + 0.5) * resolution
    cy = oy + (np.arange(h) + 0.5) * resolution
    X, Y = np.meshgrid(cx, cy)  # row 0 at the bottom until the very end
    free = shapely.contains_xy(fuzzy.crisp_geometry, X, Y)

    a, b = _segments(crisp)
    boundary = _boundary_cells(a, b, (ox, oy), resolution, (h, w))
    # a boundary point lies within half a cell diagonal of its cell's centre: one cell of margin
    near = ndimage.distance_transform_edt(~boundary) * resolution <= reach + resolution
    mu = np.zeros((h, w))
    mu[near] = fuzzy.membership(np.column_stack((X[near], Y[near])), method)
    occupied = np.zeros((h, w), bool)
    look = near & ~free  # the band lies within the support of the boundary, outside the free space
    if look.any():
        region = occupied_region(fuzzy)
        shapely.prepare(region)
        occupied[look] = shapely.contains_xy(region, X[look], Y[look])
    img = grey_levels(mu, free, occupied)
    return MembershipRaster(img[::-1].copy(), mu[::-1].copy(), free[::-1].copy(), occupied[::-1].copy(),
                            float(resolution), (float(ox), float(oy)), method, crisp.unit)


__all__ = ["BAND_QUAD_SEGS", "FREE_GREY", "FREE_STEPS", "MembershipRaster", "OCCUPIED_GREY", "OCCUPIED_STEPS",
           "UNKNOWN_GREY", "grey_levels", "mu_from_grey", "membership_raster", "obstacle_depths", "occupied_region"]
