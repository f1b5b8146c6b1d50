"""fuzzybrep membership: μ of the fuzzy boundary at points read from a CSV file."""

from __future__ import annotations

import argparse
import sys

from ..formats.points import read_points
from ..fuzzy.map import METHODS
from ._maps import add_map_argument, add_method_argument, load_map

NAME = "membership"
HELP = "print μ of the fuzzy boundary at each point of a CSV file (x,y per line)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_map_argument(p)
    p.add_argument("--points", required=True, metavar="PTS.csv", help="CSV with x,y per line (header optional)")
    add_method_argument(p, what="μ", extra=("both", "all"))


def run(args: argparse.Namespace) -> int:
    fuzzy = load_map(args)
    pts = read_points(args.points)
    # both: the default's and the exact μ side by side; all: every method's
    methods = {"both": ("safe", "exact"), "all": METHODS}.get(args.method, (args.method,))
    cols = [fuzzy.membership(pts, m) for m in methods]
    out = sys.stdout
    out.write(",".join(["x", "y"] + [f"mu_{m}" if len(methods) > 1 else "mu" for m in methods]) + "\n")
    for i, (x, y) in enumerate(pts):
        out.write(",".join([repr(float(x)), repr(float(y))] + [f"{c[i]:.6g}" for c in cols]) + "\n")
    return 0
