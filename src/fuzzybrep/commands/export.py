"""fuzzybrep export: a map file out to other tools (GeoJSON, ROS map_server, Nav2, ROS 2 bag, MCAP, SVG)."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from ._maps import add_map_argument, add_method_argument, load_map
from ._progress import steps
from ._types import add_georef_argument, alpha, file_name, number

NAME = "export"
HELP = ("export a map: α-cuts as GeoJSON, a ROS map_server pair, Nav2 map and costmap filter masks, a ROS 2 bag, "
        "a Foxglove MCAP file, an SVG picture")


_percent = number(lambda v: 0 <= v < 100, "{text!r} is not a number", "{text} must be a percentage in [0, 100)")
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
    out.add_argument("--nav2", metavar="DIR",
                     help="Nav2: the map (mode scale, PNG with alpha for unknown; or --nav2-mode raw) keeping μ, a "
                          "keepout mask from an α-cut, a speed mask from μ, and NAME_nav2_params.yaml with the "
                          "CostmapFilterInfo parameters (docs/export.md)")
    out.add_argument("--bag", metavar="OUT",
                     help="ROS 2 bag (folder): nav_msgs/OccupancyGrid on /map and visualization_msgs/MarkerArray of "
                          "the crisp boundary and α-cuts on /map_boundary, one message each at t = 0, transient local")
    out.add_argument("--mcap", metavar="OUT.mcap",
                     help="MCAP with Foxglove schemas: foxglove.Grid on /map and foxglove.SceneUpdate of the crisp "
                          "boundary and α-cuts on /map_boundary")
    out.add_argument("--svg", metavar="OUT.svg",
                     help="standalone SVG picture: crisp map, support band, α-cut outlines")
    out.add_argument("--compact", metavar="OUT.fbrc",
                     help="the compact binary map a small robot stores: vertices to 1 mm as varint steps, edge "
                          "kinds, Table 4.2 (fuzzybrep.formats.compact; the fuzzy tables follow from it in O(n))")
    add_georef_argument(p)
    p.add_argument("--alpha", type=alpha, action="append", metavar="A",
                   help="α level for --geojson, --svg, --bag and --mcap; repeat for several (default 0 0.25 0.5 0.75 1)")
    add_method_argument(p, what="α-cuts for --geojson, --svg, --bag, --mcap and the --nav2 keepout mask")
    p.add_argument("--resolution", type=_resolution, default=0.05,
                   help="--ros, --nav2, --bag, --mcap: cell side in metres (default 0.05; in the map's unit if it is "
                        "not m, cm or mm)")
    p.add_argument("--name", type=file_name, default=None,
                   help="--ros, --nav2: base name of the files (default: the map file's name)")
    add_method_argument(p, "--ros-method", what="--ros, --nav2, --bag, --mcap: μ of the cells")
    p.add_argument("--nav2-mode", choices=("scale", "raw"), default="scale",
                   help="--nav2: map_server mode of the map and the speed mask (default scale: PNG, alpha marks unknown)")
    p.add_argument("--keepout-alpha", type=alpha, default=0.0, metavar="A",
                   help="--nav2: the keepout mask keeps the robot in the inner α-cut at this α (default 0, as plan)")
    p.add_argument("--min-speed", type=_percent, default=30.0, metavar="PCT",
                   help="--nav2: the speed mask's limit at the crisp boundary, percent of the maximum (default 30)")
    p.add_argument("--bag-storage", choices=("mcap", "sqlite3"), default="mcap",
                   help="--bag: the ROS 2 bag's storage (default mcap)")
    p.add_argument("--ros-distro", choices=("humble", "jazzy"), default="humble",
                   help="--bag: the ROS 2 release whose rosbag2 reads it: humble (metadata version 5, QoS profiles "
                        "as a string; Jazzy reads it too: the default) or jazzy (version 9)")


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
    from ..formats.nav2 import nav2_paths
    from ..formats.svg import svg_document

    if not (args.geojson or args.ros or args.svg or args.compact or args.nav2 or args.bag or args.mcap):
        print("fuzzybrep export: error: give at least one of --geojson, --ros, --nav2, --bag, --mcap, --svg, --compact",
              file=sys.stderr)
        return 2
    name = args.name or Path(args.map).stem
    ros = [Path(args.ros) / f"{name}.{ext}" for ext in ("yaml", "pgm")] if args.ros else []
    nav2 = nav2_paths(args.nav2, name, args.nav2_mode) if args.nav2 else []
    bag = args.bag
    if bag and Path(bag).is_dir():  # a bag is a folder: a bag there already is replaced whole
        if not (Path(bag) / "metadata.yaml").is_file():
            raise MapFileError(bag, "is a folder but not a ROS 2 bag (no metadata.yaml): not replaced")
        if Path(args.map).resolve().is_relative_to(Path(bag).resolve()):
            raise MapFileError(bag, f"cannot write: the bag folder holds the input {args.map}, which replacing the "
                                    f"bag would delete; give another name")
        bag = None
    check_outputs(args.geojson, args.svg, args.compact, bag, args.mcap, *ros, *nav2, inputs=(args.map,))
    t0 = time.perf_counter()
    alphas = sorted(set(args.alpha)) if args.alpha else list(DEFAULT_ALPHAS)
    with_cuts = bool(args.geojson or args.svg or args.bag or args.mcap)
    with_raster = bool(args.ros or args.nav2 or args.bag or args.mcap)
    written_in_steps = (args.geojson, args.nav2, args.bag, args.mcap)
    total = (1 + len(alphas) * with_cuts + with_raster + sum(bool(x) for x in (args.svg, args.compact))
             + sum(bool(x) for x in written_in_steps))
    # --resolution is in metres, as ROS has it, unless the map's unit is one we do not know
    with steps(total) as step:
        step(f"reading {Path(args.map).name}")
        fuzzy = load_map(args)
        scale = metres_per_unit(fuzzy.unit)
        ros_unit = "m" if scale else fuzzy.unit
        # every output is made before any is written: one the format cannot hold, or a grid too
        # large, leaves no other output behind (found by the fuzzer); the Nav2 files, the bag and
        # the MCAP file are made from the raster and the α-cuts, both made here first
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
        raster = None
        if with_raster:
            first = Path(args.ros) / f"{name}.yaml" if args.ros else (nav2[0] if nav2 else Path(args.bag or args.mcap))
            step(f"membership raster at {args.resolution:g} {ros_unit}")
            try:
                raster = membership_raster(fuzzy, args.resolution / (scale or 1.0), args.ros_method)
            except ValueError as e:
                raise MapFileError(first, str(e)) from None
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
            try:
                n = write_geojson(args.geojson, crisp_features(fuzzy.crisp) + alpha_cut_features(cuts),
                                  unit=fuzzy.unit, georef=args.georef)
            except ValueError as e:
                raise MapFileError(args.geojson, str(e)) from None
            print(f"{args.geojson}: {n} bytes (crisp map and {len(cuts)} α-cuts at α = "
                  f"{', '.join(f'{a:g}' for a in alphas)}, {args.method})")
        if raster is not None:
            h, w = raster.shape
            print(f"raster: {w} × {h} cells of {args.resolution:g} {ros_unit}, μ by {args.ros_method}: free "
                  f"{raster.free_area():.6g} {fuzzy.unit}² (crisp map {fuzzy.crisp_geometry.area:.6g}), occupied "
                  f"{raster.occupied_area():.6g} (the obstacle band), unknown {raster.unknown_area():.6g}")
            if not scale:
                print(f"note: the map's unit {fuzzy.unit!r} is not m, cm or mm: resolution and origin are "
                      f"in {fuzzy.unit!r}, not in metres as ROS expects", file=sys.stderr)
        k = scale or 1.0
        if args.nav2:
            from ..formats.nav2 import write_nav2

            step(f"writing {args.nav2}")
            files = write_nav2(args.nav2, name, raster, mode=args.nav2_mode, alpha=args.keepout_alpha,
                               min_speed=args.min_speed, resolution_m=round(raster.resolution * k, 12),
                               origin_m=(round(raster.origin[0] * k, 12), round(raster.origin[1] * k, 12)))
            print(f"{files.map_yaml}: Nav2 map ({files.mode}), keepout mask at α = {files.alpha:g}, speed mask "
                  f"{files.speed_base:g} {files.speed_multiplier:+g}·mask %; parameters in {files.params}")
        if args.bag:
            from ..formats.ros2bag import write_bag

            step(f"writing {args.bag}")
            write_bag(args.bag, fuzzy, raster, cuts, args.bag_storage, scale=k, distro=args.ros_distro)
            print(f"{args.bag}: ROS 2 bag ({args.bag_storage}, for {args.ros_distro} and newer): /map OccupancyGrid, /map_boundary MarkerArray "
                  f"(crisp boundary, frontier edges, {len([c for c in cuts if c.alpha < 1])} α-cuts), latched")
        if args.mcap:
            from ..formats.foxglove_mcap import write_mcap

            step(f"writing {args.mcap}")
            n = write_mcap(args.mcap, fuzzy, raster, cuts, scale=k)
            print(f"{args.mcap}: {n} bytes of MCAP: /map foxglove.Grid, /map_boundary foxglove.SceneUpdate")
    if args.svg:
        n = write_atomic(args.svg, svg)
        print(f"{args.svg}: {n} bytes")
        if n > 10_000_000:
            print(f"note: {args.svg} is over 10 MB, which librsvg (and other readers built on libxml2) refuse to read; "
                  f"fewer --alpha levels make it smaller ({len(cuts)} now)", file=sys.stderr)
    if args.compact:
        from ..formats.compact import QUANTUM

        n = write_atomic(args.compact, compact)
        print(f"{args.compact}: {n} bytes ({stored.n_vertices} vertices, {stored.n_holes} holes)")
        if stored is not fuzzy.crisp:
            # snap rounding onto the 1 mm grid joins holes that came closer than that (issue 20: 813
            # holes became 715 without a word)
            c = fuzzy.crisp
            q = QUANTUM.get(c.unit, 1e-3)
            print(f"note: snap rounding onto the {q:g} {c.unit} grid changed the map: {c.n_vertices} -> "
                  f"{stored.n_vertices} vertices, {c.n_holes} -> {stored.n_holes} holes, {len(c.regions)} -> "
                  f"{len(stored.regions)} pieces (holes less than a quantum apart merge); area "
                  f"{fuzzy.crisp_geometry.area:.6g} -> {stored.to_shapely().area:.6g} {c.unit}²")
    if args.ros:
        yaml_path, pgm_path = write_ros(args.ros, name, raster)
        print(f"{yaml_path}, {pgm_path}: map_server trinary, grey levels carry μ")
    print(f"{time.perf_counter() - t0:.2f} s")
    return 0
