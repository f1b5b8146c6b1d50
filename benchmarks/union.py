"""The union's two engines on the build's own scan polygons: Clipper2 (pyclipr, the pairwise tree
``mapping.union.clipper_union``) against GEOS's cascaded union (``shapely.union_all``).

    python benchmarks/union.py [LOG ...] [--repeat 3]

(default: every CARMEN log benchmarks/grid.py finds). For each log the scan polygons are made as
``build_map`` makes them (beams, evidence, scan polygons), then ``mapping.union.union`` is timed
with each engine, interleaved, ``repeat`` times (median wall and CPU seconds, both cores), and
the results compared: the area of their symmetric difference over the area, and validity.
``fuzzybrep build`` uses Clipper2, which must be the faster with the same result (≤ 1e-5).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import shapely

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from fuzzybrep.brep import rings_to_shapely  # noqa: E402
from fuzzybrep.mapping import build as B, evidence, union  # noqa: E402
from fuzzybrep.mapping.scan_polygon import scan_polygons  # noqa: E402
from fuzzybrep.scans.filters import classify_all  # noqa: E402
from fuzzybrep.scans.read import read_scans  # noqa: E402


def scan_polygons_of(log: Path, cfg: B.BuildConfig = B.BuildConfig()):
    """The build's scan polygons of the log, as Shapely polygons (before the union)."""
    scans = read_scans(log)
    beams = classify_all(scans, cfg.beams, cfg.polygon)
    rays = B.ray_batches(scans, beams, cfg.evidence)
    ev = evidence.gather(rays, cfg.evidence, B.check_extent(scans, rays, cfg.evidence.cell))
    free, status, _ = B._split_free(scans, beams, evidence.clip(rays, ev, cfg.evidence))
    return rings_to_shapely([p.ring for p in scan_polygons(scans, free, status, cfg.polygon)])


def measure(log: str | Path, repeat: int = 3) -> dict:
    """Seconds (wall and CPU, median) of each engine on the log's scan polygons, and how far apart
    their unions are."""
    polys = scan_polygons_of(Path(log))
    cfg = B.BuildConfig()
    runs: dict[str, list] = {e: [] for e in union.ENGINES}
    out = {}
    for _ in range(repeat):
        for engine in union.ENGINES:
            t, c = time.perf_counter(), time.process_time()
            out[engine] = union.union(polys, simplify=cfg.presimplify, engine=engine)
            runs[engine].append((time.perf_counter() - t, time.process_time() - c))
    geos, clip = out["geos"], out["clipper"]
    res = {"log": Path(log).name, "polygons": len(polys), "repeat": repeat,
           "symmetric_difference": shapely.symmetric_difference(geos, clip).area / geos.area,
           "valid": {e: bool(g.is_valid) for e, g in out.items()},
           "holes": {e: int(sum(len(p.interiors) for p in shapely.get_parts(g))) for e, g in out.items()}}
    for e, rs in runs.items():
        res[e] = {"seconds": statistics.median(r[0] for r in rs), "cpu": statistics.median(r[1] for r in rs)}
    res["geos_over_clipper"] = res["geos"]["seconds"] / res["clipper"]["seconds"]
    return res


def markdown(results: list[dict]) -> str:
    L = ["| log | scan polygons | GEOS union_all | Clipper2 tree | GEOS ÷ Clipper2 | symmetric difference ÷ area | valid |",
         "|---|---:|---:|---:|---:|---:|:---:|"]
    for r in results:
        L.append(f"| {r['log'].split('-corrected')[0]} | {r['polygons']} | {r['geos']['seconds']:.2f} s | "
                 f"{r['clipper']['seconds']:.2f} s | **{r['geos_over_clipper']:.2f}** | {r['symmetric_difference']:.1e} | "
                 f"{'yes' if all(r['valid'].values()) else 'NO'} |")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    from grid import SEARCHED, datasets, every_log

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("logs", nargs="*", type=Path)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    logs = args.logs
    if not logs:
        d = datasets()
        if d is None:
            print(f"no folder holding carmen/ in any of {SEARCHED}: set FUZZYBREP_DATASETS", file=sys.stderr)
            return 1
        logs = list(every_log(d).values())
    print(markdown([measure(log, args.repeat) for log in logs]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
