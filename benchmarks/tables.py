"""Benchmark: ``fuzzybrep tables`` against ``fuzzybrep alpha-cut`` on one map of many holes (issue 36 item 8).

    python benchmarks/tables.py [--holes 16000] [--repeat 1]

A square room holding a grid of small square holes (``--holes`` of them), fuzzified with TME
0.02, saved, then both commands run on it as a user runs them (a process each, output to a file)
in this run: the ratio tables / alpha-cut is what to compare across machines. Before the fix
``tables`` rebuilt the map's list of rings on every table (quadratic in rings: 16,000 holes 15.5 s
where alpha-cut took a few).
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from fuzzybrep.brep import BRepMap, Region, Ring  # noqa: E402
from fuzzybrep.fuzzy.map import fuzzify  # noqa: E402


def holes_map(n: int):
    """A fuzzy map: a square room with a grid of n 0.4 m square holes 1 m apart (clockwise)."""
    side = math.ceil(math.sqrt(n))
    holes = []
    for k in range(n):
        x, y = 1.0 + k % side, 1.0 + k // side
        holes.append(Ring([(x, y), (x, y + 0.4), (x + 0.4, y + 0.4), (x + 0.4, y)]))
    w = side + 1.0
    shell = Ring([(0, 0), (w, 0), (w, w), (0, w)])
    return fuzzify(BRepMap((Region(shell, tuple(holes)),)), tme=0.02)


def run(argv: list[str]) -> float:
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "fuzzybrep.cli", *argv], check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--holes", type=int, default=16000)
    ap.add_argument("--repeat", type=int, default=1)
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as d:
        m = Path(d) / "holes.json"
        holes_map(a.holes).save(m)
        tables = min(run(["tables", str(m)]) for _ in range(a.repeat))
        cut = min(run(["alpha-cut", str(m), "--alpha", "0.5", "--out", str(Path(d) / "cut.geojson")])
                  for _ in range(a.repeat))
    print(f"{a.holes} holes: tables {tables:.2f} s, alpha-cut {cut:.2f} s, ratio tables/alpha-cut {tables / cut:.2f}")
    return 0 if tables <= cut else 1


if __name__ == "__main__":
    sys.exit(main())
