"""GeoJSON in and out: crisp maps from floor plans, α-cuts as FeatureCollections, point lists.

A crisp map can come as a GeoJSON Polygon, MultiPolygon, Feature or FeatureCollection of those,
in any unit (GeoJSON says nothing about it: the caller does). Every ring is checked and a bad
one is refused naming the feature, polygon, ring and vertex as numbered in the file (1-based).
Overlapping polygons are united; the result is a BRepMap (largest piece = principal polygon,
shells counter-clockwise, holes clockwise). A floor plan in the simulator's scheme (the demo's
floorplan.geojson) reads as its free space: features with ``"role": "obstacle"`` are cut out,
the route and glass lines carry no area and are passed over, and its top-level ``"unit"`` is
the map's unit unless the caller says otherwise. The α-cut collections fuzzybrep writes (export
--geojson, alpha-cut) read as their ``"role": "crisp"`` feature, in its ``"unit"``.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import shapely

from ..brep import BRepMap, locate_vertex, validate_ring
from ..errors import FormatLimitError, GeometryError, MapFileError
from .files import loads_json, read_limited


#: the largest GeoJSON file read, and the most positions ([x, y]) it may hold: checked before
#: the file is parsed, so that a file too large is refused before the memory for it is taken (a
#: ring of 10**7 vertices, 289 MB, took 6.1 GB and ended in GEOS's std::bad_alloc). A floor plan
#: holds thousands of positions; fuzzybrep's own α-cut exports of real logs, a few hundred thousand
MAX_GEOJSON_BYTES = 512 * 2**20
MAX_GEOJSON_POSITIONS = 5_000_000


def geojson_text(path: str | os.PathLike) -> str:
    """The text of a GeoJSON file (a byte-order mark, as Windows tools write, dropped), or
    MapFileError naming the file when it cannot be read or holds more than MAX_GEOJSON_BYTES
    (``files.read_limited``: a device or a FIFO is read one byte past the limit at most), or
    FormatLimitError when it holds more than MAX_GEOJSON_POSITIONS positions (every position opens
    a '[': counted before parsing). UnicodeDecodeError as decoding raises it."""
    raw = read_limited(path, MAX_GEOJSON_BYTES, "GeoJSON")
    brackets = raw.count(b"[")
    if brackets > MAX_GEOJSON_POSITIONS + 1000:  # every position has one; rings and polygons a few more
        raise FormatLimitError(f"the file holds about {brackets} positions; GeoJSON is read with up to "
                               f"{MAX_GEOJSON_POSITIONS}")
    return raw.decode("utf-8-sig")


def read_geojson(path: str | os.PathLike, unit: str | None = None) -> BRepMap:
    """The crisp map in a GeoJSON file. MapFileError naming the file for anything wrong: unreadable,
    too large (``geojson_text``), wrong structure, or bad geometry (then also the feature, polygon,
    ring and vertex). ``unit`` None: the file's top-level "unit", else metres."""
    path = Path(path)
    try:
        raw = geojson_text(path)
    except (OSError, UnicodeDecodeError) as e:
        raise MapFileError(path, f"cannot read: {getattr(e, 'strerror', None) or e}") from None
    except FormatLimitError as e:
        raise MapFileError(path, str(e)) from None
    try:
        obj = loads_json(raw)
    except json.JSONDecodeError as e:
        raise MapFileError(path, f"not valid JSON ({e})") from None
    try:
        return crisp_from_geojson(obj, unit)
    except ValueError as e:  # GeometryError among them
        raise MapFileError(path, str(e)) from None


def crisp_from_geojson(obj, unit: str | None = None) -> BRepMap:
    """The crisp map in a parsed GeoJSON object (see ``read_geojson``)."""
    if isinstance(obj, dict) and obj.get("georef") is not None:
        raise ValueError("georeferenced (WGS 84 longitude/latitude, written with --georef): a map is read from "
                         "its own frame, as export --geojson writes it without --georef")
    items = list(_polygon_coords(obj))
    said = obj.get("unit") if isinstance(obj, dict) else None
    if any(props.get("role") == "crisp" for _, _, props in items):
        # what export --geojson and alpha-cut write: the crisp map, then α-cuts derived from it,
        # which united with it would give the outer α = 0 cut; the crisp features carry the unit
        items = [it for it in items if it[2].get("role") == "crisp"]
        said = said if said is not None else next((p["unit"] for _, _, p in items if "unit" in p), None)
    else:
        cut = next(((where, p) for _, where, p in items if p.get("role") in ("inner", "outer")), None)
        if cut is not None:  # an α-cut alone is a margin at some α, not a crisp map
            where, p = cut
            raise ValueError(_at(where, f"an α-cut (role {p['role']!r}, alpha {p.get('alpha')!r}), not a crisp "
                                        f"map: give the file with its 'role': 'crisp' feature"))
    if said is not None and unit is not None and said != unit:
        raise ValueError(f"the file's unit is {said!r}, but {unit!r} was given")
    free = [_polygon(coords, where) for coords, where, props in items if props.get("role") != "obstacle"]
    obstacles = [_polygon(coords, where) for coords, where, props in items if props.get("role") == "obstacle"]
    if not free:
        raise ValueError("no Polygon or MultiPolygon of free space in the GeoJSON")
    geom = free[0] if len(free) == 1 else shapely.union_all(free)
    if obstacles:  # before: united with the free space, a pillar mapped as floor
        geom = geom.difference(shapely.union_all(obstacles))
    return BRepMap.from_shapely(geom, unit or (said if isinstance(said, str) else None) or "m")


def _polygon_coords(obj, where: str = "", props: dict | None = None):
    """Yield (coordinates of one polygon, its name, the properties of the feature it belongs to)
    from any GeoJSON object; ``props``: those properties."""
    if not isinstance(obj, dict):
        raise ValueError(_at(where, f"expected a GeoJSON object, got {type(obj).__name__}"))
    kind = obj.get("type")
    props = props or {}
    if kind == "FeatureCollection":
        feats = obj.get("features")
        if not isinstance(feats, list):
            raise ValueError("FeatureCollection has no list of features")
        for i, f in enumerate(feats):
            yield from _polygon_coords(f, f"feature {i + 1}")
    elif kind == "Feature":
        g = obj.get("geometry")
        if g is None:
            return  # a feature without geometry carries nothing for the map
        p = obj.get("properties")
        yield from _polygon_coords(g, where or "feature", p if isinstance(p, dict) else {})
    elif kind == "GeometryCollection":
        for i, g in enumerate(obj.get("geometries") or []):
            yield from _polygon_coords(g, f"{where + ' ' if where else ''}geometry {i + 1}", props)
    elif kind == "Polygon":
        yield obj.get("coordinates"), (where + " polygon").strip(), props
    elif kind == "MultiPolygon":
        coords = obj.get("coordinates")
        if not isinstance(coords, list):
            raise ValueError(_at(where, "MultiPolygon coordinates must be a list"))
        for j, c in enumerate(coords):
            yield c, f"{where + ' ' if where else ''}polygon {j + 1}", props
    elif kind in ("LineString", "MultiLineString") and (props.get("role") in ("route", "glass")
                                                         or props.get("material") == "glass"):
        return  # a floor plan's route, or glass on its walls: no area, nothing for the map
    elif kind in ("Point", "MultiPoint", "LineString", "MultiLineString"):
        raise ValueError(_at(where, f"a {kind} has no area; a crisp map needs Polygon or MultiPolygon"))
    else:
        raise ValueError(_at(where, f"unknown GeoJSON type {kind!r}"))


def _at(where: str, message: str) -> str:
    return f"{where}: {message}" if where else message


def _ring(coords, name: str) -> np.ndarray:
    if not isinstance(coords, list):
        raise GeometryError("a ring must be a list of positions", ring=name)
    out = np.empty((len(coords), 2))
    for j, pos in enumerate(coords):
        if not isinstance(pos, (list, tuple)) or len(pos) < 2:
            raise GeometryError(f"position {pos!r} is not [x, y]", ring=name, vertex=j + 1)
        # JSON numbers only: float() would take true (a bool is an int in Python) and "1.5"
        if not all(type(v) in (int, float) for v in pos[:2]):
            raise GeometryError(f"position {pos!r} is not [x, y] numbers", ring=name, vertex=j + 1)
        x, y = float(pos[0]), float(pos[1])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise GeometryError("coordinate is not finite", ring=name, vertex=j + 1)
        out[j] = x, y
    if len(out) > 1 and np.array_equal(out[0], out[-1]):
        out = out[:-1]  # GeoJSON closes rings by repeating the first position; we do not
    validate_ring(out, name)
    return out


def _polygon(coords, where: str) -> shapely.Polygon:
    if not isinstance(coords, list) or not coords:
        raise GeometryError("a polygon needs at least its outer ring", ring=where)
    names = [f"{where} outer ring"] + [f"{where} hole {k}" for k in range(1, len(coords))]
    rings = [_ring(c, n) for c, n in zip(coords, names)]
    poly = shapely.Polygon(rings[0], rings[1:])
    if not poly.is_valid:
        reason = shapely.is_valid_reason(poly)
        name, vertex = locate_vertex(rings, names, reason)
        raise GeometryError(f"invalid polygon: {reason}", ring=name or where, vertex=vertex)
    return poly


def geometry_json(geom) -> dict:
    """A (Multi)Polygon as a GeoJSON geometry; an empty one as an empty MultiPolygon. Rings follow
    the right-hand rule (RFC 7946, 3.1.6: exteriors counter-clockwise, holes clockwise), which
    GEOS's buffers and overlays, and so the α-cuts, do not."""
    if geom is None or geom.is_empty:
        return {"type": "MultiPolygon", "coordinates": []}
    return json.loads(shapely.to_geojson(shapely.orient_polygons(geom, exterior_cw=False)))


def alpha_cut_collection(cuts, crisp: BRepMap | None = None) -> dict:
    """A FeatureCollection of α-cuts: features with properties role (crisp, inner, outer) and alpha."""
    features = []
    if crisp is not None:
        features.append({"type": "Feature", "properties": {"role": "crisp", "alpha": 1.0, "unit": crisp.unit},
                         "geometry": geometry_json(crisp.to_shapely())})
    for c in cuts:
        for role, g in (("inner", c.inner), ("outer", c.outer)):
            features.append({"type": "Feature",
                             "properties": {"role": role, "alpha": c.alpha, "method": c.method, "unit": c.unit},
                             "geometry": geometry_json(g)})
    return {"type": "FeatureCollection", "features": features}
