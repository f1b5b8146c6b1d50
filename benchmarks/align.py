"""Maps from drifting odometry (issue 22): ``build --align`` on every shared CARMEN log.

    python benchmarks/align.py [--datasets DIR] [--repeat 1] [--seeds 5] [--only intel,aces] [--docs docs] [--plots DIR]

For each ``*.log.gz`` in ``DIR/carmen``, the log's corrected poses are the truth and
``sim.drift``'s benchmark model (5 % of distance, 2°/m, 2 % of every turn, random error; seed 0)
makes the odometry. Three maps, each from every second scan, judged on the held-out scans
(``use.evaluate.evaluate_log``: violations and explained of the exact α = 0 band, and the share of
held-out sensor positions in the map's free space):

* corrected: the scans at the log's corrected poses (the reference);
* aligned: the scans at the poses ``registration.align_scans`` found from the odometry alone, all
  scans aligned, then every second held out (what ``build --align`` gives);
* odometry: the scans at the drifting odometry poses (what ``build`` without ``--align`` gives).

Trajectory error of the aligned poses against the corrected ones: the translational RMSE with
the first pose anchored (the odometry starts at the true first pose, so the frames agree), and
the absolute trajectory error (ATE: RMSE after the best rigid fit, Horn's method, the TUM
benchmark's measure) beside it; the anchored RMSE again with ``--seeds`` draws of the odometry's
random error (median / worst: a log nobody has seen is another draw); and how far the log's own
first pose is turned against the map its corrected poses make (``anchor_disagreement``), with
the anchored RMSE that turn alone costs. Cost: the CPU seconds of ``build_map`` + ``fuzzify`` with
``--align`` over those without, on the same drifting scans, interleaved (plain, aligned, plain,
...) ``--repeat`` times, the medians' ratio. Pictures of the aligned and corrected maps go to
``--plots`` (default out/align/) for a person to look at.

With ``--docs DIR`` the results table replaces the ``align:results`` block of DIR/align.md; ``make bench``
(run.py --docs, through docs.py) writes that block too.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from fuzzybrep.fuzzy.map import fuzzify  # noqa: E402
from fuzzybrep.registration.align_scans import AlignConfig, align_scans, with_poses  # noqa: E402
from fuzzybrep.registration.segment_match import transform  # noqa: E402
from fuzzybrep.mapping.build import BuildConfig, build_map  # noqa: E402
from fuzzybrep.scans.read import read_scans  # noqa: E402
from fuzzybrep.sim.drift import DriftModel, drift_scans, drift_stats  # noqa: E402
from fuzzybrep.use import evaluate as E  # noqa: E402
from blocks import BlockError, write_block  # noqa: E402
from grid import SEARCHED, datasets, every_log  # noqa: E402

#: the logs Done-when names; the others are reported too (not tuned on)
JUDGED = ("intel", "aces", "freiburg-079")


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((a[:, :2] - b[:, :2]) ** 2, axis=1))))


def ate(a: np.ndarray, b: np.ndarray) -> float:
    """RMSE of positions a (N, ≥2) after the rigid motion that best fits them onto b (Horn / Kabsch)."""
    P, Q = a[:, :2], b[:, :2]
    mp, mq = P.mean(0), Q.mean(0)
    U, _, Vt = np.linalg.svd((P - mp).T @ (Q - mq))
    R = (U @ Vt).T
    if np.linalg.det(R) < 0:
        U[:, -1] *= -1
        R = (U @ Vt).T
    return rmse((P - mp) @ R.T + mq, Q)


def anchor_disagreement(scans, radius: float = 5.0) -> float:
    """Radians by which the log's own first pose disagrees with the map its corrected poses make:
    the first scan aligned (``registration.segment_match.align``, from that pose) to the surfaces of the corrected
    scans within ``radius`` of it, its three successors left out. The aligned poses keep the first
    pose as it is (the map's frame), so a corrected map turned by this much against its own first
    scan counts, in the anchored RMSE, at every pose (``anchor_floor``)."""
    from fuzzybrep.registration.config import AlignConfig
    from fuzzybrep.registration.surfaces import _Surfaces
    from fuzzybrep.registration.segment_match import align

    true = np.array([s.pose for s in scans])
    near = [j for j in range(4, len(scans)) if np.hypot(*(true[j, :2] - true[0, :2])) < radius]
    if not near:
        return 0.0
    cfg = AlignConfig()
    surf = _Surfaces([scans[0]] + [scans[j] for j in near], cfg)
    index = surf.index(list(range(1, len(near) + 1)), np.vstack((true[:1], true[near])))
    res = align(surf.points[0], index, true[0], width=cfg.width, start_width=cfg.start_width, max_iterations=40)
    return float(np.angle(np.exp(1j * (res.pose[2] - true[0, 2]))))


def surfaces(scans):
    """Every scan's surfaces as the alignment makes them (``consistency`` asks them at any poses)."""
    from fuzzybrep.registration.surfaces import _Surfaces

    return _Surfaces(scans, AlignConfig())


def consistency(surf, poses: np.ndarray, radius: float = 4.0, apart: int = 50, reach: float = 0.5,
                samples: int = 150) -> dict:
    """How well a set of poses makes the scans agree where the robot came back: for about
    ``samples`` scans spread over the log, each return's distance to the nearest surface
    (``registration.align_scans``'s polylines) of the scans more than ``apart`` scans away in time whose
    poses lie within ``radius`` (another pass of the same place), counted where one lies within
    ``reach``. {"median": m, "within_5cm": share, "points": n}. Both pose sets are judged by the
    same scans, so the one with the smaller residuals is the more consistent with them; the
    corrected poses are a SLAM result too, not the truth. ``surf``: the scans' ``surfaces``."""
    P = np.asarray(poses, np.float64)
    n = len(P)
    step = max(1, n // samples)
    d_all = []
    for k in range(0, n, step):
        j = np.flatnonzero((np.abs(np.arange(n) - k) > apart) & (np.hypot(*(P[:, :2] - P[k, :2]).T) < radius))
        if len(j) == 0 or len(surf.points[k]) == 0:
            continue
        d = surf.index(j.tolist(), P).nearest(transform(surf.points[k], P[k]), reach)[1]
        d_all.append(d[np.isfinite(d)])
    d = np.concatenate(d_all) if d_all else np.zeros(0)
    if not len(d):
        return {"median": float("nan"), "within_5cm": float("nan"), "points": 0}
    return {"median": float(np.median(d)), "within_5cm": float(np.mean(d < 0.05)), "points": int(len(d))}


def anchor_floor(true: np.ndarray, angle: float) -> float:
    """The anchored RMSE of the corrected poses themselves turned by ``angle`` about the first pose."""
    c, s = np.cos(angle), np.sin(angle)
    d = true[:, :2] - true[0, :2]
    turned = true[0, :2] + d @ np.array([[c, s], [-s, c]])
    return rmse(turned, true)


def held_out(scans) -> dict:
    """The held-out figures of the map of every second scan; {"error": message} when no map can be
    built (poses so far off that the evidence grid would not fit: the build's own one-line error)."""
    from fuzzybrep.errors import FuzzyBrepError

    try:
        return _held_out(scans)
    except FuzzyBrepError as e:
        return {"error": str(e)}


def _held_out(scans) -> dict:
    ev = E.evaluate_log(scans, 2, BuildConfig())
    return {"violations": ev.exact.violations, "explained": ev.exact.explained, "poses_in_free": ev.held_poses_free}


def cost(drifting, repeat: int) -> dict:
    """CPU seconds of the plain build and of the build with --align on the same scans, interleaved."""
    plain, aligned = [], []
    cfg, acfg = BuildConfig(), BuildConfig(align=AlignConfig())
    for _ in range(repeat):
        for cfg_, out in ((cfg, plain), (acfg, aligned)):
            t = time.process_time()
            r = build_map(drifting, cfg_)
            fuzzify(r.crisp, tme=cfg_.tme)
            out.append(time.process_time() - t)
    p, a = statistics.median(plain), statistics.median(aligned)
    return {"plain_cpu": p, "align_cpu": a, "ratio": a / p}


def bench(name: str, path: Path, repeat: int, plots: Path | None, seeds: int = 1) -> dict:
    print(f"[align {name}] read, drift, align", file=sys.stderr, flush=True)
    scans = read_scans(path)
    true = np.array([s.pose for s in scans])
    drifted = drift_scans(scans, DriftModel.benchmark(), seed=0)
    odo = np.array([s.odometry for s in drifted])
    stats = drift_stats(odo, true)
    t = time.process_time()
    result = align_scans(drifted)
    t_align = time.process_time() - t
    aligned = with_poses(drifted, result.poses)
    at_odo = with_poses(drifted, odo)
    row = {"log": name, "scans": len(scans), "travel": stats.travel, "odometry_final": stats.final_position,
           "odometry_rmse": rmse(odo, true), "rmse": rmse(result.poses, true), "ate": ate(result.poses, true),
           "max_error": float(np.hypot(*(result.poses[:, :2] - true[:, :2]).T).max()),
           "heading_rmse_deg": float(np.degrees(np.sqrt(np.mean(np.angle(np.exp(1j * (result.poses[:, 2] - true[:, 2]))) ** 2)))),
           "loops": result.loops, "poor": int(len(result.poor())), "align_cpu_once": t_align}
    row["anchor_deg"] = float(np.degrees(anchor_disagreement(scans)))
    row["anchor_floor"] = anchor_floor(true, np.radians(row["anchor_deg"]))
    # the same log with other draws of the odometry's random error: what an unseen log may give
    row["seed_rmse"] = [row["rmse"]] + [rmse(align_scans(drift_scans(scans, DriftModel.benchmark(), seed=k)).poses, true)
                                        for k in range(1, seeds)]
    print(f"[align {name}] rmse {row['rmse']:.3f} m (ATE {row['ate']:.3f}), {result.loops} loops; held-out maps",
          file=sys.stderr, flush=True)
    # which poses the scans agree with better where the robot came back: the corrected or the aligned
    surf = surfaces(scans)
    row["consistency"] = {"corrected": consistency(surf, true), "aligned": consistency(surf, result.poses)}
    row["corrected"] = held_out(scans)
    row["aligned"] = held_out(aligned)
    row["odometry"] = held_out(at_odo)
    print(f"[align {name}] cost x{repeat}", file=sys.stderr, flush=True)
    from fuzzybrep.errors import FuzzyBrepError

    try:
        row["cost"] = cost(at_odo, repeat)
    except FuzzyBrepError:  # no map from these poses, with or without --align
        row["cost"] = None
    if plots is not None:
        from fuzzybrep.plot import save_map_figure

        plots.mkdir(parents=True, exist_ok=True)
        for what, sc in (("aligned", aligned), ("corrected", scans), ("odometry", at_odo)):
            if "error" in row[what]:
                continue
            crisp = build_map(sc).crisp
            save_map_figure(plots / f"{name}-{what}.png", crisp, np.array([s.pose[:2] for s in sc]),
                            title=f"{name}: map from {what} poses")
    return row


def _consistency_cell(r: dict) -> str:
    c = r.get("consistency")
    if not c:
        return "n/a"
    f = lambda m: "n/a" if not m["points"] else f"{1000 * m['median']:.1f} mm, {100 * m['within_5cm']:.1f} %"  # noqa: E731
    return f"{f(c['corrected'])} / {f(c['aligned'])}"


def pct(v: float) -> str:
    return f"{100 * v:.2f} %"


def markdown(rows: list[dict], repeat: int) -> str:
    out = ["Drifting odometry: `sim.drift`'s benchmark model (5 % of distance, 2°/m, 2 % of every turn, random "
           "2 cm/√m, 0.5°/√m, 1°/√rad; seed 0). Every second scan held out; violations and explained of the exact "
           "α = 0 band; poses in free: held-out sensor positions inside the map's free space. "
           f"Cost: CPU time of build + fuzzify with `--align` ÷ without, same scans, median of {repeat} interleaved runs. "
           "Logs marked * are the ones Done-when names (tuned on); the others were not tuned on.", "",
           "Anchor: the log's own first pose against the map its corrected poses make (its first scan aligned to "
           "the corrected scans within 5 m), and the anchored RMSE that turn alone gives the corrected poses "
           "(the aligned poses keep the first pose: the map's frame). "
           f"Seeds: aligned RMSE with the odometry's random error drawn with seeds 0-{max(len(r['seed_rmse']) for r in rows) - 1 if rows else 0}, median / worst.", "",
           "Other passes: each return's distance to the nearest surface of scans more than 50 scans away in time whose "
           "poses lie within 4 m (the same place on another pass), for 150 scans spread over the log, where one lies "
           "within 0.5 m: median, and the share under 5 cm, with the corrected poses and with the aligned ones. The "
           "corrected poses are the log's own SLAM result, not the truth: where the aligned poses make the passes "
           "agree as well or better, what is left of the RMSE is as much the corrected poses' error as theirs.", "",
           "| log | scans | travel | odometry RMSE | aligned RMSE | ATE | max error | seeds | anchor | other passes: corrected / aligned | loops | poor scans | cost ratio |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        star = "*" if r["log"] in JUDGED else ""
        out.append(f"| {r['log']}{star} | {r['scans']} | {r['travel']:.0f} m | {r['odometry_rmse']:.2f} m | "
                   f"**{r['rmse']:.3f} m** | {r['ate']:.3f} m | {r['max_error']:.2f} m | "
                   f"{np.median(r['seed_rmse']):.3f} / {max(r['seed_rmse']):.3f} m | "
                   f"{r['anchor_deg']:+.2f}° ({r['anchor_floor']:.3f} m) | {_consistency_cell(r)} | {r['loops']} | {r['poor']} | "
                   + (f"**{r['cost']['ratio']:.2f}×** ({r['cost']['align_cpu']:.1f} s ÷ {r['cost']['plain_cpu']:.1f} s) |"
                      if r["cost"] else "n/a (no map) |"))
    out += ["", "| log | violations: corrected / aligned / odometry | explained: corrected / aligned / odometry | "
                "poses in free: corrected / aligned / odometry | Δ violations | Δ explained |",
            "|---|---|---|---|---:|---:|"]
    for r in rows:
        c, a, o = r["corrected"], r["aligned"], r["odometry"]
        star = "*" if r["log"] in JUDGED else ""
        if any("error" in m for m in (c, a, o)):
            na = lambda m, k: "no map" if "error" in m else pct(m[k])  # noqa: E731
            both = "error" not in c and "error" not in a
            dv = f"{100 * (a['violations'] - c['violations']):+.2f} points" if both else "n/a"
            de = f"{100 * (a['explained'] - c['explained']):+.2f} points" if both else "n/a"
            out.append(f"| {r['log']}{star} | {na(c, 'violations')} / {na(a, 'violations')} / {na(o, 'violations')} | "
                       f"{na(c, 'explained')} / {na(a, 'explained')} / {na(o, 'explained')} | "
                       f"{na(c, 'poses_in_free')} / {na(a, 'poses_in_free')} / {na(o, 'poses_in_free')} | {dv} | {de} |")
            continue
        out.append(f"| {r['log']}{star} | {pct(c['violations'])} / **{pct(a['violations'])}** / {pct(o['violations'])} | "
                   f"{pct(c['explained'])} / **{pct(a['explained'])}** / {pct(o['explained'])} | "
                   f"{pct(c['poses_in_free'])} / {pct(a['poses_in_free'])} / {pct(o['poses_in_free'])} | "
                   f"{100 * (a['violations'] - c['violations']):+.2f} points | {100 * (a['explained'] - c['explained']):+.2f} points |")
    notes = [f"- {r['log']}, {what}: no map: {m['error']}" for r in rows
             for what, m in (("aligned poses", r["aligned"]), ("odometry", r["odometry"])) if "error" in m]
    if notes:
        out += ["", *notes]
    return "\n".join(out) + "\n"


def run(d: Path, repeat: int = 1, only: list[str] | None = None, plots: Path | None = None,
        seeds: int = 5) -> tuple[str, list[dict]]:
    rows = []
    for name, p in every_log(d).items():
        if only and name not in only:
            continue
        rows.append(bench(name, p, repeat, plots, seeds))
    return markdown(rows, repeat), rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--datasets")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--only", help="comma-separated log names (default: every *.log.gz)")
    ap.add_argument("--docs", help="folder of align.md, whose align block gets the table")
    ap.add_argument("--plots", default="out/align", help="folder for the maps' pictures ('' for none)")
    ap.add_argument("--seeds", type=int, default=5, help="draws of the odometry's random error for the seeds column")
    ap.add_argument("--json", default=str(HERE / "align.json"))
    args = ap.parse_args(argv)
    d = Path(args.datasets) if args.datasets else datasets()
    if d is None:
        print(f"no CARMEN logs under any of {SEARCHED}: nothing to measure", file=sys.stderr)
        return 1
    md, rows = run(d, args.repeat, args.only.split(",") if args.only else None, Path(args.plots) if args.plots else None,
                   args.seeds)
    print(md)
    Path(args.json).write_text(json.dumps(rows, indent=1, default=float))
    if args.docs:
        try:
            write_block(Path(args.docs) / "align.md", "align:results", md)
        except BlockError as e:
            print(f"{e}; not changed", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
