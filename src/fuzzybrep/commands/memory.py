"""fuzzybrep memory: Table 5.3 for a map: fuzzy B-rep storage against occupancy grids."""

from __future__ import annotations

import argparse

from ..fuzzy import memory_markdown
from ._maps import add_map_argument, load_map

NAME = "memory"
HELP = "print Table 5.3 for a map: fuzzy B-rep memory (thesis accounting and compact) vs occupancy grids"


def _cell(s: str) -> float:
    try:
        c = float(s)
    except ValueError:
        raise argparse.ArgumentTypeError(f"cell size must be a number, got {s!r}") from None
    if not c > 0:
        raise argparse.ArgumentTypeError(f"cell size must be positive, got {s}")
    return c


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_map_argument(p)
    p.add_argument("--cell", type=_cell, action="append", metavar="SIZE",
                   help="occupancy-grid cell size in the map's unit; repeat (default 0.3 0.2 0.1)")


def run(args: argparse.Namespace) -> int:
    fuzzy = load_map(args)
    cells = args.cell or [0.3, 0.2, 0.1]
    c = fuzzy.crisp
    print(f"{args.map}: {c.n_vertices} vertices, {c.n_vertices} edges in {len(c.rings)} rings, "
          f"area {fuzzy.crisp_geometry.area:.6g} {c.unit}²")
    print()
    print(memory_markdown(fuzzy.memory(cells)))
    return 0
