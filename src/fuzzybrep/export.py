"""Maps out to other tools: GeoJSON (GIS, web maps)."""

from __future__ import annotations

import json
import os

import shapely

from .brep import BRepMap
from .mapfile import write_atomic


def feature(geom, **properties) -> dict:
    return {"type": "Feature", "properties": properties, "geometry": shapely.geometry.mapping(geom)}


def feature_collection(features: list[dict], **extra) -> dict:
    return {"type": "FeatureCollection", **extra, "features": features}


def crisp_features(crisp: BRepMap) -> list[dict]:
    """The crisp free space as one feature with ``role: crisp`` (a Polygon or MultiPolygon with holes)."""
    return [feature(crisp.to_shapely(), role="crisp", alpha=1.0, unit=crisp.unit,
                    vertices=crisp.n_vertices, holes=crisp.n_holes)]


def write_geojson(path: str | os.PathLike, features: list[dict], **extra) -> int:
    """A FeatureCollection written atomically; returns bytes written."""
    return write_atomic(path, json.dumps(feature_collection(features, **extra)).encode())
