"""fuzzybrep plan: a path from start to goal in the space free at confidence α."""

from __future__ import annotations

import argparse
import json
import math
import sys

from ..use.plan import MODES, planner
from ._maps import add_map_argument, add_method_argument, load_map
from ._types import alpha, finite, number

NAME = "plan"
HELP = "plan a path that stays in the space free at confidence α, kept a robot's radius from its edge"


_radius = number(lambda r: 0 <= r < math.inf, "radius must be a number, got {text!r}",
                 "radius must be a finite number ≥ 0, got {text}")


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_map_argument(p)
    p.add_argument("--start", type=finite, nargs=2, required=True, metavar=("X", "Y"), help="where the robot is")
    p.add_argument("--goal", type=finite, nargs=2, required=True, metavar=("X", "Y"), help="where it should go")
    p.add_argument("--alpha", type=alpha, default=0.0, metavar="A",
                   help="plan in the inner α-cut, the space free at confidence α (default 0: the support's "
                        "inner bound, the safest)")
    p.add_argument("--radius", type=_radius, default=0.0, metavar="R",
                   help="the robot's radius, in the map's unit: the free space is shrunk by it (default 0)")
    p.add_argument("--mode", choices=MODES, default="shortest",
                   help="shortest: the exact shortest path (default); clearance: along the medial axis, "
                        "as far from obstacles as the space allows")
    add_method_argument(p, what="the α-cut planned in")
    p.add_argument("--json", action="store_true", help="print the plan as JSON: path, length, mode, alpha, ...")
    p.add_argument("--plot", metavar="PNG", help="picture of the map, the safe region and the path")


def run(args: argparse.Namespace) -> int:
    if args.plot:
        from ..formats.files import check_outputs
        from ..plot import check_figure_path

        check_outputs(args.plot, inputs=(args.map,))  # not the map read, whatever its name
        check_figure_path(args.plot)  # before the planning, not after it
    fuzzy = load_map(args)
    pl = planner(fuzzy, args.alpha, args.radius, args.method)
    result = pl.plan(args.start, args.goal, args.mode)
    if args.plot:
        from ..plot import save_plan_figure

        save_plan_figure(args.plot, fuzzy.crisp, pl.safe, [result],
                         title=f"{result.mode} path, α = {args.alpha:g}, radius {args.radius:g} ({args.method})")
    out = sys.stdout
    if args.json:
        out.write(json.dumps(result.to_json(), separators=(",", ":")) + "\n")
        return 0
    u = result.unit
    # 6 significant digits: a map in mm (the thesis's unit) has lengths of 10000 and more, which 4
    # would print as 1.087e+04
    out.write(f"{result.mode} path: length {result.length:.6g} {u}, {len(result.path)} points, "
              f"clearance {result.clearance:.6g} {u} (α = {args.alpha:g}, radius {args.radius:g}, {args.method})\n")
    if result.note:
        out.write(f"note: {result.note}\n")
    # rounded to an eighth of the tolerance the path was checked with: read back, it is still
    # inside (6 significant digits were 1 cm at 1000 m from the origin, metres at 500 000)
    step = pl.tolerance / 8
    for x, y in result.path:
        out.write(f"{_coordinate(x, step)} {_coordinate(y, step)}\n")
    return 0


def _coordinate(v: float, step: float) -> str:
    """``v`` with the fewest significant digits (17 at most: they read back exactly) that keep
    it within ``step`` / 2; "-9.8", not "-9.800000000"."""
    v = float(v)
    if v == 0:  # -0.0 too
        return "0"
    digits = math.floor(math.log10(abs(v))) + 1 - math.floor(math.log10(step))
    # enough digits on paper may not be enough read back: near 7e16, where floats lie 16 apart,
    # 16 digits named a float 8 away from v with a step of 10; one more digit then
    for d in range(min(max(digits, 1), 17), 17):
        text = f"{v:.{d}g}"
        if abs(float(text) - v) <= step / 2:
            return text
    return f"{v:.17g}"
