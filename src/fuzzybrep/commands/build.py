"""fuzzybrep build: scans in, map file (and picture) out."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from ._logopts import add_log_arguments, read_log, read_notes
from ._maps import DEFAULT_TME_M, add_mf_arguments, tme_from_args
from ._types import non_negative, number, positive

NAME = "build"
HELP = "build a map from a laser log (CARMEN, CSV scans or a ROS bag)"


# lines.LineConfig's rule, checked here so that a bad value is a usage error and not a traceback
_theta_step = number(lambda d: 0 < d <= 45, "{text!r} is not a number", "{text} must be in (0, 45] degrees")


def add_arguments(p) -> None:
    add_log_arguments(p)
    p.add_argument("--out", required=True, help="map file to write (JSON)")
    p.add_argument("--plot", help="picture of the map to write (PNG, SVG or PDF)")
    p.add_argument("--consolidate", action="store_true",
                   help="merge pairs of 180° scans taken at one spot facing opposite ways into 360° scans (thesis 5.2)")
    p.add_argument("--lines", choices=["hough", "iepf"], default="hough", help="line extractor (default: hough, thesis 3.2.1.1)")
    p.add_argument("--theta-step", type=_theta_step, default=1.0, help="Hough θ step in degrees (default 1)")
    p.add_argument("--max-usable", type=positive, default=8.0, help="longest range whose free space is trusted (default 8)")
    p.add_argument("--no-return-free", type=non_negative, default=0.0,
                   help="free range claimed along every beam with no return (default 0: only up to the segment "
                        "joining its neighbours' ends)")
    p.add_argument("--no-return-unknown", action="store_true",
                   help="beams with no return claim nothing, not even up to the segment joining the ends of the "
                        "beams either side that saw something")
    p.add_argument("--footprint", type=non_negative, default=0.3,
                   help="radius of the robot's footprint about the laser, free where the robot stood (m, default 0.3; "
                        "0: none)")
    p.add_argument("--no-evidence", action="store_true",
                   help="plain union of scan polygons, without clipping rays at obstacles other scans saw")
    p.add_argument("--no-clear", action="store_true", help="obstacles are never cleared by later free rays (static world)")
    p.add_argument("--min-hole-area", type=non_negative, help="drop holes of at most this area (map unit², default 0: only those simplification leaves without area)")
    p.add_argument("--simplify", type=non_negative, help="vertex reduction tolerance (map unit, default TME/4)")
    p.add_argument("--align", action="store_true",
                   help="the log's poses are odometry that drifts: align every scan to the map of the scans before it "
                        "and close loops (a pose graph) before mapping; the aligned poses and each scan's match quality "
                        "go into the map file. Uses the log's odometry only (its odom fields where it has them)")
    p.add_argument("--no-loops", action="store_true", help="with --align: no loop closure (scan-to-map alignment only)")
    p.add_argument("--strict", action="store_true",
                   help="with --align: an alignment that fails its check against the scans (returns in space another "
                        "pass saw free) is an error (exit status 2, no map written) instead of a warning")
    p.add_argument("--widen-tme", action="store_true",
                   help="with --align: add the aligned poses' own error (90th percentile of the per-scan σ, at least "
                        "2 cm) to TME, as the thesis adds the odometry's error to the laser's")
    p.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    add_mf_arguments(p, default_tme=DEFAULT_TME_M, unit="metres (build reads metric logs)")


def config_from_args(args):
    from ..mapping.build import BuildConfig

    cfg = BuildConfig()
    cfg = replace(
        cfg,
        beams=replace(cfg.beams, max_usable=args.max_usable, no_return_free=args.no_return_free,
                      no_return_chord=not args.no_return_unknown),
        polygon=replace(cfg.polygon, lines=replace(cfg.polygon.lines, method=args.lines, theta_step=args.theta_step),
                        footprint=args.footprint),
        evidence=replace(cfg.evidence, clear=not args.no_clear),
        use_evidence=not args.no_evidence,
        # the uncertainty the map carries also sets its vertex reduction (TME/4), as in evaluate;
        # before, --tme reached only the membership function
        tme=tme_from_args(args),
    )
    if args.min_hole_area is not None:
        cfg = replace(cfg, min_hole_area=args.min_hole_area)
    if args.simplify is not None:
        cfg = replace(cfg, simplify=args.simplify)
    if getattr(args, "align", False):
        from ..registration.align_scans import AlignConfig

        cfg = replace(cfg, align=AlignConfig(loop_closure=not args.no_loops, strict=args.strict))
    return cfg


class _Silent:
    """What --quiet shows: nothing. Stands in for rich's Console and Progress, whose import was
    30 ms of every quiet build (a build of a small log takes half a second)."""

    def print(self, *args, **kwargs) -> None:
        pass

    def add_task(self, *args, **kwargs) -> int:
        return 0

    def update(self, *args, **kwargs) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> bool:
        return False


def run(args) -> int:
    from ..formats.files import check_outputs
    from ..fuzzy.map import fuzzify
    from ..mapping.build import build_map
    from ..plot import check_figure_path, save_map_figure
    from ..scans.consolidate import consolidate_pairs
    from ._maps import mf_from_args

    if args.quiet:
        console = _Silent()
    else:
        from rich.console import Console

        console = Console(stderr=True)
    if (args.no_loops or args.widen_tme or args.strict) and not args.align:
        from ..errors import FuzzyBrepError

        flag = '--no-loops' if args.no_loops else '--widen-tme' if args.widen_tme else '--strict'
        raise FuzzyBrepError(f"{flag} needs --align")
    cfg = config_from_args(args)
    check_outputs(args.out, args.plot, inputs=(args.log,))  # before the work, not after it
    if args.plot:
        check_figure_path(args.plot)
    if args.frontier_mf is None:
        args.frontier_mf = args.mf  # frontier edges get their own FM index, same function until told otherwise
    mf, frontier_mf = mf_from_args(args)  # before: a bad --mf or --tme was found only once the map was built
    t0 = time.perf_counter()
    scans, report = read_log(args)
    if args.consolidate:
        scans, report.consolidated = consolidate_pairs(scans)
        if not report.consolidated:  # the summary counts pairs only when there are some: say it did nothing
            report.notes.append("--consolidate: no two consecutive scans were taken at one spot (within 5 cm) "
                                "facing opposite ways (180° ± 10°): the scans are used as they are")
    for line in read_notes(report):  # before: the bag's pose source was never shown, nor what was assumed
        console.print(line, markup=False, highlight=False, soft_wrap=True)

    if args.quiet:
        bar = _Silent()
    else:
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        bar = Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                       TimeElapsedColumn(), console=console, transient=True, disable=len(scans) < 200)
    with bar:
        task = bar.add_task("align" if cfg.align else "scan polygons", total=len(scans))
        result = build_map(scans, cfg, progress=lambda stage, done, total: bar.update(task, description=stage,
                                                                                     completed=done))
    scans = result.scans  # the aligned poses, with --align
    align_notes = []
    if result.alignment is not None:
        from ..registration.align_scans import pose_error

        al = result.alignment
        poor = al.poor()
        align_notes.append(f"--align: {len(scans)} scans aligned from odometry, {al.loops} loop closure(s); "
                           f"median match {100 * float(np.median(al.quality.inliers)):.0f} % of returns"
                           + (f"; {100 * float((al.loop_chi > 3).mean()):.1f} % of the loop edges disagree with the "
                              f"solved poses by over 3σ" if len(al.loop_chi) else ""))
        if al.calibration is not None and al.calibration.steps:
            align_notes.append(f"--align: {al.calibration.describe()}, taken out of every step")
        if al.check is not None:  # a failed check with --strict stopped the build already
            align_notes.insert(0, ("" if al.check.ok else "WARNING: ") + f"--align: {al.check.describe(scans)}")
        if len(poor):
            share = len(poor) / len(scans)
            align_notes.append(f"note: alignment poor for {len(poor)} scan(s) ({100 * share:.1f} %; first: "
                               f"{scans[int(poor[0])].source or f'scan {int(poor[0]) + 1}'}): under "
                               f"{100 * al.config.poor_inliers:.0f} % of the returns matched, or the position known "
                               f"only to more than {al.config.poor_sigma:g} {cfg.unit} (a featureless corridor); the map "
                               f"there is as good as the odometry" + ("" if args.widen_tme else "; --widen-tme widens TME"))
        if args.widen_tme:
            from ._maps import mf_from_args as _mf

            widen = pose_error(al)
            args.tme = cfg.tme + widen
            args.laser_error = args.odometry_error = None  # TME given as their sum, widened
            mf, frontier_mf = _mf(args)
            align_notes.append(f"--widen-tme: TME {cfg.tme:g} + {widen:.3f} (the aligned poses' error) = {args.tme:.3f} {cfg.unit}")
    for note in result.notes:  # what the build decided (the scans' order when their timestamps cannot give it)
        console.print(f"note: {note}", markup=False, highlight=False, soft_wrap=True)

    poses = np.array([[*s.pose, s.timestamp] for s in scans])
    meta = {
        "source": Path(args.log).name,
        "scans": len(scans),
        "line_extractor": args.lines,
        "built_with": "fuzzybrep",
    }
    if result.alignment is not None:
        meta["alignment"] = result.alignment.metadata()
    t_fuzzy = time.perf_counter()
    fuzzy = fuzzify(result.crisp, mf, frontier_mf=frontier_mf)
    result.timings["fuzzify"] = time.perf_counter() - t_fuzzy
    nbytes = fuzzy.save(args.out, poses=poses, metadata=meta)
    if args.plot:
        save_map_figure(args.plot, result.crisp, poses[:, :2], fuzzy=fuzzy,
                        title=f"{Path(args.log).name}: fuzzy B-rep map\n{mf.describe()}")  # two lines: a wide map's title fits
    seconds = time.perf_counter() - t0
    crisp = result.crisp
    pieces = len(crisp.regions) - 1
    console.print(
        f"[bold]{Path(args.log).name}[/bold]: {len(scans)} scans"
        + (f" ({report.consolidated} pairs consolidated)" if report.consolidated else "")
        + f", {crisp.n_vertices} vertices, {crisp.n_holes} holes"
        + (f", {pieces} detached piece(s) kept" if pieces else "")
        + f", free area {crisp.area:.1f} {crisp.unit}², {nbytes} bytes -> {args.out}"
        + f", {seconds:.2f} s ({len(scans) / seconds:.0f} scans/s)",
        soft_wrap=True,  # one line to grep in a log: rich wraps at 80 columns where stderr is no terminal
    )
    for line in align_notes:
        console.print(line, markup=False, highlight=False, soft_wrap=True)
    return 0
