"""fuzzybrep memory: Table 5.3 for a map: fuzzy B-rep storage against occupancy grids."""

from __future__ import annotations

import argparse
import math

from ..errors import MapFileError
from ..fuzzy.memory import THESIS_GRID_CELLS, memory_markdown
from ._maps import add_map_argument, load_map
from ._types import number

NAME = "memory"
HELP = "print Table 5.3 for a map: fuzzy B-rep memory (thesis accounting and compact) vs occupancy grids"


_cell = number(lambda c: 0 < c < math.inf, "cell size must be a number, got {text!r}",
               "cell size must be a positive finite number, got {text}")


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_map_argument(p)
    p.add_argument("--cell", type=_cell, action="append", metavar="SIZE",
                   help="occupancy-grid cell size in the map's unit; repeat (default the thesis's 30, 20 and 10 cm, "
                        "in the map's unit: 0.3 0.2 0.1 for metres, 300 200 100 for millimetres)")


def run(args: argparse.Namespace) -> int:
    fuzzy = load_map(args)
    if args.cell is None and fuzzy.unit not in THESIS_GRID_CELLS:
        raise MapFileError(args.map, f"no default grid cells for unit {fuzzy.unit!r}: give them with --cell")
    rows = fuzzy.memory(args.cell)  # before printing: an error is the only output
    c = fuzzy.crisp
    print(f"{args.map}: {c.n_vertices} vertices, {c.n_vertices} edges in {len(c.rings)} rings, "
          f"area {fuzzy.crisp_geometry.area:.6g} {c.unit}²")
    print()
    print(memory_markdown(rows))
    return 0
