"""Every measured figure of docs/*.md, written into its page between the page's markers.

    python benchmarks/docs.py [--docs docs] [--repeat 3] [--only grid,fuzzy,demo,simulator,export,viewer]

``make bench`` runs it through ``run.py --docs docs`` (which hands over the real-log maps it has
built); alone it builds the maps it needs. Each page's blocks (``BLOCKS``) are measured in this
run and written with ``blocks.write_block`` between ``<!-- benchmark:NAME:start -->`` and
``<!-- benchmark:NAME:end -->``:

grid.md       grid:example, grid:yaml   ``fuzzybrep grid`` on the Intel log: what it prints, the YAML
              grid:numbers              ``grid.py``'s table: sizes, free area, grid ÷ read, naive ÷ grid
fuzzy.md      fuzzy:alpha-cut           ``alpha_cut.py`` on the synthetic jagged and clean floors
              fuzzy:exact-cut           ``exact_cut.py`` on the Intel and Freiburg maps and the jagged floor
demo.md       demo:poses                seed 0's scan pose errors under each pose model
              demo:seeds                UMBmark, TME and pose errors over seeds 0-9
              demo:bridge               the filtered map with and without evidence.no_return_bridge
              demo:room                 the demo on the page's own example floor plan
simulator.md  simulator:floor           the built-in floor's areas and lengths, the route's stops
              simulator:drift           odometry drift at the end of the route, per robot, seeds 0-4
export.md     export:yaml, export:free-area   ``export --ros`` of the Intel map
              export:classes, export:nav2     ``raster_classes.py``: free/occupied/unknown against the
                                              grid, and the raster's areas against the map's, every log
viewer.md     viewer:intel              the page's α-cut construction against alpha_cut on the Intel map
pose_graph.md pose_graph:results        ``pose_graph.py``: false loop closures each pose-graph back end survives

Speed is given as ratios against a baseline timed in the same run; absolute seconds only where a
block says they are the measuring machine's.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import os
import re
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import shapely

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "src"))

from blocks import demote_headings, write_block  # noqa: E402
from grid import LOGS, SEARCHED, datasets  # noqa: E402

#: page -> its blocks, in the order they appear
PAGES = {
    "grid.md": ("grid:example", "grid:yaml", "grid:numbers"),
    "fuzzy.md": ("fuzzy:alpha-cut", "fuzzy:exact-cut"),
    "demo.md": ("demo:poses", "demo:seeds", "demo:bridge", "demo:room"),
    "simulator.md": ("simulator:floor", "simulator:drift"),
    "export.md": ("export:yaml", "export:classes", "export:free-area", "export:nav2"),
    "viewer.md": ("viewer:intel",),
    "localise.md": ("localise:results",),
    "align.md": ("align:results",),
    "slam.md": ("slam:results",),
    "pose_graph.md": ("pose_graph:results",),
}
#: every (page, block) this script writes; tests/test_docblocks.py checks the pages hold exactly these
BLOCKS = [(page, name) for page, names in PAGES.items() for name in names]

SEEDS = range(10)  # the demo's seeds, as run.py's demo table
DRIFT_SEEDS = range(5)


def stamp(timed: bool) -> str:
    """The line that opens a block: who wrote it, when, and (for timings) on what."""
    when = time.strftime("%Y-%m-%d")
    if not timed:
        return f"*Written by `python benchmarks/docs.py` (`make bench`) on {when}.*"
    return (f"*Measured by `python benchmarks/docs.py` (`make bench`) on {when}, {os.cpu_count()} cores. Absolute "
            "times are that machine's under its load; ratios are against a baseline timed in the same run.*")


def pct(x: float, digits: int = 1) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{100 * x:.{digits}f} %"


class Context:
    """What the pages share: the datasets, the timing repeat, and the real-log maps (built once)."""

    def __init__(self, d: Path | None, repeat: int, maps: dict | None = None, demo_runs: list | None = None):
        self.d, self.repeat, self.maps, self.runs = d, repeat, dict(maps or {}), demo_runs

    def demo_runs(self) -> list:
        """The built-in demo for every seed of SEEDS (run.py's, when it gives them)."""
        if self.runs is None:
            from fuzzybrep.sim import demo
            from fuzzybrep.sim.world import builtin_floor, builtin_route

            self.runs = [demo.run_demo(builtin_floor(), builtin_route(), seed=s) for s in SEEDS]
        return self.runs

    def map(self, name: str):
        """The fuzzy map of a CARMEN log as ``fuzzybrep build`` makes it (default settings)."""
        if name not in self.maps:
            from fuzzybrep.mapping.build import BuildConfig, build_map
            from fuzzybrep.fuzzy.map import fuzzify
            from fuzzybrep.scans.read import read_scans

            if self.d is None or not (self.d / LOGS[name]).is_file():
                raise FileNotFoundError(f"no {LOGS[name]} in any of {SEARCHED}")
            cfg = BuildConfig()
            self.maps[name] = fuzzify(build_map(read_scans(self.d / LOGS[name]), cfg).crisp, tme=cfg.tme)
        return self.maps[name]


# ------------------------------------------------------------------------------------ grid.md


def grid_blocks(ctx: Context) -> dict[str, str]:
    import grid

    printed, yaml = grid.example(ctx.d)
    return {"grid:example": f"```\n{printed}\n```",
            "grid:yaml": f"```yaml\n{yaml}\n```",
            "grid:numbers": grid.table(ctx.d, repeat=ctx.repeat)}  # its first line says the times are this machine's


# ----------------------------------------------------------------------------------- fuzzy.md


def fuzzy_blocks(ctx: Context) -> dict[str, str]:
    import alpha_cut
    import exact_cut
    from fuzzybrep.fuzzy.map import fuzzify

    alphas = [0.0, 0.25, 0.5, 0.75, 1.0]
    floors = {j: fuzzify(alpha_cut.synthetic_map(0, jagged=j)) for j in (True, False)}
    parts = [stamp(True)]
    for jagged, fz in floors.items():
        label = f"synthetic floor, {'jagged' if jagged else 'clean'} (seed 0)"
        parts.append(demote_headings(alpha_cut.run(fz, alphas, ctx.repeat, label)))
    maps = [(f"{name} map", ctx.map(name)) for name in ("intel", "freiburg-079")]
    maps.append(("synthetic floor, jagged (seed 0)", floors[True]))
    exact = demote_headings(exact_cut.run(maps, [0.0, 0.5], ctx.repeat))
    return {"fuzzy:alpha-cut": "\n\n".join(parts), "fuzzy:exact-cut": stamp(True) + "\n\n" + exact}


# ------------------------------------------------------------------------------------ demo.md


def demo_blocks(ctx: Context, page: Path) -> dict[str, str]:
    from fuzzybrep.sim import demo
    from fuzzybrep.sim.pose_error import MODELS, pose_errors, scan_poses
    from fuzzybrep.sim.truth import length_inside
    from fuzzybrep.sim.world import Route, World

    runs = ctx.demo_runs()

    # seed 0's scans under each pose model
    r0 = runs[0]
    rows = ["| seed 0 | position error max / mean | heading error max / mean | returns within TME |", "|---|---|---|---|"]
    for model in MODELS:
        e = pose_errors(r0.run.scans, scan_poses(r0.run, model), r0.run.true_poses).summary(
            r0.odometry_error_mm / 1000, r0.tme_m)
        p, h = e["position_error_m"], e["heading_error_deg"]
        dist = (lambda v: f"{v * 1000:.0f} mm") if p["max"] < 1 else (lambda v: f"{v:.1f} m")
        rows.append(f"| `{model}` | {dist(p['max'])} / {dist(p['mean'])} | {h['max']:.2f}° / {h['mean']:.2f}° | "
                    f"{pct(e['returns_within_tme'])} |")
    poses = stamp(False) + "\n\n" + "\n".join(rows)

    # UMBmark, TME and the re-localised pose errors, seed by seed
    rows = ["| seed | UMBmark odometry error | TME | UMBmark β | β over a 5 m leg, at 8 m | largest scan position "
            "error | below the odometry error | largest heading error | returns within TME | worst return error |",
            "|---:|---:|---:|---:|---:|---:|:---:|---:|---:|---:|"]
    below = 0
    for r in runs:
        e = r.errors.summary(r.odometry_error_mm / 1000, r.tme_m)
        ok = e["position_error_within_odometry_error"]
        below += ok
        beta = abs(r.umbmark.beta_deg)
        rows.append(f"| {r.seed} | {r.odometry_error_mm:.1f} mm | {r.tme_mm:.1f} mm | {beta:.2f}° | "
                    f"{8 * math.radians(beta * 5 / 4) * 100:.0f} cm | {e['position_error_m']['max'] * 1000:.0f} mm | "
                    f"{'yes' if ok else 'no'} | {e['heading_error_deg']['max']:.2f}° | {pct(e['returns_within_tme'])} | "
                    f"{e['point_error_m']['max']:.2f} m |")
    seeds = "\n".join([stamp(False), "",
                       f"The re-localised scan position error stays below the UMBmark odometry error on {below} of "
                       f"{len(runs)} seeds.", "", *rows])

    # the filtered map with and without the no-return bridge (exact α-cut)
    rows = ["| seed | bridge on: seen wall in support | bridge on: glass in safe region | bridge off: seen wall in support "
            "| bridge off: glass in safe region | bridge off: boundary within TME |",
            "|---:|---:|---:|---:|---:|---:|"]
    swallowed = 0
    for r in runs:
        f = r.maps["filtered"]
        off_cfg = replace(f.config, evidence=replace(f.config.evidence, no_return_bridge=0.0))
        off = demo.build_and_score("filtered", r.scans, off_cfg, r.tme_m, r.world, r.seen)
        glass = [length_inside(r.world.glass_walls, m.support["exact"].inner) for m in (f, off)]
        swallowed += glass[1] > 0
        rows.append(f"| {r.seed} | {pct(f.truth['exact'].support_coverage, 2)} | {glass[0]:.2f} m | "
                    f"{pct(off.truth['exact'].support_coverage, 2)} | {glass[1]:.2f} m | "
                    f"{pct(off.truth['exact'].boundary_within_tme)} |")
    bridge = "\n".join([stamp(False), "",
                        f"Without the bridge (`evidence.no_return_bridge = 0`) glass lies inside the exact safe region "
                        f"on {swallowed} of {len(runs)} seeds.", "", *rows])

    # the page's own example floor plan
    example = re.search(r"## Your own floor plan.*?```json\n(.*?)```", page.read_text(), re.S)
    if example is None:
        raise ValueError(f"{page}: no ```json floor plan under 'Your own floor plan'")
    with tempfile.TemporaryDirectory() as tmp:
        world_file = Path(tmp) / "room.geojson"
        world_file.write_text(example.group(1))
        world, route = World.from_geojson(world_file), Route.from_file(world_file)
    rr = demo.run_demo(world, route, seed=0, world_source="room.geojson")
    rows = ["| map | α-cut | seen wall in support | wall in safe region | boundary within TME | all three |",
            "|---|---|---:|---:|---:|:---:|"]
    for name in demo.BUILDS:
        for method in demo.ALPHA_METHODS:
            m, t = rr.maps[name], rr.maps[name].truth[method]
            rows.append(f"| {name} | {method} | {pct(t.support_coverage)} | {t.unsafe_wall_length:.2f} m | "
                        f"{pct(t.boundary_within_tme)} | {'yes' if m.passes(method) else 'no'} |")
    room = "\n".join([stamp(False), "", f"The example (seed 0): {len(rr.scans)} scans over {rr.route.length:.0f} m.",
                      "", *rows])
    return {"demo:poses": poses, "demo:seeds": seeds, "demo:bridge": bridge, "demo:room": room}


# ------------------------------------------------------------------------------- simulator.md


def simulator_blocks(ctx: Context) -> dict[str, str]:
    from fuzzybrep.sim.simulate import DiffDrive, Laser, simulate_run
    from fuzzybrep.sim.world import builtin_floor, builtin_route

    world, route = builtin_floor(), builtin_route()
    stops = route.stop_distances()
    skipped = stops[-1] + route.spacing
    floor = (f"{stamp(False)}\n\nThe free space is {world.free.area:.1f} m², and its outer boundary encloses "
             f"{shapely.Polygon(world.free.exterior).area:.0f} m². Its walls are {world.walls.length:.1f} m long, "
             f"{world.glass_walls.length:.0f} m of them glass. The route is {'closed' if route.closed else 'open'} and "
             f"{route.length:.0f} m long. With a stop every {route.spacing:g} m it makes **{len(stops)} stops** "
             f"({stops[0]:g}, {stops[1]:g}, …, {stops[-1]:g} m; a stop at {skipped:g} m would be "
             f"{route.length - skipped:g} m from home and repeat the first), so {2 * len(stops)} scans.")
    robots = [("ideal (`DiffDrive()`)", DiffDrive()),
              ("slip only (`DiffDrive(slip=0.0005)`)", DiffDrive(slip=0.0005)),
              ("Table I.2, calibrated (the default)", DiffDrive.pioneer_3dx()),
              ("Table I.1, before calibration", DiffDrive.pioneer_3dx(calibrated=False))]
    rows = [f"| robot | final position error, mean (min to max) over seeds {DRIFT_SEEDS[0]}–{DRIFT_SEEDS[-1]} | "
            "final heading error, mean (min to max) |", "|---|---|---|"]
    for label, robot in robots:
        drift = np.array([simulate_run(world, route, Laser(), robot, seed=s).final_drift for s in DRIFT_SEEDS])
        pos, head = drift[:, 0], np.degrees(drift[:, 1])
        if pos.max() == 0 and not head.any():
            rows.append(f"| {label} | 0 | 0 |")
            continue
        deg = lambda v: f"{v:+.1f}°".replace("-", "−")  # noqa: E731
        rows.append(f"| {label} | {pos.mean():.2f} m ({pos.min():.2f} to {pos.max():.2f}) | "
                    f"{deg(head.mean())} ({deg(head.min())} to {deg(head.max())}) |")
    return {"simulator:floor": floor, "simulator:drift": stamp(False) + "\n\n" + "\n".join(rows)}


# ---------------------------------------------------------------------------------- export.md


def export_blocks(ctx: Context) -> dict[str, str]:
    from fuzzybrep.formats.export import membership_raster, write_ros

    fz = ctx.map("intel")
    r = membership_raster(fz, 0.05, "exact")
    with tempfile.TemporaryDirectory() as tmp:
        yaml_path, _ = write_ros(tmp, "intel", r)
        yaml = Path(yaml_path).read_text().rstrip()
    crisp = fz.crisp_geometry.area
    free = r.free_area()
    area = (f"{stamp(False)}\n\nOn the Intel map at 0.05 m: {free:.2f} m² of free cells against the crisp map's "
            f"{crisp:.2f} m², {pct(abs(free - crisp) / crisp, 3)} apart.")
    import raster_classes

    rows = raster_classes.run(ctx.d, 0.05, maps={k: v for k, v in ctx.maps.items()})
    return {"export:yaml": f"```yaml\n{yaml}\n```", "export:free-area": area,
            "export:classes": f"{stamp(False)}\n\n{raster_classes.table(rows)}",
            "export:nav2": f"{stamp(False)}\n\n{raster_classes.nav2_table(rows)}"}


# ---------------------------------------------------------------------------------- viewer.md


def viewer_blocks(ctx: Context) -> dict[str, str]:
    from fuzzybrep.viewer import swept_cut

    fz = ctx.map("intel")
    parts = []
    for alpha in (0.0, 0.5):
        cut = fz.alpha_cut(alpha)
        inner, outer = swept_cut(fz, alpha)
        band = cut.outer.area - cut.inner.area
        d = max(shapely.symmetric_difference(inner, cut.inner).area, shapely.symmetric_difference(outer, cut.outer).area)
        parts.append(f"{d / band:.1e} at α = {alpha:g}")
    return {"viewer:intel": "On the Intel lab map the symmetric difference, inner or outer whichever is larger, is "
                            f"{' and '.join(parts)} of the band's area (written by `benchmarks/docs.py`, `make bench`)."}


# ----------------------------------------------------------------------------------------- run

def localise_blocks(ctx: Context) -> dict[str, str]:
    """docs/localise.md: tracking, the odometry baseline and global localisation on every log
    (benchmarks/localise.py; its maps are from the even scans, so none of run.py's is reused)."""
    import localise

    return {"localise:results": localise.markdown(localise.bench(ctx.d, ctx.repeat), ctx.repeat)}


def align_blocks(ctx: Context) -> dict[str, str]:
    """docs/align.md: ``build --align`` on every shared log with drifting odometry (benchmarks/align.py),
    the maps' pictures in out/align/."""
    import align

    md, _ = align.run(ctx.d, ctx.repeat, plots=HERE.parent / "out" / "align")
    return {"align:results": stamp(True) + "\n\n" + md}


def slam_blocks(ctx: Context) -> dict[str, str]:
    """docs/slam.md: ``build --align`` on the raw logs and the ACES bag, scored on the benchmark's
    relations (benchmarks/slam.py), the maps' pictures in out/slam/."""
    import slam

    return {"slam:results": stamp(True) + "\n\n" + slam.run(ctx.d, plots=HERE.parent / "out" / "slam")}


def pose_graph_blocks(ctx: Context) -> dict[str, str]:
    """docs/pose_graph.md: the pose-graph back ends against false loop closures (benchmarks/pose_graph.py)."""
    import pose_graph

    md, _ = pose_graph.run(ctx.d, ctx.repeat)
    return {"pose_graph:results": stamp(True) + "\n\n" + md}


MAKERS = {"grid.md": grid_blocks, "fuzzy.md": fuzzy_blocks, "demo.md": demo_blocks,
          "simulator.md": simulator_blocks, "export.md": export_blocks, "viewer.md": viewer_blocks,
          "localise.md": localise_blocks, "align.md": align_blocks,
          "slam.md": slam_blocks, "pose_graph.md": pose_graph_blocks}
NEEDS_LOGS = {"grid.md", "fuzzy.md", "export.md", "viewer.md", "localise.md", "align.md", "slam.md", "pose_graph.md"}


def run(docs: Path, repeat: int = 3, maps: dict | None = None, only: list[str] | None = None,
        d: Path | None = None, demo_runs: list | None = None) -> dict[str, float]:
    """Measure and write the blocks of every page (or of ``only``, page names without .md). Returns
    the seconds each page took. ``maps`` and ``demo_runs``: what run.py already built, not built again."""
    ctx = Context(d if d is not None else datasets(), repeat, maps, demo_runs)
    seconds = {}
    for page in PAGES:
        make = MAKERS[page]
        if only and page.removesuffix(".md") not in only:
            continue
        if page in NEEDS_LOGS and ctx.d is None:
            print(f"[docs] {page}: no CARMEN logs in any of {SEARCHED}; its blocks are left as they are",
                  file=sys.stderr)
            continue
        print(f"[docs] {page}", file=sys.stderr, flush=True)
        t = time.perf_counter()
        with contextlib.redirect_stdout(io.StringIO()):  # the scripts' progress lines go to stderr already
            blocks = make(ctx, docs / page) if page == "demo.md" else make(ctx)
        if set(blocks) != set(PAGES[page]):
            raise RuntimeError(f"{page}: made {sorted(blocks)}, the page lists {PAGES[page]}")
        for name in PAGES[page]:
            write_block(docs / page, name, blocks[name])
        seconds[page] = time.perf_counter() - t
        print(f"[docs] {page}: {seconds[page]:.1f} s", file=sys.stderr, flush=True)
    return seconds


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--docs", default=str(HERE.parent / "docs"), help="folder of the pages (default: docs/)")
    ap.add_argument("--repeat", type=int, default=3, help="timings per measurement")
    ap.add_argument("--only", help="comma-separated pages without .md, e.g. grid,demo")
    ap.add_argument("--datasets", help="folder holding carmen/ (default as run.py)")
    args = ap.parse_args(argv)
    only = args.only.split(",") if args.only else None
    if only and (bad := set(only) - {p.removesuffix(".md") for p in PAGES}):
        ap.error(f"unknown page(s) {', '.join(sorted(bad))}")
    run(Path(args.docs), args.repeat, only=only, d=Path(args.datasets) if args.datasets else None)
    return 0


if __name__ == "__main__":
    sys.exit(main())
