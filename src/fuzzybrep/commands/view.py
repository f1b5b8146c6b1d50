"""fuzzybrep view: one self-contained HTML page to look at a map (α slider, μ under the cursor)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ._maps import add_map_argument, load_map
from ._progress import steps
from ._types import number

NAME = "view"
HELP = "write one self-contained HTML page showing the map, its α-cuts, μ under the cursor, poses and a path"


_levels = number(lambda n: 2 <= n <= 1001, "--alphas must be a whole number, got {text!r}",
                 "--alphas must be 2 to 1001, got {value}", cast=int)


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_map_argument(p)
    p.add_argument("--html", required=True, metavar="OUT.html", help="page to write (no network needed to open it)")
    p.add_argument("--path", metavar="PATH.json", help='planned path to draw: {"path": [[x, y], ...]}')
    p.add_argument("--method", type=lambda s: {"sweep": "thesis"}.get(s, s), choices=("safe", "thesis"), default="safe",
                   help="α-cuts and μ the page draws: safe (the conservative sweep, default) or thesis (the "
                        "thesis's single normal vertex sweep; sweep is its old name)")
    p.add_argument("--alphas", type=_levels, default=101, metavar="N",
                   help="positions of the α slider from 0 to 1 (default 101: steps of 0.01)")


def run(args: argparse.Namespace) -> int:
    from ..formats.files import check_outputs
    from ..formats.mapfile import read_map
    from ..viewer import read_path, write_html

    check_outputs(args.html, inputs=(args.map, args.path))
    t0 = time.perf_counter()
    with steps(2) as step:
        step(f"reading {Path(args.map).name}")
        m = read_map(args.map)
        fuzzy = load_map(args, m)
        path = read_path(args.path) if args.path else None
        step(f"α-cuts at {args.alphas} levels into {args.html}")
        n = write_html(args.html, fuzzy, m.poses, path, name=Path(args.map).name, slider_levels=args.alphas,
                       method=args.method)
    extras = [f"{len(m.poses)} poses"] if m.poses is not None else []
    if path is not None:
        extras.append(f"a path of {len(path)} points")
    print(f"{args.html}: {n} bytes ({fuzzy.crisp.n_vertices} vertices, {fuzzy.crisp.n_holes} holes"
          f"{', ' + ', '.join(extras) if extras else ''}), {time.perf_counter() - t0:.2f} s")
    return 0
