"""Benchmark: localisation on the fuzzy map (issue 21), on every shared CARMEN log.

    python benchmarks/localise.py [--datasets DIR] [--repeat 3] [--docs docs] [--json FILE]

For each ``*.log.gz`` in ``DIR/carmen`` (found, not listed here: a log added there is measured):

* the map: built from the log's even scans (``BuildConfig()``, fuzzified with its TME) and saved;
* the run: the odd scans, their poses kept as the truth, with drifting odometry made the way
  ``fuzzybrep drift`` makes it (``DriftModel.benchmark()``: 5 % of distance, 2°/m, 2 % of every
  turn, random 2 cm/√m, 0.5°/√m, 1°/√rad; seed 0), tracked from the true first pose;
* accuracy against the truth: absolute trajectory error (RMSE, m and degrees; the share of poses
  within TME; the largest), the relative pose error over 1 m and 10 m of travel (Kümmerle et al.
  2009: for every pose, the first later one at least that much travel away; the error of the
  relative motion between them, RMS), and the same for the drifting odometry alone, the baseline;
* speed of the whole command (``fuzzybrep localise MAP LOG --out TRACK.csv --quiet`` in a fresh
  process): its CPU time on the whole run against its CPU time on a run of the first two scans
  (start-up: Python, imports, reading the map and the log, the sensor model), in the same run,
  interleaved, median of ``--repeat``; scans/s = (scans − 2) / (whole − start-up);
* global localisation (``--global``) on the first 40 odd scans of every log (the issue's
  Done-when names intel and aces): the scan at which it converged (None: not in 40), and the
  position and heading error there, so that a convergence on the wrong pose shows;
* the choice of tracker: on intel and aces, a plain particle filter (``mcl.track_particles``,
  500 particles, the same sensor model and odometry) against the matching tracker, both
  in-process CPU time.

Writes the Markdown block ``localise:results`` of docs/localise.md (with ``--docs``; ``make bench``
runs it through docs.py) and prints it.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "src"))

from fuzzybrep.fuzzy.map import fuzzify  # noqa: E402
from fuzzybrep.mapping.build import BuildConfig, build_map  # noqa: E402
from fuzzybrep.scans.carmen import write_carmen  # noqa: E402
from fuzzybrep.scans.read import read_scans  # noqa: E402
from fuzzybrep.scans.scan import relative, wrap  # noqa: E402
from fuzzybrep.sim.drift import DriftModel, drift_scans, drift_stats  # noqa: E402
from fuzzybrep.use.localise import localise  # noqa: E402
from fuzzybrep.use.mcl import track_particles  # noqa: E402
from fuzzybrep.use.sensor_model import SensorModel  # noqa: E402

#: the logs whose global localisation the issue's Done-when names
GLOBAL_DONE_WHEN = ("intel", "aces")
#: the logs whose tracking it names
TRACKING_DONE_WHEN = ("intel", "aces", "freiburg-079")
GLOBAL_SCANS = 40
#: the logs on which the particle filter is compared with matching
COMPARE = ("intel", "aces")
PARTICLES = 500
RPE_DISTANCES = (1.0, 10.0)


def discover(d: Path) -> list[tuple[str, Path]]:
    """(name, path) of every CARMEN log in ``d/carmen``, by name; "-corrected" left off the name."""
    from grid import every_log

    return list(every_log(d).items())


def ate(est: np.ndarray, true: np.ndarray, tme: float) -> dict:
    """Absolute trajectory error (the frames are the same: the map's is the truth's)."""
    e = np.hypot(*(est[:, :2] - true[:, :2]).T)
    h = np.degrees(np.abs(wrap(est[:, 2] - true[:, 2])))
    return {"rmse_m": float(np.sqrt(np.mean(e ** 2))), "rmse_deg": float(np.sqrt(np.mean(h ** 2))),
            "max_m": float(e.max()), "within_tme": float(np.mean(e <= tme))}


def rpe(est: np.ndarray, true: np.ndarray, distance: float) -> dict:
    """Relative pose error over ``distance`` of travel (Kümmerle et al. 2009): for every pose i,
    j the first pose whose travel from i is at least ``distance``; the error of est's motion
    i → j against the truth's, RMS over the pairs (translation m, rotation degrees)."""
    steps = np.hypot(*np.diff(true[:, :2], axis=0).T)
    travel = np.concatenate(([0.0], np.cumsum(steps)))
    j = np.searchsorted(travel, travel + distance)
    i = np.flatnonzero(j < len(true))
    if len(i) == 0:
        return {"pairs": 0, "trans_m": math.nan, "rot_deg": math.nan}
    j = j[i]
    d = relative(relative(true[i], true[j]), relative(est[i], est[j]))
    return {"pairs": int(len(i)), "trans_m": float(np.sqrt(np.mean(d[:, 0] ** 2 + d[:, 1] ** 2))),
            "rot_deg": float(np.degrees(np.sqrt(np.mean(d[:, 2] ** 2))))}


def accuracy(est: np.ndarray, true: np.ndarray, tme: float) -> dict:
    return {"ate": ate(est, true, tme), **{f"rpe_{d:g}m": rpe(est, true, d) for d in RPE_DISTANCES}}


def child_cpu(cmd: list[str]) -> tuple[float, float]:
    """(CPU seconds, wall seconds) of a command run to its end in a fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, wall


def fuzzybrep_exe() -> str:
    exe = Path(sys.executable).parent / "fuzzybrep"
    return str(exe) if exe.exists() else "fuzzybrep"


def bench_log(name: str, path: Path, repeat: int, work: Path) -> dict:
    print(f"[localise] {name}: map from the even scans", file=sys.stderr, flush=True)
    scans = read_scans(path)
    cfg = BuildConfig()
    t = time.perf_counter()
    fz = fuzzify(build_map(scans[0::2], cfg).crisp, tme=cfg.tme)
    build_s = time.perf_counter() - t
    map_path = work / f"{name}-even.json"
    fz.save(map_path)
    model = DriftModel.benchmark()
    odd = drift_scans(scans[1::2], model, seed=0)
    true = np.array([s.pose for s in odd])
    odo = np.array([s.odometry for s in odd])
    stats = drift_stats(odo, true)
    log_path, start_path = work / f"{name}-odd-drift.log", work / f"{name}-start.log"
    write_carmen(log_path, odd)
    write_carmen(start_path, odd[:2])
    print(f"[localise] {name}: tracking {len(odd)} odd scans", file=sys.stderr, flush=True)
    t = time.process_time()
    track = localise(fz, odd)
    track_cpu = time.process_time() - t
    row = {
        "log": name, "scans": len(odd), "beams": int(len(odd[0].ranges)), "travel_m": stats.travel,
        "map_seconds": build_s, "tme": cfg.tme,
        "odometry": {"drift": stats.summary(), **accuracy(odo, true, cfg.tme)},
        "tracking": {**accuracy(track.poses, true, cfg.tme), "lost": int((track.status == 1).sum()),
                     "offset": track.offset, "cpu_seconds_in_process": track_cpu},
    }
    # the whole command, and its start-up, interleaved
    exe = fuzzybrep_exe()
    full, start = [], []
    for _ in range(repeat):
        for log, out in ((log_path, full), (start_path, start)):
            out.append(child_cpu([exe, "localise", str(map_path), str(log), "--out", str(work / "track.csv"),
                                  "--quiet"]))
    cpu_full, cpu_start = statistics.median(c for c, _ in full), statistics.median(c for c, _ in start)
    wall_full, wall_start = statistics.median(w for _, w in full), statistics.median(w for _, w in start)
    row["speed"] = {"cpu_whole": cpu_full, "cpu_start_up": cpu_start, "wall_whole": wall_full,
                    "wall_start_up": wall_start,
                    "scans_per_second": (len(odd) - 2) / max(cpu_full - cpu_start, 1e-9),
                    "scans_per_second_wall": (len(odd) - 2) / max(wall_full - wall_start, 1e-9)}
    if name in COMPARE:
        print(f"[localise] {name}: particle filter tracking", file=sys.stderr, flush=True)
        sm = SensorModel.from_map(fz)
        t = time.process_time()
        pf = track_particles(sm, odd, odo, true[0], np.random.default_rng(0), particles=PARTICLES)
        row["particles"] = {**accuracy(pf, true, cfg.tme), "cpu_seconds": time.process_time() - t}
    print(f"[localise] {name}: global localisation on the first {GLOBAL_SCANS} scans", file=sys.stderr, flush=True)
    n = min(GLOBAL_SCANS, len(odd))
    t = time.process_time()
    g = localise(fz, odd[:n], global_search=True)
    gl = {"scans": n, "converged_at": g.converged_at, "cpu_seconds": time.process_time() - t}
    if g.converged_at is not None:
        k = g.converged_at
        gl["error_m"] = float(np.hypot(*(g.poses[k, :2] - true[k, :2])))
        gl["error_deg"] = float(np.degrees(abs(wrap(g.poses[k, 2] - true[k, 2]))))
        gl["within_tme_after"] = float(np.mean(np.hypot(*(g.poses[k:, :2] - true[k:n, :2]).T) <= cfg.tme))
    row["global"] = gl
    print(f"[localise] {name}: {json.dumps(row['tracking']['ate'])}, {row['speed']['scans_per_second']:.0f} scans/s",
          file=sys.stderr, flush=True)
    return row


def bench(d: Path, repeat: int = 3) -> list[dict]:
    with tempfile.TemporaryDirectory(prefix="fuzzybrep-localise-") as tmp:
        return [bench_log(name, path, repeat, Path(tmp)) for name, path in discover(d)]


def markdown(rows: list[dict], repeat: int) -> str:
    env = (f"Measured by `python benchmarks/localise.py` on {time.strftime('%Y-%m-%d')} "
           f"({os.cpu_count()} cores, Python {sys.version.split()[0]}); speed: median of {repeat} interleaved runs "
           f"of the whole command, CPU time.")
    L = [env, "", "**Tracking** (maps from the even scans; the odd scans from drifting odometry, 5 % of distance and "
         "2°/m, from the true first pose; errors against the log's corrected poses)", "",
         "| log | scans | beams | travel | ATE RMSE | ATE RMSE ° | within TME | largest | RPE 1 m | RPE 1 m ° | "
         "RPE 10 m | RPE 10 m ° | lost | scans/s (whole command) | start-up |",
         "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        a, r1, r10 = r["tracking"]["ate"], r["tracking"]["rpe_1m"], r["tracking"]["rpe_10m"]
        L.append(f"| {r['log']} | {r['scans']} | {r['beams']} | {r['travel_m']:.0f} m | {a['rmse_m']:.4f} m | "
                 f"{a['rmse_deg']:.3f} | {100 * a['within_tme']:.2f} % | {a['max_m']:.3f} m | {r1['trans_m']:.4f} m | "
                 f"{r1['rot_deg']:.3f} | {r10['trans_m']:.4f} m | {r10['rot_deg']:.3f} | {r['tracking']['lost']} | "
                 f"**{r['speed']['scans_per_second']:.0f}** | {r['speed']['cpu_start_up']:.2f} s |")
    L += ["", "**Baseline: the drifting odometry alone** (the same runs)", "",
          "| log | odometry | ATE RMSE | ATE RMSE ° | within TME | RPE 1 m | RPE 1 m ° | RPE 10 m | RPE 10 m ° |",
          "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        o = r["odometry"]
        a, r1, r10 = o["ate"], o["rpe_1m"], o["rpe_10m"]
        L.append(f"| {r['log']} | {o['drift']} | {a['rmse_m']:.2f} m | {a['rmse_deg']:.1f} | "
                 f"{100 * a['within_tme']:.1f} % | {r1['trans_m']:.4f} m | {r1['rot_deg']:.3f} | "
                 f"{r10['trans_m']:.3f} m | {r10['rot_deg']:.2f} |")
    searched = [r["log"] for r in rows if "global" in r]
    L += ["", f"**Global localisation** (`--global`, no start, on the first {GLOBAL_SCANS} odd scans of "
          f"{', '.join(searched)})", "",
          "| log | converged at scan | position error there | heading error there | within TME from there | CPU |",
          "|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        if "global" not in r:
            continue
        g = r["global"]
        if g["converged_at"] is None:
            L.append(f"| {r['log']} | **not in {g['scans']}** (it says so) | | | | {g['cpu_seconds']:.1f} s |")
        else:
            L.append(f"| {r['log']} | **{g['converged_at'] + 1}** | {g['error_m']:.3f} m | {g['error_deg']:.2f}° | "
                     f"{100 * g['within_tme_after']:.1f} % | {g['cpu_seconds']:.1f} s |")
    L += ["", f"**Matching or particles for tracking** (the same runs; a particle filter of {PARTICLES} particles on "
          "the same sensor model and odometry, `mcl.track_particles`; in-process CPU time, start-up aside)", "",
          "| log | tracker | ATE RMSE | ATE RMSE ° | within TME | largest | scans/s |", "|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        if "particles" not in r:
            continue
        for label, a, sec in (("matching (`localise`)", r["tracking"]["ate"], r["tracking"]["cpu_seconds_in_process"]),
                              (f"particle filter, {PARTICLES}", r["particles"]["ate"], r["particles"]["cpu_seconds"])):
            L.append(f"| {r['log']} | {label} | {a['rmse_m']:.4f} m | {a['rmse_deg']:.3f} | {100 * a['within_tme']:.2f} % | "
                     f"{a['max_m']:.3f} m | {r['scans'] / sec:.0f} |")
    L += ["", "**The issue's Done-when**, as measured above:", ""]
    by = {r["log"]: r for r in rows}
    for name in TRACKING_DONE_WHEN:
        if name in by:
            a = by[name]["tracking"]["ate"]
            ok = a["within_tme"] >= 0.99 and a["rmse_m"] <= 0.05 and a["rmse_deg"] <= 1.0
            L.append(f"- tracking on {name}: {100 * a['within_tme']:.2f} % within TME, {a['rmse_m']:.4f} m, "
                     f"{a['rmse_deg']:.3f}° RMSE: {'met' if ok else '**not met**'} (≥ 99 %, ≤ 0.05 m, ≤ 1°)")
    for name in GLOBAL_DONE_WHEN:
        if name in by:
            g = by[name]["global"]
            ok = g["converged_at"] is not None and g["converged_at"] < 20 and g.get("error_m", 1e9) <= by[name]["tme"]
            at = "never" if g["converged_at"] is None else f"at scan {g['converged_at'] + 1}"
            L.append(f"- global localisation on {name}: converged {at}: {'met' if ok else '**not met**'} (within 20 scans)")
    for r in rows:
        need = 200 if r["log"] == "intel" else 100 if r["beams"] >= 360 else None
        if need:
            s = r["speed"]["scans_per_second"]
            L.append(f"- speed on {r['log']} ({r['beams']} beams): {s:.0f} scans/s: "
                     f"{'met' if s >= need else '**not met**'} (≥ {need})")
    return "\n".join(L)


def main(argv=None) -> int:
    from grid import SEARCHED, datasets

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--datasets", help=f"folder holding carmen/ (default: the first of {SEARCHED})")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--docs", help="write the localise:results block of DOCS/localise.md")
    ap.add_argument("--json", help="also write the results as JSON")
    args = ap.parse_args(argv)
    d = Path(args.datasets) if args.datasets else datasets()
    if d is None:
        print(f"no CARMEN logs in any of {SEARCHED}", file=sys.stderr)
        return 1
    rows = bench(d, args.repeat)
    md = markdown(rows, args.repeat)
    print(md)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")
    if args.docs:
        from blocks import write_block

        write_block(Path(args.docs) / "localise.md", "localise:results", md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
