"""Benchmark: path planning on real maps — graph sizes, build and query times.

    python benchmarks/plan.py MAP.json [MAP.json ...] [--alpha A ...] [--radius R ...] [--pairs N]
                              [--out FILE.md]

For every map, α and radius it reports, in this run: the α-cut's time, the safe region's
vertices, the corners (reflex and flat vertices), the corner pairs tangent at both ends, those
walked after the outside-cell test, the visibility graph's edges and its build time; then the
median and largest time of a shortest-path query and of a clearance query over N random pairs of
free points of the largest piece (after the graphs are built), and the medial axis's build time.
Every path is checked to lie in the safe region. Times are wall-clock seconds on this machine:
compare them within one run.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import shapely

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from fuzzybrep.fuzzy.map import FuzzyBRepMap  # noqa: E402
from fuzzybrep.formats.files import write_atomic  # noqa: E402
from fuzzybrep.use.plan import Planner, free_points  # noqa: E402


def timed(f):
    t = time.perf_counter()
    out = f()
    return out, time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("maps", nargs="+")
    ap.add_argument("--alpha", type=float, action="append")
    ap.add_argument("--radius", type=float, action="append")
    ap.add_argument("--pairs", type=int, default=50)
    ap.add_argument("--out")
    a = ap.parse_args(argv)
    rows = ["| map | α | radius | α-cut s | safe vertices | corners | tangent pairs | walked | edges | "
            "graph s | shortest query s (median / max) | medial s | clearance query s (median / max) |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for path in a.maps:
        fz = FuzzyBRepMap.load(path)
        name = Path(path).stem
        print(f"{name}: {fz.crisp.n_vertices} vertices, {fz.crisp.n_holes} holes", file=sys.stderr)
        for alpha in a.alpha or [0.0]:
            cut, t_cut = timed(lambda: fz.alpha_cut(alpha).inner)
            for radius in a.radius or [0.0, 0.2]:
                pl = Planner(cut, radius, alpha=alpha, method="safe", fuzzy=fz)
                graph, t_graph = timed(lambda: pl.visibility)
                pts = free_points(pl.largest_piece, 2 * a.pairs, np.random.default_rng(1))
                ts = []
                for s, g in zip(pts[: a.pairs], pts[a.pairs:]):
                    p, t = timed(lambda: pl.plan(s, g))
                    assert pl.covers(p.path)
                    ts.append(t)
                _, t_medial = timed(lambda: (pl.medial, pl.axis_links))
                tc = []
                for s, g in zip(pts[: a.pairs], pts[a.pairs:]):
                    p, t = timed(lambda: pl.plan(s, g, "clearance"))
                    assert pl.covers(p.path)
                    tc.append(t)
                c = graph.counts
                rows.append(f"| {name} | {alpha:g} | {radius:g} | {t_cut:.2f} | {shapely.get_num_coordinates(pl.safe)} | "
                            f"{c['corners']} | {c['tangent']} | {c['walked']} | {c['edges']} | {t_graph:.2f} | "
                            f"{statistics.median(ts):.3f} / {max(ts):.3f} | {t_medial:.2f} | "
                            f"{statistics.median(tc):.3f} / {max(tc):.3f} |")
                print(rows[-1], file=sys.stderr)
    text = "\n".join(rows) + "\n"
    if a.out:
        write_atomic(a.out, text.encode())
    sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
