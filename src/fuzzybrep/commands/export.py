"""fuzzybrep export: a map file out to other tools (GeoJSON, ROS map_server, SVG)."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from ._maps import add_map_argument, add_method_argument, load_map
from ._progress import steps
from ._types import alpha, file_name, number

NAME = "export"
HELP = "export a map: α-cuts as GeoJSON, a ROS map_server pair (PGM + YAML), an SVG picture"


_resolution = number(lambda r: 0 < r < math.inf, "resolution must be a number, got {text!r}",
                     "resolution must be positive, got {text}")


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_map_argument(p)
    out = p.add_argument_group("outputs (at least one)")
    out.add_argument("--geojson", metavar="OUT.geojson",
                     help="FeatureCollection: the crisp map (role crisp) and per α an inner and an outer feature")
    out.add_argument("--ros", metavar="DIR",
                     help="ROS map_server pair DIR/NAME.pgm + DIR/NAME.yaml (trinary; grey levels carry μ, "
                          "see docs/export.md)")
    out.add_argument("--svg", metavar="OUT.svg",
                     help="standalone SVG picture: crisp map, support band, α-cut outlines")
    out.add_argument("--compact", metavar="OUT.fbrc",
                     help="the compact binary map a small robot stores: vertices to 1 mm as varint steps, edge "
                          "kinds, Table 4.2 (fuzzybrep.formats.compact; the fuzzy tables follow from it in O(n))")
    p.add_argument("--alpha", type=alpha, action="append", metavar="A",
                   help="α level for --geojson and --svg; repeat for several (default 0 0.25 0.5 0.75 1)")
    add_method_argument(p, what="α-cuts for --geojson and --svg")
    p.add_argument("--resolution", type=_resolution, default=0.05,
                   help="--ros: cell side in metres (default 0.05; in the map's unit if it is not m, cm or mm)")
    p.add_argument("--name", type=file_name, default=None, help="--ros: base name of the files (default: the map file's name)")
    add_method_argument(p, "--ros-method", what="--ros: μ of the grey levels")


def run(args: argparse.Namespace) -> int:
    from ..errors import MapFileError
    from ..formats.export import (
        DEFAULT_ALPHAS,
        alpha_cut_features,
        crisp_features,
        membership_raster,
        metres_per_unit,
        write_geojson,
        write_ros,
    )
    from ..formats.files import check_outputs, write_atomic
    from ..formats.svg import svg_document

    if not (args.geojson or args.ros or args.svg or args.compact):
        print("fuzzybrep export: error: give at least one of --geojson, --ros, --svg, --compact", file=sys.stderr)
        return 2
    name = args.name or Path(args.map).stem
    ros = [Path(args.ros) / f"{name}.{ext}" for ext in ("yaml", "pgm")] if args.ros else []
    check_outputs(args.geojson, args.svg, args.compact, *ros, inputs=(args.map,))
    t0 = time.perf_counter()
    alphas = sorted(set(args.alpha)) if args.alpha else list(DEFAULT_ALPHAS)
    with_cuts = bool(args.geojson or args.svg)
    total = 1 + len(alphas) * with_cuts + sum(bool(x) for x in (args.geojson, args.svg, args.compact, args.ros))
    with steps(total) as step:
        step(f"reading {Path(args.map).name}")
        fuzzy = load_map(args)
        # every output is made before any is written: one the format cannot hold, or a grid too
        # large, leaves no other output behind (found by the fuzzer)
        if args.compact:
            from ..errors import FormatLimitError
            from ..formats.compact import encode, stored_map

            step(f"encoding {args.compact}")
            mfs = fuzzy.table.to_dicts()
            try:
                stored = stored_map(fuzzy.crisp, mfs)
                compact = encode(stored, mfs)
            except FormatLimitError as e:
                raise MapFileError(args.compact, f"cannot write a compact map: {e}") from None
        if args.ros:
            # --resolution is in metres, as ROS has it, unless the map's unit is one we do not know
            step(f"membership raster for {args.ros}")
            scale = metres_per_unit(fuzzy.unit)
            ros_unit = "m" if scale else fuzzy.unit
            try:
                raster = membership_raster(fuzzy, args.resolution / (scale or 1.0), args.ros_method)
            except ValueError as e:
                raise MapFileError(Path(args.ros) / f"{name}.yaml", str(e)) from None
        cuts = []
        for a in alphas if with_cuts else []:
            step(f"α-cut at α = {a:g} ({args.method})")
            cuts.append(fuzzy.alpha_cut(a, args.method))
        if args.svg:
            step(f"drawing {args.svg}")
            support = next((c for c in cuts if c.alpha == 0.0), None) or fuzzy.alpha_cut(0.0, args.method)
            svg = svg_document(fuzzy, cuts, support, title=Path(args.map).name).encode("utf-8")
        if args.geojson:
            step(f"writing {args.geojson}")
            n = write_geojson(args.geojson, crisp_features(fuzzy.crisp) + alpha_cut_features(cuts))
            print(f"{args.geojson}: {n} bytes (crisp map and {len(cuts)} α-cuts at α = "
                  f"{', '.join(f'{a:g}' for a in alphas)}, {args.method})")
    if args.svg:
        n = write_atomic(args.svg, svg)
        print(f"{args.svg}: {n} bytes")
    if args.compact:
        n = write_atomic(args.compact, compact)
        snapped = f", {fuzzy.crisp.n_vertices} before snap rounding" if stored is not fuzzy.crisp else ""
        print(f"{args.compact}: {n} bytes ({stored.n_vertices} vertices{snapped})")
    if args.ros:
        yaml_path, pgm_path = write_ros(args.ros, name, raster)
        h, w = raster.shape
        crisp_area = fuzzy.crisp_geometry.area
        print(f"{yaml_path}, {pgm_path}: {w} × {h} cells of {args.resolution:g} {ros_unit}, free area "
              f"{raster.free_area():.6g} {fuzzy.unit}² (crisp map {crisp_area:.6g}), μ by {args.ros_method}")
        if not scale:
            print(f"note: the map's unit {fuzzy.unit!r} is not m, cm or mm: the YAML's resolution and origin are "
                  f"in {fuzzy.unit!r}, not in metres as ROS expects", file=sys.stderr)
    print(f"{time.perf_counter() - t0:.2f} s")
    return 0
