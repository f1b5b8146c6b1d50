"""The benchmark behind every figure in the README: speed, size and truthfulness on the real logs.

    python benchmarks/run.py [--datasets DIR] [--repeat 3] [--out benchmarks/results.md] [--readme README.md]
                             [--docs docs]

For each CARMEN log in ``DIR/carmen`` (by default the first of $FUZZYBREP_DATASETS,
../shared/datasets beside the checkout that holds carmen/) it measures,
in one run:

* speed: the full pipeline (read, beams, evidence, scan polygons, union, fuzzify), the median of
  ``--repeat`` runs, split per stage, as scans per second and as ratios against two baselines
  timed in the same run on the same scans: the naive union of raw scan fans (what a union without
  any of the truthfulness work costs) and the occupancy-grid mapper (the baseline the thesis
  argues against);
* size: the fuzzy map's compact encoding and the thesis's Table 5.3 accounting, against the 5 cm
  occupancy grid of the same log (4 bytes a cell as in Table 5.3, and 1 byte a cell as a PGM);
* truthfulness on all scans (issue: crisp pipeline): endpoints under 5 m inside the crisp free
  space shrunk by 0.2 m, and outside it grown by 0.2 m;
* prediction of held-out scans (every second held out): endpoints explained by the support band,
  violations (inside the safe region at α = 0), beyond; for the exact band, the default (safe)
  α-cut's band and the thesis's sweep band; violations on small isolated objects (people, legs);
  free-space IoU against the grid;
* peak memory: what building the map (build + fuzzify) needs beyond the read scans, against the
  grid mapper, each in a fresh process (``peak.py``);
* scaling: the pipeline on the first 1/8, 1/4, 1/2 and all scans of the largest log;
* α-cuts on the largest map: reading them from the stored lines against GEOS buffer, and the
  sweep's approximation error against the exact fuzzification;
* the whole commands (``commands.py``), on every log in ``DIR/carmen``: ``fuzzybrep build LOG``
  against ``fuzzybrep grid LOG --resolution 0.05``, time and peak memory, interleaved in fresh
  processes, and build's time on prefixes of freiburg-campus (issue 17: ≤ 3×, ≤ 1× and 8× the
  scans in ≤ 9× the time).
* the default (safe) α-cut on the map of every log in ``DIR/carmen`` (``safe_cut.py``): its band
  against the exact one, the area it claims beyond the exact offsets, its CPU time against GEOS
  buffering the crisp map by the same distances, at α = 0, 0.5, 0.9.

Writes the Markdown report (and a JSON twin) and, with --readme, replaces the block between
``<!-- benchmark:start -->`` and ``<!-- benchmark:end -->`` in the README with it (``blocks.py``).
With --docs DIR it then runs ``docs.py`` on the pages in DIR, handing over the maps it built:
every measured figure of docs/*.md is written there between its own markers.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import shapely

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from fuzzybrep.use import evaluate as E  # noqa: E402
from fuzzybrep.mapping.build import BuildConfig, build_map  # noqa: E402
from fuzzybrep.fuzzy.memory import compact_bytes
from fuzzybrep.fuzzy.map import fuzzify  # noqa: E402
from fuzzybrep.mapping.grid import occupancy_grid  # noqa: E402
from fuzzybrep.scans.read import read_scans  # noqa: E402
from grid import SEARCHED, datasets, every_log  # noqa: E402  (the logs and where they are: one lookup, grid.py's)
import peak  # noqa: E402
import commands  # noqa: E402  (the whole commands, build against grid)
from blocks import BlockError, demote_headings, write_block  # noqa: E402


def median_time(fn, repeat: int):
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def pipeline(path: Path, cfg: BuildConfig, n: int | None = None):
    """Read, build and fuzzify: the full pipeline, with its stage times."""
    t0 = time.perf_counter()
    scans = read_scans(path)
    if n is not None:
        scans = scans[:n]
    t_read = time.perf_counter() - t0
    r = build_map(scans, cfg)
    t1 = time.perf_counter()
    fz = fuzzify(r.crisp, tme=cfg.tme)
    t_fuzzify = time.perf_counter() - t1
    stages = {"read": t_read, **r.timings, "fuzzify": t_fuzzify}
    return scans, r, fz, stages


def naive_union(scans):
    """The plain union of raw scan fans (sensor + every return), GEOS cascaded union: the cost of a
    map without any of the truthfulness work (and without its truthfulness). Returns the time and
    the union."""
    fans = []
    for s in scans:
        e = s.endpoints()[s.returns]
        fans.append(np.vstack((s.pose[:2], e)))
    polys = shapely.make_valid(shapely.polygons([shapely.linearrings(np.vstack((f, f[:1]))) for f in fans]))
    t = time.perf_counter()
    u = shapely.union_all(polys)
    return time.perf_counter() - t, u


def all_scan_truthfulness(scans, crisp, cfg) -> tuple[float, float, float]:
    """Issue 2: endpoints under 5 m inside the free space shrunk by 0.2 m / outside it grown by 0.2 m;
    and the share of all endpoints inside that came and went (seen free by other scans of the log
    both before and after): obstacles that issue 5 asks the map to drop, so the floor under any
    held-out violation rate of a map that follows it."""
    pts = E.endpoints(scans)
    s = E.score(pts, *E.band_by_buffer(crisp.to_shapely(), 0.2))
    went = E.came_and_went(pts[s.violated], E.endpoint_times(scans)[s.violated], scans, cfg, 0.2)
    return s.violations, s.beyond, float(went.sum() / len(pts))


def bench_log(name: str, path: Path, repeat: int, maps: dict | None = None) -> dict:
    """The log's row of every table; its fuzzy map goes into ``maps`` (for docs.py) when given."""
    cfg = BuildConfig()
    print(f"[{name}] pipeline x{repeat}", file=sys.stderr, flush=True)
    runs = [pipeline(path, cfg) for _ in range(repeat)]
    totals = [sum(st.values()) for *_, st in runs]
    k = int(np.argsort(totals)[len(totals) // 2])
    scans, r, fz, stages = runs[k]
    total = totals[k]
    print(f"[{name}] baselines", file=sys.stderr, flush=True)
    naive = [naive_union(scans) for _ in range(repeat)]
    t_naive = statistics.median(t for t, _ in naive)
    naive_inside = E.score(E.endpoints(scans), *E.band_by_buffer(naive[0][1], 0.2)).violations
    t_grid, grid = median_time(lambda: occupancy_grid(scans, 0.05), repeat)
    crisp = r.crisp
    if maps is not None:
        maps[name] = fz
    inside, outside, went = all_scan_truthfulness(scans, crisp, cfg)
    print(f"[{name}] held-out evaluation", file=sys.stderr, flush=True)
    ev = E.evaluate_log(scans, 2, cfg)
    # the other policy for things that came and went: keep every obstacle any kept scan saw
    keep = replace(cfg, evidence=replace(cfg.evidence, clear=False))
    ev_keep = E.evaluate_log(scans, 2, keep).exact.violations
    # what the spike filter's cut at narrow openings costs the held-out figures (issue 5 asks for
    # no fans through doors; issue 17 for 96 % explained): the same judgement with it letting
    # every opening through
    ev_open = E.evaluate_log(scans, 2, replace(cfg, beams=replace(cfg.beams, min_gap=0.0)))
    iou_all = E.free_space_iou(fz.crisp_geometry, grid)
    # the robot's own track: where it stood must be free (issue 17), in the crisp map and in the
    # default α-cut's safe region at α = 0
    xy = np.array([s.pose[:2] for s in scans])
    track = {"crisp": float(shapely.contains_xy(fz.crisp_geometry, xy[:, 0], xy[:, 1]).mean()),
             "safe": float(shapely.contains_xy(fz.alpha_cut(0.0).inner, xy[:, 0], xy[:, 1]).mean())}
    print(f"[{name}] peak memory", file=sys.stderr, flush=True)
    peaks = peak.measure(path)
    mem = {
        "compact": compact_bytes(fz),
        "thesis": 4 * (10 + 6) * crisp.n_vertices,
        "grid_cells": grid.cells,
        "grid_4B": grid.nbytes(4),
        "grid_1B": grid.nbytes(1),
    }
    return {
        "log": name, "scans": len(scans), "beams": int(sum(len(s.ranges) for s in scans)),
        "seconds": total, "scans_per_second": len(scans) / total, "stages": stages,
        "naive_union_seconds": t_naive, "grid_seconds": t_grid,
        "vertices": crisp.n_vertices, "holes": crisp.n_holes, "pieces": len(crisp.regions) - 1,
        "area": crisp.area, "memory": mem,
        "all_scans": {"inside_shrunk": inside, "inside_came_and_went": went, "outside_grown": outside, "free_iou": iou_all,
                      "naive_union_inside_shrunk": naive_inside},
        "poses_free": track,
        "held_out": ev.as_dict() | {"violations_keeping_every_obstacle": ev_keep,
                                    "openings_open": {"explained": ev_open.exact.explained,
                                                      "violations": ev_open.exact.violations,
                                                      "violations_rest": ev_open.violations_rest,
                                                      "map_bytes_compact": ev_open.map_bytes_compact}},
        "peak_memory": peaks,
    }


def bench_scaling(path: Path, repeat: int) -> list[dict]:
    scans = read_scans(path)
    out = []
    for frac in (8, 4, 2, 1):
        n = len(scans) // frac
        cfg = BuildConfig()
        times = []
        for _ in range(repeat):
            t = time.perf_counter()
            r = build_map(scans[:n], cfg)
            fuzzify(r.crisp, tme=cfg.tme)
            times.append(time.perf_counter() - t)
        out.append({"scans": n, "seconds": statistics.median(times)})
        print(f"[scaling] {n} scans: {out[-1]['seconds']:.2f} s", file=sys.stderr, flush=True)
    return out


def demo_runs(seeds: int = 10) -> tuple[list, float]:
    """The built-in demo (the thesis's chapter 5 on a simulated E1 floor) for seeds 0 to seeds - 1,
    and the seconds seed 0's run took (its summary says them); docs.py's demo blocks use the same runs."""
    from fuzzybrep.sim import demo
    from fuzzybrep.sim.world import builtin_floor, builtin_route

    t = time.perf_counter()
    runs = [demo.run_demo(builtin_floor(), builtin_route(), seed=0)]
    seconds = time.perf_counter() - t
    runs += [demo.run_demo(builtin_floor(), builtin_route(), seed=seed) for seed in range(1, seeds)]
    return runs, seconds


def demo_md(runs: list, seconds: float) -> str:
    """Seed 0's summary and the Done-when criteria over all ``runs``, for the default (safe), the
    exact and the thesis's α-cut."""
    from fuzzybrep.sim import demo

    lines = demo.summary(runs[0], None, seconds)
    rows = ["| seed | safe (default): seen wall in support | safe: wall in safe region | exact: seen wall in support | "
            "exact: wall in safe region | boundary within TME | thesis: seen wall in support | thesis: wall in safe "
            "region | all three (safe) | all three (exact) |",
            "|---:|---:|---:|---:|---:|---:|---:|---:|:---:|:---:|"]
    passed = {"safe": 0, "exact": 0}
    for r in runs:
        m = r.maps["filtered"]
        s, e, w = m.truth["safe"], m.truth["exact"], m.truth["thesis"]
        for k in passed:
            passed[k] += m.passes(k)
        rows.append(f"| {r.seed} | {pct(s.support_coverage)} | {s.unsafe_wall_length:.2f} m | {pct(e.support_coverage)} | "
                    f"{e.unsafe_wall_length:.2f} m | {pct(e.boundary_within_tme)} | {pct(w.support_coverage)} | "
                    f"{w.unsafe_wall_length:.2f} m | {'yes' if m.passes('safe') else 'no'} | "
                    f"{'yes' if m.passes('exact') else 'no'} |")
    return "\n".join(["**The built-in demo** (`fuzzybrep demo`; seed 0's summary, figures skipped)", "", "```", *lines,
                      "```", "", f"The Done-when criteria over {len(runs)} seeds (filtered map): all three hold with the "
                      f"default (safe) α-cut in {passed['safe']} of {len(runs)}, with the exact one in "
                      f"{passed['exact']}.", "", *rows])


def pct(x: float) -> str:
    return f"{100 * x:.2f} %"


def kb(n: int) -> str:
    return f"{n / 1024:.1f} kB"


def safe_cut_rows(d: Path, maps: dict, repeat: int) -> tuple[list[dict], list[dict]]:
    """``safe_cut.py`` on the map of every log in ``d/carmen``: those ``bench_log`` built, and the
    others built here with the same defaults. (rows at its three α, its α sweep per map)"""
    import safe_cut

    rows, sweeps = [], []
    for name, path in every_log(d).items():
        fz = maps.get(name)
        if fz is None:
            print(f"[safe cut] building {name}", file=sys.stderr, flush=True)
            cfg = BuildConfig()
            fz = fuzzify(build_map(read_scans(path), cfg).crisp, tme=cfg.tme)
        rows += safe_cut.measure(name, fz, safe_cut.ALPHAS, max(repeat, 5))
        sweeps.append(safe_cut.sweep(name, fz))
    return rows, sweeps


def markdown(results: list[dict], scaling: list[dict], alpha_md: str, env: dict, demo: str = "",
             whole: tuple[list, dict | None] | None = None, safe_md: str = "") -> str:
    L = []
    L += [f"Measured by `python benchmarks/run.py` on {env['when']} ({env['machine']}, {env['cpus']} cores, "
          f"Python {env['python']}, GEOS {env['geos']}); median of {env['repeat']} runs. Absolute times move with "
          "the machine's load; the ratios against baselines timed in the same run are the stable figures.", ""]
    L += ["**Speed and size**", "",
          "| log | scans | full pipeline | scans/s | × naive union of raw fans | × 5 cm grid mapper | vertices | holes | compact map | 5 cm grid (4 B/cell) | grid ÷ map |",
          "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in results:
        m = r["memory"]
        L.append(f"| {r['log']} | {r['scans']} | {r['seconds']:.2f} s | **{r['scans_per_second']:.0f}** | "
                 f"{r['seconds'] / r['naive_union_seconds']:.2f} | {r['seconds'] / r['grid_seconds']:.2f} | "
                 f"{r['vertices']} | {r['holes']} | {kb(m['compact'])} | {kb(m['grid_4B'])} | "
                 f"**{m['grid_4B'] / m['compact']:.0f}×** |")
    L += ["", "The × columns give the pipeline's time as a multiple of each baseline's time on the same scans "
          "(< 1: faster than the baseline). Other accountings of the same maps: "]
    L += ["", "| log | thesis accounting (Table 5.3: 16 numbers × 4 B per vertex) | 5 cm grid as PGM (1 B/cell) | grid cells | PGM ÷ compact map |",
          "|---|---:|---:|---:|---:|"]
    for r in results:
        m = r["memory"]
        L.append(f"| {r['log']} | {kb(m['thesis'])} ({m['grid_4B'] / m['thesis']:.1f}× under the 4 B grid) | "
                 f"{kb(m['grid_1B'])} | {m['grid_cells']} | {m['grid_1B'] / m['compact']:.1f}× |")
    L += ["", "**Time per stage** (seconds, same runs)", "",
          "| log | read | beams | evidence | scan polygons | union | edge kinds | fuzzify |", "|---|" + "---:|" * 7]
    for r in results:
        s = r["stages"]
        L.append(f"| {r['log']} | " + " | ".join(f"{s[k]:.2f}" for k in
                                                  ("read", "beams", "evidence", "scan polygons", "union", "edge kinds", "fuzzify")) + " |")
    L += ["", "**Peak memory while building** (each in a fresh process; resident memory beyond what the process "
          "held once the log was read: what a robot needs free to build the map on board)", "",
          peak.markdown([(r["log"], r["peak_memory"]) for r in results]).rstrip("\n")]
    L += ["", "**Truthful free space, all scans** (endpoints closer than 5 m)", "",
          "| log | inside the free space shrunk by 0.2 m | … of which came and went | outside it grown by 0.2 m | free-space IoU with the 5 cm grid | the same, inside a plain union of raw scan fans |",
          "|---|---:|---:|---:|---:|---:|"]
    for r in results:
        a = r["all_scans"]
        L.append(f"| {r['log']} | {pct(a['inside_shrunk'])} | {pct(a['inside_came_and_went'])} | "
                 f"{pct(a['outside_grown'])} | {a['free_iou']:.3f} | {pct(a['naive_union_inside_shrunk'])} |")
    L += ["", "Came and went: beams of other scans of the log passed more than 0.2 m beyond the endpoint both "
          "before and after its own scan saw it (people walking, doors). The map drops such obstacles, as "
          "issue 5 asks, so they stay inside its free space although the map saw them. Held-out scans see "
          "such things too, and each is a violation there: a map that drops them cannot be expected to score "
          "much fewer held-out violations than this column."]
    L += ["", "**The robot's own track** (every scan pose of the log)", "",
          "| log | poses in the crisp free space | poses in the safe region at α = 0 (default α-cut) |", "|---|---:|---:|"]
    for r in results:
        L.append(f"| {r['log']} | {pct(r['poses_free']['crisp'])} | {pct(r['poses_free']['safe'])} |")
    L += ["", "**Held-out scans** (map from all scans but every second; the held-out endpoints closer than 5 m "
          "judged against the map's support at α = 0 with TME = 0.19913 m)", "",
          "| log | explained | violations | … of which on small isolated objects | … of which no kept scan saw within TME | … of those, a kept beam passed through | … of which came and went | … of which neither | beyond | safe band (default): violations | thesis band: explained | thesis band: violations | free-space IoU | violations, every obstacle kept |",
          "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in results:
        h = r["held_out"]
        L.append(f"| {r['log']} | {pct(h['exact']['explained'])} | {pct(h['exact']['violations'])} | "
                 f"{pct(h['violations_on_small_objects'])} | {pct(h['violations_unseen'])} | "
                 f"{pct(h.get('violations_seen_through', float('nan')))} | "
                 f"{pct(h['violations_came_and_went'])} | {pct(h['violations_rest'])} | "
                 f"{pct(h['exact']['beyond'])} | "
                 f"{pct(h['safe']['violations'])} | "
                 f"{pct(h['thesis']['explained'])} | {pct(h['thesis']['violations'])} | {h['free_iou']:.3f} | "
                 f"{pct(h['violations_keeping_every_obstacle'])} |")
    L += ["", "Explained: inside the support band. Violation: inside the safe region at α = 0 (an obstacle where the "
          "map promises free space). Small isolated objects: a run of beams under 0.5 m across in front of both "
          "neighbours, judged from the held-out scan alone (legs, people, poles). No kept scan saw within TME: "
          "no return of any scan the map was built from lies within TME of the endpoint, so no map of those scans "
          "could put a boundary there without inventing it; a kept beam passed through: of those, the ones a beam of a "
          "kept scan passed more than TME beyond, which every map true to the kept scans calls free (a floor under "
          "the violations no method of mapping these scans can go below). Came and went: beams of kept scans passed more than "
          "TME beyond the endpoint both before and after the held-out scan saw it (a person walking by, a door), "
          "so the map is right to call it free. Neither: a kept scan saw a return within TME and it did not come and "
          "go, yet the map promises free space there: what a better map could have avoided, unless kept scans saw "
          "it stand and then saw through it. Exact band: the Extension "
          "principle (±TME offsets); safe band: the default α-cut's, which holds the exact band (docs/fuzzy.md); "
          "thesis band: the thesis's single-normal-vertex approximation of it. "
          "Every obstacle kept: the same judgement of a map that never clears an obstacle later scans saw "
          "through (evidence.clear off), the other answer to people walking by."]
    L += ["", "**What the held-out endpoints beyond the map are** (the same held-out judgement)", "",
          "| log | explained | beyond | … a kept scan saw a return within TME | … no kept scan did | "
          "explained, were every endpoint a kept scan saw within TME explained | "
          "spike filter letting every opening through: explained | … violations | … of which neither | … compact map |",
          "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in results:
        h = r["held_out"]
        o = h.get("openings_open")
        seen = h.get("beyond_seen", float("nan"))
        beyond = h["exact"]["beyond"]
        L.append(f"| {r['log']} | {pct(h['exact']['explained'])} | {pct(beyond)} | {pct(seen)} | {pct(beyond - seen)} | "
                 f"{pct(1 - h['violations_unseen'] - (beyond - seen))} | "
                 + (f"{pct(o['explained'])} | {pct(o['violations'])} | {pct(o['violations_rest'])} | "
                    f"{o['map_bytes_compact'] / h['map_bytes_compact']:.2f}× |" if o else "n/a | n/a | n/a | n/a |"))
    L += ["", "Beyond: outside the outer polygon at α = 0. A kept scan saw a return within TME: the map of the kept "
          "scans had the evidence for a boundary there and drew none (a room seen only through a door, which the "
          "spike filter cuts back to the doorway; a surface behind the first one other scans saw, where the "
          "evidence stops the beam; a return beyond max_usable). No kept scan did: no map of the kept scans could "
          "explain it without inventing a surface. Explained, were every endpoint a kept scan saw within TME "
          "explained: all but the unseen violations and the unseen beyond, what a map of the kept scans could "
          "reach without inventing surfaces (it counts as explained those that no kept scan saw but the band "
          "holds anyway). Spike filter letting every opening "
          "through: the map built with `BeamConfig(min_gap=0)`, so that fans through doors and panes stay (the "
          "needles issue 5 rules out), judged the same way; compact map: its size against the default map's."]
    if scaling:
        base = scaling[0]
        L += ["", "**Scaling** (the largest log, first n scans; build + fuzzify)", "",
              "| scans | seconds | seconds per 1000 scans | × time of the first row | × scans |", "|---:|---:|---:|---:|---:|"]
        for s in scaling:
            L.append(f"| {s['scans']} | {s['seconds']:.2f} | {1000 * s['seconds'] / s['scans']:.2f} | "
                     f"{s['seconds'] / base['seconds']:.2f} | {s['scans'] / base['scans']:.0f} |")
    if whole:
        L += ["", "**The whole commands** (`fuzzybrep build LOG` against `fuzzybrep grid LOG --resolution 0.05`, "
              "each a fresh process with its start-up, interleaved, median time and largest peak resident memory "
              f"of {env['repeat']} runs: `benchmarks/commands.py`)", "", commands.markdown(*whole).rstrip("\n")]
    if alpha_md:
        # the α-cut script's own headings become bold lines, so the README keeps one "## Results"
        L += ["", demote_headings(alpha_md)]
    if safe_md:
        L += ["", safe_md]
    if demo:
        L += ["", demo]
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--datasets", help="folder holding carmen/ (default: the first of $FUZZYBREP_DATASETS, ../shared/datasets that holds carmen/)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(HERE / "results.md"))
    ap.add_argument("--readme", help="README whose benchmark block to replace with the report")
    ap.add_argument("--no-scaling", action="store_true")
    ap.add_argument("--docs", help="also write the generated blocks of the documentation pages in this folder (docs.py)")
    args = ap.parse_args(argv)
    d = Path(args.datasets) if args.datasets else datasets()
    logs = list(every_log(d).items()) if d else []  # every log the folder holds (issue 17)
    if not logs:
        print(f"no CARMEN logs under {d or 'any of ' + SEARCHED}: nothing to measure", file=sys.stderr)
        return 1
    maps: dict = {}
    results = [bench_log(n, p, args.repeat, maps) for n, p in logs]
    largest = max(logs, key=lambda lp: lp[1].stat().st_size)
    scaling = [] if args.no_scaling else bench_scaling(largest[1], args.repeat)
    from alpha_cut import run as alpha_run  # the α-cut benchmark, on the largest map

    alpha_md = alpha_run(maps[largest[0]], [0.0, 0.25, 0.5, 0.75, 1.0], args.repeat, f"{largest[0]} map")
    env = {"when": time.strftime("%Y-%m-%d"), "machine": platform.machine(), "cpus": os.cpu_count(),
           "python": platform.python_version(), "geos": shapely.geos_version_string, "repeat": args.repeat}
    whole = [commands.measure(p, args.repeat) for _, p in logs]
    campus = d / "carmen" / "freiburg-campus-corrected.log.gz"
    grow = commands.scaling(campus, repeat=args.repeat) if campus.is_file() and not args.no_scaling else None
    runs, seconds = demo_runs()
    import safe_cut

    safe_rows, safe_sweeps = safe_cut_rows(d, maps, args.repeat)
    md = markdown(results, scaling, alpha_md, env, demo_md(runs, seconds), (whole, grow),
                  safe_cut.markdown(safe_rows, max(args.repeat, 5), safe_sweeps))
    Path(args.out).write_text(md)
    Path(args.out).with_suffix(".json").write_text(json.dumps({"env": env, "logs": results, "scaling": scaling,
                                                             "commands": whole, "commands_scaling": grow,
                                                             "safe_cut": safe_rows, "safe_cut_sweep": safe_sweeps}, indent=1, default=float))
    print(md)
    if args.readme:
        try:
            write_block(args.readme, None, md)
        except BlockError as e:
            print(f"{e}; not changed", file=sys.stderr)
            return 1
    if args.docs:
        import docs  # the documentation pages' figures, with the maps built above

        docs.run(Path(args.docs), args.repeat, maps, d=d, demo_runs=runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
