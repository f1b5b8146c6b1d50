"""How many false loop closures the pose-graph back ends survive (issue 33, item 2).

    python benchmarks/pose_graph.py [--datasets DIR] [--repeat 3] [--seed 0] [--only intel,aces] [--docs docs | --no-docs]

Graphs made from the corrected CARMEN logs (intel, aces, freiburg-079 in ``DIR/carmen``; a log
that is absent is skipped with a message): the log's poses are the truth.

* odometry edges between consecutive poses, the true step plus Gaussian noise of standard
  deviation 2 cm + 5 % of the step's length (each of x, y) and 1° + 2°/m of it (θ), information
  the inverse of those variances;
* true loop edges between poses within 1 m and 15° of each other but more than 30 indices apart,
  at most one for every 10 poses (the first pose of each run of 10 that has a partner, the partner
  drawn at random), the true relative pose plus 2 cm / 0.5° noise, information accordingly,
  robust;
* N false loop edges (N = 0, 1, 5, 10, 20, 50, 100), robust, joining random pairs of poses more
  than 30 indices and more than 5 m apart, with a plausible-looking relative pose (what a true
  loop says: within 1 m and 15°, drawn at random) and the true loops' information. The false
  edges of a smaller N are the first of a larger N's.

The start is the odometry chain (the poses composed from the noisy odometry edges from the true
first pose), what a SLAM front end hands the back end. Every back end is called with
``pose_graph.solve``'s defaults (10 iterations, the first 3 plain). Reported: the RMSE of the
solved positions against the truth (pose 0 is held at the true first pose, so no alignment),
whether the back end "survived" (RMSE within 1.5 × its own N = 0 RMSE, or below 0.1 m), and the
solve time (median of ``--repeat``, ms) with its ratio to ``pose_graph.solve`` timed in the same run.

The tables are printed and replace the ``pose_graph:results`` block of docs/pose_graph.md (``--docs
DIR``: DIR/pose_graph.md; ``--no-docs`` or ``--only``: printed only); ``make bench`` (docs.py) writes that block too.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "src"))

from fuzzybrep import read_scans  # noqa: E402
from fuzzybrep.registration import pose_graph  # noqa: E402
from fuzzybrep.scans.scan import compose, relative, wrap  # noqa: E402
from blocks import write_block  # noqa: E402
from grid import LOGS, SEARCHED, datasets  # noqa: E402

FALSE = (0, 1, 5, 10, 20, 50, 100)
LOOP_SIGMA = (0.02, np.radians(0.5))
LOOP_INFO = np.diag([1 / LOOP_SIGMA[0] ** 2, 1 / LOOP_SIGMA[0] ** 2, 1 / LOOP_SIGMA[1] ** 2])


def back_ends() -> dict:
    """{name: solve}: pose_graph.solve, and GTSAM's when gtsam is installed."""
    out = {"pose_graph": pose_graph.solve}
    try:
        import gtsam  # noqa: F401
    except ImportError:
        print("[pose_graph] gtsam is not installed: only pose_graph.solve is measured", file=sys.stderr)
        return out
    from fuzzybrep.registration import pose_graph_gtsam as G

    out["gtsam Cauchy"] = G.solve
    out["gtsam DCS"] = lambda *a, **k: G._solve(*a, **k, kernel="dcs")
    out["gtsam GNC-TLS"] = G.solve_gnc
    return out


def make_graph(true: np.ndarray, rng: np.random.Generator):
    """The odometry and true loop edges of ``true`` (module docstring): (i, j, z, info, robust) lists
    of arrays, and the odometry chain as the start."""
    n = len(true)
    steps = relative(true[:-1], true[1:])
    dist = np.hypot(steps[:, 0], steps[:, 1])
    st = 0.02 + 0.05 * dist
    sr = np.radians(1.0) + np.radians(2.0) * dist
    z_odo = steps + rng.normal(size=(n - 1, 3)) * np.column_stack((st, st, sr))
    info_odo = np.zeros((n - 1, 3, 3))
    info_odo[:, 0, 0] = info_odo[:, 1, 1] = 1 / st ** 2
    info_odo[:, 2, 2] = 1 / sr ** 2
    start = [true[0]]
    for s in z_odo:
        start.append(compose(start[-1], s))
    # true loops: within 1 m and 15°, more than 30 apart; one from each run of 10 poses that has one
    li, lj = [], []
    for a0 in range(0, n, 10):
        for a in range(a0, min(a0 + 10, n)):
            b = np.arange(a + 31, n)
            d = np.hypot(*(true[b, :2] - true[a, :2]).T)
            ok = b[(d < 1.0) & (np.abs(wrap(true[b, 2] - true[a, 2])) < np.radians(15))]
            if len(ok):
                li.append(a), lj.append(int(rng.choice(ok)))
                break
    li, lj = np.array(li, np.int64), np.array(lj, np.int64)
    z_loop = relative(true[li], true[lj]) + rng.normal(size=(len(li), 3)) * [LOOP_SIGMA[0], LOOP_SIGMA[0], LOOP_SIGMA[1]]
    i = np.r_[np.arange(n - 1), li]
    j = np.r_[np.arange(1, n), lj]
    z = np.vstack((z_odo, z_loop.reshape(-1, 3)))
    info = np.concatenate((info_odo, np.broadcast_to(LOOP_INFO, (len(li), 3, 3))))
    robust = np.r_[np.zeros(n - 1, bool), np.ones(len(li), bool)]
    return (i, j, z, info, robust), np.array(start)


def false_loops(true: np.ndarray, count: int, rng: np.random.Generator):
    """``count`` false loop edges: pairs more than 30 indices and 5 m apart, said to be within 1 m and 15°."""
    n, fi, fj = len(true), [], []
    while len(fi) < count:
        a, b = sorted(rng.integers(0, n, 2).tolist())
        if b - a > 30 and np.hypot(*(true[b, :2] - true[a, :2])) > 5.0:
            fi.append(a), fj.append(b)
    r, phi = rng.uniform(0, 1.0, count), rng.uniform(-np.pi, np.pi, count)
    z = np.column_stack((r * np.cos(phi), r * np.sin(phi), rng.uniform(-1, 1, count) * np.radians(15)))
    return np.array(fi, np.int64), np.array(fj, np.int64), z


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((a[:, :2] - b[:, :2]) ** 2, axis=1))))


def bench_log(true: np.ndarray, solvers: dict, repeat: int, seed: int) -> list[dict]:
    """One row per (N, back end): rmse, seconds, survived, ratio."""
    rng = np.random.default_rng(seed)
    (i, j, z, info, robust), start = make_graph(true, rng)
    fi, fj, fz = false_loops(true, max(FALSE), rng)
    rows, base = [], {}
    for n_false in FALSE:
        ei, ej = np.r_[i, fi[:n_false]], np.r_[j, fj[:n_false]]
        ez = np.vstack((z, fz[:n_false]))
        einfo = np.concatenate((info, np.broadcast_to(LOOP_INFO, (n_false, 3, 3))))
        er = np.r_[robust, np.ones(n_false, bool)]
        times = {name: [] for name in solvers}
        out = {}
        for _ in range(repeat):  # interleaved: every back end once a round
            for name, f in solvers.items():
                t = time.perf_counter()
                out[name] = f(start, ei, ej, ez, einfo, er)
                times[name].append(time.perf_counter() - t)
        for name in solvers:
            e = rmse(out[name], true) if np.isfinite(out[name]).all() else float("inf")
            base.setdefault(name, e)
            t = statistics.median(times[name])
            rows.append({"false": n_false, "solver": name, "rmse": e, "seconds": t,
                         "ratio": t / statistics.median(times["pose_graph"]),
                         "survived": bool(e <= 1.5 * base[name] or e < 0.1)})
    return rows, {"poses": len(true), "loops": int(robust.sum()), "start": rmse(start, true)}


def markdown(results: dict, repeat: int) -> str:
    lines = []
    for log, (rows, meta) in results.items():
        names = list(dict.fromkeys(r["solver"] for r in rows))
        lines += [f"**{log}**: {meta['poses']} poses, {meta['loops']} true loop edges, odometry start "
                  f"{meta['start']:.2f} m RMSE", "",
                  "| false loops | " + " | ".join(names) + " |",
                  "|---:|" + "---|" * len(names)]
        for n_false in FALSE:
            cells = []
            for name in names:
                r = next(r for r in rows if r["false"] == n_false and r["solver"] == name)
                mark = "✓" if r["survived"] else "✗"
                cells.append(f"{r['rmse']:.3f} m {mark}, {1e3 * r['seconds']:.0f} ms ({r['ratio']:.2f}×)")
            lines.append(f"| {n_false} | " + " | ".join(cells) + " |")
        lines.append("")
    names = list(dict.fromkeys(r["solver"] for rows, _ in results.values() for r in rows))
    lines += ["**Most false loops survived** (largest N with every smaller N survived too):", "",
              "| back end | " + " | ".join(results) + " |", "|---|" + "---:|" * len(results)]
    for name in names:
        cells = []
        for rows, _ in results.values():
            ok = -1
            for n_false in FALSE:
                if not next(r for r in rows if r["false"] == n_false and r["solver"] == name)["survived"]:
                    break
                ok = n_false
            cells.append(str(ok) if ok >= 0 else "none")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += ["", f"Cells: RMSE of the solved positions, ✓ survived / ✗ not, the median solve time of {repeat} "
              "and its ratio to `pose_graph.solve` in the same run (this machine under its load)."]
    return "\n".join(lines)


def run(d: Path | None, repeat: int = 3, seed: int = 0, only: list[str] | None = None) -> tuple[str, dict]:
    solvers = back_ends()
    results = {}
    for log, rel in LOGS.items():
        if only and log not in only:
            continue
        if d is None or not (d / rel).is_file():
            print(f"[pose_graph] {log}: no {rel} in any of {SEARCHED}; skipped", file=sys.stderr)
            continue
        true = np.array([s.pose for s in read_scans(d / rel)])
        t = time.perf_counter()
        results[log] = bench_log(true, solvers, repeat, seed)
        print(f"[pose_graph] {log}: {time.perf_counter() - t:.1f} s", file=sys.stderr, flush=True)
    return markdown(results, repeat), results


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--datasets", help=f"folder holding carmen/ (default: {SEARCHED})")
    ap.add_argument("--repeat", type=int, default=3, help="timings per solve (median)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", help="comma-separated logs, e.g. intel,aces")
    ap.add_argument("--docs", default=str(HERE.parent / "docs"), help="folder of pose_graph.md (default: docs/)")
    ap.add_argument("--no-docs", action="store_true", help="print the tables only")
    args = ap.parse_args(argv)
    d = Path(args.datasets) if args.datasets else datasets()
    md, _ = run(d, args.repeat, args.seed, args.only.split(",") if args.only else None)
    print(md)
    if not args.no_docs and not args.only:
        write_block(Path(args.docs) / "pose_graph.md", "pose_graph:results", md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
