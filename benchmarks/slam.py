"""Poses from a robot's own odometry, scored on the SLAM benchmark (issue 33).

    python benchmarks/slam.py [--datasets DIR] [--only intel,fr079] [--docs docs] [--plots out/slam]

For each raw log in ``DIR/raw`` (intel, aces, fr079: full scan rate, the robot's own odometry) and
the ACES ROS 1 bag in ``DIR/bags``, in one run: ``fuzzybrep build LOG --align`` and ``fuzzybrep
build LOG`` as whole commands (fresh processes, wall time, interleaved), the aligned poses read
back from the map file and scored on the log's relations (``registration.relations``: the metric
of Kümmerle et al. 2009, mean ± standard deviation of the absolute and the squared errors), beside
the raw odometry scored the same way and the published figures of graph mapping and Cartographer
(Hess et al., ICRA 2016, Table II; graph mapping quoted there from Kümmerle et al. 2009). The
alignment's own verdict (``registration.check``) is reported too. Pictures of the aligned maps go
to ``--plots``. With ``--docs`` the table is written into docs/slam.md between its markers.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from fuzzybrep.registration.align_scans import odometry_of  # noqa: E402
from fuzzybrep.registration.check import CheckConfig  # noqa: E402
from fuzzybrep.registration.relations import read_relations, score  # noqa: E402
from fuzzybrep.scans.read import read_scans  # noqa: E402
from grid import datasets  # noqa: E402

#: (name, log under the datasets folder, relations file)
LOGS = [("intel", "raw/intel.clf.gz", "raw/intel.relations"), ("aces", "raw/aces.clf.gz", "raw/aces.relations"),
        ("fr079", "raw/fr079.clf.gz", "raw/fr079.relations"), ("aces (bag)", "bags/aces.orig.bag", "raw/aces.relations")]
#: published results on the same relations, absolute errors: (translational m mean, sd), (rotational ° mean, sd)
#: graph mapping: Kümmerle et al. 2009 as quoted by Hess et al. 2016, Table II; Cartographer: Hess et al. 2016, Table II
PUBLISHED = {
    "intel": {"graph mapping": ((0.031, 0.026), (1.3, 4.7)), "Cartographer": ((0.0229, 0.0239), (0.453, 1.335))},
    "aces": {"graph mapping": ((0.044, 0.044), (0.4, 0.4)), "Cartographer": ((0.0375, 0.0426), (0.373, 0.469))},
    "fr079": {"graph mapping": ((0.056, 0.042), (0.6, 0.6)), "Cartographer": ((0.0452, 0.0354), (0.538, 0.718))},
}


def _build(log: Path, out: Path, align: bool, plot: Path | None = None) -> float:
    exe = Path(sys.executable).with_name("fuzzybrep")
    cmd = [str(exe), "build", str(log), "--out", str(out), "--quiet"] + (["--align"] if align else [])
    if plot is not None:
        cmd += ["--plot", str(plot)]
    t = time.perf_counter()
    subprocess.run(cmd, check=True)
    return time.perf_counter() - t


def bench_log(d: Path, name: str, log: str, rel: str, plots: Path | None, tmp: Path) -> dict:
    path, relations = d / log, read_relations(d / rel)
    scans = read_scans(path)
    times = np.array([s.timestamp for s in scans])
    odo = score(times, odometry_of(scans), relations)
    slug = name.replace(" ", "").replace("(", "-").replace(")", "")
    aligned_map, plain_map = tmp / f"{slug}-aligned.json", tmp / f"{slug}.json"
    plot = None if plots is None else plots / f"{slug}-aligned.png"
    t_plain = _build(path, plain_map, False)
    t_align = _build(path, aligned_map, True, plot)
    doc = json.loads(aligned_map.read_text())
    poses = np.array(doc["scans"]["poses"], np.float64)
    got = score(poses[:, 3], poses[:, :3], relations)
    check = doc.get("metadata", {}).get("alignment", {}).get("check", {})
    return {"name": name, "scans": len(scans), "odometry": odo, "aligned": got, "check": check,
            "t_align": t_align, "t_plain": t_plain}


def _ms(pair, digits=3):
    return f"{pair[0]:.{digits}f} ± {pair[1]:.{digits}f}"


def markdown(rows: list[dict]) -> str:
    out = ["`fuzzybrep build LOG --align`, the aligned poses from the map file scored on the benchmark's relations "
           "(absolute errors, mean ± standard deviation; squared errors in m² and deg²). Published figures: graph "
           "mapping (Kümmerle et al. 2009, as quoted by Hess et al. 2016, Table II) and Cartographer (Hess et al., "
           "\"Real-Time Loop Closure in 2D LIDAR SLAM\", ICRA 2016, Table II). Time: whole commands, wall clock, "
           "`build --align` against `build` on the same log in the same run.",
           "",
           "| log | scans | raw odometry | `--align` translational (m) | rotational (°) | squared trans. (m²) | squared rot. (deg²) "
           "| graph mapping | Cartographer | check | time: --align / plain | ratio | scans/s |",
           "|---|---:|---|---|---|---|---|---|---|---|---|---:|---:|"]
    for r in rows:
        key = r["name"].split(" ")[0]
        pub = PUBLISHED.get(key, {})
        gm = pub.get("graph mapping")
        ca = pub.get("Cartographer")
        a, o = r["aligned"], r["odometry"]
        chk = r["check"]
        verdict = "n/a" if not chk else (("passed" if chk["ok"] else "**FAILED**") + f" ({100 * chk['contradicted']:.1f} %)")
        out.append(f"| {r['name']} | {r['scans']} | {o.trans[0]:.3f} m, {o.rot[0]:.2f}° | **{_ms(a.trans, 4)}** | {_ms(a.rot, 3)} "
                   f"| {a.trans_sq[0]:.5f} ± {a.trans_sq[1]:.5f} | {a.rot_sq[0]:.3f} ± {a.rot_sq[1]:.3f} "
                   f"| {_ms(gm[0])} m, {gm[1][0]:g}° | {_ms(ca[0], 4)} m, {ca[1][0]:g}° " if gm else "| | ")
        out[-1] += (f"| {verdict} | {r['t_align']:.1f} s / {r['t_plain']:.1f} s | {r['t_align'] / r['t_plain']:.2f}× "
                    f"| {r['scans'] / r['t_align']:.0f} |")
    out.append("")
    c = CheckConfig()
    out.append("Check: the aligned poses against the scans (`registration.check`): the share of the scans where the robot "
               f"came back that put over {100 * c.share:.0f} % of their returns in space another pass saw free; over "
               f"{100 * c.fail_share:.0f} % fails.")
    return "\n".join(out)


def run(d: Path, only: list[str] | None = None, plots: Path | None = None) -> str:
    rows = []
    if plots is not None:
        plots.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name, log, rel in LOGS:
            if only and name.split(" ")[0] not in only and name not in only:
                continue
            if not (d / log).exists() or not (d / rel).exists():
                print(f"[slam] {name}: {d / log} or {d / rel} absent: skipped", file=sys.stderr)
                continue
            print(f"[slam] {name}", file=sys.stderr, flush=True)
            rows.append(bench_log(d, name, log, rel, plots, Path(tmp)))
            r = rows[-1]
            print(f"[slam] {name}: {r['aligned'].summary()}, {r['t_align']:.1f} s / {r['t_plain']:.1f} s",
                  file=sys.stderr, flush=True)
    return markdown(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--datasets", help="folder holding raw/ and bags/ (default: as run.py finds carmen/)")
    ap.add_argument("--only", help="comma-separated logs: intel, aces, fr079, bag")
    ap.add_argument("--docs", help="write the table into DOCS/slam.md between its markers")
    ap.add_argument("--plots", default=str(HERE.parent / "out" / "slam"), help="pictures of the aligned maps")
    args = ap.parse_args(argv)
    d = Path(args.datasets) if args.datasets else datasets()
    if d is None or not (d / "raw").is_dir():
        print(f"[slam] no raw/ logs under {d}: nothing to measure", file=sys.stderr)
        return 0
    only = None
    if args.only:
        only = ["aces (bag)" if o == "bag" else o for o in args.only.split(",")]
    md = run(d, only, Path(args.plots))
    print(md)
    if args.docs:
        from blocks import write_block
        from docs import stamp

        write_block(Path(args.docs) / "slam.md", "slam:results", stamp(True) + "\n\n" + md)
    return 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONDONTWRITEBYTECODE", "1")
    sys.exit(main())
