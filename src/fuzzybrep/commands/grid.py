"""fuzzybrep grid: scans in, occupancy grid out as a ROS map_server map (PGM + YAML)."""

from __future__ import annotations

import time
from pathlib import Path

from ._logopts import add_log_arguments, read_log, read_notes
from ._types import file_name, non_negative, positive

NAME = "grid"
HELP = "build a log-odds occupancy grid (the baseline) and write it as a ROS map (PGM + YAML)"


def add_arguments(p) -> None:
    add_log_arguments(p)
    p.add_argument("--out", required=True, help="folder to write NAME.pgm and NAME.yaml into")
    p.add_argument("--name", type=file_name, default=None,
                   help="file name stem (default: the log's name without its extensions, as export names its files "
                        "after the map's: intel-corrected.log.gz gives intel-corrected.pgm and .yaml)")
    p.add_argument("--resolution", type=positive, default=0.05, help="cell side in metres (default 0.05)")
    p.add_argument("--max-usable", type=positive, default=8.0,
                   help="longest range whose free space and hit are trusted; farther returns mark free space up to it (default 8)")
    p.add_argument("--no-return-free", type=non_negative, default=0.0,
                   help="free range claimed along beams with no return (default 0: they mark nothing)")
    p.add_argument("--quiet", action="store_true", help="no summary")


def check_grid_size(log, scans, resolution: float, max_usable: float, no_return_free: float = 0.0) -> None:
    """ScanValueError before the work if an occupancy grid of ``scans`` at ``resolution`` would be
    too large to hold: a too fine resolution otherwise ends in NumPy failing to allocate petabytes.

    The limit is the one ``export --ros`` keeps to. The scan positions' box widened by the longest
    beam holds every traced beam; only when that box is over the limit are the beams traced ends
    looked at, so that a grid which fits is never refused."""
    import numpy as np

    from ..arrays import cell_count_text
    from ..errors import ScanValueError
    from ..formats.rosmap import MAX_CELLS
    from ..mapping.build import farthest_out
    from ..mapping.grid import beams_of, lattice

    xy = np.array([s.pose[:2] for s in scans])
    reach = max(max_usable, no_return_free)
    _, _, nx, ny = lattice(*(xy.min(axis=0) - reach), *(xy.max(axis=0) + reach), resolution)
    if nx * ny <= MAX_CELLS:
        return
    b = beams_of(scans, max_usable, no_return_free)
    if len(b.length):
        x, y = np.concatenate((b.ox, b.ex)), np.concatenate((b.oy, b.ey))
        _, _, nx, ny = lattice(x.min(), y.min(), x.max(), y.max(), resolution)
    if nx * ny > MAX_CELLS:
        # a corrupt range or pose makes a grid as large as a too fine resolution does: name what lies farthest out
        what, d, source = farthest_out(scans, np.median(xy, axis=0))
        raise ScanValueError(log, None, f"a grid at resolution {resolution:g} over these scans would have "
                                        f"{cell_count_text(nx)} × {cell_count_text(ny)} cells (limit {MAX_CELLS}): give a "
                                        f"coarser --resolution; the farthest out is {what} in {source}, {d:.3g} m from the "
                                        f"median scan position (is its range or pose corrupt, or the log not in metres?)")


def log_stem(log) -> str:
    """A log's name without its extensions: intel-corrected.log.gz -> intel-corrected, run.bag -> run,
    a bag folder -> its name; "map" if nothing is left."""
    path = Path(log)
    name = path.parent.name if path.name == "metadata.yaml" else path.name  # a ROS 2 bag's folder
    for ext in (".gz", ".log", ".clf", ".txt", ".csv", ".bag", ".db3", ".mcap", ".yaml"):
        if name.lower().endswith(ext) and len(name) > len(ext):
            name = name[: -len(ext)]
    return name or "map"


def run(args) -> int:
    from ..formats.files import check_outputs
    from ..formats.rosmap import write_grid
    from ..mapping.grid import occupancy_grid

    if args.name is None:
        args.name = log_stem(args.log)
    check_outputs(*(Path(args.out) / f"{args.name}.{ext}" for ext in ("yaml", "pgm")), inputs=(args.log,))
    t0 = time.perf_counter()
    scans, report = read_log(args)
    t1 = time.perf_counter()
    check_grid_size(args.log, scans, args.resolution, args.max_usable, args.no_return_free)
    grid = occupancy_grid(scans, resolution=args.resolution, max_usable=args.max_usable,
                          no_return_free=args.no_return_free)
    t2 = time.perf_counter()
    yaml_path, pgm_path = write_grid(Path(args.out) / f"{args.name}.yaml", grid,
                                     comment=f"fuzzybrep grid {Path(args.log).name}, {args.resolution:g} m/pix")
    if not args.quiet:
        for line in read_notes(report):
            print(line)
        ny, nx = grid.shape
        print(f"{Path(args.log).name}: {len(scans)} scans -> {nx} x {ny} = {grid.cells} cells at {grid.resolution:g} m, "
              f"{grid.nbytes(4)} bytes at 4 B/cell ({pgm_path.stat().st_size} bytes of PGM), "
              f"free area {grid.free_area():.1f} m², occupied {int(grid.occupied().sum())} cells; "
              f"read {t1 - t0:.2f} s, grid {t2 - t1:.2f} s -> {yaml_path}, {pgm_path}")
    return 0
