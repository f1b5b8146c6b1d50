"""fuzzybrep localise: where was the robot at every scan of a log, on a saved fuzzy map."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ._logopts import add_log_arguments, read_log, read_notes
from ._maps import add_map_argument
from ._types import finite, number, seed

#: ``--max-updates``: a whole number ≥ 1
updates_bound = number(lambda n: n >= 1, "--max-updates must be a whole number, got {text!r}",
                       "--max-updates must be ≥ 1, got {text}", cast=int)

NAME = "localise"
#: how far outside the map's free space a start may lie (map unit)
START_SLACK_M = 1.0

HELP = "localise every scan of a log on a saved fuzzy map (tracking from a start, or --global)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_map_argument(p)
    add_log_arguments(p)
    p.add_argument("--out", required=True, metavar="TRACK.csv",
                   help="the track: time,x,y,theta,confidence,status, one row per scan in scan order")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--start", type=finite, nargs=3, metavar=("X", "Y", "THETA"),
                   help="the first scan's pose on the map (THETA in radians; default: the log's first pose)")
    g.add_argument("--global", dest="global_search", action="store_true",
                   help="no start: search the map's free space (Monte Carlo localisation) until one pose "
                        "explains the scans, then track; says at which scan it converged, or that it did not")
    p.add_argument("--max-updates", type=updates_bound, default=None, metavar="N",
                   help="--global gives up (exit 2, nothing written) after N filter updates without converging; "
                        "the filter updates only after 0.2 m or 30° of odometry (default 100)")
    p.add_argument("--online", action="store_true",
                   help="the filter's poses as a robot would have them then (default: smoothed, each pose "
                        "also using the scans after it)")
    p.add_argument("--seed", type=seed, default=0, help="random seed of the particles and local searches (default 0)")
    p.add_argument("--plot", metavar="FIG", help="picture of the track over the map, coloured by confidence")
    p.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    p.epilog = ("Exit status 0: localised; 1: --global did not converge by the end of the log (the track is "
                "written, every pose the search's best guess with confidence 0); 2: bad input, or --global reached "
                "its bound of filter updates without converging (nothing written).")


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace

    import numpy as np
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from ..errors import LocalisationError, MapFileError, ScanValueError
    from ..formats.files import check_outputs
    from ..use.localise import CONFIG, STATUS_NAMES, TRACKED, localise
    from ..use.sensor_model import SensorModel
    from ._maps import load_map

    console = Console(stderr=True, quiet=args.quiet)
    check_outputs(args.out, args.plot, inputs=(args.map, args.log))  # before the work, not after it
    if args.plot:
        from ..plot import check_figure_path

        check_figure_path(args.plot)
    t0 = time.perf_counter()
    fuzzy = load_map(args)
    try:
        model = SensorModel.from_map(fuzzy)
    except ValueError as e:  # no obstacle edge: nothing a return could be matched to
        raise MapFileError(args.map, str(e)) from None
    scans, report = read_log(args)
    for line in read_notes(report):
        console.print(line, markup=False, highlight=False, soft_wrap=True)
    if args.start is not None:
        start = np.array(args.start, np.float64)
    else:
        start = None if args.global_search else scans[0].pose
    # a start a little outside the free space is a robot where the map saw nothing; one metres
    # away is a wrong --start or a log of another place, which tracking would only make worse
    if start is not None and model.free_space.distance(_point(start)) > START_SLACK_M:
        where = "--start" if args.start is not None else "the log's first pose"
        raise ScanValueError(args.log, None,
                             f"{where} ({start[0]:g}, {start[1]:g}) lies more than {START_SLACK_M:g} m outside "
                             f"the free space of the map {args.map}: give --start X Y THETA on the map, or "
                             f"--global to search for it")
    cfg = replace(CONFIG, smooth=not args.online, max_updates=args.max_updates or CONFIG.max_updates)
    t1 = time.perf_counter()
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                  TimeElapsedColumn(), console=console, transient=True,
                  disable=args.quiet or len(scans) < 200) as bar:
        task = bar.add_task("global search" if args.global_search else "tracking", total=len(scans))
        try:
            track = localise(model, scans, start=start, global_search=args.global_search, config=cfg, seed=args.seed,
                             progress=lambda done, total: bar.update(task, completed=done))
        except LocalisationError as e:  # the bound: nothing is written
            raise LocalisationError(f"{args.log}: {e}") from None
    t2 = time.perf_counter()
    nbytes = track.write_csv(args.out)
    if args.plot:
        from ..plot import save_track_figure

        truth = np.array([s.pose for s in scans]) if all(s.odometry is not None for s in scans) else None
        save_track_figure(args.plot, fuzzy.crisp, track.poses, track.confidence, track.status == TRACKED, truth,
                          title=f"{Path(args.log).name} on {Path(args.map).name}")
    for note in track.notes:
        console.print(f"note: {note}", markup=False, highlight=False, soft_wrap=True)
    counts = ", ".join(f"{int((track.status == k).sum())} {name}" for k, name in STATUS_NAMES.items()
                       if (track.status == k).any())
    k0 = track.converged_at if track.converged_at is not None else len(track)
    conf = float(track.confidence[k0:].mean()) if k0 < len(track) else 0.0
    console.print(f"[bold]{Path(args.log).name}[/bold]: {len(track)} scans ({counts}), mean confidence {conf:.3f}, "
                  f"range offset {track.offset:+.4f} {fuzzy.crisp.unit}, {nbytes} bytes -> {args.out}, "
                  f"{t2 - t1:.2f} s ({len(track) / max(t2 - t1, 1e-9):.0f} scans/s; "
                  f"{t1 - t0:.2f} s reading the map and the log)", soft_wrap=True)
    if args.global_search and track.converged_at is None:
        return 1  # the track was written, but the robot was not found: scripts must be able to tell
    return 0


def _point(pose):
    import shapely

    return shapely.Point(float(pose[0]), float(pose[1]))

