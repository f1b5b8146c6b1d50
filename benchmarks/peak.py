"""Peak memory of building a map from a log, against the occupancy-grid mapper on the same scans.

    python benchmarks/peak.py [LOG ...]      (default: every CARMEN log benchmarks/grid.py finds)

Each measurement runs in a fresh Python process, which reads the log and then builds one thing:
the crisp map and its fuzzification (``build_map`` + ``fuzzify``, as ``fuzzybrep build`` does), or
the 5 cm log-odds grid (``occupancy_grid``). The process's peak resident memory (Linux's VmHWM)
after the read and after the build give the memory the build needed beyond the scans it was
given: what a robot must have free to build its map on board. A peak is a high-water mark, so it
moves little with the machine's load, unlike a time.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from grid import LOGS, SEARCHED, datasets  # noqa: E402

#: runs in the fresh process: prints the peak (KiB) after the read and after the build. VmHWM,
#: not getrusage's ru_maxrss: Linux carries ru_maxrss over fork and exec, so a child of a large
#: process (run.py, after building Freiburg) would report its parent's peak; VmHWM is the
#: high-water mark of the child's own memory
_CHILD = """
import sys
def peak():
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmHWM:"))
from fuzzybrep.scans.read import read_scans
scans = read_scans(sys.argv[1])
read = peak()
if sys.argv[2] == "map":
    from fuzzybrep.mapping.build import build_map
    from fuzzybrep.fuzzy import fuzzify
    fuzzify(build_map(scans).crisp)
else:
    from fuzzybrep.mapping.grid import occupancy_grid
    occupancy_grid(scans, 0.05)
print(read, peak())
"""


def peak(path: Path, what: str) -> tuple[int, int]:
    """(peak bytes after reading ``path``, peak bytes after building ``what``: "map" or "grid")."""
    out = subprocess.run([sys.executable, "-c", _CHILD, str(path), what], capture_output=True, text=True, check=True)
    read, built = (int(v) * 1024 for v in out.stdout.split())
    return read, built


def measure(path: Path) -> dict:
    read, built = peak(path, "map")
    grid_read, grid_built = peak(path, "grid")
    return {"read": read, "map": built - read, "grid": grid_built - grid_read}


def markdown(rows: list[tuple[str, dict]]) -> str:
    mb = lambda n: f"{n / 2**20:.0f} MB"  # noqa: E731
    L = ["| log | process after reading the log | build + fuzzify: peak beyond that | 5 cm grid mapper: peak beyond that | map ÷ grid |",
         "|---|---:|---:|---:|---:|"]
    for name, m in rows:
        L.append(f"| {name} | {mb(m['read'])} | {mb(m['map'])} | {mb(m['grid'])} | {m['map'] / max(m['grid'], 1):.1f} |")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    paths = [Path(a) for a in (argv if argv is not None else sys.argv[1:])]
    if not paths:
        d = datasets()
        if d is None:
            print(f"no folder holding carmen/ in any of {SEARCHED}: set FUZZYBREP_DATASETS", file=sys.stderr)
            return 1
        paths = [d / p for p in LOGS.values() if (d / p).is_file()]
    print(markdown([(p.name.split("-corrected")[0], measure(p)) for p in paths]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
