"""Worlds for the simulator: floor plans with glass, from GeoJSON or built in, and routes.

A world is free space as one shapely Polygon (holes are obstacles); its boundary is the walls, and
lines on that boundary mark which walls are glass. Metres throughout; docs/simulator.md describes
the GeoJSON scheme for your own floor plan and route.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely

from ..errors import FormatLimitError, MapFileError, WorldError
from ..formats.files import loads_json, write_atomic
from ..formats.geojson import geojson_text

#: glass lines may lie this far (m) off the free-space boundary; wall pieces shorter than twice
#: this (the slivers a glass line's end cuts off the neighbouring wall) are dropped
GLASS_TOLERANCE = 1e-3
#: GeoJSON "unit" member -> metres
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}


# --------------------------------------------------------------------------------------- world


@dataclass(frozen=True, eq=False)
class World:
    """Free space (one Polygon, holes = obstacles) and which parts of its boundary are glass.

    free       the space the laser can see through; its boundary rings are the walls.
    glass      linework on that boundary marking glass walls (empty: no glass).
    segments   (W, 4) derived: every wall segment as x0, y0, x1, y1.
    is_glass   (W,) derived: the segment is glass.
    """

    free: shapely.Polygon
    glass: shapely.MultiLineString = field(default_factory=shapely.MultiLineString)
    name: str = ""
    segments: np.ndarray = field(init=False, repr=False)
    is_glass: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        free = self.free
        if not isinstance(free, shapely.Polygon):
            raise WorldError(f"free space must be one Polygon, got {getattr(free, 'geom_type', type(free).__name__)}")
        if free.is_empty or free.area <= 0:
            raise WorldError("free space is empty")
        if not free.is_valid:
            raise WorldError(f"free space is not a valid polygon: {shapely.is_valid_reason(free)}")
        glass = shapely.MultiLineString() if self.glass is None else self.glass
        if glass.geom_type not in ("LineString", "MultiLineString"):
            raise WorldError(f"glass must be lines, got {glass.geom_type}")
        boundary = free.boundary
        if not glass.is_empty:
            off = glass.difference(boundary.buffer(GLASS_TOLERANCE)).length
            if off > 0:
                raise WorldError(f"{off:.3g} m of glass line is not on a wall: glass must lie on the "
                                 f"free-space boundary (within {GLASS_TOLERANCE * 1000:g} mm)")
            zone = glass.buffer(GLASS_TOLERANCE, cap_style="flat")
            parts = [(boundary.difference(zone), False), (boundary.intersection(zone), True)]
        else:
            parts = [(boundary, False)]
        segs, flags = [], []
        for lines, is_glass in parts:
            s = _segments(lines)
            s = s[np.hypot(s[:, 2] - s[:, 0], s[:, 3] - s[:, 1]) > 2 * GLASS_TOLERANCE]
            segs.append(s)
            flags.append(np.full(len(s), is_glass))
        segments, is_glass = np.vstack(segs), np.concatenate(flags)
        for a in (segments, is_glass):
            a.setflags(write=False)
        object.__setattr__(self, "glass", glass)
        object.__setattr__(self, "segments", segments)
        object.__setattr__(self, "is_glass", is_glass)

    @property
    def walls(self) -> shapely.MultiLineString:
        """Every wall (the whole free-space boundary) as straight segments."""
        return _as_lines(self.segments)

    @property
    def glass_walls(self) -> shapely.MultiLineString:
        return _as_lines(self.segments[self.is_glass])

    # -------------------------------------------------------------------------- GeoJSON

    @classmethod
    def from_geojson(cls, path: str | os.PathLike) -> "World":
        """Read a floor plan; see docs/simulator.md for the scheme.

        A FeatureCollection (or one Feature, or a bare geometry). Polygon and MultiPolygon features
        are free space (``"role": "free"``, the default) or are cut out of it (``"role":
        "obstacle"``); LineString features with ``"role": "glass"`` or ``"material": "glass"``
        mark glass walls on the boundary, as does ``"material": "glass"`` on a polygon; a
        ``"role": "route"`` LineString is the route (read by ``Route.from_file``). Coordinates
        are metres unless the collection has ``"unit": "cm"`` or ``"mm"``.
        """
        features, scale = _read_geojson(path)
        free, obstacles, glass = [], [], []
        for k, feat in features:
            geom, props = feat["geometry"], feat["properties"]
            role = props.get("role")
            material = props.get("material")
            if material not in (None, "glass", "opaque"):
                raise WorldError(f"material must be glass or opaque, got {material!r}", path, k)
            if geom.geom_type in ("Polygon", "MultiPolygon"):
                role = role or "free"
                if role not in ("free", "obstacle"):
                    raise WorldError(f"a polygon's role must be free or obstacle, got {role!r}", path, k)
                if not geom.is_valid:
                    raise WorldError(f"invalid polygon: {shapely.is_valid_reason(geom)}", path, k)
                (free if role == "free" else obstacles).append(geom)
                if material == "glass":
                    glass.append(geom.boundary)
            elif geom.geom_type in ("LineString", "MultiLineString"):
                role = role or ("glass" if material == "glass" else None)
                if role == "glass":
                    glass.append(geom)
                elif role != "route":
                    raise WorldError(f"a line must have role glass or route (or material glass), got role {role!r}", path, k)
            else:
                raise WorldError(f"unsupported geometry {geom.geom_type}: use Polygon, MultiPolygon or LineString", path, k)
        if not free:
            raise WorldError("no free-space polygon (a Polygon feature with role free or no role)", path)
        space = shapely.union_all(free)
        if obstacles:
            space = space.difference(shapely.union_all(obstacles))
        pieces = [g for g in shapely.get_parts(space) if g.geom_type == "Polygon" and g.area > 0]
        if len(pieces) != 1:
            areas = ", ".join(f"{g.area * scale**2:.3g}" for g in sorted(pieces, key=lambda g: -g.area)[:5])
            raise WorldError(f"free space must be one connected polygon, got {len(pieces)} pieces "
                             f"(areas {areas} m²)" if pieces else "free space has no area", path)
        glass_lines = _lines(_scaled(shapely.union_all(glass), scale)) if glass else shapely.MultiLineString()
        try:
            return cls(shapely.orient_polygons(_scaled(pieces[0], scale)), glass_lines, name=Path(path).stem)
        except WorldError as e:
            raise WorldError(e.reason, path) from None

    def to_geojson(self, route: "Route | None" = None) -> dict:
        """The world (and a route) as a GeoJSON FeatureCollection ``from_geojson`` reads back."""
        feats = [_feature(self.free, {"role": "free", "name": self.name})]
        if not self.glass.is_empty:
            feats.append(_feature(self.glass, {"role": "glass", "material": "glass"}))
        if route is not None:
            feats.append(_feature(shapely.LineString(route.waypoints), {"role": "route", "spacing": route.spacing}))
        return {"type": "FeatureCollection", "unit": "m", "features": feats}

    def write_geojson(self, path: str | os.PathLike, route: "Route | None" = None) -> int:
        """Write atomically, one feature a line; returns bytes written."""
        doc = self.to_geojson(route)
        feats = ",\n".join(json.dumps(f) for f in doc.pop("features"))
        text = json.dumps(doc)[:-1] + ', "features": [\n' + feats + "\n]}\n"
        return write_atomic(Path(path), text.encode())


def _segments(lines) -> np.ndarray:
    """(W, 4) straight segments of any linework (points in it are ignored), vectorised."""
    parts = shapely.get_parts(lines)
    while np.isin(shapely.get_type_id(parts), (4, 5, 6, 7)).any():  # multi-parts inside collections
        parts = shapely.get_parts(parts)
    parts = parts[np.isin(shapely.get_type_id(parts), (1, 2))]
    if len(parts) == 0:
        return np.empty((0, 4))
    coords, idx = shapely.get_coordinates(parts, return_index=True)
    same = idx[1:] == idx[:-1]
    return np.hstack((coords[:-1][same], coords[1:][same]))


def _scaled(geom, factor: float):
    """Coordinates multiplied by ``factor`` (a unit conversion)."""
    return geom if factor == 1.0 else shapely.transform(geom, lambda c: c * factor)


def _as_lines(segments: np.ndarray) -> shapely.MultiLineString:
    return shapely.MultiLineString(list(segments.reshape(-1, 2, 2))) if len(segments) else shapely.MultiLineString()


def _lines(geom) -> shapely.MultiLineString:
    """Any linework as one MultiLineString (merged where pieces join)."""
    if geom.is_empty:
        return shapely.MultiLineString()
    merged = shapely.line_merge(shapely.union_all(geom))
    parts = [p for p in shapely.get_parts(merged) if p.geom_type == "LineString"]
    return shapely.MultiLineString(parts)


def _feature(geom, props: dict) -> dict:
    return {"type": "Feature", "properties": props, "geometry": json.loads(shapely.to_geojson(geom))}


def _read_geojson(path: str | os.PathLike) -> tuple[list[tuple[int, dict]], float]:
    """Features as (1-based index, {"geometry": shapely, "properties": dict}) and the unit scale."""
    try:
        doc = loads_json(geojson_text(path))  # size-checked before parsing; a byte-order mark is no JSON error
    except MapFileError as e:  # unreadable, or larger than GeoJSON is read
        raise WorldError(e.reason, path) from None
    except FormatLimitError as e:
        raise WorldError(str(e), path) from None
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise WorldError(f"not valid JSON ({e})", path) from None
    if not isinstance(doc, dict) or "type" not in doc:
        raise WorldError("not GeoJSON: expected an object with a type", path)
    unit = doc.get("unit", "m")
    if unit not in UNITS:
        raise WorldError(f"unit must be one of {', '.join(UNITS)}, got {unit!r}", path)
    if doc["type"] == "FeatureCollection":
        raw = doc.get("features")
        if not isinstance(raw, list):
            raise WorldError("FeatureCollection has no features list", path)
    elif doc["type"] == "Feature":
        raw = [doc]
    else:
        raw = [{"type": "Feature", "properties": {}, "geometry": doc}]
    out = []
    for k, feat in enumerate(raw, 1):
        if not isinstance(feat, dict) or feat.get("type") != "Feature" or not isinstance(feat.get("geometry"), dict):
            raise WorldError("not a Feature with a geometry", path, k)
        props = feat.get("properties") or {}
        if not isinstance(props, dict):
            raise WorldError("properties must be an object", path, k)
        try:
            geom = shapely.from_geojson(json.dumps(feat["geometry"]))
        except shapely.errors.GEOSException as e:
            raise WorldError(f"bad geometry: {e}", path, k) from None
        if geom.is_empty:
            raise WorldError("empty geometry", path, k)
        if not np.isfinite(shapely.get_coordinates(geom)).all():
            raise WorldError("coordinates are not finite", path, k)
        out.append((k, {"geometry": geom, "properties": props}))
    return out, UNITS[unit]


# ------------------------------------------------------------------------ the built-in floor

#: E1-like floor plan (metres): the footprint is 55 m × 45 m; the corridor ring (2.4 m wide) runs
#: round a central block of 36.6 m × 26.6 m; its centre line is a 39 m × 29 m rectangle (136 m).
FOOTPRINT = (0.0, 0.0, 55.0, 45.0)
CORRIDOR_WIDTH = 2.4
CENTRE_LINE = (8.0, 8.0, 47.0, 37.0)
#: home: section A (south passage), facing west, so the route runs clockwise A, B, C, D
HOME = (27.5, 8.0)


def builtin_floor() -> World:
    """A floor modelled on the E1 fifth floor of chapter 5 (Figure 5.2).

    A corridor ring round one central block (the map's single hole), four passages A (south),
    B (west), C (north), D (east); closed office doors as 0.2 m recesses; an open door into a
    7 m × 5.65 m room in section A (the artifact the thesis saw there); a lift lobby cut into the
    block in section B; glass along the block side of section C's east half and along the outer
    side of section D (the spikes of section 5.2: beyond the glass the laser finds nothing within
    8 m). Not to scale of the real building, which the thesis does not give.
    """
    x0, y0, x1, y1 = CENTRE_LINE
    h = CORRIDOR_WIDTH / 2
    box = shapely.box
    ring = box(x0 - h, y0 - h, x1 + h, y1 + h).difference(box(x0 + h, y0 + h, x1 - h, y1 - h))
    out_s, out_n, out_w, out_e = y0 - h, y1 + h, x0 - h, x1 + h  # outer walls
    in_s, in_w = y0 + h, x0 + h  # block walls
    d, r = 0.2, 0.45  # recess depth, half door width
    pieces = [ring]
    pieces += [box(c - r, out_s - d, c + r, out_s) for c in (12.0, 19.0, 33.0, 40.0)]  # A, outer
    pieces += [box(c - r, in_s, c + r, in_s + d) for c in (15.0, 36.0)]  # A, block side
    pieces += [box(out_w - d, c - r, out_w, c + r) for c in (13.0, 20.0, 27.0, 33.0)]  # B, outer
    pieces += [box(c - r, out_n, c + r, out_n + d) for c in (12.0, 19.0, 26.0)]  # C, outer (west half)
    pieces += [box(out_e, c - r, out_e + d, c + r) for c in (10.5,)]  # D, outer (south of the glass)
    # the open door (0.9 m, in a 0.15 m wall) and its room, section A
    room_n = round(out_s - 0.15, 9)
    pieces += [box(25.5, room_n, 26.4, out_s), box(22.0, 1.0, 29.0, room_n)]
    # lift lobby, section B, cut 3 m into the central block
    pieces += [box(in_w, 20.0, in_w + 3.0, 26.0)]
    # simplify(0) drops the collinear vertices the union leaves where boxes meet
    free = shapely.orient_polygons(shapely.simplify(shapely.union_all(pieces), 0.0))
    in_n = y1 - h
    glass = shapely.MultiLineString([
        [(30.0, in_n), (42.0, in_n)],  # section C: east half, block side
        [(out_e, 13.0), (out_e, 34.0)],  # section D: the alley's glass fence, outer side
    ])
    return World(free, glass, name="e1-fifth-floor")


# ----------------------------------------------------------------------------------- route


#: stops a route may have: each is two scans cast and held in memory (136 000 ran for minutes,
#: 1.4e11 asked NumPy for a terabyte; the built-in route has 27)
MAX_STOPS = 100_000


@dataclass(frozen=True, eq=False)
class Route:
    """Waypoints (n, 2) in metres, driven in order, and a stop every ``spacing`` metres.

    Stops are at 0, spacing, 2·spacing, ... along the path. A closed route (last waypoint equals
    the first) skips a final stop closer than spacing/2 to the end: it would repeat the first.
    """

    waypoints: np.ndarray
    spacing: float = 5.0

    def __post_init__(self) -> None:
        try:
            w = np.array(self.waypoints, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise WorldError(f"route waypoints must be (n, 2) numbers: {e}") from None
        if w.ndim != 2 or w.shape[1] != 2:
            raise WorldError(f"route waypoints must be an (n, 2) array of x, y, got shape {w.shape}")
        if len(w) < 2:
            raise WorldError(f"a route needs at least 2 waypoints, got {len(w)}")
        if not np.isfinite(w).all():
            raise WorldError(f"route waypoint {int(np.argmax(~np.isfinite(w).all(axis=1))) + 1} is not finite")
        same = np.hypot(*np.diff(w, axis=0).T) == 0
        if same.any():
            raise WorldError(f"route waypoint {int(np.argmax(same)) + 2} repeats the one before")
        if not (math.isfinite(self.spacing) and self.spacing > 0):
            raise WorldError(f"stop spacing must be positive, got {self.spacing!r}")
        length = float(np.hypot(*np.diff(w, axis=0).T).sum())
        if length / self.spacing > MAX_STOPS:
            raise WorldError(f"stop spacing {self.spacing:g} m gives {length / self.spacing:.3g} stops along the "
                             f"route's {length:.3g} m (at most {MAX_STOPS}): give a wider spacing")
        w.setflags(write=False)
        object.__setattr__(self, "waypoints", w)

    @property
    def closed(self) -> bool:
        return bool(np.allclose(self.waypoints[0], self.waypoints[-1], rtol=0, atol=1e-9))

    @property
    def cumulative(self) -> np.ndarray:
        """(n,) distance along the route to every waypoint."""
        return np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(self.waypoints, axis=0).T))))

    @property
    def length(self) -> float:
        return float(self.cumulative[-1])

    @property
    def headings(self) -> np.ndarray:
        """(n-1,) heading of every leg."""
        d = np.diff(self.waypoints, axis=0)
        return np.arctan2(d[:, 1], d[:, 0])

    def stop_distances(self) -> np.ndarray:
        """Distance along the route of every stop."""
        s = np.arange(0.0, self.length + 1e-9, self.spacing)
        if self.closed:  # the first stop stays, even with a spacing longer than the route
            s = s[(s == 0) | (s < self.length - self.spacing / 2)]
        return s

    def poses_at(self, s: np.ndarray) -> np.ndarray:
        """(k, 3) pose at each distance: on the path, heading along the leg that starts there."""
        s = np.asarray(s, dtype=np.float64)
        cum = self.cumulative
        leg = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(cum) - 2)
        d = np.diff(self.waypoints, axis=0)[leg]
        frac = ((s - cum[leg]) / (cum[leg + 1] - cum[leg]))[:, None]
        xy = self.waypoints[leg] + frac * d
        return np.column_stack((xy, self.headings[leg]))

    @classmethod
    def from_file(cls, path: str | os.PathLike, spacing: float | None = None) -> "Route":
        """A route from GeoJSON (the LineString feature with role route, or the only LineString)
        or from CSV (``x,y`` per line, optional header, ``#`` comments). Spacing: the argument,
        else the feature's ``spacing`` property, else 5 m."""
        path = Path(path)
        if path.suffix.lower() in (".geojson", ".json"):
            features, scale = _read_geojson(path)
            lines = [(k, f) for k, f in features if f["geometry"].geom_type == "LineString"]
            routes = [(k, f) for k, f in lines if f["properties"].get("role") == "route"]
            # a lone LineString without a role is the route, unless it is a glass wall
            unmarked = [(k, f) for k, f in lines
                        if not f["properties"].get("role") and f["properties"].get("material") != "glass"]
            chosen = routes or (unmarked if len(lines) == 1 and len(unmarked) == 1 else [])
            if len(chosen) != 1:
                raise WorldError(f"expected one LineString feature with role route, found {len(routes)}", path)
            k, feat = chosen[0]
            sp = spacing if spacing is not None else feat["properties"].get("spacing", 5.0)
            try:
                return cls(shapely.get_coordinates(feat["geometry"]) * scale, float(sp))
            except (WorldError, TypeError, ValueError) as e:
                raise WorldError(getattr(e, "reason", str(e)), path, k) from None
        try:
            text = path.read_text(encoding="utf-8-sig")  # -sig: a spreadsheet's byte-order mark
        except (OSError, UnicodeDecodeError) as e:
            raise WorldError(f"cannot read: {getattr(e, 'strerror', None) or e}", path) from None
        pts = []
        for n, line in enumerate(text.splitlines(), 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            fields = [f.strip() for f in line.split(",")]
            if len(fields) != 2:
                raise WorldError(f"line {n}: expected x,y, got {len(fields)} fields", path)
            try:
                pts.append((float(fields[0]), float(fields[1])))
            except ValueError:
                if pts or [f.lower() for f in fields] != ["x", "y"]:
                    raise WorldError(f"line {n}: not a number pair: {line!r}", path) from None
        try:
            return cls(np.array(pts), 5.0 if spacing is None else spacing)
        except WorldError as e:
            raise WorldError(e.reason, path) from None


def builtin_route(spacing: float = 5.0) -> Route:
    """The thesis's route (Figure 5.7): clockwise round the corridor ring from home in section A.

    136 m along the corridor centre line; with a stop every 5 m that is 27 stops (thesis 5.3:
    "approximately 140 meters", "27 360° local laser range scans").
    """
    x0, y0, x1, y1 = CENTRE_LINE
    return Route(np.array([HOME, (x0, y0), (x0, y1), (x1, y1), (x1, y0), HOME]), spacing)


def check_route(world: World, route: Route) -> None:
    """Raise WorldError if the route leaves the free space (the robot would drive through a wall)."""
    outside = ~shapely.contains_xy(world.free, route.waypoints[:, 0], route.waypoints[:, 1])
    if outside.any():
        k = int(np.argmax(outside))
        raise WorldError(f"route waypoint {k + 1} {route.waypoints[k].tolist()} is not in the free space")
    leaves = shapely.LineString(route.waypoints).difference(world.free)
    if leaves.length > 0:
        x, y = shapely.get_coordinates(leaves)[0]
        raise WorldError(f"the route crosses a wall near ({x:.3f}, {y:.3f})")
