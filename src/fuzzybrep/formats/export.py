"""Maps out to other tools: GeoJSON (GIS, web maps) and ROS map_server maps (Nav2, move_base).

- GeoJSON: the crisp free space and, per α, the inner and outer polygons of the α-cut, one
  feature each with properties ``role`` (crisp, inner, outer), ``alpha`` and ``unit``.
- ROS: a PGM + YAML pair that map_server loads in trinary mode as free / occupied / unknown and
  whose grey levels also carry the membership μ of the fuzzy boundary (``membership_raster``).
  The encoding is in docs/export.md; in short, with map_saver's thresholds (0.196, 0.65):

  =================  ==========================  ======================================
  grey level v       map_server (trinary)        meaning
  =================  ==========================  ======================================
  254 − round(48μ)   free (206..254)             inside the crisp free space
  205                unknown                     outside the explored space
  round(88μ)         occupied (0..88)            in a hole, or beyond an obstacle edge
                                                 within its outer support
  =================  ==========================  ======================================

SVG pictures are in ``fuzzybrep.svg``.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely
from scipy import ndimage

from ..arrays import cell_count_text, cells_area
from ..brep import FRONTIER, BRepMap
from .files import write_atomic
from .geojson import alpha_cut_collection, geometry_json
from .rosmap import FREE_THRESH, MAX_CELLS, OCCUPIED_THRESH, write_ros_map

#: default levels of ``fuzzybrep export --geojson`` and ``--svg``
DEFAULT_ALPHAS = (0.0, 0.25, 0.5, 0.75, 1.0)

# ROS grey levels. map_server reads v as the occupancy probability p = (255 − v)/255 and, in
# trinary mode, p < free_thresh as free and p > occupied_thresh as occupied. With map_saver's
# thresholds every level below keeps its class, so a stock map_server sees free, occupied and
# unknown exactly where the crisp map says, and the shade within a class is μ.
#: free cell deep in free space (μ = 0); FREE_GREY − FREE_STEPS = 206 is free next to the boundary
FREE_GREY = 254
FREE_STEPS = 48
#: map_saver's unknown
UNKNOWN_GREY = 205
#: occupied cell deep in an obstacle (μ = 0); OCCUPIED_STEPS = 88 is occupied next to the boundary
OCCUPIED_GREY = 0
OCCUPIED_STEPS = 88
_UNIT_QUANTUM = {"m": 1e-3, "cm": 0.1, "mm": 1.0}
METRES_PER_UNIT = {"m": 1.0, "cm": 0.01, "mm": 0.001}


def coordinate_quantum(unit: str, extent: float) -> float:
    """The rounding step of coordinates in pictures and the viewer: a millimetre in the map's
    unit, or for an unknown unit a power of ten near 1e-5 of the map's extent."""
    if unit in _UNIT_QUANTUM:
        return _UNIT_QUANTUM[unit]
    return 10.0 ** math.floor(math.log10(max(extent, 1e-300) * 1e-5))


# ---------------------------------------------------------------------------------------------
# GeoJSON


def feature(geom, **properties) -> dict:
    return {"type": "Feature", "properties": properties, "geometry": geometry_json(geom)}


def feature_collection(features: list[dict], **extra) -> dict:
    return {"type": "FeatureCollection", **extra, "features": features}


def crisp_features(crisp: BRepMap) -> list[dict]:
    """The crisp free space as one feature with ``role: crisp`` (a Polygon or MultiPolygon with holes)."""
    return [feature(crisp.to_shapely(), role="crisp", alpha=1.0, unit=crisp.unit,
                    vertices=crisp.n_vertices, holes=crisp.n_holes)]


def alpha_cut_features(cuts) -> list[dict]:
    """An ``inner`` and an ``outer`` feature per α-cut (properties role, alpha, method, unit)."""
    return alpha_cut_collection(cuts)["features"]


def write_geojson(path: str | os.PathLike, features: list[dict], **extra) -> int:
    """A FeatureCollection written atomically; returns bytes written."""
    return write_atomic(path, json.dumps(feature_collection(features, **extra), separators=(",", ":")).encode())


# ---------------------------------------------------------------------------------------------
# ROS map_server


@dataclass(frozen=True, eq=False)
class MembershipRaster:
    """The map on a grid of square cells, as the ROS image encodes it.

    image       (h, w) uint8 grey levels, row 0 at the TOP (as the PGM stores it)
    mu          (h, w) μ of the fuzzy boundary at each cell centre, row 0 at the top
    free        (h, w) bool: cell centre in the crisp free space
    occupied    (h, w) bool: in a hole, or outside the explored space within the outer support
                of an obstacle edge
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

    def free_area(self) -> float:
        return cells_area(int(self.free.sum()), self.resolution)


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


def _segments(crisp: BRepMap) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(a, b, kind) of every crisp edge: (m, 2), (m, 2), (m,)."""
    rings = crisp.rings
    a = np.vstack([r.vertices for r in rings])
    b = np.vstack([np.roll(r.vertices, -1, axis=0) for r in rings])
    return a, b, np.concatenate([r.kinds for r in rings])


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
    """Rasterise a fuzzy B-rep map at cell centres: classes from the crisp map, μ from the fuzzy one.

    Inside/outside is one vectorised ``shapely.contains_xy`` over all cell centres; μ
    (``fuzzy.membership(points, method)``) is evaluated only at cells within the support of the
    boundary, found with a distance transform of the cells the boundary crosses. The grid covers
    the map's bounding box grown by the outer support and a cell, on a lattice of ``resolution``.
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
    # the lattice of the resolution, so that maps of one building line up cell for cell
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
    shells = shapely.union_all([shapely.Polygon(r.shell.vertices) for r in crisp.regions])
    shapely.prepare(shells)
    in_shell = shapely.contains_xy(shells, X, Y)

    a, b, kind = _segments(crisp)
    boundary = _boundary_cells(a, b, (ox, oy), resolution, (h, w))
    # a boundary point lies within half a cell diagonal of its cell's centre: one cell of margin
    near = ndimage.distance_transform_edt(~boundary) * resolution <= reach + resolution
    mu = np.zeros((h, w))
    mu[near] = fuzzy.membership(np.column_stack((X[near], Y[near])), method)

    # beyond the principal polygon only the outer band of an obstacle edge is known to be
    # occupied; beyond a frontier edge, and farther out, nothing was seen
    occupied = in_shell & ~free
    band = ~in_shell & (mu > 0)
    if band.any():
        tree = shapely.STRtree(shapely.linestrings(np.stack((a, b), axis=1)))
        pi, si = tree.query_nearest(shapely.points(X[band], Y[band]), all_matches=False)
        nearest_kind = np.empty(int(band.sum()), np.uint8)
        nearest_kind[pi] = kind[si]
        occupied[band] = nearest_kind != FRONTIER
    img = grey_levels(mu, free, occupied)
    return MembershipRaster(img[::-1].copy(), mu[::-1].copy(), free[::-1].copy(), occupied[::-1].copy(),
                            float(resolution), (float(ox), float(oy)), method, crisp.unit)


def metres_per_unit(unit: str) -> float | None:
    """How many metres one map unit is (ROS wants metres), or None for a unit we do not know."""
    return METRES_PER_UNIT.get(unit)


def write_ros(directory: str | os.PathLike, name: str, raster: MembershipRaster) -> tuple[Path, Path]:
    """Write DIR/NAME.yaml and DIR/NAME.pgm (trinary mode, map_saver's thresholds). Returns both paths.

    map_server reads resolution and origin in metres: a map in cm or mm is converted; a map in a
    unit we do not know keeps its unit (and the caller should say so).
    """
    scale = metres_per_unit(raster.unit) or 1.0
    comment = (f"fuzzybrep fuzzy B-rep map, {raster.resolution:g} {raster.unit}/pixel, mu by {raster.method}\n"
               f"grey: free {FREE_GREY}-round({FREE_STEPS}*mu), unknown {UNKNOWN_GREY}, "
               f"occupied {OCCUPIED_GREY}+round({OCCUPIED_STEPS}*mu)")
    origin = (round(raster.origin[0] * scale, 12), round(raster.origin[1] * scale, 12), 0.0)
    return write_ros_map(Path(directory) / f"{name}.yaml", raster.image, round(raster.resolution * scale, 12), origin,
                         occupied_thresh=OCCUPIED_THRESH, free_thresh=FREE_THRESH, negate=False, mode="trinary",
                         comment=comment)


__all__ = [
    "DEFAULT_ALPHAS", "FREE_GREY", "FREE_STEPS", "FREE_THRESH", "MembershipRaster", "OCCUPIED_GREY", "OCCUPIED_STEPS",
    "OCCUPIED_THRESH", "UNKNOWN_GREY", "alpha_cut_features", "coordinate_quantum", "crisp_features", "feature",
    "feature_collection", "grey_levels", "membership_raster", "metres_per_unit", "mu_from_grey", "write_geojson", "write_ros",
]
