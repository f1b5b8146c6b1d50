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
  205                unknown                     nothing seen: a hole's inside beyond the
                                                 obstacle band, beyond a frontier, outside
  round(88μ)         occupied (0..88)            in the obstacle band: within the support of
                                                 an obstacle edge, on its obstacle side
  =================  ==========================  ======================================

  The classes and the raster are ``fuzzybrep.formats.raster``'s. Nav2 (map in scale or raw mode,
  costmap filter masks) is ``fuzzybrep.formats.nav2``; SVG pictures are ``fuzzybrep.formats.svg``.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from ..brep import BRepMap
from .files import write_atomic
from .geojson import alpha_cut_collection, geometry_json
from .georef import georeference, local_crs
from .raster import (FREE_GREY, FREE_STEPS, OCCUPIED_GREY, OCCUPIED_STEPS, UNKNOWN_GREY, MembershipRaster, grey_levels,
                     membership_raster, mu_from_grey)
from .rosmap import FREE_THRESH, OCCUPIED_THRESH, write_ros_map

#: default levels of ``fuzzybrep export --geojson`` and ``--svg``
DEFAULT_ALPHAS = (0.0, 0.25, 0.5, 0.75, 1.0)

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


def write_geojson(path: str | os.PathLike, features: list[dict], *, unit: str | None = None,
                  georef: tuple[float, float, float] | None = None, **extra) -> int:
    """A FeatureCollection written atomically; returns bytes written. ``unit``: the map's, declared
    as its local frame (``georef.local_crs``); ``georef`` (lon, lat, heading): every position
    turned into WGS 84 lon/lat instead (``georef.georeference``; ValueError for a unit whose
    length in metres is not known)."""
    fc = geojson_collection(feature_collection(features, **extra), unit, georef)
    return write_atomic(path, json.dumps(fc, separators=(",", ":")).encode())


def geojson_collection(fc: dict, unit: str | None, georef: tuple[float, float, float] | None = None) -> dict:
    """``fc`` with its frame declared (``unit``) or georeferenced (``georef``), as ``write_geojson``."""
    if georef is not None:
        k = metres_per_unit(unit or "m")
        if k is None:
            raise ValueError(f"--georef needs the map's unit in metres, and {unit!r} is not m, cm or mm")
        return georeference(fc, k, *georef)
    if unit is None:
        return fc
    crs = local_crs(unit)
    return {"type": fc["type"], **crs, **{k: v for k, v in fc.items() if k != "type"}}


# ---------------------------------------------------------------------------------------------
# ROS map_server


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
    "feature_collection", "geojson_collection", "grey_levels", "membership_raster", "metres_per_unit", "mu_from_grey", "write_geojson", "write_ros",
]
