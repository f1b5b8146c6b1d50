"""Localisation on the fuzzy map (issue 21): drifting odometry, tracking, global localisation, the
``localise`` and ``drift`` commands; real logs skip with a reason when absent, and their full runs
wait for FUZZYBREP_BIG_LOGS=1 (``make bench`` measures them: benchmarks/localise.py)."""

from __future__ import annotations

import gzip
import math
import os

import numpy as np
import pytest

import fuzzybrep
from fuzzybrep import cli
from fuzzybrep.fuzzy.map import fuzzify
from fuzzybrep.mapping.build import BuildConfig, build_map
from fuzzybrep.scans.carmen import read_carmen, write_carmen
from fuzzybrep.scans.csvscans import read_csv, write_csv
from fuzzybrep.scans.scan import Scan, compose, decompose, recompose, relative, wrap
from fuzzybrep.sim.demo import build_config
from fuzzybrep.sim.drift import DriftModel, drift_poses, drift_scans, drift_stats
from fuzzybrep.sim.pose_error import with_poses
from fuzzybrep.sim.simulate import builtin_floor, builtin_route, simulate_run
from fuzzybrep.use.localise import LOST, TRACKED, localise
from fuzzybrep.use.sensor_model import UNKNOWN, SensorModel

TME = 0.19913  # the shared logs' (and the demo's) total maximum error, metres
BIG = os.environ.get("FUZZYBREP_BIG_LOGS") == "1"


def errors(track, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and heading (degrees) error of every pose of a track."""
    return np.hypot(*(track.poses[:, :2] - truth[:, :2]).T), np.degrees(np.abs(wrap(track.poses[:, 2] - truth[:, 2])))


# ----------------------------------------------------------------------------- the demo floor


@pytest.fixture(scope="module")
def demo_floor():
    """The built-in floor's fuzzy map, built from a simulated run at its true poses (seed 0), and
    a second run (seed 1: other laser noise, bias and wheel slip) to localise on it."""
    world, route = builtin_floor(), builtin_route()
    mapping = simulate_run(world, route, seed=0)
    built = build_map(with_poses(mapping.scans, mapping.true_poses), build_config(route))
    return fuzzify(built.crisp, tme=TME), simulate_run(world, route, seed=1)


def test_demo_run_is_localised_against_its_true_poses(demo_floor):
    # issue 21 done-when: a simulated run of the built-in demo floor, localised from its own
    # odometry (the scans' poses: dead reckoning of the simulated Pioneer), against the truth
    fz, run = demo_floor
    odometry = run.odometry_poses
    track = fuzzybrep.localise(fz, run.scans, odometry, start=run.true_poses[0])
    assert len(track) == len(run.scans) and (track.status == TRACKED).all()
    e, eh = errors(track, run.true_poses)
    drift = np.hypot(*(odometry[:, :2] - run.true_poses[:, :2]).T)
    assert drift.max() > 5.0  # the odometry alone ends metres off: the map does the work
    assert (e <= TME).mean() >= 0.99
    assert math.sqrt(np.mean(e ** 2)) <= 0.05 and math.sqrt(np.mean(eh ** 2)) <= 1.0
    assert ((track.confidence > 0.5) & (track.confidence <= 1)).all()
    assert np.array_equal(track.times, [s.timestamp for s in run.scans])


def test_demo_tracking_is_seeded_and_online_differs_from_smoothed(demo_floor):
    from dataclasses import replace

    from fuzzybrep.use.localise import CONFIG

    fz, run = demo_floor
    a = localise(fz, run.scans, run.odometry_poses, start=run.true_poses[0], seed=3)
    b = localise(fz, run.scans, run.odometry_poses, start=run.true_poses[0], seed=3)
    assert np.array_equal(a.poses, b.poses)
    online = localise(fz, run.scans, run.odometry_poses, start=run.true_poses[0], config=replace(CONFIG, smooth=False))
    assert not np.array_equal(online.poses, a.poses)
    assert np.array_equal(online.poses[-1], a.poses[-1])  # the smoother ends where the filter does
    e, _ = errors(online, run.true_poses)
    assert (e <= TME).mean() >= 0.95


def test_a_wrong_start_far_off_is_not_tracked_as_if_right(demo_floor):
    # 3 m off along the corridor and 30° turned: the alignment cannot honestly agree with the
    # map, so confidence must drop (scans marked lost or low grades), not stay as high as when right
    fz, run = demo_floor
    good = localise(fz, run.scans[:6], run.odometry_poses[:6], start=run.true_poses[0])
    bad_start = run.true_poses[0] + np.array([0.0, 1.2, math.radians(30)])
    bad = localise(fz, run.scans[:6], run.odometry_poses[:6], start=bad_start)
    eb, _ = errors(bad, run.true_poses[:6])
    # either it found its way back to the truth, or it says it is unsure
    assert (eb <= TME).all() or bad.confidence.mean() < good.confidence.mean() - 0.1 or (bad.status == LOST).any()


def test_a_scan_with_no_return_keeps_the_prediction(demo_floor):
    # every beam of scan 5 saw nothing (no return is unknown, not a wall): that scan cannot be
    # aligned, so it keeps the odometry's prediction and is marked lost; the run goes on tracked
    fz, run = demo_floor
    scans = list(run.scans[:12])
    s = scans[5]
    scans[5] = Scan(np.full(len(s.ranges), s.max_range), s.bearings, s.pose, s.timestamp, s.max_range, s.source)
    track = localise(fz, scans, run.odometry_poses[:12], start=run.true_poses[0])
    assert track.status[5] == LOST and (np.delete(track.status, 5) == TRACKED).all()
    e, _ = errors(track, run.true_poses[:12])
    assert (np.delete(e, 5) <= TME).all() and any("1 of 12 scans" in n for n in track.notes)


def test_sensor_model_grades_from_the_map():
    # a 4 m × 2 m room, one side a frontier: μ is 1 on a wall, falls to 0 at TME, frontier unknown
    from fuzzybrep.brep import FRONTIER, OBSTACLE, BRepMap, Region, Ring

    ring = Ring(np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 2.0], [0.0, 2.0]]),
                np.array([OBSTACLE, FRONTIER, OBSTACLE, OBSTACLE]))
    fz = fuzzify(BRepMap([Region(ring)], unit="m"), tme=0.2)
    model = SensorModel.from_map(fz)
    mu = model.membership(np.array([[2.0, 0.0], [2.0, 0.1], [2.0, 0.3], [4.05, 1.0], [2.0, -0.1]]))
    assert mu[0] == pytest.approx(1.0) and mu[1] == pytest.approx(0.5, abs=0.02) and mu[2] == 0.0
    assert mu[3] == UNKNOWN  # nearest a frontier: the map does not know
    assert mu[4] == pytest.approx(0.5, abs=0.02)
    # likelihood: the true pose of a scan scores above one 0.3 m off
    pose = np.array([2.0, 1.0, -math.pi / 2])
    ll = model.log_likelihood(np.array([pose, pose + [0.0, 0.3, 0.0]]), np.array([[1.0, 0.0], [-1.0, 0.0]]), 0.1)
    assert ll[0] > ll[1]


# ---------------------------------------------------------------------------- drifting odometry


def straight(n=400, step=0.05) -> np.ndarray:
    return np.column_stack((np.arange(n) * step, np.zeros(n), np.zeros(n)))


def test_drift_rates_are_as_documented():
    m = DriftModel.from_rates(0.05, 2.0, 0.02)
    assert m.distance_error == pytest.approx(0.05) and math.degrees(m.heading_drift) == pytest.approx(2.0)
    assert m.turn_error == pytest.approx(0.02)
    # the module docstring's wheel parameters
    assert (round(m.E_d, 5), round(m.E_b, 5), round(m.E_s, 5)) == (0.99116, 0.97143, 0.95240)
    # 20 m straight: the odometry reports 21 m and has turned 40°
    odo = drift_poses(straight(), m, seed=None)
    st = drift_stats(odo, straight())
    assert st.distance_ratio == pytest.approx(1.05, abs=1e-3) and st.heading_per_m == pytest.approx(2.0, abs=0.01)
    assert math.degrees(odo[-1, 2]) == pytest.approx(2.0 * 19.95, abs=0.05)
    # turning on the spot through 10 quarter turns: reported 2 % larger
    spin = np.column_stack((np.zeros(11), np.zeros(11), wrap(np.arange(11) * math.pi / 2)))
    turned = np.sum(wrap(np.diff(drift_poses(spin, m, seed=None)[:, 2])))
    assert turned == pytest.approx(1.02 * 10 * math.pi / 2, rel=1e-6)


def test_drift_command_defaults_are_the_benchmark_model():
    from fuzzybrep.commands.drift import model_from_args
    from fuzzybrep.sim.drift import BENCHMARK_RATES

    args = cli.parser("drift").parse_args(["drift", "LOG", "--out", "OUT"])
    assert (args.distance_error, args.heading_drift, args.turn_error) == (
        BENCHMARK_RATES["distance"], BENCHMARK_RATES["heading_deg_per_m"], BENCHMARK_RATES["turn"])
    assert (args.sigma_distance, args.sigma_heading, args.sigma_turn) == (
        BENCHMARK_RATES["sigma_distance"], BENCHMARK_RATES["sigma_heading_deg"], BENCHMARK_RATES["sigma_turn_deg"])
    assert model_from_args(args) == DriftModel.benchmark()


def test_drift_is_seeded_starts_true_and_has_random_error():
    m = DriftModel.benchmark()
    true = straight()
    a, b, c = drift_poses(true, m, 7), drift_poses(true, m, 7), drift_poses(true, m, 8)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.array_equal(a[0], true[0])
    # no error at all: the odometry is the truth
    assert np.allclose(drift_poses(true, DriftModel(), 0), true, atol=1e-12)
    # random error: over 100 seeds the final heading spreads by about 0.5°/√m × √20 m
    ends = np.array([math.degrees(drift_poses(true, m, s)[-1, 2]) for s in range(100)])
    assert ends.mean() == pytest.approx(2.0 * 19.95, abs=0.6)
    assert 1.2 < ends.std() < 3.8


def test_drift_model_rejects_nonsense():
    with pytest.raises(ValueError, match="E_d"):
        DriftModel(E_d=0.0)
    with pytest.raises(ValueError, match="sigma_turn"):
        DriftModel(sigma_turn=-1.0)
    with pytest.raises(ValueError, match="random generator"):
        DriftModel.benchmark().reported(np.ones(2), np.zeros(2), None)


def test_decompose_recompose_round_trip():
    rng = np.random.default_rng(2)
    steps = np.column_stack((rng.normal(0, 1, 200), rng.normal(0, 1, 200), rng.uniform(-3, 3, 200)))
    r1, t, r2 = decompose(steps)
    back = recompose(r1, t, r2)
    assert np.allclose(back[:, :2], steps[:, :2]) and np.allclose(wrap(back[:, 2] - steps[:, 2]), 0, atol=1e-12)
    assert (np.abs(r1) <= math.pi / 2 + 1e-12).all()  # a step behind the robot is driven backwards
    a = np.column_stack((rng.normal(0, 5, 50), rng.normal(0, 5, 50), rng.uniform(-3, 3, 50)))
    b = np.column_stack((rng.normal(0, 5, 50), rng.normal(0, 5, 50), rng.uniform(-3, 3, 50)))
    assert np.allclose(compose(a, relative(a, b)), b)


def test_drifted_logs_read_back_with_their_odometry(tmp_path):
    run = simulate_run(builtin_floor(), builtin_route(), seed=2)
    scans = drift_scans(with_poses(run.scans, run.true_poses), DriftModel.benchmark(), seed=5)
    for name, write, read in (("d.log.gz", write_carmen, read_carmen), ("d.csv", write_csv, read_csv)):
        write(tmp_path / name, scans)
        back = read(tmp_path / name)
        assert np.array_equal([s.pose for s in back], [s.pose for s in scans])
        assert np.array_equal([s.odometry for s in back], [s.odometry for s in scans])
    assert gzip.open(tmp_path / "d.log.gz").read(1)  # gzip, as the name says


def test_csv_with_part_of_the_odometry_columns_is_refused(tmp_path):
    from fuzzybrep.errors import ScanFormatError

    p = tmp_path / "s.csv"
    p.write_text("scan,time,x,y,theta,bearing,range,odom_x,odom_y\n0,0,0,0,0,0,1,0,0\n0,0,0,0,0,0.1,1,0,0\n")
    with pytest.raises(ScanFormatError, match=r"s\.csv.*line 1.*odom_theta"):
        read_csv(p)


def test_write_carmen_refuses_beams_flaser_cannot_hold(tmp_path):
    from fuzzybrep.errors import ScanFormatError

    s = Scan(np.ones(4), np.linspace(-1, 1, 4), np.zeros(3))
    with pytest.raises(ScanFormatError, match="do not spread evenly"):
        write_carmen(tmp_path / "x.log", [s])
    assert not (tmp_path / "x.log").exists()


# ------------------------------------------------------------------------------ the commands


@pytest.fixture(scope="module")
def demo_files(demo_floor, tmp_path_factory):
    """The demo map as a map file and the second run as CSV scans with odometry (the true poses
    as x, y, theta; the odometry as odom_x, odom_y, odom_theta, as ``fuzzybrep drift`` writes)."""
    fz, run = demo_floor
    d = tmp_path_factory.mktemp("localise")
    fz.save(d / "map.json")
    scans = [Scan(s.ranges, s.bearings, p, s.timestamp, s.max_range, s.source, s.pose)
             for s, p in zip(run.scans, run.true_poses)]
    write_csv(d / "run.csv", scans)
    return d, run


def test_localise_command_writes_one_row_per_scan(demo_files, capsys):
    d, run = demo_files
    out, fig = d / "track.csv", d / "track.png"
    assert cli.main(["localise", str(d / "map.json"), str(d / "run.csv"), "--out", str(out), "--plot", str(fig)]) == 0
    err = capsys.readouterr().err
    assert f"run.csv: {len(run.scans)} scans ({len(run.scans)} tracked)" in err and f"-> {out}" in err
    lines = out.read_text().splitlines()
    assert lines[0] == "time,x,y,theta,confidence,status"
    rows = [r.split(",") for r in lines[1:]]
    assert len(rows) == len(run.scans)
    t = np.array([float(r[0]) for r in rows])
    assert np.array_equal(t, [s.timestamp for s in run.scans])  # scan order
    xyz = np.array([[float(v) for v in r[1:4]] for r in rows])
    assert (np.hypot(*(xyz[:, :2] - run.true_poses[:, :2]).T) <= TME).mean() >= 0.99
    assert {r[5] for r in rows} == {"tracked"}
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_localise_command_global_that_does_not_converge_exits_1(demo_files, tmp_path, capsys):
    d, run = demo_files
    short = tmp_path / "short.csv"
    write_csv(short, read_csv(d / "run.csv")[:2])
    out = tmp_path / "t.csv"
    assert cli.main(["localise", str(d / "map.json"), str(short), "--out", str(out), "--global"]) == 1
    assert "note: global localisation did not converge in 2 scans" in capsys.readouterr().err
    rows = out.read_text().splitlines()[1:]
    assert len(rows) == 2 and all(r.endswith(",0.0,searching") for r in rows)  # confidence 0 until found


def test_localise_command_start_far_off_the_map_is_an_error(demo_files, tmp_path, capsys):
    d, _ = demo_files
    out = tmp_path / "t.csv"
    assert cli.main(["localise", str(d / "map.json"), str(d / "run.csv"), "--out", str(out),
                     "--start", "900", "0", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert "run.csv" in err and "--start (900, 0) lies more than 1 m outside the free space" in err
    assert len(err.splitlines()) == 1 and not out.exists()


@pytest.mark.parametrize("extra, message", [
    (["--start", "nan", "0", "0"], "nan must be a finite number"),
    (["--start", "1", "1", "0", "--global"], "not allowed with argument"),
])
def test_localise_command_bad_options(demo_files, tmp_path, capsys, extra, message):
    d, _ = demo_files
    with pytest.raises(SystemExit) as ex:
        cli.main(["localise", str(d / "map.json"), str(d / "run.csv"), "--out", str(tmp_path / "t.csv"), *extra])
    assert ex.value.code == 2 and message in capsys.readouterr().err


def test_localise_command_bad_map_and_log(demo_files, tmp_path, capsys):
    d, _ = demo_files
    out = tmp_path / "t.csv"
    broken = tmp_path / "broken.json"
    broken.write_text('{"format": "fuzzybrep-map", "rings": [')
    assert cli.main(["localise", str(broken), str(d / "run.csv"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("fuzzybrep localise: error:") and "broken.json" in err and len(err.splitlines()) == 1
    bad = tmp_path / "bad.csv"
    text = (d / "run.csv").read_text().splitlines()
    bad.write_text("\n".join(text[:40] + [text[40].replace(",", ",nan,", 1)] + text[41:]) + "\n")
    assert cli.main(["localise", str(d / "map.json"), str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "bad.csv" in err and "line 41" in err and len(err.splitlines()) == 1
    assert cli.main(["localise", str(d / "map.json"), str(tmp_path / "missing.log"), "--out", str(out)]) == 2
    assert "missing.log" in capsys.readouterr().err
    assert cli.main(["localise", str(d / "map.json"), str(d / "run.csv"), "--out", str(d / "run.csv")]) == 2
    assert "run.csv" in capsys.readouterr().err
    assert not out.exists()


def test_drift_command_writes_a_seeded_drifting_log(demo_files, tmp_path, capsys):
    d, run = demo_files
    a, b = tmp_path / "a.log", tmp_path / "b.log"
    for p in (a, b):
        assert cli.main(["drift", str(d / "run.csv"), "--out", str(p), "--seed", "4"]) == 0
    out = capsys.readouterr().out
    assert "+5.00 % of distance, +2.000°/m" in out
    assert a.read_bytes() == b.read_bytes()
    back = read_carmen(a)
    assert np.allclose([s.pose for s in back], run.true_poses)
    odo = np.array([s.odometry for s in back])
    assert np.array_equal(odo[0], back[0].pose) and np.hypot(*(odo[-1, :2] - run.true_poses[-1, :2])) > 1.0
    with pytest.raises(SystemExit):
        cli.main(["drift", str(d / "run.csv"), "--out", str(tmp_path / "c.log"), "--distance-error", "-2"])
    assert "must be a number above -1" in capsys.readouterr().err


# -------------------------------------------------------------------------------- real logs


@pytest.fixture(scope="module")
def intel_even_odd(real_scans):
    """Intel's fuzzy map from its even scans, and its odd scans with the benchmark's drifting
    odometry (skips when the log is absent)."""
    scans = list(real_scans("intel"))
    cfg = BuildConfig()
    fz = fuzzify(build_map(scans[0::2], cfg).crisp, tme=cfg.tme)
    return fz, drift_scans(scans[1::2], DriftModel.benchmark(), seed=0)


def test_intel_tracking_from_drifting_odometry(intel_even_odd):
    fz, odd = intel_even_odd
    n = len(odd) if BIG else 120
    truth = np.array([s.pose for s in odd[:n]])
    track = localise(fz, odd[:n])
    e, eh = errors(track, truth)
    odo = np.array([s.odometry for s in odd[:n]])
    assert np.hypot(*(odo[-1, :2] - truth[-1, :2])) > 5 * TME  # the odometry alone is lost
    assert (e <= TME).mean() >= 0.99 and math.sqrt(np.mean(e ** 2)) <= 0.05
    assert math.sqrt(np.mean(eh ** 2)) <= 1.0


def test_intel_global_localisation_converges_within_20_scans(intel_even_odd):
    fz, odd = intel_even_odd
    n = len(odd) if BIG else 25
    truth = np.array([s.pose for s in odd[:n]])
    track = localise(fz, odd[:n], global_search=True)
    assert track.converged_at is not None and track.converged_at < 20
    e, _ = errors(track, truth)
    assert (e[track.converged_at:] <= TME).all()
    assert any(f"converged at scan {track.converged_at + 1}" in n for n in track.notes)


def test_particle_filter_baseline_tracks_intel(intel_even_odd):
    # the tracker the benchmark compares matching with: it must track too, or the comparison is empty
    from fuzzybrep.use.mcl import track_particles
    from fuzzybrep.use.sensor_model import SensorModel

    fz, odd = intel_even_odd
    odd = odd[:60]
    truth = np.array([s.pose for s in odd])
    est = track_particles(SensorModel.from_map(fz), odd, np.array([s.odometry for s in odd]), truth[0],
                          np.random.default_rng(0), particles=300)
    e = np.hypot(*(est[:, :2] - truth[:, :2]).T)
    odo = np.array([s.odometry for s in odd])
    assert (e <= 2 * TME).mean() >= 0.9 and e.max() < np.hypot(*(odo[:, :2] - truth[:, :2]).T).max()


@pytest.mark.skipif(not BIG, reason="full real-log localisation runs take minutes: set FUZZYBREP_BIG_LOGS=1 "
                                    "(make bench measures them: benchmarks/localise.py)")
@pytest.mark.parametrize("name", ["aces", "freiburg"])
def test_big_logs_tracking_meets_the_done_when(real_scans, name):
    scans = list(real_scans(name))
    cfg = BuildConfig()
    fz = fuzzify(build_map(scans[0::2], cfg).crisp, tme=cfg.tme)
    odd = drift_scans(scans[1::2], DriftModel.benchmark(), seed=0)
    track = localise(fz, odd)
    e, eh = errors(track, np.array([s.pose for s in odd]))
    assert (e <= TME).mean() >= 0.99 and math.sqrt(np.mean(e ** 2)) <= 0.05
    assert math.sqrt(np.mean(eh ** 2)) <= 1.0
