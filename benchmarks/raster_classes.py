"""Free, occupied and unknown: the fuzzy map's raster (``membership_raster``) against ``fuzzybrep grid``.

    python benchmarks/raster_classes.py [--resolution 0.05] [--maps DIR] [--out FILE.md]

For every CARMEN log in ../shared/datasets (or $FUZZYBREP_DATASETS): the map ``fuzzybrep build``
makes (or DIR/NAME.json, when --maps gives a folder of them), rasterised at the resolution, and
the log-odds occupancy grid of the same scans at the same resolution. Both lie on the lattice of
the resolution, so their cells coincide; a cell outside one grid's extent is unknown to it. The
table gives each one's free, occupied and unknown area over the union of the two extents, and how
the cells agree: of the raster's occupied cells, how many the grid calls occupied or has a hit
within a cell of (walls one cell thick in the grid lie anywhere in the band); of the cells deep in
holes (inside a hole, farther than 0.5 m from every obstacle edge), how many each calls unknown.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import shapely
from scipy import ndimage

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "src"))

from fuzzybrep.formats.raster import membership_raster  # noqa: E402
from fuzzybrep.mapping.grid import occupancy_grid  # noqa: E402

#: every shared log, by the name the table gives it
ALL_LOGS = {name: f"carmen/{name}-corrected.log.gz"
            for name in ("intel", "aces", "freiburg-079", "freiburg-campus", "fhw", "orebro")}
DEEP = 0.5  # m: "deep in a hole", as issue 20 counted on belgioioso


def compare(fz, scans, resolution: float = 0.05) -> dict:
    """The two rasters on one lattice and what the table reports of them."""
    r = membership_raster(fz, resolution, "exact")
    g = occupancy_grid(scans, resolution)
    # lattice indices of both grids' lower-left cells
    ri0, rj0 = (int(round(v / resolution)) for v in r.origin)
    gi0, gj0 = (int(round(v / resolution)) for v in g.origin)
    rh, rw = r.shape
    gh, gw = g.shape
    i0, j0 = min(ri0, gi0), min(rj0, gj0)
    i1, j1 = max(ri0 + rw, gi0 + gw), max(rj0 + rh, gj0 + gh)
    shape = (j1 - j0, i1 - i0)

    def place(mask, i, j):  # a bottom-row-first mask into the union frame
        out = np.zeros(shape, bool)
        out[j - j0 : j - j0 + mask.shape[0], i - i0 : i - i0 + mask.shape[1]] = mask
        return out

    ours = {k: place(getattr(r, k)[::-1], ri0, rj0) for k in ("free", "occupied")}
    ours["unknown"] = ~(ours["free"] | ours["occupied"])
    theirs = {"free": place(g.free(), gi0, gj0), "occupied": place(g.occupied(), gi0, gj0)}
    theirs["unknown"] = ~(theirs["free"] | theirs["occupied"])
    cell = resolution ** 2
    # deep in holes: inside a region's shell, outside the free space, farther than DEEP from every obstacle edge
    cx = (np.arange(i0, i1) + 0.5) * resolution
    cy = (np.arange(j0, j1) + 0.5) * resolution
    X, Y = np.meshgrid(cx, cy)
    shells = shapely.union_all([shapely.Polygon(reg.shell.vertices) for reg in fz.crisp.regions])
    in_hole = shapely.contains_xy(shells, X, Y) & ~ours["free"]
    near_wall = ndimage.binary_dilation(ours["occupied"], iterations=max(1, int(round(DEEP / resolution))))
    deep = in_hole & ~near_wall
    hit_near = ndimage.binary_dilation(theirs["occupied"], iterations=1)
    # the map's own areas (polygons) against the raster's cells, as --nav2 writes them
    from fuzzybrep.formats.raster import occupied_region

    box = r.extent().area
    own = {"free": fz.crisp_geometry.area, "occupied": occupied_region(fz).area}
    own["unknown"] = box - own["free"] - own["occupied"]
    cells = {"free": r.free_area(), "occupied": r.occupied_area(), "unknown": r.unknown_area()}
    occ = ours["occupied"]
    return {
        "areas": {side: {k: float(m.sum() * cell) for k, m in d.items()} for side, d in (("fuzzy", ours), ("grid", theirs))},
        "occupied_in_grid": float((occ & theirs["occupied"]).sum() / max(occ.sum(), 1)),
        "occupied_near_grid_hit": float((occ & hit_near).sum() / max(occ.sum(), 1)),
        "grid_occupied_in_ours": float((theirs["occupied"] & occ).sum() / max(theirs["occupied"].sum(), 1)),
        "grid_occupied_in_free": float((theirs["occupied"] & ours["free"]).sum() / max(theirs["occupied"].sum(), 1)),
        "free_agree": float((ours["free"] & theirs["free"]).sum() / max(ours["free"].sum(), 1)),
        "deep_cells": int(deep.sum()),
        "deep_unknown_ours": float((deep & ours["unknown"]).sum() / max(deep.sum(), 1)),
        "deep_unknown_grid": float((deep & theirs["unknown"]).sum() / max(deep.sum(), 1)),
        "own": own,
        "cells": cells,
    }


def table(rows: dict[str, dict]) -> str:
    head = ("| log | free m² (fuzzy / grid) | occupied m² (fuzzy / grid) | unknown m² (fuzzy / grid) "
            "| fuzzy occupied: grid occupied / grid hit within a cell | grid occupied: in fuzzy occupied / free / unknown "
            "| fuzzy free the grid calls free | cells deep in holes | … unknown (fuzzy / grid) |\n"
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    lines = [head]
    for name, c in rows.items():
        a, b = c["areas"]["fuzzy"], c["areas"]["grid"]
        lines.append(f"| {name} | {a['free']:.0f} / {b['free']:.0f} | {a['occupied']:.0f} / {b['occupied']:.0f} "
                     f"| {a['unknown']:.0f} / {b['unknown']:.0f} "
                     f"| {100 * c['occupied_in_grid']:.1f} % / {100 * c['occupied_near_grid_hit']:.1f} % "
                     f"| {100 * c['grid_occupied_in_ours']:.1f} % / {100 * c['grid_occupied_in_free']:.1f} % / "
                     f"{100 * (1 - c['grid_occupied_in_ours'] - c['grid_occupied_in_free']):.1f} % "
                     f"| {100 * c['free_agree']:.1f} % | {c['deep_cells']} "
                     f"| {100 * c['deep_unknown_ours']:.1f} % / {100 * c['deep_unknown_grid']:.1f} % |")
    return "\n".join(lines)


def nav2_table(rows: dict[str, dict]) -> str:
    """The raster's cells (what ``--nav2`` writes and map_server reads back) against the map's own areas."""
    lines = ["| log | free m²: cells / map | occupied m²: cells / map | unknown m²: cells / map | largest difference |",
             "|---|---:|---:|---:|---:|"]
    for name, c in rows.items():
        cells, own = c["cells"], c["own"]
        worst = max(abs(cells[k] - own[k]) / own[k] for k in own if own[k] > 0)
        lines.append(f"| {name} | {cells['free']:.1f} / {own['free']:.1f} | {cells['occupied']:.1f} / {own['occupied']:.1f} "
                     f"| {cells['unknown']:.1f} / {own['unknown']:.1f} | {100 * worst:.2f} % |")
    return "\n".join(lines)


def run(d: Path, resolution: float = 0.05, maps: dict | None = None, maps_dir: Path | None = None) -> dict[str, dict]:
    from fuzzybrep.fuzzy.map import FuzzyBRepMap, fuzzify
    from fuzzybrep.mapping.build import BuildConfig, build_map
    from fuzzybrep.scans.read import read_scans

    rows = {}
    for name, rel in ALL_LOGS.items():
        if not (d / rel).is_file():
            continue
        print(f"[raster] {name}", file=sys.stderr, flush=True)
        scans = read_scans(d / rel)
        if maps and name in maps:
            fz = maps[name]
        elif maps_dir is not None and (maps_dir / f"{name}.json").is_file():
            fz = FuzzyBRepMap.load(maps_dir / f"{name}.json")
        else:
            cfg = BuildConfig()
            fz = fuzzify(build_map(scans, cfg).crisp, tme=cfg.tme)
        rows[name] = compare(fz, scans, resolution)
    return rows


def main(argv=None) -> int:
    from grid import SEARCHED, datasets

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--resolution", type=float, default=0.05)
    ap.add_argument("--maps", help="folder of NAME.json maps already built (default: build them)")
    ap.add_argument("--out", help="write the table here too")
    args = ap.parse_args(argv)
    d = datasets()
    if d is None:
        print(f"no folder holding carmen/ in any of {SEARCHED}: set FUZZYBREP_DATASETS", file=sys.stderr)
        return 2
    rows = run(d, args.resolution, maps_dir=Path(args.maps) if args.maps else None)
    text = table(rows) + "\n\n" + nav2_table(rows)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
