"""fuzzybrep membership: μ of the fuzzy boundary at points read from a CSV file."""

from __future__ import annotations

import argparse
import sys

from ..formats.geojson import read_points
from ._maps import add_map_argument, load_map

NAME = "membership"
HELP = "print μ of the fuzzy boundary at each point of a CSV file (x,y per line)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_map_argument(p)
    p.add_argument("--points", required=True, metavar="PTS.csv", help="CSV with x,y per line (header optional)")
    p.add_argument("--method", choices=("sweep", "exact", "both"), default="sweep",
                   help="sweep (default), exact (Extension principle), or both columns")


def run(args: argparse.Namespace) -> int:
    fuzzy = load_map(args)
    pts = read_points(args.points)
    methods = ("sweep", "exact") if args.method == "both" else (args.method,)
    cols = [fuzzy.membership(pts, m) for m in methods]
    out = sys.stdout
    out.write(",".join(["x", "y"] + [f"mu_{m}" if len(methods) > 1 else "mu" for m in methods]) + "\n")
    for i, (x, y) in enumerate(pts):
        out.write(",".join([repr(float(x)), repr(float(y))] + [f"{c[i]:.6g}" for c in cols]) + "\n")
    return 0
