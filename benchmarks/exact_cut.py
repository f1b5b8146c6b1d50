"""Benchmark: the exact α-cut as computed now against the former whole-map GEOS buffers.

    python benchmarks/exact_cut.py [MAP.json ...] [--alpha A ...] [--repeat N]
                                   [--tme-in T --tme-out T] [--frontier-tme T] [--out FILE.md]

For each map (fuzzy map files as ``fuzzybrep build`` writes them; without any, the synthetic
jagged floor of ``alpha_cut.py``) and each α it times, in the same run:

- former: what ``alpha_cut(α, "exact")`` computed before: GEOS buffer of the whole crisp map by −d
          and +d when one symmetric distance applies, else the crisp map minus and plus the band
          of each function's edges buffered as one MultiLineString (the wider side of an
          asymmetric function buffered per ring and cut by it);
- now:    ``alpha_cut(α, "exact")``: each principal polygon and hole buffered alone (one
          distance), or every edge alone and the buffers united once (the band);

and reports former ÷ now (> 1: now is faster) and the areas of the symmetric differences of the
inner and of the outer polygons relative to the crisp map's area, which should be rounding only.
``--tme-in/--tme-out`` refuzzify with an asymmetric triangular function, ``--frontier-tme`` gives
frontier edges their own one (several distances): the band paths.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import shapely

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from alpha_cut import best, synthetic_map  # noqa: E402
from fuzzybrep.brep import Ring  # noqa: E402
from fuzzybrep.fuzzy.exact import EXACT_QUAD_SEGS, cut_distances  # noqa: E402
from fuzzybrep.fuzzy.map import FuzzyBRepMap, fuzzify  # noqa: E402
from fuzzybrep.formats.files import write_atomic  # noqa: E402
from fuzzybrep.fuzzy.membership import Triangular  # noqa: E402
from fuzzybrep.geometry import clean, polygonal  # noqa: E402


def former_cut(fz: FuzzyBRepMap, alpha: float, quad_segs: int = EXACT_QUAD_SEGS) -> tuple:
    """(inner, outer) as ``alpha_cut(α, "exact")`` computed them before the ring-by-ring cut."""
    crisp = fz.crisp_geometry
    symmetric, sided = cut_distances(fz, alpha)
    ds = {d for _, d in symmetric}
    if not sided and len(ds) == 1:
        d = ds.pop()
        if d == 0.0:
            return crisp, crisp
        return (polygonal(shapely.buffer(crisp, -d, quad_segs=quad_segs)),
                polygonal(shapely.buffer(crisp, d, quad_segs=quad_segs)))
    parts = [shapely.buffer(shapely.multilinestrings(g["lines"]), d, quad_segs=quad_segs) for g, d in symmetric if d > 0]
    for g, d_in, d_out in sided:
        if d_in == d_out == 0.0:
            continue
        parts.append(shapely.buffer(shapely.multilinestrings(g["lines"]), min(d_in, d_out), quad_segs=quad_segs))
        rings, idx = np.unique(g["ring"], return_inverse=True)
        order = np.argsort(idx, kind="stable")
        wide = shapely.buffer(shapely.multilinestrings(g["lines"][order], indices=idx[order]), max(d_in, d_out),
                              quad_segs=quad_segs)
        cut = shapely.intersection if d_in > d_out else shapely.difference
        parts.extend(cut(wide, fz.ring_polygons[rings]))
    if not parts:
        return crisp, crisp
    band = shapely.union_all(parts)
    return clean(shapely.difference(crisp, band)), clean(shapely.union(crisp, band))


def run(maps: list[tuple[str, FuzzyBRepMap]], alphas: list[float], repeat: int) -> str:
    out = ["## Exact α-cut: former whole-map buffers ÷ now, timed in the same run", "",
           f"{'Median' if repeat >= 3 else 'Best'} of {repeat}. Δ: area of the symmetric difference between former and now, "
           "relative to the crisp map's area.", "",
           "| map | vertices | holes | functions | α | former ÷ now | inner Δ | outer Δ |",
           "|---|---:|---:|---|---:|---:|---:|---:|"]
    for label, fz in maps:
        fz.alpha_cut(0.5, "exact")  # build the cached stacks and edge groups once, as a loaded map would
        c, area = fz.crisp, fz.crisp_geometry.area
        functions = ", ".join(dict.fromkeys(f.formula() for _, f in fz.table))
        for a in alphas:
            t_former = best(lambda: former_cut(fz, a), repeat)
            t_now = best(lambda: fz.alpha_cut(a, "exact"), repeat)
            old, new = former_cut(fz, a), fz.alpha_cut(a, "exact")
            di, do = (shapely.area(shapely.symmetric_difference(x, y)) / area
                      for x, y in ((old[0], new.inner), (old[1], new.outer)))
            out.append(f"| {label} | {c.n_vertices} | {c.n_holes} | {functions} | {a:g} | {t_former / t_now:.1f} | "
                       f"{di:.1e} | {do:.1e} |")
            print(out[-1], file=sys.stderr, flush=True)
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="*", help="map JSON files (fuzzy); default: the synthetic jagged floor")
    ap.add_argument("--alpha", type=float, action="append", help="α levels (default 0 and 0.5)")
    ap.add_argument("--repeat", type=int, default=3, help="timings per measurement")
    ap.add_argument("--tme-in", type=float, help="refuzzify with Triangular(tme_in, tme_out)")
    ap.add_argument("--tme-out", type=float)
    ap.add_argument("--frontier-tme", type=float, help="refuzzify with frontier edges on Triangular(this)")
    ap.add_argument("--out", help="also write the Markdown report to this file")
    args = ap.parse_args(argv)
    if (args.tme_in is None) != (args.tme_out is None):
        ap.error("give both --tme-in and --tme-out")
    maps = [(Path(p).name, FuzzyBRepMap.load(p)) for p in args.maps] or \
        [("synthetic floor, jagged (seed 0)", fuzzify(synthetic_map(0)))]
    if args.tme_in is not None or args.frontier_tme is not None:
        frontier = Triangular(args.frontier_tme) if args.frontier_tme is not None else None
        refuzzified = []
        for label, fz in maps:
            mf = Triangular(tme_in=args.tme_in, tme_out=args.tme_out) if args.tme_in is not None else fz.table[1]
            crisp = fz.crisp.with_rings([Ring(r.vertices, r.kinds) for r in fz.crisp.rings])  # every FM 1
            refuzzified.append((label, fuzzify(crisp, mf, frontier_mf=frontier)))
        maps = refuzzified
    report = run(maps, args.alpha or [0.0, 0.5], args.repeat)
    print(report)
    if args.out:
        write_atomic(args.out, report.encode())
    return 0


if __name__ == "__main__":
    sys.exit(main())
