"""Where a map's GeoJSON says its coordinates are: a local engineering CRS, or WGS 84 lon/lat.

RFC 7946 GeoJSON means WGS 84 longitude/latitude, so a reader takes a map's metres for degrees
(GDAL put Freiburg campus at latitude −155.6, and could not reproject it). Without a
georeference, ``export --geojson`` and ``alpha-cut`` declare the map's own frame with OGC JSON-FG's
top-level ``coordRefSys`` member (``local_crs``). With ``--georef LON LAT HEADING`` (the map
origin's WGS 84 position, and the bearing of the map's x axis in degrees clockwise from north)
every position is turned into true longitude/latitude (``to_lonlat``).

The conversion is a local tangent plane on the WGS 84 ellipsoid: east/north metres from the
origin, then latitude and longitude by the meridian and prime-vertical radii of curvature at the
origin, to second order in distance/radius. Against PROJ's azimuthal equidistant projection
about the origin (``tests/test_georef.py``, through GDAL) it is within 1 mm out to 1 km
from the origin and 10 cm at 10 km (at 48° N; the error grows as the distance cubed), far below any map's TME; maps of more
than a few kilometres should be georeferenced with a proper projection.
"""

from __future__ import annotations

import math

import numpy as np

#: WGS 84 semi-major axis (m) and flattening
WGS84_A = 6378137.0
WGS84_F = 1 / 298.257223563
_E2 = WGS84_F * (2 - WGS84_F)

#: JSON-FG (OGC 21-045r1) ``coordRefSys``: WGS 84 longitude/latitude
CRS84 = "http://www.opengis.net/def/crs/OGC/0/CRS84"


def local_crs(unit: str) -> dict:
    """The top-level members that declare a map's own frame: a local engineering CRS (no datum on
    the Earth; x, y in ``unit`` from the map's origin, the first scan's frame for a built map)."""
    return {"coordRefSys": {"type": "Reference", "href": f"urn:fuzzybrep:crs:local-engineering:{unit}"},
            "fuzzybrepFrame": {"kind": "local engineering CRS", "axes": ["x", "y"], "unit": unit,
                               "note": "not WGS 84 longitude/latitude: export with --georef LON LAT HEADING for "
                                       "RFC 7946 coordinates"}}


def check_georef(lon: float, lat: float, heading: float) -> None:
    """ValueError (one line) unless LON in [−180, 180], LAT in (−90, 90) and HEADING finite."""
    if not (math.isfinite(lon) and -180 <= lon <= 180):
        raise ValueError(f"--georef: longitude must lie in [-180, 180], got {lon:g}")
    if not (math.isfinite(lat) and -90 < lat < 90):
        raise ValueError(f"--georef: latitude must lie in (-90, 90), got {lat:g}")
    if not math.isfinite(heading):
        raise ValueError(f"--georef: heading must be a finite number of degrees, got {heading:g}")


def to_lonlat(xy_m: np.ndarray, lon0: float, lat0: float, heading: float) -> np.ndarray:
    """(n, 2) map coordinates in metres → (n, 2) WGS 84 longitude, latitude in degrees.

    The map's x axis points ``heading`` degrees clockwise from north, its y axis 90° to the left
    of it: east = x·sin h − y·cos h, north = x·cos h + y·sin h."""
    xy = np.asarray(xy_m, dtype=np.float64).reshape(-1, 2)
    h = math.radians(heading)
    east = xy[:, 0] * math.sin(h) - xy[:, 1] * math.cos(h)
    north = xy[:, 0] * math.cos(h) + xy[:, 1] * math.sin(h)
    phi0 = math.radians(lat0)
    m, n, t = _meridian_radius(phi0), _normal_radius(phi0), math.tan(phi0)
    # second order in distance/radius: a straight line east on the plane leaves the parallel
    # towards the equator, and a degree of longitude widens towards the equator
    phi = phi0 + north / m - east * east * t / (2 * m * n)
    lam = math.radians(lon0) + (east / (n * math.cos(phi0))) * (1 + north * t / m)
    lon = (np.degrees(lam) + 180.0) % 360.0 - 180.0
    return np.column_stack((lon, np.degrees(phi)))


def _meridian_radius(phi):
    s = np.sin(phi)
    return WGS84_A * (1 - _E2) / (1 - _E2 * s * s) ** 1.5


def _normal_radius(phi):
    s = np.sin(phi)
    return WGS84_A / np.sqrt(1 - _E2 * s * s)


def georeference(collection: dict, metres_per_unit: float, lon0: float, lat0: float, heading: float) -> dict:
    """The FeatureCollection with every Polygon/MultiPolygon position in WGS 84 lon/lat (9
    decimals: 0.1 mm), a top-level ``coordRefSys`` of CRS84 and a ``georef`` member saying how."""
    def convert(coords, depth):
        if depth == 0:
            a = np.asarray(coords, dtype=np.float64).reshape(-1, 2)
            return np.round(to_lonlat(a * metres_per_unit, lon0, lat0, heading), 9).tolist()
        return [convert(c, depth - 1) for c in coords]

    out = {k: v for k, v in collection.items() if k not in ("features", "coordRefSys", "fuzzybrepFrame")}
    out["coordRefSys"] = CRS84
    out["georef"] = {"origin_lon": lon0, "origin_lat": lat0, "heading_deg": heading,
                     "method": "local tangent plane on the WGS 84 ellipsoid"}
    feats = []
    for f in collection["features"]:
        g = f.get("geometry") or {}
        depth = {"Polygon": 1, "MultiPolygon": 2}.get(g.get("type"))
        if depth is not None:
            g = {**g, "coordinates": [convert(c, depth - 1) for c in g["coordinates"]]}
        feats.append({**f, "geometry": g or f.get("geometry")})
    out["features"] = feats
    return out


__all__ = ["CRS84", "check_georef", "georeference", "local_crs", "to_lonlat"]
