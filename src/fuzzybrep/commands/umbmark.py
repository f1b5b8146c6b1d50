"""``fuzzybrep umbmark RUNS.csv``: UMBmark (thesis Appendix I) from ten stop positions."""

from __future__ import annotations

import argparse
import json
import math

from ..sim.umbmark import (
    BORENSTEIN_EB_TURN,
    REV_COUNT,
    SIDE_MM,
    THESIS_EB_TURN,
    WHEEL_MM,
    WHEELBASE_MM,
    read_runs,
    total_maximum_error,
    umbmark,
)

NAME = "umbmark"
HELP = "odometry systematic errors from UMBmark square runs (thesis Appendix I)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("runs", metavar="RUNS.csv",
                   help="stop positions in mm: header direction,x,y; direction cw or ccw; five runs each")
    p.add_argument("--side", type=float, default=SIDE_MM, help="side L of the square path, mm (default %(default)g)")
    p.add_argument("--wheelbase", type=float, default=WHEELBASE_MM, help="nominal wheelbase b, mm (default %(default)g)")
    p.add_argument("--wheel", type=float, default=WHEEL_MM,
                   help="travel per wheel revolution for driftFactor, mm (default %(default)g)")
    p.add_argument("--rev-count", type=float, default=REV_COUNT,
                   help="revCount the runs were made with (default %(default)g)")
    p.add_argument("--borenstein-eb", action="store_true",
                   help="E_b = 90°/(90° - α) as Borenstein & Feng derive it, not 180°/(180° - α) as the thesis prints it")
    p.add_argument("--lrf-error", type=float, default=15.0,
                   help="laser range finder error for the TME line, mm (default %(default)g)")
    p.add_argument("--json", action="store_true", help="print the values as JSON")


def run(args: argparse.Namespace) -> int:
    cw, ccw = read_runs(args.runs)
    turn = BORENSTEIN_EB_TURN if args.borenstein_eb else THESIS_EB_TURN
    res = umbmark(cw, ccw, side=args.side, wheelbase=args.wheelbase, wheel=args.wheel,
                  rev_count=args.rev_count, eb_turn_deg=turn)
    if args.json:
        # JSON has no infinity: R is infinite when β = 0 (equal wheels)
        print(json.dumps({k: (v if math.isfinite(v) else None) for k, v in res.as_dict().items()}, indent=2))
        return 0
    tme = total_maximum_error(res.E_max_syst, args.lrf_error)
    rows = [
        ("centre of gravity, cw", f"x = {res.x_cg_cw:.1f} mm, y = {res.y_cg_cw:.1f} mm, r = {res.r_cw:.2f} mm"),
        ("centre of gravity, ccw", f"x = {res.x_cg_ccw:.1f} mm, y = {res.y_cg_ccw:.1f} mm, r = {res.r_ccw:.2f} mm"),
        ("E_max,syst", f"{res.E_max_syst:.2f} mm"),
        ("alpha (Eq. 6)", f"{res.alpha_deg:.4f}°"),
        ("beta (Eq. 8)", f"{res.beta_deg:.4f}°"),
        ("R (Eq. 7)", f"{res.R:.1f} mm"),
        ("E_d = D_R/D_L (Eq. 4)", f"{res.E_d:.6f}"),
        ("E_b = b_actual/b_nominal (Eq. 5)", f"{res.E_b:.6f}  ({turn:g}°/({turn:g}° - alpha))"),
        ("driftFactor", f"{res.drift_factor:.2f}  (({args.wheel:g} mm · E_d - {args.wheel:g} mm) · 10)"),
        ("revCount", f"{res.rev_count:.2f}  ({args.rev_count:g} / E_b)"),
        ("TME", f"{tme:.2f} mm  ({abs(args.lrf_error):g} mm laser + {res.E_max_syst:.2f} mm odometry)"),
    ]
    print(f"UMBmark: {len(cw)} cw and {len(ccw)} ccw runs, L = {args.side:g} mm, b = {args.wheelbase:g} mm")
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"  {k:<{width}}  {v}")
    return 0
