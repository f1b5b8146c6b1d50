"""The simulator: ray casting, LMS200, glass, odometry errors, the built-in floor and route, GeoJSON."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import shapely

from fuzzybrep import cli
from fuzzybrep.errors import ScanFormatError, WorldError
from fuzzybrep.sim.umbmark import BORENSTEIN_EB_TURN, TABLE_I1, TABLE_I2, THESIS_EB_TURN, read_runs, umbmark
from fuzzybrep.sim.simulate import (FOOTPRINT, DiffDrive, Laser, Route, World, builtin_floor, builtin_route,
                                    cast_rays, integrate, load_scans, save_run, simulate_run, umbmark_runs)

NO_GLASS = dict(glass_pass=0.0, glass_reflect=0.0)


def room(w=10.0, h=4.0, glass=None) -> World:
    return World(shapely.box(0, 0, w, h), glass if glass is not None else shapely.MultiLineString())


def glass_world() -> World:
    """A 10 m × 10 m room with a 1 m thick block at x = 6..7; the block's faces are glass."""
    free = shapely.orient_polygons(shapely.box(0, 0, 10, 10).difference(shapely.box(6, 2, 7, 8)))
    return World(free, shapely.box(6, 2, 7, 8).boundary)


# ------------------------------------------------------------------------- rays and laser


def test_ray_hits_wall_at_known_distance():
    t, seg = cast_rays(room(), np.array([[2.0, 2.0], [2.0, 2.0], [2.0, 2.0]]), np.array([0.0, math.pi / 2, math.pi]), 8.0)
    np.testing.assert_allclose(t, [8.0, 2.0, 2.0])
    assert (seg >= 0).all()


def test_laser_reading_is_distance_plus_bias_plus_noise():
    laser = Laser(bias=0.010, sigma=0.005, **NO_GLASS)
    ranges, _ = laser.measure(room(), np.array([[5.0, 2.0, math.pi / 2]] * 200), np.random.default_rng(1), bias=0.010)
    centre = ranges[:, 90]  # bearing 0: straight at the wall 2 m away
    assert np.mean(centre) == pytest.approx(2.010, abs=0.002)
    assert np.std(centre) == pytest.approx(0.005, rel=0.2)


def test_no_return_beyond_8_m():
    laser = Laser(sigma=0.0, systematic=0.0, **NO_GLASS)
    ranges, seg = laser.measure(room(w=20.0), np.array([[1.0, 2.0, 0.0]]), np.random.default_rng(0), bias=0.0)
    assert ranges[0, 90] == 8.0 and seg[0, 90] == -1  # the far wall is 19 m away
    assert ranges[0, 0] == pytest.approx(2.0) and ranges[0, 180] == pytest.approx(2.0)
    scan = simulate_run(room(w=20.0), Route([(1.0, 2.0), (2.0, 2.0)]), laser, DiffDrive(), seed=0).scans[0]
    assert not scan.returns[90] and scan.returns[0]


def test_laser_geometry_is_the_lms200():
    laser = Laser()
    assert laser.n_beams == 181 and laser.max_range == 8.0
    np.testing.assert_allclose(np.degrees(laser.bearings), np.arange(-90, 91))
    assert (laser.systematic, laser.sigma) == (0.015, 0.005)


def test_systematic_error_is_one_bias_per_run_within_15_mm():
    biases = [Laser().draw_bias(np.random.default_rng(s)) for s in range(200)]
    assert max(map(abs, biases)) <= 0.015 and np.std(biases) > 0.005


@pytest.mark.parametrize("kwargs, expected", [
    (dict(glass_pass=0.0, glass_reflect=0.0), 1.0),  # glass returns the beam like a wall
    (dict(glass_pass=1.0, glass_reflect=0.0), 5.0),  # passes the block, hits the east wall
    (dict(glass_pass=0.0, glass_reflect=1.0), 7.0),  # 1 m out, bounces back 6 m to the west wall
])
def test_glass_opaque_pass_reflect(kwargs, expected):
    t, _ = cast_rays(glass_world(), np.array([[5.0, 5.0]]), np.array([0.0]), 8.0, rng=np.random.default_rng(0), **kwargs)
    assert t[0] == pytest.approx(expected)


def test_glass_oblique_reflection_is_specular():
    # 45° up-right from (5, 3): glass at (6, 4); mirrored, the beam runs up-left to the north wall
    t, _ = cast_rays(glass_world(), np.array([[5.0, 3.0]]), np.array([math.pi / 4]), 12.0,
                     glass_reflect=1.0, rng=np.random.default_rng(0))
    assert t[0] == pytest.approx(math.sqrt(2) + 6 * math.sqrt(2))  # (6, 4) -> (0, 10)


def test_glass_pass_probability():
    o = np.tile([5.0, 5.0], (4000, 1))
    t, _ = cast_rays(glass_world(), o, np.zeros(4000), 8.0, glass_pass=0.3, rng=np.random.default_rng(2))
    assert np.isclose(t, 5.0).mean() == pytest.approx(0.3, abs=0.03)
    assert np.isclose(t, 1.0).mean() == pytest.approx(0.7, abs=0.03)


def test_all_glass_walls_pass_to_nothing():
    """Every wall glass (issue 36 item 7: an IndexError): a beam through the pane finds no opaque wall
    behind it and returns nothing; one the pane returns keeps its range."""
    w = room(glass=shapely.box(0, 0, 10, 4).boundary)
    assert w.is_glass.all()
    t, idx = cast_rays(w, np.array([[5.0, 2.0]] * 400), np.zeros(400), 8.0, glass_pass=0.5,
                       rng=np.random.default_rng(1))
    through = np.isinf(t)
    assert 100 < through.sum() < 300
    np.testing.assert_array_equal(idx[through], -1)
    np.testing.assert_allclose(t[~through], 5.0)


def test_glass_on_builtin_floor_makes_spikes():
    w, r = builtin_floor(), builtin_route()
    opaque = simulate_run(w, r, Laser(**NO_GLASS), DiffDrive(), seed=3)
    clear = simulate_run(w, r, Laser(glass_pass=1.0, glass_reflect=0.0), DiffDrive(), seed=3)
    n_opaque = sum(int((~s.returns).sum()) for s in opaque.scans)
    n_clear = sum(int((~s.returns).sum()) for s in clear.scans)
    assert n_clear > n_opaque + 100  # beams through section C and D glass find nothing within 8 m


# ------------------------------------------------------------------------------ odometry


def test_ideal_robot_has_exact_odometry():
    run = simulate_run(builtin_floor(), builtin_route(), robot=DiffDrive(), seed=0)
    np.testing.assert_allclose(run.odometry_path, run.true_path, atol=1e-9)
    assert run.drift.max() < 1e-9


def test_straight_line_heading_error_follows_E_d():
    for e_d in (1.001, 1.002, 0.998):
        robot = DiffDrive(E_d=e_d)
        _, dth = robot.odometry_motion(np.array([10.0]), np.array([0.0]))
        # encoders scale each wheel by D/D_i: (1 - E_d²) / (2 E_d b) per metre
        assert dth[0] == pytest.approx(10 * (1 - e_d**2) / (2 * e_d * 0.267), rel=1e-12)


def test_turn_error_follows_E_b():
    robot = DiffDrive(E_b=1.01)
    ds, dth = robot.odometry_motion(np.array([0.0]), np.array([math.pi / 2]))
    assert dth[0] == pytest.approx(math.pi / 2 * 1.01) and ds[0] == pytest.approx(0.0)
    # driving by odometry, the robot turns 1/E_b of what it commands
    _, true = robot.true_motion(np.array([0.0]), np.array([math.pi / 2]))
    assert true[0] == pytest.approx(math.pi / 2 / 1.01)


def test_true_motion_inverts_odometry_motion():
    robot = DiffDrive(E_d=1.003, E_b=0.98)
    ds, dth = np.array([1.0, 0.0, 2.5]), np.array([0.0, 1.2, -0.3])
    np.testing.assert_allclose(robot.true_motion(*robot.odometry_motion(ds, dth)), (ds, dth), atol=1e-12)


def test_route_drift_grows_with_the_errors():
    w, r = builtin_floor(), builtin_route()
    drift = [simulate_run(w, r, robot=DiffDrive(E_d=1 + k), seed=0).final_drift for k in (0.0005, 0.001, 0.002)]
    pos, head = np.array(drift).T
    assert 0 < pos[0] < pos[1] < pos[2]
    np.testing.assert_allclose(head[1:] / head[:-1], 2.0, rtol=0.01)  # heading error is linear in E_d - 1
    turn_drift = [simulate_run(w, r, robot=DiffDrive(E_b=1 + k), seed=0).final_drift[0] for k in (0.001, 0.002)]
    assert 0 < turn_drift[0] < turn_drift[1]


def test_integrate_arcs_exactly():
    # a quarter circle of radius 2 in four pieces ends at (2, 2) heading 90°
    p = integrate(np.zeros(3), np.full(4, math.pi / 4), np.full(4, math.pi / 8))
    np.testing.assert_allclose(p[-1], [2.0, 2.0, math.pi / 2], atol=1e-12)


def test_umbmark_runs_recover_the_robot_with_borenstein_form():
    robot = DiffDrive(E_d=1.001, E_b=1.01)
    cw, ccw = umbmark_runs(robot, side=4000, seed=0)
    assert cw.shape == ccw.shape == (5, 2)
    res = umbmark(cw, ccw, eb_turn_deg=BORENSTEIN_EB_TURN)
    assert res.E_d == pytest.approx(1.001, abs=1e-4)  # Borenstein's equations are first-order
    assert res.E_b == pytest.approx(1.01, abs=5e-4)
    # the thesis's Eq. 5 (180°) finds only about half of the wheelbase error
    thesis = umbmark(cw, ccw, eb_turn_deg=THESIS_EB_TURN)
    assert (thesis.E_b - 1) / (1.01 - 1) == pytest.approx(0.5, abs=0.05)


def test_thesis_tables_fit_umbmark_frame():
    """docs/umbmark.md: in UMBmark's frame (x along the first leg, y left) the simulated robot stops
    where the thesis's did: Table I.2 to 5.5 mm with a fitted E_d, E_b; Table I.1 in its quadrants."""
    cw, ccw = umbmark_runs(DiffDrive(E_d=1.000985, E_b=1.000885), runs=1)
    got = np.concatenate((cw[0], ccw[0]))
    want = np.concatenate([t.mean(axis=0) for t in TABLE_I2])
    assert np.abs(got - want).max() < 6.0
    cw, ccw = umbmark_runs(DiffDrive.pioneer_3dx(calibrated=False, slip=0.0), runs=1)
    assert np.array_equal(np.sign(cw[0]), np.sign(TABLE_I1[0].mean(axis=0)))
    assert np.array_equal(np.sign(ccw[0]), np.sign(TABLE_I1[1].mean(axis=0)))


def test_pioneer_after_calibration_reproduces_table_i2_scale():
    cw, ccw = umbmark_runs(DiffDrive.pioneer_3dx(), seed=1)
    res = umbmark(cw, ccw)
    assert 100 < res.E_max_syst < 250  # Table I.2: 184.13 mm
    assert np.std(cw[:, 0]) > 5  # slip scatters the five runs


# ------------------------------------------------------------------ floor, route, runs


def test_builtin_floor_is_valid_with_the_central_block_as_hole():
    w = builtin_floor()
    assert isinstance(w.free, shapely.Polygon) and w.free.is_valid
    assert len(w.free.interiors) == 1
    x0, y0, x1, y1 = shapely.Polygon(w.free.interiors[0]).bounds
    assert (x1 - x0, y1 - y0) == pytest.approx((36.6, 26.6))
    assert shapely.box(*FOOTPRINT).contains(w.free)
    assert FOOTPRINT[2:] == (55.0, 45.0)
    assert w.glass_walls.length == pytest.approx(12.0 + 21.0)  # sections C and D
    assert shapely.contains_xy(w.free, 25.0, 3.0)  # the room behind the open door in section A


def test_builtin_route_is_the_thesis_route():
    r = builtin_route()
    assert r.length == pytest.approx(136.0) and r.closed
    assert abs(r.length - 140) / 140 < 0.05
    assert len(r.stop_distances()) == 27
    assert shapely.Polygon(r.waypoints).exterior.is_ccw is False  # clockwise
    assert np.diff(r.stop_distances()) == pytest.approx(5.0)


def test_simulated_run_shape_and_poses():
    w, r = builtin_floor(), builtin_route()
    run = simulate_run(w, r, seed=0)
    assert len(run.scans) == 54 and run.true_poses.shape == (54, 3) and len(run.stops) == 27
    front, back = run.true_poses[::2], run.true_poses[1::2]
    np.testing.assert_allclose(front[:, :2], run.stops[:, :2], atol=1e-9)
    np.testing.assert_allclose(np.cos(front[:, 2] - run.stops[:, 2]), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.cos(back[:, 2] - front[:, 2]), -1.0, atol=1e-12)  # 180° apart
    for s, true in zip(run.scans, run.true_poses):
        assert s.ranges.shape == (181,) and s.max_range == 8.0
    # scans carry the odometry pose, which drifts from the true one
    assert run.drift[0] < 1e-9 and run.drift[-1] > 0.5
    assert np.all(np.diff([s.timestamp for s in run.scans]) > 0)


def test_seeded_runs_are_reproducible():
    w, r = builtin_floor(), builtin_route()
    a, b, c = (simulate_run(w, r, seed=s) for s in (7, 7, 8))
    for x, y in zip(a.scans, b.scans):
        np.testing.assert_array_equal(x.ranges, y.ranges)
        np.testing.assert_array_equal(x.pose, y.pose)
    assert not np.array_equal(a.scans[0].ranges, c.scans[0].ranges)
    np.testing.assert_array_equal(umbmark_runs(DiffDrive.pioneer_3dx(), seed=4)[0],
                                  umbmark_runs(DiffDrive.pioneer_3dx(), seed=4)[0])


def test_consolidated_scan_covers_the_turn_with_the_same_points():
    run = simulate_run(builtin_floor(), builtin_route(), robot=DiffDrive(), seed=0)
    front, back = run.scans[0], run.scans[1]
    full = run.consolidated()[0]
    assert full.full_circle and np.all(np.diff(full.bearings) > 0)
    assert len(full.ranges) == 360  # the two ±90° beams appear once
    got = full.endpoints()[full.returns]
    # the back scan's first and last beams repeat the front scan's last and first directions
    want = np.vstack((front.endpoints()[front.returns], back.endpoints()[1:-1][back.returns[1:-1]]))
    d = np.min(np.hypot(*(want[:, None, :] - got[None, :, :]).transpose(2, 0, 1)), axis=1)
    assert d.max() < 1e-9


def test_route_through_a_wall_is_rejected():
    with pytest.raises(WorldError, match="crosses a wall"):
        simulate_run(builtin_floor(), Route([(8.0, 8.0), (47.0, 37.0)]))
    with pytest.raises(WorldError, match="waypoint 1"):
        simulate_run(builtin_floor(), Route([(20.0, 20.0), (8.0, 8.0)]))


def test_save_and_load_scans(tmp_path):
    run = simulate_run(builtin_floor(), builtin_route(), seed=0)
    save_run(tmp_path / "s.npz", run)
    scans, true = load_scans(tmp_path / "s.npz")
    assert len(scans) == 54
    np.testing.assert_array_equal(scans[5].ranges, run.scans[5].ranges)
    np.testing.assert_array_equal(scans[5].pose, run.scans[5].pose)
    np.testing.assert_array_equal(true, run.true_poses)
    (tmp_path / "bad.npz").write_bytes(b"nope")
    with pytest.raises(ScanFormatError, match="bad.npz"):
        load_scans(tmp_path / "bad.npz")


# ------------------------------------------------------------------------------- GeoJSON


def test_world_geojson_round_trip(tmp_path):
    w, r = builtin_floor(), builtin_route()
    path = tmp_path / "floor.geojson"
    w.write_geojson(path, r)
    back = World.from_geojson(path)
    assert back.free.equals_exact(w.free, 0)
    np.testing.assert_array_equal(back.segments, w.segments)
    np.testing.assert_array_equal(back.is_glass, w.is_glass)
    rr = Route.from_file(path)
    np.testing.assert_array_equal(rr.waypoints, r.waypoints)
    assert rr.spacing == 5.0


def _write(tmp_path, features, **extra):
    path = tmp_path / "w.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", **extra, "features": features}))
    return path


def _poly(coords, **props):
    return {"type": "Feature", "properties": props, "geometry": {"type": "Polygon", "coordinates": [coords]}}


def _line(coords, **props):
    return {"type": "Feature", "properties": props, "geometry": {"type": "LineString", "coordinates": coords}}


SQUARE = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]


def test_geojson_scheme_obstacles_glass_units(tmp_path):
    sq_mm = [[x * 1000, y * 1000] for x, y in SQUARE]
    path = _write(tmp_path, [
        _poly(sq_mm),
        _poly([[4000, 4000], [6000, 4000], [6000, 6000], [4000, 6000], [4000, 4000]], role="obstacle"),
        _line([[0, 0], [10000, 0]], material="glass"),
    ], unit="mm")
    w = World.from_geojson(path)
    assert w.free.area == pytest.approx(96.0) and len(w.free.interiors) == 1
    assert w.glass_walls.length == pytest.approx(10.0)


def test_geojson_glass_on_part_of_a_wall(tmp_path):
    w = World.from_geojson(_write(tmp_path, [_poly(SQUARE), _line([[2, 10], [7, 10]], role="glass")]))
    assert w.glass_walls.length == pytest.approx(5.0)
    assert w.walls.length == pytest.approx(40.0)


@pytest.mark.parametrize("doc, match", [
    ("{not json", "not valid JSON"),
    (json.dumps([1, 2]), "not GeoJSON"),
    (json.dumps({"type": "FeatureCollection", "features": []}), "no free-space polygon"),
    (json.dumps({"type": "FeatureCollection", "unit": "ft", "features": []}), "unit must be one of"),
    (json.dumps({"type": "FeatureCollection", "features": [_poly(SQUARE), {"type": "Feature"}]}),
     "feature 2: not a Feature with a geometry"),
    (json.dumps({"type": "FeatureCollection", "features": [_poly([[0, 0], [2, 2], [2, 0], [0, 2], [0, 0]])]}),
     "feature 1: invalid polygon: Self-intersection"),
    (json.dumps({"type": "FeatureCollection", "features": [
        _poly(SQUARE), _poly([[20, 0], [30, 0], [30, 10], [20, 10], [20, 0]])]}), "one connected polygon, got 2 pieces"),
    (json.dumps({"type": "FeatureCollection", "features": [_poly(SQUARE), _line([[5, 1], [5, 9]], role="glass")]}),
     "glass line is not on a wall"),
    (json.dumps({"type": "FeatureCollection", "features": [_poly(SQUARE, role="floor")]}),
     "feature 1: a polygon's role must be free or obstacle"),
    (json.dumps({"type": "FeatureCollection", "features": [_poly(SQUARE), _line([[1, 1], [2, 2]])]}),
     "feature 2: a line must have role glass or route"),
])
def test_geojson_errors(tmp_path, doc, match):
    path = tmp_path / "w.geojson"
    path.write_text(doc)
    with pytest.raises(WorldError, match=match) as e:
        World.from_geojson(path)
    assert str(path) in str(e.value)


def test_route_from_csv_and_errors(tmp_path):
    path = tmp_path / "route.csv"
    path.write_text("# my route\nx,y\n1,1\n1,8\n8,8\n")
    r = Route.from_file(path, spacing=2.0)
    assert r.length == pytest.approx(14.0) and not r.closed
    assert r.stop_distances().tolist() == [0, 2, 4, 6, 8, 10, 12, 14]
    np.testing.assert_allclose(r.poses_at([7.0])[0], [1.0, 8.0, 0.0])  # at a waypoint: the next leg's heading
    path.write_text("1,1\n1,1\n")
    with pytest.raises(WorldError, match="waypoint 2 repeats"):
        Route.from_file(path)
    path.write_text("1,1\n2,two\n")
    with pytest.raises(WorldError, match="line 2: not a number pair"):
        Route.from_file(path)


# ------------------------------------------------------------------------------ command


def test_simulate_command_writes_world_scans_and_runs(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(cli, "COMMANDS", ["simulate", "umbmark"])
    world, scans, runs = tmp_path / "w.geojson", tmp_path / "s.npz", tmp_path / "runs.csv"
    code = cli.main(["simulate", "--seed", "2", "--world-out", str(world), "--out", str(scans),
                     "--umbmark-out", str(runs), "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["stops"] == 27 and summary["scans"] == 54 and summary["route_length_m"] == pytest.approx(136.0)
    assert len(load_scans(scans)[0]) == 54
    assert [len(a) for a in read_runs(runs)] == [5, 5]
    # the written world and its route drive the same simulation again
    assert cli.main(["simulate", "--world", str(world), "--seed", "2", "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["final_drift_m"] == summary["final_drift_m"]


def test_simulate_command_needs_a_route_for_a_custom_world(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(cli, "COMMANDS", ["simulate"])
    path = _write(tmp_path, [_poly(SQUARE)])
    assert cli.main(["simulate", "--world", str(path)]) == 2
    assert "found 0 (pass --route, or give the world file a route feature)" in capsys.readouterr().err
    route = tmp_path / "r.csv"
    route.write_text("1,1\n9,1\n9,9\n")
    assert cli.main(["simulate", "--world", str(path), "--route", str(route), "--spacing", "4"]) == 0
    assert "16.0 m, 5 stops" in capsys.readouterr().out
    assert cli.main(["simulate", "--glass-pass", "0.8", "--glass-reflect", "0.5"]) == 2
    assert "bad robot or laser option" in capsys.readouterr().err


def test_stop_spacing_longer_than_a_closed_route_still_stops_at_the_start(capsys):
    # before: no stop at all (the start was dropped as "near the end"), then an IndexError in simulate_run
    route = builtin_route(1000.0)
    assert route.closed and route.stop_distances().tolist() == [0.0]
    assert cli.main(["simulate", "--spacing", "1000", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["scans"] == 2  # one stop: its two 180° scans


def test_stop_spacing_too_fine_for_memory_is_refused(capsys):
    # before: NumPy failing to allocate a terabyte for 1.4e11 stops
    with pytest.raises(WorldError, match=r"stop spacing 1e-09 m gives 1\.36e\+11 stops along the route's 136 m "
                                         r"\(at most 100000\)"):
        builtin_route(1e-9)
    assert cli.main(["simulate", "--spacing", "1e-9"]) == 2
    assert "simulate: error: stop spacing 1e-09 m gives" in capsys.readouterr().err


def test_route_outside_the_world_names_the_route_file(tmp_path, capsys):
    # before: "route waypoint 1 [0.0, 0.0] is not in the free space", naming no file
    route = tmp_path / "r.csv"
    route.write_text("x,y\n0,0\n100,100\n")
    for command in (["simulate", "--route", route], ["demo", "--out", tmp_path / "d", "--route", route]):
        assert cli.main([str(a) for a in command]) == 2
        err = capsys.readouterr().err
        assert f"error: {route}: route waypoint 1 [0.0, 0.0] is not in the free space (world: built-in floor)" in err, err


def test_simulate_checks_every_output_before_writing_any(tmp_path, capsys):
    # before: the scans were written, then --world-out failed on a folder
    assert cli.main(["simulate", "--out", str(tmp_path / "s.npz"), "--umbmark-out", str(tmp_path / "u.csv"),
                     "--world-out", str(tmp_path)]) == 2
    assert f"{tmp_path}: cannot write: it is a folder" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_simulated_scans_written_as_csv_are_read_by_build(tmp_path, monkeypatch, capsys):
    # issue 20: `simulate --out sim.npz` could not be read by build; a .csv is CSV scans at the
    # odometry poses (what the robot knows), which build reads, and an .npz given to build says so
    monkeypatch.setattr(cli, "COMMANDS", ["simulate", "build"])
    scans, run = tmp_path / "sim.csv", tmp_path / "sim.npz"
    assert cli.main(["simulate", "--seed", "1", "--out", str(scans)]) == 0
    assert cli.main(["simulate", "--seed", "1", "--out", str(run)]) == 0
    from fuzzybrep.scans.read import read_scans

    read = read_scans(scans)
    saved, _ = load_scans(run)
    assert len(read) == len(saved) == 54
    np.testing.assert_allclose([s.pose for s in read], [s.pose for s in saved], atol=1e-12)
    assert cli.main(["build", str(scans), "--out", str(tmp_path / "m.json"), "--quiet"]) == 0
    capsys.readouterr()
    assert cli.main(["build", str(run), "--out", str(tmp_path / "n.json"), "--quiet"]) == 2
    assert "write the scans with `fuzzybrep simulate --out SCANS.csv`" in capsys.readouterr().err
