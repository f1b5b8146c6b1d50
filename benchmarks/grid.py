"""Benchmark: the occupancy-grid baseline on the real logs.

    python benchmarks/grid.py [--resolution 0.05] [--repeat 3] [--naive-scans 40] [--out FILE.md]

For every CARMEN log in ../shared/datasets (or $FUZZYBREP_DATASETS) it times, in this run:

- read:  reading the log (``read_scans``): the baseline every other time is divided by;
- grid:  ``occupancy_grid`` at the resolution (best of ``--repeat``);
- naive: a per-beam Python loop (Amanatides-Woo traversal, the textbook implementation) over the
         first ``--naive-scans`` scans, scaled to the whole log by the number of cells traversed;

and reports the grid's size (cells, bytes at 4 B/cell as the thesis counts, PGM bytes), its free
area, and speed as ratios: grid/read, and naive/grid (how much the vectorised traversal saves).
Absolute seconds are shown for this machine only; compare ratios across machines.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from fuzzybrep.mapping.grid import L_FREE, L_OCC, beams_of, occupancy_grid  # noqa: E402
from fuzzybrep.formats.files import write_atomic  # noqa: E402
from fuzzybrep.formats.rosmap import write_grid  # noqa: E402
from fuzzybrep.scans.read import read_scans  # noqa: E402

LOGS = {"intel": "carmen/intel-corrected.log.gz", "aces": "carmen/aces-corrected.log.gz",
        "freiburg-079": "carmen/freiburg-079-corrected.log.gz"}


def every_log(d: Path) -> dict[str, Path]:
    """{name: path} of every CARMEN log in ``d/carmen`` (``*.log.gz`` and ``*.log``), named as
    ``fuzzybrep build`` names its map (``intel-corrected.log.gz`` is intel): the benchmarks run on
    whatever logs the folder holds, not a list of the ones we know."""
    out = {}
    for path in sorted((d / "carmen").glob("*.log*")):
        if path.name.endswith((".log", ".log.gz")):
            out[path.name.split(".log")[0].removesuffix("-corrected")] = path
    return out


#: where ``datasets`` looks, in order, for a folder holding carmen/ (said when it finds none)
SEARCHED = "$FUZZYBREP_DATASETS, ../shared/datasets beside the checkout"


def datasets() -> Path | None:
    here = Path(__file__).resolve().parents[1]
    for c in (os.environ.get("FUZZYBREP_DATASETS"), here.parent / "shared" / "datasets"):
        if c and (Path(c) / "carmen").is_dir():
            return Path(c)
    return None


def naive_grid(scans, resolution: float, max_usable: float = 8.0) -> tuple[dict, int]:
    """The textbook loop: every beam walked cell by cell. Returns (log-odds by cell, cells visited)."""
    lo: dict[tuple[int, int], float] = {}
    visited = 0
    for s in scans:
        x, y = s.pose[0] / resolution, s.pose[1] / resolution
        for r, a, ret in zip(s.ranges.tolist(), s.world_angles().tolist(), s.returns.tolist()):
            if not ret:
                continue
            hit = r <= max_usable
            length = min(r, max_usable) / resolution
            du, dv = math.cos(a), math.sin(a)
            ix, iy = math.floor(x), math.floor(y)
            ex, ey = math.floor(x + length * du), math.floor(y + length * dv)
            sx, sy = (1 if du > 0 else -1), (1 if dv > 0 else -1)
            tx = ((ix + (sx > 0)) - x) / du if du else math.inf
            ty = ((iy + (sy > 0)) - y) / dv if dv else math.inf
            dx, dy = (abs(1 / du) if du else math.inf), (abs(1 / dv) if dv else math.inf)
            while (ix, iy) != (ex, ey):
                lo[ix, iy] = lo.get((ix, iy), 0.0) + L_FREE
                visited += 1
                if tx < ty:
                    ix, tx = ix + sx, tx + dx
                else:
                    iy, ty = iy + sy, ty + dy
            lo[ix, iy] = lo.get((ix, iy), 0.0) + (L_OCC if hit else L_FREE)
            visited += 1
    return lo, visited


def cells_traversed(scans, resolution: float) -> int:
    b = beams_of(scans)
    f = lambda v: np.floor(v / resolution)  # noqa: E731
    return int((np.abs(f(b.ex) - f(b.ox)) + np.abs(f(b.ey) - f(b.oy)) + 1).sum())


def best(fn, repeat: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def table(d: Path, resolution: float = 0.05, repeat: int = 3, naive_scans: int = 40) -> str:
    """The Markdown report for every CARMEN log under ``d``: sizes, free area, ratios (see module doc)."""
    rows = []
    for name, path in every_log(d).items():
        t_read, scans = best(lambda: read_scans(path), repeat)
        t_grid, g = best(lambda: occupancy_grid(scans, resolution), repeat)
        sub = scans[:naive_scans]
        t0 = time.perf_counter()
        naive_grid(sub, resolution)
        t_naive_sub = time.perf_counter() - t0
        t_naive = t_naive_sub * cells_traversed(scans, resolution) / cells_traversed(sub, resolution)
        with tempfile.TemporaryDirectory() as tmp:
            _, pgm = write_grid(Path(tmp) / "map.yaml", g)
            pgm_bytes = pgm.stat().st_size
        beams = sum(len(s.ranges) for s in scans)
        ny, nx = g.shape
        rows.append((name, len(scans), beams, f"{nx} × {ny}", g.cells, g.nbytes(4), pgm_bytes, g.free_area(),
                     int(g.occupied().sum()), t_read, t_grid, t_grid / t_read, t_naive / t_grid))
    md = [f"Occupancy grid at {resolution:g} m, {os.cpu_count()} core(s); times best of {repeat}, in seconds on the "
          f"machine that ran the script (compare the ratios); naive time scaled from the first {naive_scans} scans "
          "by cells traversed.", "",
          "| log | scans | beams | grid | cells | bytes (4 B/cell) | PGM bytes | free area m² | occupied cells "
          "| read s | grid s | grid / read | naive / grid |",
          "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        md.append(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]:,} | {r[5]:,} | {r[6]:,} | {r[7]:.1f} | {r[8]:,} "
                  f"| {r[9]:.3f} | {r[10]:.3f} | {r[11]:.2f} | {r[12]:.0f} |")
    return "\n".join(md) + "\n"


def example(d: Path, log: str = "intel") -> tuple[str, str]:
    """What ``fuzzybrep grid`` prints for ``log`` and the YAML file it writes, as a reader would
    run it from the checkout (``../shared/datasets/...``, ``--out out/intel-grid``)."""
    import contextlib
    import io

    from fuzzybrep.cli import main as cli

    shown_log, shown_out = f"../shared/datasets/{LOGS[log]}", f"out/{log}-grid"
    with tempfile.TemporaryDirectory() as tmp:
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            if cli(["grid", str(d / LOGS[log]), "--out", tmp]) != 0:
                raise RuntimeError(f"fuzzybrep grid {log} failed")
        printed = out.getvalue().replace(tmp, shown_out).replace(str(d / LOGS[log]), shown_log).rstrip()
        yaml = (Path(tmp) / f"{Path(LOGS[log]).name.split('.')[0]}.yaml").read_text().rstrip()  # named after the log
    return f"$ fuzzybrep grid {shown_log} --out {shown_out}\n{printed}", yaml


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=float, default=0.05)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--naive-scans", type=int, default=40)
    ap.add_argument("--out", help="also write the Markdown here")
    args = ap.parse_args(argv)
    d = datasets()
    if d is None:
        print(f"no folder holding carmen/ in any of {SEARCHED}: set FUZZYBREP_DATASETS", file=sys.stderr)
        return 1
    text = table(d, args.resolution, args.repeat, args.naive_scans)
    print(text)
    if args.out:
        write_atomic(args.out, text.encode())
    return 0


if __name__ == "__main__":
    sys.exit(main())
