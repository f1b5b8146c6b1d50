"""The thesis's chapter 5 experiment end to end, on a simulated floor, checked against the truth.

    run       = drive the route with the Pioneer 3-DX and its LMS200 (``simulate``)
    umbmark   = the 5 + 5 square runs of Appendix I with the same robot; odometry error = max r_cg
    tme       = 15 mm laser error + odometry error (thesis 4.1.1)
    poses     = the pose the map uses for every scan (``localise``; re-localised at each stop)
    scans     = the two 180° scans of each stop consolidated into one 360° scan (thesis 5.2)
    maps      = crisp map, fuzzified with TME, built twice: glass spikes filtered and unfiltered
    truth     = each map scored against the floor plan (``truth``), memory against grids (Table 5.3)

``run_demo`` reads like that list. ``report`` turns a result into the JSON of ``report.json``,
``summary`` into the lines ``fuzzybrep demo`` prints. Metres throughout, except the UMBmark and
TME figures, which keep the thesis's millimetres (keys ending in ``_mm``).
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, replace

import numpy as np
import shapely

from ..fuzzy.map import AlphaCut, FuzzyBRepMap, fuzzify
from ..mapping.build import BuildConfig, BuildResult, build_map
from .pose_error import MODELS, PoseErrors, pose_errors, scan_poses, with_poses
from .simulate import DiffDrive, Laser, Route, SimRun, World, consolidate, simulate_run, umbmark_runs
from .truth import TruthScore, score_cuts, seen_walls
from .umbmark import SIDE_MM, UMBmarkResult, total_maximum_error, umbmark

#: the LMS200's systematic error in mm-mode (Table 5.1; thesis 4.1.1)
LRF_ERROR_MM = 15.0
#: the thesis's TME (Appendix I, Table 5.2), for comparison with the simulated robot's
THESIS_TME_MM = 199.13
#: Table 5.3's occupancy-grid cells (m)
GRID_CELLS = (0.3, 0.2, 0.1)
#: the Done-when criteria: share of the seen wall inside the support band, wall length inside the
#: safe region (α = 0), share of the crisp boundary within TME of a wall
MIN_SUPPORT_COVERAGE = 0.99
MAX_UNSAFE_WALL_M = 0.0
MIN_BOUNDARY_WITHIN_TME = 0.90
ALPHA_METHODS = ("safe", "exact", "thesis")
#: the methods the summary prints: the map's own (default) α-cut and the exact one it must stay
#: within; the thesis's sweep, which does not (docs/fuzzy.md), is in the report only
SUMMARY_METHODS = ("safe", "exact")
BUILDS = ("filtered", "unfiltered")


# ----------------------------------------------------------------------------- configuration


def no_return_reach(route: Route) -> float:
    """How far a beam with no return is taken to be free: half the longest gap between stops + 0.5 m.

    A beam that returns nothing crossed free space, unless it went through glass. Along a corridor
    the beams within a few degrees of its axis return nothing (the far end is beyond 8 m); if they
    claim nothing, every stretch between two stops keeps a diamond of unknown space on its axis,
    a hole in the map. Claiming half the gap closes it from both sides; claiming no more keeps
    short the needles that beams through glass draw, and evidence (``no_return_bridge``) stops
    them at the pane.
    """
    s = route.stop_distances()
    gaps = np.diff(np.r_[s, route.length if route.closed else s[-1]])
    gap = float(gaps.max()) if len(gaps) and gaps.max() > 0 else route.spacing
    return min(gap / 2 + 0.5, Laser.max_range)


def build_config(route: Route, filtered: bool = True) -> BuildConfig:
    """The crisp pipeline's settings for simulated LMS200 scans (metres).

    filtered    the spike filter cuts back groups of up to 12 beams reaching 0.5 m beyond both
                neighbours (glass, and doorways seen from afar); evidence clips every ray at
                obstacles other scans saw, never clearing them (the simulated world is static),
                and every no-return beam also where it crosses between two obstacle cells
                less than 1 m apart (a pane between its sparse returns; evidence.bridged).
    unfiltered  neither: a plain union of scan polygons, glass spikes and all (thesis Figure 5.8).

    Both trust returns up to the LMS200's 8 m and let no-return beams claim ``no_return_reach``.
    """
    base = BuildConfig()
    # the simulated glass lets beams through or mirrors them one by one, so the runs of beams
    # past a pane are wider than any gap a real scan shows: openings up to 1 m count as spikes,
    # and a mirror's phantom wall 0.2 m behind the pane is already beyond the map's uncertainty
    beams = replace(base.beams, max_usable=Laser.max_range, no_return_free=no_return_reach(route),
                    spike_width=base.beams.spike_width if filtered else 0, min_gap=1.0, spike_jump=0.2)
    return replace(base, beams=beams, evidence=replace(base.evidence, clear=False), use_evidence=filtered)


# ------------------------------------------------------------------------------------ results


@dataclass
class MapResult:
    """One build of the map: crisp and fuzzy, its α = 0 cuts by both methods, scored."""

    name: str
    config: BuildConfig
    build: BuildResult
    fuzzy: FuzzyBRepMap
    support: dict[str, AlphaCut]  # α = 0 cut per method
    truth: dict[str, TruthScore]  # per method
    seconds: float

    def criteria(self, method: str) -> dict[str, bool]:
        t = self.truth[method]
        return {
            "support_coverage": t.support_coverage >= MIN_SUPPORT_COVERAGE,
            "unsafe_wall_length": t.unsafe_wall_length <= MAX_UNSAFE_WALL_M,
            "boundary_within_tme": t.boundary_within_tme >= MIN_BOUNDARY_WITHIN_TME,
        }

    def passes(self, method: str) -> bool:
        return all(self.criteria(method).values())


@dataclass
class DemoResult:
    world: World
    route: Route
    run: SimRun
    robot: DiffDrive
    umbmark_runs: tuple[np.ndarray, np.ndarray]
    umbmark: UMBmarkResult
    tme_m: float
    pose_model: str
    poses: np.ndarray  # (S, 3) the pose the map used for each 180° scan
    errors: PoseErrors
    scans: list  # consolidated 360° scans at the poses the map used
    seen: shapely.MultiLineString  # the wall the robot saw (``seen_walls`` from the true poses)
    maps: dict[str, MapResult]
    seed: int
    world_source: str
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def odometry_error_mm(self) -> float:
        return self.umbmark.E_max_syst

    @property
    def tme_mm(self) -> float:
        return total_maximum_error(self.odometry_error_mm, LRF_ERROR_MM)

    @property
    def seconds(self) -> float:
        return sum(self.timings.values())


class _Timer:
    def __init__(self, out: dict[str, float]):
        self.out = out

    @contextmanager
    def __call__(self, name: str):
        t0 = time.perf_counter()
        yield
        self.out[name] = self.out.get(name, 0.0) + time.perf_counter() - t0


# ----------------------------------------------------------------------------------- the demo


def run_demo(world: World, route: Route, seed: int = 0, pose_model: str = "relocalised",
             world_source: str = "built-in") -> DemoResult:
    """Simulate, calibrate, map and score: the thesis's chapter 5 on ``world`` (see module doc)."""
    if pose_model not in MODELS:
        raise ValueError(f"pose model must be one of {', '.join(MODELS)}, got {pose_model!r}")
    timings: dict[str, float] = {}
    timer = _Timer(timings)
    robot = DiffDrive.pioneer_3dx(calibrated=True)
    with timer("simulate"):
        run = simulate_run(world, route, Laser(), robot, seed=seed)
        seen = seen_walls(world, run.true_poses)  # the truth every build is scored against
    with timer("umbmark"):
        runs = umbmark_runs(robot, SIDE_MM, seed=seed)
        um = umbmark(*runs, side=SIDE_MM)
        tme = total_maximum_error(um.E_max_syst, LRF_ERROR_MM) / 1000.0
    with timer("poses"):
        poses = scan_poses(run, pose_model)
        placed = with_poses(run.scans, poses)
        errors = pose_errors(run.scans, poses, run.true_poses)
        scans = [consolidate(a, b) for a, b in zip(placed[::2], placed[1::2])]
    maps = {}
    for name in BUILDS:
        with timer(f"map ({name})"):
            maps[name] = build_and_score(name, scans, build_config(route, name == "filtered"), tme, world, seen)
    return DemoResult(world, route, run, robot, runs, um, tme, pose_model, poses, errors, scans, seen, maps, seed,
                      world_source, timings)


def build_and_score(name: str, scans, config: BuildConfig, tme: float, world: World,
                    seen: shapely.MultiLineString) -> MapResult:
    """Crisp map, fuzzy map with TME, both α = 0 cuts, and their scores against the world."""
    t0 = time.perf_counter()
    built = build_map(scans, config)
    fz = fuzzify(built.crisp, tme=tme)
    support = {m: fz.alpha_cut(0.0, m) for m in ALPHA_METHODS}
    scores = score_cuts(world, seen, fz.crisp_geometry, [(c.band, c.inner) for c in support.values()], tme)
    return MapResult(name, config, built, fz, support, dict(zip(support, scores)), time.perf_counter() - t0)


# ------------------------------------------------------------------------------------- report


def memory_rows(fz: FuzzyBRepMap) -> list[dict]:
    """Table 5.3 for a map: thesis accounting, compact, grids over its area and its bounding box."""
    rows = fz.memory(GRID_CELLS)
    ref = rows[0].bytes
    return [{"representation": r.representation, "numbers": r.numbers, "bytes": r.bytes,
             "times_fuzzy_brep": round(r.bytes / ref, 3)} for r in rows]


def map_report(m: MapResult) -> dict:
    crisp = m.fuzzy.crisp
    rows = memory_rows(m.fuzzy)
    by_cell = {f"grid_{round(c * 100)}cm_bytes": rows[2 + k]["bytes"] for k, c in enumerate(GRID_CELLS)}
    by_cell_bbox = {f"grid_{round(c * 100)}cm_bbox_bytes": rows[2 + len(GRID_CELLS) + k]["bytes"]
                    for k, c in enumerate(GRID_CELLS)}
    truth = {}
    for method, t in m.truth.items():
        truth[method] = {
            "seen_wall_length_m": t.seen_wall_length,
            "support_coverage": t.support_coverage,
            "unsafe_wall_length_m": t.unsafe_wall_length,
            "boundary_within_tme": t.boundary_within_tme,
            "criteria": m.criteria(method),
            "passes": m.passes(method),
        }
    return {
        "vertices": crisp.n_vertices,
        "principal_vertices": len(crisp.principal),
        "holes": crisp.n_holes,
        "hole_vertices": int(sum(len(h) for h in crisp.holes)),
        "detached_pieces": len(crisp.regions) - 1,
        "free_area_m2": float(crisp.area),
        "support_area_m2": float(m.support["safe"].band.area),
        "hausdorff_m": m.truth["safe"].hausdorff,
        "bytes_thesis": rows[0]["bytes"],
        "bytes_compact": rows[1]["bytes"],
        **by_cell,
        **by_cell_bbox,
        "memory_table": rows,
        "truth": truth,
        "config": _config_dict(m.config),
        "clipped_beams": m.build.clipped_beams,
        "seconds": m.seconds,
    }


def _config_dict(cfg: BuildConfig) -> dict:
    d = asdict(cfg)
    d["evidence"].pop("chunk", None)
    d["polygon"]["jump_angle_deg"] = math.degrees(d["polygon"].pop("jump_angle"))
    d["polygon"]["corner_angle_deg"] = math.degrees(d["polygon"].pop("corner_angle"))
    d["polygon"]["lines"]["relax"] = list(d["polygon"]["lines"]["relax"])
    return d


def report(r: DemoResult) -> dict:
    """Everything ``report.json`` holds (see docs/demo.md for every key), ready for strict JSON."""
    um = r.umbmark
    pos, head = r.run.final_drift
    world = r.world
    return json_safe({
        "format": "fuzzybrep-demo-report",
        "version": 1,
        "seed": r.seed,
        "world": {
            "source": r.world_source, "name": world.name, "free_area_m2": float(world.free.area),
            "holes": len(world.free.interiors), "wall_length_m": float(world.walls.length),
            "glass_length_m": float(world.glass_walls.length),
        },
        "route": {
            "length_m": r.route.length, "spacing_m": r.route.spacing, "stops": len(r.run.stops),
            "scans_180": len(r.run.scans), "scans": len(r.scans),
        },
        "robot": {"E_d": r.robot.E_d, "E_b": r.robot.E_b, "slip": r.robot.slip,
                  "laser_bias_mm": r.run.laser_bias * 1000.0},
        "umbmark": {
            "side_mm": SIDE_MM,
            "cw_mm": np.round(r.umbmark_runs[0], 3).tolist(), "ccw_mm": np.round(r.umbmark_runs[1], 3).tolist(),
            "r_cw_mm": um.r_cw, "r_ccw_mm": um.r_ccw, "odometry_error_mm": um.E_max_syst,
            "alpha_deg": um.alpha_deg, "beta_deg": um.beta_deg, "E_d": um.E_d, "E_b": um.E_b,
        },
        "tme": {
            "lrf_error_mm": LRF_ERROR_MM, "odometry_error_mm": um.E_max_syst, "tme_mm": r.tme_mm, "tme_m": r.tme_m,
            "thesis_tme_mm": THESIS_TME_MM,
        },
        "poses": {
            "model": r.pose_model,
            **r.errors.summary(um.E_max_syst / 1000.0, r.tme_m),
            "dead_reckoning_final_drift_m": pos,
            "dead_reckoning_final_heading_error_deg": math.degrees(head),
        },
        "maps": {name: map_report(m) for name, m in r.maps.items()},
        "criteria": {
            "min_support_coverage": MIN_SUPPORT_COVERAGE, "max_unsafe_wall_length_m": MAX_UNSAFE_WALL_M,
            "min_boundary_within_tme": MIN_BOUNDARY_WITHIN_TME,
        },
        "timings_s": dict(r.timings),
    })


def json_safe(obj):
    """NaN and infinities as null, NumPy scalars as plain numbers: strict JSON."""
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, (np.integer, np.bool_)):
        return obj.item()
    return obj


# ------------------------------------------------------------------------------------ summary


def _pct(x: float) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{100 * x:.1f} %"


def summary(r: DemoResult, out: str | None = None, seconds: float | None = None) -> list[str]:
    """A few lines a person reads in ten seconds."""
    e = r.errors.summary(r.odometry_error_mm / 1000.0, r.tme_m)
    f = r.maps["filtered"]
    rows, k = memory_rows(f.fuzzy), len(GRID_CELLS)
    lines = [
        f"{r.world.name or r.world_source}: {len(r.scans)} scans over {r.route.length:.0f} m, "
        f"UMBmark odometry error {r.odometry_error_mm:.1f} mm -> TME {r.tme_mm:.1f} mm (thesis {THESIS_TME_MM} mm)",
        f"poses {r.pose_model}: scan pose error up to {e['position_error_m']['max'] * 1000:.0f} mm and "
        f"{e['heading_error_deg']['max']:.1f}° (mean {e['position_error_m']['mean'] * 1000:.0f} mm, "
        f"{e['heading_error_deg']['mean']:.1f}°); {_pct(e['returns_within_tme'])} of returns within TME",
        f"map: {f.fuzzy.crisp.n_vertices} vertices ({f.fuzzy.crisp.n_holes} holes): {rows[0]['bytes']} bytes as "
        f"Table 5.3 counts, {rows[1]['bytes']} compact",
        "grids at " + "/".join(f"{round(c * 100)}" for c in GRID_CELLS) + " cm: "
        + "/".join(str(row["bytes"]) for row in rows[2:2 + k]) + " bytes over the map's area, "
        + "/".join(str(row["bytes"]) for row in rows[2 + k:2 + 2 * k]) + " over its bounding box",
    ]
    lines.append(f"{'map':<10} {'α = 0':<6}{'seen wall in support':>22}{'wall in safe region':>22}"
                 f"{'boundary within TME':>22}")
    for name in BUILDS:
        m = r.maps[name]
        for method in SUMMARY_METHODS:
            t, ok = m.truth[method], m.criteria(method)
            cells = [(_pct(t.support_coverage), ok["support_coverage"]),
                     (f"{t.unsafe_wall_length:.2f} m", ok["unsafe_wall_length"]),
                     (_pct(t.boundary_within_tme), ok["boundary_within_tme"])]
            lines.append(f"{name:<10} {method:<6}" + "".join(f"{v:>16} {'ok' if good else 'FAIL':<5}" for v, good in cells))
    lines.append(f"need >= {_pct(MIN_SUPPORT_COVERAGE)}, 0 m and >= {_pct(MIN_BOUNDARY_WITHIN_TME)}; "
                 f"done in {r.seconds if seconds is None else seconds:.1f} s" + (f"; files in {out}" if out else ""))
    return [line.rstrip() for line in lines]
