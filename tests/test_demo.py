"""``fuzzybrep demo``: the thesis's experiment end to end on the built-in floor and on a user's floor,
the pose models it can use, and the Done-when criteria against the ground truth."""

from __future__ import annotations

import contextlib
import io
import json
import math

import numpy as np
import pytest
import shapely

from fuzzybrep import cli
from fuzzybrep.sim.demo import MIN_BOUNDARY_WITHIN_TME, MIN_SUPPORT_COVERAGE, build_config, no_return_reach, run_demo
from fuzzybrep.fuzzy.map import FuzzyBRepMap
from fuzzybrep.sim.pose_error import pose_errors, relocalised_poses, scan_poses
from fuzzybrep.sim.simulate import DiffDrive, Laser, Route, World, builtin_floor, builtin_route, simulate_run
from fuzzybrep.sim.world import Route as WorldRoute

FIGURES = ["fig_alpha_stack.png", "fig_support.png", "fig_membership_3d.png", "fig_map_vs_floorplan.png"]
FILES = ["floorplan.geojson", "map.json", "report.json", *FIGURES]
#: the docs/demo.md example: a 10 m × 6 m room, a pillar, a glass south wall, a route with stops every 2 m
ROOM = {"type": "FeatureCollection", "unit": "m", "features": [
    {"type": "Feature", "properties": {"role": "free"},
     "geometry": {"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 6], [0, 6], [0, 0]]]}},
    {"type": "Feature", "properties": {"role": "obstacle"},
     "geometry": {"type": "Polygon", "coordinates": [[[4, 2.5], [5, 2.5], [5, 3.5], [4, 3.5], [4, 2.5]]]}},
    {"type": "Feature", "properties": {"material": "glass"},
     "geometry": {"type": "LineString", "coordinates": [[0, 0], [10, 0]]}},
    {"type": "Feature", "properties": {"role": "route", "spacing": 2},
     "geometry": {"type": "LineString", "coordinates": [[1, 1], [9, 1], [9, 5], [1, 5], [1, 1]]}},
]}


def _demo(*argv: str) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = cli.main(["demo", *argv])
    return code, out.getvalue()


@pytest.fixture(scope="module")
def builtin_run(tmp_path_factory):
    """One full ``fuzzybrep demo`` on the built-in floor (figures included): (folder, report, stdout)."""
    out = tmp_path_factory.mktemp("demo")
    code, text = _demo("--out", str(out))
    assert code == 0
    return out, json.loads((out / "report.json").read_text()), text


# -------------------------------------------------------------------------------- the command


def test_demo_writes_every_file(builtin_run):
    out, rep, _ = builtin_run
    assert sorted(p.name for p in out.iterdir()) == sorted(FILES)
    assert sorted(rep["files"]) == sorted(FILES)
    for name in FIGURES:
        data = (out / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 50_000, name


def test_floorplan_is_the_ground_truth_and_reads_back(builtin_run):
    out, _, _ = builtin_run
    world, truth = World.from_geojson(out / "floorplan.geojson"), builtin_floor()
    assert world.free.symmetric_difference(truth.free).area < 1e-9
    assert world.glass_walls.length == pytest.approx(truth.glass_walls.length)
    route = Route.from_file(out / "floorplan.geojson")
    np.testing.assert_allclose(route.waypoints, builtin_route().waypoints)


def test_map_file_is_the_filtered_fuzzy_map(builtin_run):
    out, rep, _ = builtin_run
    fz = FuzzyBRepMap.load(out / "map.json")
    m = rep["maps"]["filtered"]
    assert fz.crisp.n_vertices == m["vertices"] and fz.crisp.n_holes == m["holes"]
    assert fz.table[1].support_in == pytest.approx(rep["tme"]["tme_m"])
    assert json.loads((out / "map.json").read_text())["scans"]["count"] == rep["route"]["scans"] == 27


def test_report_holds_the_experiment(builtin_run):
    _, rep, _ = builtin_run
    assert rep["route"] == {"length_m": pytest.approx(136.0), "spacing_m": 5.0, "stops": 27, "scans_180": 54,
                            "scans": 27}
    um = rep["umbmark"]
    assert len(um["cw_mm"]) == len(um["ccw_mm"]) == 5
    assert um["odometry_error_mm"] == max(um["r_cw_mm"], um["r_ccw_mm"])
    assert rep["tme"]["tme_mm"] == pytest.approx(15.0 + um["odometry_error_mm"])
    assert rep["tme"]["tme_m"] == pytest.approx(rep["tme"]["tme_mm"] / 1000)
    for key in ("position_error_m", "heading_error_deg", "point_error_m"):
        assert set(rep["poses"][key]) >= {"max", "mean"}
    assert rep["poses"]["model"] == "relocalised"
    for build in ("filtered", "unfiltered"):
        m = rep["maps"][build]
        for key in ("vertices", "holes", "bytes_thesis", "bytes_compact", "grid_30cm_bytes", "grid_20cm_bytes",
                    "grid_10cm_bytes", "hausdorff_m", "memory_table"):
            assert key in m, (build, key)
        # thesis accounting: 10 numbers per vertex and 6 per edge, 4 bytes each (Table 5.3)
        assert m["bytes_thesis"] == 4 * 16 * m["vertices"]
        assert m["grid_30cm_bytes"] < m["grid_20cm_bytes"] < m["grid_10cm_bytes"]
        for method in ("safe", "exact", "thesis"):
            t = m["truth"][method]
            assert 0 <= t["support_coverage"] <= 1 and t["unsafe_wall_length_m"] >= 0
            assert set(t["criteria"]) == {"support_coverage", "unsafe_wall_length", "boundary_within_tme"}
    assert rep["total_seconds"] > 0 and rep["timings_s"]["simulate"] > 0


def test_summary_is_short_and_names_the_criteria(builtin_run):
    _, rep, text = builtin_run
    lines = text.strip().splitlines()
    assert len(lines) <= 10
    assert f"TME {rep['tme']['tme_mm']:.1f} mm" in lines[0]
    assert "filtered" in text and "unfiltered" in text and "need >= 99.0 %" in lines[-1]


# ------------------------------------------------------------------- Done when (built-in floor)


def test_relocalised_pose_error_is_one_leg_and_tme_covers_positions(builtin_run):
    _, rep, _ = builtin_run
    p = rep["poses"]
    odometry_error_m = rep["umbmark"]["odometry_error_mm"] / 1000
    assert p["position_error_m"]["max"] < odometry_error_m  # ≈ 0.09 m against ≈ 0.16 m
    assert p["position_error_within_odometry_error"]
    assert p["heading_error_deg"]["max"] < 2.5  # ≈ 0.22°/m over a 5 m leg, plus slip
    # heading error moves far returns more: most, not all, stay within TME
    assert 0.95 < p["returns_within_tme"] < 1.0
    # dead reckoning over the whole route would be metres and tens of degrees off
    assert p["dead_reckoning_final_drift_m"] > 3 and abs(p["dead_reckoning_final_heading_error_deg"]) > 15


def test_support_encloses_the_seen_wall(builtin_run):
    _, rep, _ = builtin_run
    t = rep["maps"]["filtered"]["truth"]["exact"]
    assert t["support_coverage"] >= MIN_SUPPORT_COVERAGE
    assert t["seen_wall_length_m"] > 250


def test_crisp_boundary_lies_within_tme_of_a_wall(builtin_run):
    _, rep, _ = builtin_run
    assert rep["maps"]["filtered"]["truth"]["exact"]["boundary_within_tme"] >= MIN_BOUNDARY_WITHIN_TME


def test_no_wall_in_the_safe_region(builtin_run):
    _, rep, _ = builtin_run
    assert rep["maps"]["filtered"]["truth"]["exact"]["unsafe_wall_length_m"] == 0.0


@pytest.mark.parametrize("seed", [4, 6])
def test_other_seeds_meet_every_criterion(seed):
    # the seeds on which beams through glass once left 0.30 and 0.17 m of pane in the safe region:
    # no-return beams slipped between its sparse returns (evidence.bridged now stops them)
    m = run_demo(builtin_floor(), builtin_route(), seed=seed).maps["filtered"]
    for method in ("exact", "safe"):
        assert m.criteria(method) == dict.fromkeys(("support_coverage", "unsafe_wall_length", "boundary_within_tme"), True)
        assert m.truth[method].unsafe_wall_length == 0.0


def test_the_default_cut_meets_every_criterion(builtin_run):
    """The map's own α = 0 cut (the safe sweep, what plan and the viewer use) holds the exact band,
    so it meets the criteria the exact cut meets: the seen wall in its support, no wall in its
    safe region, the boundary within TME."""
    _, rep, _ = builtin_run
    t = rep["maps"]["filtered"]["truth"]["safe"]
    assert t["support_coverage"] >= MIN_SUPPORT_COVERAGE
    assert t["unsafe_wall_length_m"] == 0.0
    assert t["passes"]


@pytest.mark.xfail(strict=True, reason="the thesis's single-normal-vertex band narrows to TME·sin(θ/2) at the sharp "
                                       "vertices of a jagged crisp boundary; docs/fuzzy.md, docs/demo.md")
def test_thesis_sweep_support_encloses_the_seen_wall(builtin_run):
    _, rep, _ = builtin_run
    assert rep["maps"]["filtered"]["truth"]["thesis"]["support_coverage"] >= MIN_SUPPORT_COVERAGE


def test_unfiltered_glass_spikes_break_the_map(builtin_run):
    _, rep, _ = builtin_run
    f, u = rep["maps"]["filtered"]["truth"]["exact"], rep["maps"]["unfiltered"]["truth"]["exact"]
    assert u["unsafe_wall_length_m"] > 10 * max(f["unsafe_wall_length_m"], 0.1)
    assert u["boundary_within_tme"] < 0.6 < f["boundary_within_tme"]


def test_raw_odometry_fails_the_criteria(tmp_path):
    code, text = _demo("--out", str(tmp_path), "--raw-odometry", "--no-figures")
    assert code == 0
    rep = json.loads((tmp_path / "report.json").read_text())
    assert rep["poses"]["model"] == "odometry"
    assert rep["poses"]["position_error_m"]["max"] > 3.0
    t = rep["maps"]["filtered"]["truth"]["exact"]
    assert t["support_coverage"] < 0.5 and t["unsafe_wall_length_m"] > 20 and t["boundary_within_tme"] < 0.5
    assert not any(rep["maps"]["filtered"]["truth"][m]["passes"] for m in ("safe", "exact", "thesis"))
    assert "poses odometry" in text and sorted(rep["files"]) == ["floorplan.geojson", "map.json", "report.json"]


# ------------------------------------------------------------------------------ the pose models


def test_raw_odometry_with_other_poses_is_refused(tmp_path, capsys):
    """--raw-odometry is --poses odometry: given with --poses true it silently won, and the run
    the user asked for (true poses) was not the one made."""
    with pytest.raises(SystemExit) as e:
        cli.main(["demo", "--raw-odometry", "--poses", "true", "--no-figures", "--out", str(tmp_path / "o")])
    assert e.value.code == 2 and "not allowed with" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_ideal_robot_relocalised_poses_are_true():
    run = simulate_run(builtin_floor(), builtin_route(), Laser(), DiffDrive(), seed=1)
    np.testing.assert_allclose(relocalised_poses(run), run.true_poses, atol=1e-9)


def test_relocalised_error_is_one_leg_of_dead_reckoning():
    """A straight corridor with equal legs and a systematic robot: every stop after the first has
    the same error (one leg), while dead reckoning's grows with every leg."""
    world = World(shapely.box(0, 0, 60, 3))
    route = WorldRoute([(1, 1.5), (56, 1.5)], spacing=5.0)
    robot = DiffDrive(E_d=1.002, E_b=1.001)
    run = simulate_run(world, route, Laser(), robot, seed=0)
    reloc = pose_errors(run.scans, scan_poses(run, "relocalised"), run.true_poses)
    dead = pose_errors(run.scans, scan_poses(run, "odometry"), run.true_poses)
    front = reloc.position[2::2]
    np.testing.assert_allclose(front, front[0], rtol=1e-6)
    assert front[0] > 0.01
    assert np.all(np.diff(dead.position[::2]) > 0) and dead.position[-2] > 5 * front[0]
    assert reloc.point.max() < dead.point.max()


def test_true_poses_have_no_error():
    run = simulate_run(builtin_floor(), builtin_route(), Laser(), DiffDrive.pioneer_3dx(), seed=0)
    e = pose_errors(run.scans, scan_poses(run, "true"), run.true_poses)
    assert e.position.max() == 0 and e.point.max() == 0
    with pytest.raises(ValueError, match="pose model"):
        scan_poses(run, "slam")


def test_no_return_reach_closes_the_widest_gap_between_stops():
    assert no_return_reach(builtin_route()) == pytest.approx(3.5)  # the last stop is 6 m from home
    assert no_return_reach(WorldRoute([(0, 0), (10, 0)], spacing=2.0)) == pytest.approx(1.5)
    f, u = build_config(builtin_route()), build_config(builtin_route(), filtered=False)
    assert f.use_evidence and not u.use_evidence
    assert f.beams.spike_width > 0 and u.beams.spike_width == 0
    assert f.beams.no_return_free == u.beams.no_return_free == pytest.approx(3.5)


# --------------------------------------------------------------------------- your own floor plan


def test_user_floor_plan_and_route(tmp_path):
    world = tmp_path / "room.geojson"
    world.write_text(json.dumps(ROOM))
    code, text = _demo("--world", str(world), "--out", str(tmp_path / "out"), "--seed", "3")
    assert code == 0
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert rep["world"]["source"] == str(world) and rep["world"]["name"] == "room"
    assert rep["route"]["length_m"] == pytest.approx(24.0) and rep["route"]["stops"] == 12
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(FILES)
    t = rep["maps"]["filtered"]["truth"]["exact"]
    assert t["support_coverage"] >= MIN_SUPPORT_COVERAGE and t["unsafe_wall_length_m"] == 0.0
    assert "room: 12 scans over 24 m" in text


def test_user_route_file_overrides_the_world_route(tmp_path):
    world = tmp_path / "room.geojson"
    world.write_text(json.dumps({**ROOM, "features": ROOM["features"][:3]}))  # no route feature
    route = tmp_path / "route.csv"
    route.write_text("x,y\n1,1\n9,1\n9,5\n")
    code, _ = _demo("--world", str(world), "--route", str(route), "--spacing", "3", "--out", str(tmp_path / "b"),
                    "--no-figures")
    assert code == 0
    rep = json.loads((tmp_path / "b" / "report.json").read_text())
    assert rep["route"]["length_m"] == pytest.approx(12.0) and rep["route"]["spacing_m"] == 3.0
    assert rep["route"]["stops"] == 5


def test_missing_route_names_the_fix(tmp_path, capsys):
    """A world file without a route feature: the glass line (material glass, no role) is not taken
    for the route, and the message says what to do."""
    world = tmp_path / "room.geojson"
    world.write_text(json.dumps({**ROOM, "features": ROOM["features"][:3]}))
    assert cli.main(["demo", "--world", str(world), "--out", str(tmp_path / "o"), "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert "expected one LineString feature with role route, found 0" in err
    assert "pass --route, or give the world file a route feature" in err


def test_invalid_world_is_refused_with_the_reason(tmp_path, capsys):
    bowtie = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {},
         "geometry": {"type": "Polygon", "coordinates": [[[0, 0], [4, 4], [4, 0], [0, 4], [0, 0]]]}}]}
    path = tmp_path / "bad.geojson"
    path.write_text(json.dumps(bowtie))
    assert cli.main(["demo", "--world", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "bad.geojson, feature 1: invalid polygon: Self-intersection" in err
    assert not (tmp_path / "o").exists()
    path.write_text("{not json")
    assert cli.main(["demo", "--world", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "not valid JSON" in capsys.readouterr().err


def test_route_through_a_wall_is_refused(tmp_path, capsys):
    world = tmp_path / "room.geojson"
    world.write_text(json.dumps(ROOM))
    route = tmp_path / "route.csv"
    route.write_text("1,1\n9,1\n12,1\n")  # the last waypoint is outside the room
    assert cli.main(["demo", "--world", str(world), "--route", str(route), "--out", str(tmp_path / "o")]) == 2
    assert "route waypoint 3 [12.0, 1.0] is not in the free space" in capsys.readouterr().err
    route.write_text("3,1\n6,4\n")  # straight through the pillar
    assert cli.main(["demo", "--world", str(world), "--route", str(route), "--out", str(tmp_path / "o")]) == 2
    assert "the route crosses a wall near" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_report_is_strict_json(builtin_run):
    out, _, _ = builtin_run

    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    json.loads((out / "report.json").read_text(), parse_constant=refuse)
    assert not math.isnan(json.loads((out / "report.json").read_text())["maps"]["filtered"]["hausdorff_m"])


def test_figure_headlines_name_and_score_the_cut_they_draw():
    # issue 20: Figure 5.13's headline gave the sweep's scores whatever was drawn; fig_support's
    # band was the frontier edges' orange, and its letters A-D were not explained
    from matplotlib.colors import to_rgb

    from fuzzybrep import figures, plot
    from fuzzybrep.sim import demo
    from fuzzybrep.sim.world import builtin_floor, builtin_route

    r = demo.run_demo(builtin_floor(), builtin_route(), seed=0)
    method = figures.figure_method(r)
    assert method == demo.ALPHA_METHODS[0]
    t = r.maps["filtered"].truth[method]
    h = figures.floorplan_headline(r)
    assert f"{method} α-cut" in h and f"{100 * t.support_coverage:.1f} %" in h and f"{t.unsafe_wall_length:.2f} m" in h
    assert sum(abs(a - b) for a, b in zip(to_rgb(figures.BAND), to_rgb(plot.FRONTIER_EDGE))) > 0.3
