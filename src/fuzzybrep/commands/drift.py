"""fuzzybrep drift: a log with true poses in, the same log with drifting odometry out."""

from __future__ import annotations

import math
from pathlib import Path

from ._logopts import add_log_arguments, read_log, read_notes
from ._types import finite, non_negative, number, positive, seed

NAME = "drift"
HELP = "give a log whose poses are true (a SLAM-corrected log) drifting odometry, for localisation benchmarks"

_error = number(lambda v: -1 < v < math.inf, "{text!r} is not a number", "{text} must be a number above -1")


def add_arguments(p) -> None:
    add_log_arguments(p)
    p.add_argument("--out", required=True,
                   help="log to write: CSV scans when it ends in .csv or .csv.gz, else a CARMEN log (gzip when .gz); "
                        "the poses are the input's (the truth), the odometry fields drift")
    p.add_argument("--seed", type=seed, default=0, help="random seed of the odometry's random error (default 0)")
    # the defaults are sim.drift.BENCHMARK_RATES (a test holds them equal: importing sim.drift here
    # would put NumPy into every `fuzzybrep --help`)
    g = p.add_argument_group("odometry error (Appendix I); defaults: the localisation benchmark's")
    g.add_argument("--distance-error", type=_error, default=0.05,
                   help="the odometry reports (1 + this) × the distance driven (default 0.05: 5 %%)")
    g.add_argument("--heading-drift", type=finite, default=2.0,
                   help="degrees the odometry turns per metre driven straight (default 2)")
    g.add_argument("--turn-error", type=_error, default=0.02,
                   help="the odometry reports (1 + this) × every turn (default 0.02)")
    g.add_argument("--ed", type=positive, metavar="E_D",
                   help="UMBmark's E_d = D_R/D_L instead of --heading-drift (with --eb and --es: the wheels' own errors)")
    g.add_argument("--eb", type=positive, metavar="E_B", help="UMBmark's E_b = b_actual/b_nominal instead of --turn-error")
    g.add_argument("--es", type=positive, metavar="E_S",
                   help="mean wheel diameter / nominal instead of --distance-error")
    g.add_argument("--wheelbase", type=positive, default=0.267, help="nominal wheelbase b in metres (default 0.267, the Pioneer 3-DX)")
    g.add_argument("--sigma-distance", type=non_negative, default=0.02,
                   help="random distance error, metres per √m driven (default 0.02)")
    g.add_argument("--sigma-heading", type=non_negative, default=0.5,
                   help="random heading error, degrees per √m driven (default 0.5)")
    g.add_argument("--sigma-turn", type=non_negative, default=1.0,
                   help="random turn error, degrees per √rad turned (default 1)")
    p.add_argument("--quiet", action="store_true", help="no summary")


def model_from_args(args):
    """The DriftModel the options ask for: the rates, or UMBmark's wheel parameters where given."""
    from ..sim.drift import DriftModel

    rates = DriftModel.from_rates(args.distance_error, args.heading_drift, args.turn_error, args.wheelbase,
                                  args.sigma_distance, args.sigma_heading, args.sigma_turn)
    if args.ed is None and args.eb is None and args.es is None:
        return rates
    from dataclasses import replace

    return replace(rates, E_d=rates.E_d if args.ed is None else args.ed, E_b=rates.E_b if args.eb is None else args.eb,
                   E_s=rates.E_s if args.es is None else args.es)


def run(args) -> int:
    import numpy as np

    from ..formats.files import check_outputs
    from ..scans.carmen import write_carmen
    from ..scans.csvscans import write_csv
    from ..sim.drift import drift_scans, drift_stats

    model = model_from_args(args)
    check_outputs(args.out, inputs=(args.log,))
    scans, report = read_log(args)
    out = drift_scans(scans, model, args.seed)
    name = Path(args.out).name.lower()
    if name.endswith((".csv", ".csv.gz")):
        nbytes = write_csv(args.out, out)
    else:
        header = (f"fuzzybrep drift {Path(args.log).name} --seed {args.seed}: {model.describe()}\n"
                  "x y theta: the input's pose (the truth); odom_x odom_y odom_theta: the drifting odometry")
        nbytes = write_carmen(args.out, out, header=header)
    if not args.quiet:
        for line in read_notes(report):
            print(line)
        stats = drift_stats(np.array([s.odometry for s in out]), np.array([s.pose for s in out]))
        print(f"{Path(args.log).name}: {len(out)} scans, {model.describe()}")
        print(f"{stats.summary()}; {nbytes} bytes -> {args.out}")
    return 0
