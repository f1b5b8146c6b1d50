"""Where ``build --align``'s remaining error comes from (docs/align.md, "Where it does not work").

    python benchmarks/align_limits.py [--datasets DIR] [--only aces,intel,orebro]

For each shared log (default aces, intel, orebro), from the log's corrected poses, not from odometry:

* match vs corrected pose: every scan aligned (``registration.segment_match.align``, the front end's settings)
  to the surfaces of the 16 key scans before it at their corrected poses, from its own corrected
  pose: the median distance and heading between where it lands and where it started;
* fixed point: a pose graph of those matches (consecutive edges) and of ``_refine``'s matches of
  every place seen twice, solved from the corrected poses: its anchored RMSE and ATE against
  them. What the estimator moves the corrected poses to when it starts at them: the error no
  odometry, loop search or calibration can take away;
* from perfect odometry: ``align_scans`` with the corrected poses as the odometry (no drift at
  all): its anchored RMSE and ATE against them;
* the same match figures on the simulated demo floor at its exact poses: the matcher's own
  precision where the poses have no error (against the real logs' match vs corrected pose, what
  is the corrected poses' own).

The odometry's systematic error ``registration.calibrate_odometry`` learns from the benchmark's drift
(5 %, 2°/m, 2 % of every turn; seed 0). And the demo floor's first 40 scans (``tests/test_align.py``'s run) aligned with and without the
odometry calibration: RMSE against the true poses.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from fuzzybrep.mapping import align_scans as A  # noqa: E402
from fuzzybrep.registration import pose_graph  # noqa: E402
from fuzzybrep.scans.read import read_scans  # noqa: E402
from fuzzybrep.scans.scan import relative, wrap  # noqa: E402
from fuzzybrep.sim.drift import DriftModel, drift_scans  # noqa: E402
from fuzzybrep.registration.segment_match import align  # noqa: E402
from align import ate, rmse  # noqa: E402
from grid import datasets, every_log  # noqa: E402


def limits(scans) -> dict:
    cfg = A.AlignConfig()
    true = np.array([s.pose for s in scans])
    surf = A._Surfaces(scans, cfg)
    keys, dev = [0], []
    edges: tuple[list, ...] = ([], [], [], [], [])
    for k in range(1, len(scans)):
        index = surf.index(keys[-cfg.window:], true)
        pts = A._subsample(surf.points[k], cfg.max_points)
        r = align(pts, index, true[k], width=cfg.width, start_width=cfg.start_width, max_iterations=cfg.iterations)
        dev.append((math.hypot(*(r.pose[:2] - true[k, :2])), float(wrap(r.pose[2] - true[k, 2]))))
        for e, v in zip(edges, (k - 1, k, relative(true[k - 1], r.pose), A._edge_information(r.covariance, true[k - 1, 2]), False)):
            e.append(v)
        last = true[keys[-1]]
        if math.hypot(*(true[k, :2] - last[:2])) >= cfg.key_distance or abs(wrap(true[k, 2] - last[2])) >= cfg.key_turn:
            keys.append(k)
    travel = np.r_[0.0, np.cumsum(np.hypot(*np.diff(true[:, :2], axis=0).T))]
    added = A._refine(true.copy(), keys, travel, surf, cfg, edges)
    added += A._refine_local(true.copy(), keys, travel, surf, cfg, edges)
    fixed = pose_graph.solve(true, *(np.array(e) for e in edges))
    dev = np.array(dev)
    return {"match_m": float(np.median(dev[:, 0])), "match_deg": float(np.degrees(np.median(np.abs(dev[:, 1])))),
            "match_deg_rms": float(np.degrees(np.sqrt(np.mean(dev[:, 1] ** 2)))), "refine_edges": added, "rmse": rmse(fixed, true), "ate": ate(fixed, true)}


def demo_floor() -> tuple[float, float, dict]:
    sys.path.insert(0, str(HERE.parent / "tests"))
    import test_align as T

    true, drifted = T._demo_floor_run()
    on = A.align_scans(drifted[:40]).poses
    off = A.align_scans(drifted[:40], A.AlignConfig(calibrate=False)).poses
    return rmse(on, true[:40]), rmse(off, true[:40]), limits(A.with_poses(drifted, true))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--datasets")
    ap.add_argument("--only", default="aces,intel,orebro")
    args = ap.parse_args(argv)
    d = Path(args.datasets) if args.datasets else datasets()
    if d is not None:
        for name, p in every_log(d).items():
            if name not in args.only.split(","):
                continue
            scans = read_scans(p)
            learnt = A.align_scans(drift_scans(scans, DriftModel.benchmark(), seed=0)).calibration
            print(f"{name}: from the benchmark's drift (seed 0), {learnt.describe()}")
            r = limits(scans)
            print(f"{name}: match vs corrected pose (median) {100 * r['match_m']:.1f} cm, {r['match_deg']:.2f}° "
                  f"(RMS {r['match_deg_rms']:.2f}°); fixed point from the corrected poses ({r['refine_edges']} "
                  f"refinement edges): anchored RMSE {r['rmse']:.3f} m, ATE {r['ate']:.3f} m")
            true = np.array([s.pose for s in scans])
            perfect = A.align_scans(scans, odometry=true).poses
            print(f"{name}: from perfect odometry (the corrected poses): anchored RMSE {rmse(perfect, true):.3f} m, "
                  f"ATE {ate(perfect, true):.3f} m")
    on, off, sim = demo_floor()
    print(f"demo floor at its exact poses: match vs true pose (median) {100 * sim['match_m']:.1f} cm, "
          f"{sim['match_deg']:.2f}° (RMS {sim['match_deg_rms']:.2f}°)")
    print(f"demo floor, first 40 scans: RMSE {on:.3f} m with the odometry calibration, {off:.3f} m without")
    return 0


if __name__ == "__main__":
    sys.exit(main())
