"""The whole commands as a user waits for them: `fuzzybrep build LOG` against `fuzzybrep grid LOG
--resolution 0.05`, time and peak memory, and how build's time grows with the scans.

    python benchmarks/commands.py [LOG ...] [--repeat 3] [--scaling LOG]

(default: every log in carmen/ of the datasets folder benchmarks/grid.py finds, and the scaling
on its freiburg-campus log if there). ``run.py`` (``make bench``) runs both into the README.

Every figure is a whole command in a fresh process, start-up and imports included, as a user
waits for it: ``measure(log)`` runs ``grid`` and ``build`` interleaved (grid, build, grid,
build, ...), ``repeat`` times each, and takes the median wall time and the largest peak resident
memory of each. ``scaling(log)`` writes the first 1/8, 1/4, 1/2 and all of a log's scans to
temporary logs and times ``build`` on each, interleaved too. Issue 17 asks: build ≤ 3× grid's
time and ≤ grid's peak memory on every log, and 8× the scans in ≤ 9× the time.

The package's bytecode is compiled first (``compiled``), as ``pip install`` does for an
installed package: an editable install has none, and where PYTHONDONTWRITEBYTECODE is set (this
machine sets it) Python would compile every module from source at every start and never keep
it, 0.3 s of every command here, more of build's (it imports more) than of grid's.

Peak memory is each command's ru_maxrss, from ``os.wait4`` on it, as /usr/bin/time reports it.
Linux carries ru_maxrss over fork and exec (a child's peak starts at its parent's resident size
when it forked), so each command is started by a small stdlib-only Python process (``_WRAPPER``)
and not by this one, which may hold maps of its own (run.py): the wrapper's few MB are the floor.
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

#: started with python -S -c: forks, execs argv, waits with wait4 and prints wall seconds, user
#: and system CPU seconds, peak RSS (KiB) and the exit status; the command's own output is dropped
_WRAPPER = r"""
import os, sys, time
t = time.perf_counter()
pid = os.fork()
if pid == 0:
    fd = os.open(os.devnull, os.O_RDWR)
    os.dup2(fd, 0); os.dup2(fd, 1); os.dup2(fd, 2)
    try:
        os.execv(sys.argv[1], sys.argv[1:])
    finally:
        os._exit(127)
_, status, ru = os.wait4(pid, 0)
print(time.perf_counter() - t, ru.ru_utime, ru.ru_stime, ru.ru_maxrss, os.waitstatus_to_exitcode(status))
"""


def compiled() -> None:
    """Byte-compile the fuzzybrep package the commands import (as pip does when it installs one),
    so that a command's time is its own and not that of compiling its modules."""
    import compileall
    import importlib.util

    spec = importlib.util.find_spec("fuzzybrep")
    if spec is not None and spec.submodule_search_locations:
        for where in spec.submodule_search_locations:
            compileall.compile_dir(where, quiet=1)


def fuzzybrep() -> list[str]:
    """The fuzzybrep command of this Python (the venv's entry script, as a user runs it)."""
    script = Path(sys.executable).with_name("fuzzybrep")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "fuzzybrep.cli"]


def run(argv: list[str]) -> dict:
    """One whole command: wall seconds, CPU seconds (user + system) and peak resident bytes."""
    out = subprocess.run([sys.executable, "-S", "-c", _WRAPPER, *argv], capture_output=True, text=True, check=True)
    wall, user, system, maxrss, code = out.stdout.split()
    if int(code) != 0:
        raise RuntimeError(f"{' '.join(argv)} exited with status {code}")
    return {"seconds": float(wall), "cpu": float(user) + float(system), "peak": int(maxrss) * 1024}


def commands(log: Path, out: Path) -> dict[str, list[str]]:
    """The two commands compared, as a user types them (outputs into ``out``)."""
    fb = fuzzybrep()
    return {"grid": [*fb, "grid", str(log), "--resolution", "0.05", "--out", str(out / "grid"), "--quiet"],
            "build": [*fb, "build", str(log), "--out", str(out / "map.json"), "--quiet"]}


def measure(log: str | Path, repeat: int = 3) -> dict:
    """``fuzzybrep build LOG`` against ``fuzzybrep grid LOG --resolution 0.05``, interleaved,
    ``repeat`` times each: median seconds, median CPU seconds and largest peak memory of each, and
    build's time and memory as multiples of grid's."""
    log = Path(log)
    compiled()
    runs: dict[str, list[dict]] = {"grid": [], "build": []}
    with tempfile.TemporaryDirectory() as tmp:
        cmds = commands(log, Path(tmp))
        for _ in range(repeat):
            for name, argv in cmds.items():
                runs[name].append(run(argv))
    res: dict = {"log": log.name, "repeat": repeat}
    for name, rs in runs.items():
        res[name] = {"seconds": statistics.median(r["seconds"] for r in rs),
                     "cpu": statistics.median(r["cpu"] for r in rs),
                     "peak": max(r["peak"] for r in rs), "all_seconds": [r["seconds"] for r in rs]}
    res["time_ratio"] = res["build"]["seconds"] / res["grid"]["seconds"]
    res["memory_ratio"] = res["build"]["peak"] / res["grid"]["peak"]
    return res


def write_prefix(log: Path, n: int, dest: Path) -> int:
    """The log's lines up to and with its n-th FLASER line, written to ``dest`` (plain text, so
    that reading it costs no more than reading the original). Returns the scans written."""
    opener = gzip.open if log.suffix == ".gz" else open
    scans = 0
    with opener(log, "rt", errors="replace") as src, open(dest, "w") as out:
        for line in src:
            out.write(line)
            if line.startswith("FLASER"):
                scans += 1
                if scans >= n:
                    break
    return scans


def count_scans(log: Path) -> int:
    opener = gzip.open if log.suffix == ".gz" else open
    with opener(log, "rt", errors="replace") as src:
        return sum(line.startswith("FLASER") for line in src)


def scaling(log: str | Path, fractions=(8, 4, 2, 1), repeat: int = 3) -> dict:
    """``fuzzybrep build`` on the first 1/f of the log's scans for each f in ``fractions``,
    interleaved: median seconds per prefix, and the time of all scans over that of the first
    prefix against the scans' ratio (issue 17: 8× the scans in at most 9× the time)."""
    log = Path(log)
    compiled()
    total = count_scans(log)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        logs = []
        for f in fractions:
            p = tmp / f"first-{f}.log"
            logs.append((write_prefix(log, total // f, p), p))
        times: dict[Path, list[float]] = {p: [] for _, p in logs}
        for _ in range(repeat):
            for _, p in logs:
                times[p].append(run(commands(p, tmp)["build"])["seconds"])
        for n, p in logs:
            rows.append({"scans": n, "seconds": statistics.median(times[p]), "all_seconds": times[p]})
    first, last = rows[0], rows[-1]
    return {"log": log.name, "repeat": repeat, "rows": rows, "scans_ratio": last["scans"] / first["scans"],
            "time_ratio": last["seconds"] / first["seconds"]}


def markdown(results: list[dict], grow: dict | None = None) -> str:
    """The two tables: build against grid per log, and build's time over prefixes of one log."""
    mb = lambda n: f"{n / 2**20:.0f} MB"  # noqa: E731
    L = ["| log | `grid --resolution 0.05` | `build` | build ÷ grid, time | grid peak memory | build peak memory | build ÷ grid, memory |",
         "|---|---:|---:|---:|---:|---:|---:|"]
    for r in results:
        name = r["log"].split("-corrected")[0]
        L.append(f"| {name} | {r['grid']['seconds']:.2f} s | {r['build']['seconds']:.2f} s | **{r['time_ratio']:.2f}** | "
                 f"{mb(r['grid']['peak'])} | {mb(r['build']['peak'])} | **{r['memory_ratio']:.2f}** |")
    if grow:
        base = grow["rows"][0]
        L += ["", f"`fuzzybrep build` on the first scans of {grow['log'].split('-corrected')[0]}:", "",
              "| scans | seconds | × scans | × time |", "|---:|---:|---:|---:|"]
        for row in grow["rows"]:
            L.append(f"| {row['scans']} | {row['seconds']:.2f} | {row['scans'] / base['scans']:.2f} | "
                     f"{row['seconds'] / base['seconds']:.2f} |")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    from grid import SEARCHED, datasets, every_log

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("logs", nargs="*", type=Path)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scaling", type=Path, help="log whose prefixes to time (default: freiburg-campus, if found)")
    ap.add_argument("--no-scaling", action="store_true")
    ap.add_argument("--json", type=Path, help="also write the figures as JSON here")
    args = ap.parse_args(argv)
    logs = args.logs
    d = datasets()
    if not logs:
        if d is None:
            print(f"no folder holding carmen/ in any of {SEARCHED}: set FUZZYBREP_DATASETS", file=sys.stderr)
            return 1
        logs = list(every_log(d).values())
    results = []
    for log in logs:
        print(f"[commands] {log.name}", file=sys.stderr, flush=True)
        results.append(measure(log, args.repeat))
    grow = None
    if not args.no_scaling:
        target = args.scaling or (d / "carmen" / "freiburg-campus-corrected.log.gz" if d else None)
        if target is not None and target.is_file():
            print(f"[commands] scaling on {target.name}", file=sys.stderr, flush=True)
            grow = scaling(target, repeat=args.repeat)
    if args.json:
        args.json.write_text(json.dumps({"logs": results, "scaling": grow}, indent=1))
    print(markdown(results, grow))
    return 0


if __name__ == "__main__":
    sys.exit(main())
