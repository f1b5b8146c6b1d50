"""``fuzzybrep simulate``: drive the simulated Pioneer 3-DX round a floor plan and scan (thesis ch. 5)."""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import replace

from ..errors import FuzzyBrepError
from ..sim.simulate import DiffDrive, Laser, save_run, simulate_run, umbmark_runs
from ..sim.umbmark import write_runs
from ._types import seed
from ._world import add_world_arguments, world_and_route

NAME = "simulate"
HELP = "simulate the thesis's experiment: a Pioneer 3-DX with an LMS200 round a floor plan"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_world_arguments(p, "world and route (docs/simulator.md)")
    g = p.add_argument_group("robot (Appendix I)")
    g.add_argument("--uncalibrated", action="store_true",
                   help="odometry errors from Table I.1 (before calibration) instead of Table I.2")
    g.add_argument("--ed", type=float, help="E_d = D_R/D_L (overrides the table's)")
    g.add_argument("--eb", type=float, help="E_b = b_actual/b_nominal (overrides the table's)")
    g.add_argument("--slip", type=float, help="non-systematic wheel error, m per √m of travel (default 0.0005)")
    g = p.add_argument_group("laser (LMS200)")
    g.add_argument("--glass-pass", type=float, default=Laser.glass_pass,
                   help="probability a beam passes through glass (default %(default)g)")
    g.add_argument("--glass-reflect", type=float, default=Laser.glass_reflect,
                   help="probability a beam reflects off glass (default %(default)g); 0 and 0: glass is a wall")
    p.add_argument("--seed", type=seed, default=0, help="random seed (default %(default)d)")
    g = p.add_argument_group("outputs")
    g.add_argument("--out", metavar="SCANS.csv",
                   help="write the scans: .csv or .csv.gz as CSV scans at the odometry poses, which build, grid and "
                        "evaluate read; .npz the whole run (scans, odometry and true poses) for Python "
                        "(fuzzybrep.sim.simulate.load_scans)")
    g.add_argument("--world-out", metavar="FILE.geojson", help="write the world and route as GeoJSON")
    g.add_argument("--umbmark-out", metavar="RUNS.csv",
                   help="also simulate the 5 + 5 UMBmark square runs (4 m) with this robot; write them for `fuzzybrep umbmark`")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")


def run(args: argparse.Namespace) -> int:
    from ..formats.files import check_outputs

    # the floor plan and route read are inputs: --world-out onto --world rewrote the user's plan
    check_outputs(args.out, args.world_out, args.umbmark_out, inputs=(args.world, args.route))
    world, route, _ = world_and_route(args)
    robot = DiffDrive.pioneer_3dx(calibrated=not args.uncalibrated)
    overrides = {k: v for k, v in (("E_d", args.ed), ("E_b", args.eb), ("slip", args.slip)) if v is not None}
    try:
        robot = replace(robot, **overrides)
        laser = Laser(glass_pass=args.glass_pass, glass_reflect=args.glass_reflect)
    except ValueError as e:
        raise FuzzyBrepError(f"bad robot or laser option: {e}") from None
    sim = simulate_run(world, route, laser, robot, seed=args.seed)
    pos, head = sim.final_drift
    summary = {
        "world": world.name, "free_area_m2": world.free.area, "holes": len(world.free.interiors),
        "wall_length_m": world.walls.length, "glass_length_m": world.glass_walls.length,
        "route_length_m": route.length, "stops": len(sim.stops), "scans": len(sim.scans),
        "E_d": robot.E_d, "E_b": robot.E_b, "slip": robot.slip, "laser_bias_mm": sim.laser_bias * 1000,
        "final_drift_m": pos, "final_heading_error_deg": math.degrees(head), "max_drift_m": float(sim.drift.max()),
        "seed": args.seed,
    }
    if args.out:
        if args.out.lower().endswith(".npz"):
            save_run(args.out, sim)
        else:
            from ..scans.csvscans import write_csv

            write_csv(args.out, sim.scans)  # the odometry poses: what the robot knows, as a real log has
        summary["out"] = args.out
    if args.world_out:
        world.write_geojson(args.world_out, route)
        summary["world_out"] = args.world_out
    if args.umbmark_out:
        write_runs(args.umbmark_out, *umbmark_runs(robot, seed=args.seed))
        summary["umbmark_out"] = args.umbmark_out
    if args.json:
        print(json.dumps(summary, indent=2))
        return 0
    print(f"world {world.name}: {world.free.area:.1f} m² free, {len(world.free.interiors)} hole(s), "
          f"{world.walls.length:.1f} m of wall ({world.glass_walls.length:.1f} m glass)")
    print(f"route {route.length:.1f} m, {len(sim.stops)} stops every {route.spacing:g} m, {len(sim.scans)} scans of {laser.n_beams} beams")
    print(f"robot E_d = {robot.E_d:.6f}, E_b = {robot.E_b:.6f}, slip {robot.slip:g} m/√m; laser bias {sim.laser_bias * 1000:+.1f} mm")
    print(f"odometry drift at the end: {pos:.3f} m, heading {math.degrees(head):+.2f}°; largest at a scan {sim.drift.max():.3f} m")
    for key, what in (("out", "scans"), ("world_out", "world"), ("umbmark_out", "UMBmark runs")):
        if key in summary:
            print(f"wrote {what} to {summary[key]}")
    return 0
