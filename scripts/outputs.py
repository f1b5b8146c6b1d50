#!/usr/bin/env python3
"""Snapshot every output of the command line, and compare two snapshots byte for byte.

A refactor must not change what fuzzybrep writes. This runs the commands a user runs (build,
export in every format, tables, α-cuts by both methods, membership, memory, view, plan, fuzzify,
grid, evaluate, simulate, umbmark, demo) on the three logs the project grew up on and on the
built-in demo, through the ``fuzzybrep`` next to the Python that runs it, and hashes every file
and every printed line. Lines that report elapsed time are masked (``0.9 s`` becomes ``<t> s``);
nothing else is.

    python scripts/outputs.py snapshot OUT_DIR [--logs DIR] [--quick]
    python scripts/outputs.py compare BEFORE_DIR AFTER_DIR
    python scripts/outputs.py rehash DIR          (hash a snapshot's files again)

Run ``snapshot`` from a checkout of the old code and again from the new one (each with its own
.venv), then ``compare``: it lists every file that differs and exits 1 if any does.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

LOGS = ["intel", "aces", "freiburg-079"]
#: elapsed times in printed output ("done in 0.9 s", "1.23 s", "(12 ms)", "took 3.2s"); nothing else
_TIMES = re.compile(r"\b\d+(\.\d+)?\s?(s|ms|µs|min)\b|\b\d+(\.\d+)? scans/s\b")


def fuzzybrep() -> str:
    exe = Path(sys.executable).with_name("fuzzybrep")
    if not exe.exists():
        sys.exit(f"no fuzzybrep beside {sys.executable}: run with the checkout's .venv/bin/python")
    return str(exe)


def run(out: Path, name: str, *args: str) -> None:
    """Run one command in ``out``; keep its stdout, stderr and status as ``name.txt``."""
    r = subprocess.run([fuzzybrep(), *args], cwd=out, capture_output=True, text=True)
    text = f"$ fuzzybrep {' '.join(args)}\nstatus {r.returncode}\n--- stdout\n{r.stdout}--- stderr\n{r.stderr}"
    (out / f"{name}.txt").write_text(_TIMES.sub("<t>", text))
    print(f"  {name}: status {r.returncode}", flush=True)


def map_poses(path: Path) -> list[list[float]]:
    return (json.loads(path.read_text()).get("scans") or {}).get("poses") or []


def snapshot(out: Path, logs: Path, quick: bool) -> None:
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    for name in LOGS[:1] if quick else LOGS:
        log = (logs / f"carmen/{name}-corrected.log.gz").resolve()
        if not log.exists():
            print(f"skipping {name}: {log} not found")
            continue
        d = out / name
        d.mkdir()
        print(name, flush=True)
        run(d, "build", "build", str(log), "--out", "map.json", "--plot", "map.png")
        run(d, "export", "export", "map.json", "--geojson", "map.geojson", "--ros", "ros", "--svg", "map.svg",
            "--compact", "map.fbrc")
        run(d, "export-exact", "export", "map.json", "--geojson", "exact.geojson", "--method", "exact", "--alpha", "0.5")
        run(d, "tables", "tables", "map.json", "--csv", "tables")
        for method in ("sweep", "exact"):
            for a in ("0", "0.5", "0.9"):
                run(d, f"cut-{method}-{a}", "alpha-cut", "map.json", "--alpha", a, "--method", method,
                    "--out", f"cut-{method}-{a}.geojson")
        poses = map_poses(d / "map.json")
        pts = poses[:: max(1, len(poses) // 50)]
        (d / "points.csv").write_text("x,y\n" + "".join(f"{p[0]!r},{p[1]!r}\n" for p in pts))
        run(d, "membership", "membership", "map.json", "--points", "points.csv", "--method", "both")
        run(d, "memory", "memory", "map.json")
        run(d, "view", "view", "map.json", "--html", "map.html")
        a, b = poses[0], poses[len(poses) // 2]
        for mode in ("shortest", "clearance"):
            run(d, f"plan-{mode}", "plan", "map.json", "--start", repr(a[0]), repr(a[1]), "--goal", repr(b[0]),
                repr(b[1]), "--alpha", "0.5", "--mode", mode, "--json", "--plot", f"plan-{mode}.png")
        run(d, "fuzzify", "fuzzify", "map.geojson", "--tme", "0.2", "--out", "refuzzified.json")
        run(d, "compact-tables", "tables", "map.fbrc")
        run(d, "grid", "grid", str(log), "--resolution", "0.05", "--out", "grid")
        if name == "intel" or not quick:
            run(d, "evaluate", "evaluate", str(log))
    d = out / "demo"
    d.mkdir()
    print("demo", flush=True)
    run(d, "demo", "demo", "--out", "demo")
    run(d, "simulate", "simulate", "--out", "sim.npz", "--world-out", "world.geojson", "--umbmark-out", "runs.csv")
    run(d, "umbmark", "umbmark", "runs.csv", "--json")
    run(d, "umbmark-thesis", "umbmark", "runs.csv")
    write_manifest(out)


def _untimed(d):
    """A report's JSON with its elapsed times (keys ``seconds``, ``timings``, ``timings_s``) set to 0."""
    if isinstance(d, dict):
        return {k: (_zero(v) if k in ("seconds", "total_seconds", "timings", "timings_s") else _untimed(v)) for k, v in d.items()}
    if isinstance(d, list):
        return [_untimed(v) for v in d]
    return d


def _zero(v):
    return {k: 0 for k in v} if isinstance(v, dict) else 0


def write_manifest(out: Path) -> None:
    """Hash every output under ``out`` (times masked) into ``out/manifest.json``."""
    manifest = {}
    for p in sorted(out.rglob("*")):
        if p.is_file() and p.name != "manifest.json":
            data = p.read_bytes()
            if p.name == "report.md" or p.suffix == ".txt":
                data = _TIMES.sub("<t>", data.decode()).encode()
            elif p.name == "report.json":
                data = json.dumps(_untimed(json.loads(data)), sort_keys=True).encode()
            manifest[str(p.relative_to(out))] = hashlib.sha256(data).hexdigest()
    (out / "manifest.json").write_text(json.dumps(manifest, indent=1, sort_keys=True))
    print(f"{len(manifest)} outputs hashed into {out / 'manifest.json'}")


def compare(a: Path, b: Path) -> int:
    ma = json.loads((a / "manifest.json").read_text())
    mb = json.loads((b / "manifest.json").read_text())
    bad = 0
    for k in sorted(set(ma) | set(mb)):
        if ma.get(k) != mb.get(k):
            bad += 1
            what = "only before" if k not in mb else "only after" if k not in ma else "differs"
            print(f"{what}: {k}")
    print(f"{len(ma)} outputs before, {len(mb)} after, {bad} differ")
    return 1 if bad else 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("snapshot")
    s.add_argument("out", type=Path)
    s.add_argument("--logs", type=Path, default=Path(os.environ.get("FUZZYBREP_DATASETS", "../shared/datasets")))
    s.add_argument("--quick", action="store_true", help="intel and the demo only")
    r = sub.add_parser("rehash", help="hash a snapshot's files again (after changing what is masked)")
    r.add_argument("out", type=Path)
    c = sub.add_parser("compare")
    c.add_argument("before", type=Path)
    c.add_argument("after", type=Path)
    args = ap.parse_args()
    if args.cmd == "snapshot":
        snapshot(args.out.resolve(), args.logs, args.quick)
        return 0
    if args.cmd == "rehash":
        write_manifest(args.out.resolve())
        return 0
    return compare(args.before, args.after)


if __name__ == "__main__":
    sys.exit(main())
