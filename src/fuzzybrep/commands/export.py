"""fuzzybrep export: a map file out to other tools."""

from __future__ import annotations

NAME = "export"
HELP = "export a map to GeoJSON"


def add_arguments(p) -> None:
    p.add_argument("map", help="map file (JSON) written by fuzzybrep build")
    p.add_argument("--geojson", required=True, help="GeoJSON file to write: a FeatureCollection, features with role 'crisp'")


def run(args) -> int:
    from ..export import crisp_features, write_geojson
    from ..mapfile import read_map

    m = read_map(args.map)
    n = write_geojson(args.geojson, crisp_features(m.crisp))
    print(f"{args.geojson}: {n} bytes ({m.crisp.n_vertices} vertices, {m.crisp.n_holes} holes)")
    return 0
