"""``fuzzybrep demo``: the thesis's chapter 5 experiment on a simulated floor, checked against the truth."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from ._types import seed
from ._world import add_world_arguments

NAME = "demo"
HELP = "reproduce the thesis's experiment on a built-in (or your) floor plan and check the map against the truth"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", metavar="DIR", default="fuzzybrep-demo",
                   help="folder for floorplan.geojson, map.json, report.json and the figures (default %(default)s)")
    p.add_argument("--seed", type=seed, default=0, help="random seed of the run and the UMBmark runs (default %(default)d)")
    add_world_arguments(p, "your own floor plan (docs/demo.md)")
    # one or the other: with both, --raw-odometry would silently override what --poses asked for
    g = p.add_argument_group("poses the map uses").add_mutually_exclusive_group()
    g.add_argument("--poses", choices=["relocalised", "odometry", "true"], default="relocalised",
                   help="relocalised (default): the robot knows its pose when it leaves each stop, so every scan "
                        "carries one leg of odometry error; odometry: pure dead reckoning from home; true: no error")
    g.add_argument("--raw-odometry", action="store_true", help="same as --poses odometry: see what dead reckoning does")
    p.add_argument("--no-figures", action="store_true", help="skip the four figures (faster)")
    p.add_argument("--json", action="store_true", help="print report.json instead of the summary")


def run(args: argparse.Namespace) -> int:
    from ..formats.files import check_outputs, write_atomic
    from ..sim.demo import report, run_demo, summary
    from ._world import world_and_route

    t0 = time.perf_counter()
    out = Path(args.out)
    names = ["floorplan.geojson", "map.json", "report.json"]
    if not args.no_figures:
        from ..figures import FIGURES

        names += list(FIGURES)
    # before the run, not after it; --world out/floorplan.geojson would be rewritten by its own copy
    check_outputs(*(out / n for n in names), inputs=(args.world, args.route))
    world, route, source = world_and_route(args)
    result = run_demo(world, route, seed=args.seed, pose_model="odometry" if args.raw_odometry else args.poses,
                      world_source=source)

    t_out = time.perf_counter()
    world.write_geojson(out / "floorplan.geojson", route)
    fz = result.maps["filtered"].fuzzy
    poses = [[*s.pose, s.timestamp] for s in result.scans]
    fz.save(out / "map.json", poses=poses, metadata={
        "source": "fuzzybrep demo", "world": source, "seed": args.seed, "pose_model": result.pose_model,
        "tme_m": result.tme_m, "build": "filtered", "scans": len(result.scans),
    })
    result.timings["write files"] = time.perf_counter() - t_out
    files = ["floorplan.geojson", "map.json", "report.json"]
    if not args.no_figures:
        from ..figures import FIGURES

        for name, draw in FIGURES.items():
            t = time.perf_counter()
            draw(result, out / name)
            result.timings[f"figure {name}"] = time.perf_counter() - t
            files.append(name)
    rep = report(result)
    rep["files"] = files
    rep["total_seconds"] = time.perf_counter() - t0
    text = json.dumps(rep, indent=1, allow_nan=False)
    write_atomic(out / "report.json", (text + "\n").encode())
    if args.json:
        print(text)
    else:
        print("\n".join(summary(result, str(out), rep["total_seconds"])))
    return 0
