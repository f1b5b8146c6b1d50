"""Newer CARMEN logs (issue 36, item 5): ROBOTLASER1 scans with their own beam geometry and maximum
range, RAWLASER1 scans placed by the ODOM stream, and one message type per log."""

from __future__ import annotations

import gzip
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from fuzzybrep import ScanFormatError, ScanValueError
from fuzzybrep.scans.carmen import read_carmen
from fuzzybrep.scans.read import read_scans
from fuzzybrep.scans.report import ReadReport

from conftest import log_path

PI = math.pi
#: the command line as a user runs it
CLI = [sys.executable, "-c", "import sys; from fuzzybrep.cli import main; sys.exit(main(sys.argv[1:]))"]


def robotlaser(ranges, laser=(1.0, 2.0, 0.5), robot=None, t=10.0, start=-PI / 2, fov=PI, res=None, top=81.83,
               remissions=(), host=True):
    n = len(ranges)
    res = fov / (n - 1) if res is None else res
    robot = laser if robot is None else robot
    fields = ["ROBOTLASER1", 0, start, fov, res, top, 0.01, 0, n, *ranges, len(remissions), *remissions,
              *laser, *robot, 0.3, 0.1, 0.5, 0.2, 0.0, t]
    return " ".join(str(f) for f in fields) + (f" host {t}\n" if host else "\n")


def rawlaser(ranges, t, start=-PI / 2, fov=PI, top=81.83):
    n = len(ranges)
    fields = ["RAWLASER1", 0, start, fov, fov / (n - 1), top, 0.01, 0, n, *ranges, 0, t, "host", t]
    return " ".join(str(f) for f in fields) + "\n"


def odom(x, y, th, t):
    return f"ODOM {x} {y} {th} 0.1 0.0 0.0 {t} host {t}\n"


def flaser(ranges, pose=(1.0, 2.0, 0.5), t=10.0) -> str:
    x, y, th = pose
    return f"FLASER {len(ranges)} {' '.join(str(r) for r in ranges)} {x} {y} {th} {x} {y} {th} {t} host {t}\n"


def write(path, lines, gz=False):
    data = "".join(lines).encode()
    path.write_bytes(gzip.compress(data) if gz else data)
    return path


@pytest.mark.parametrize("gz", [False, True])
def test_robotlaser1_bearings_ranges_pose_and_maximum_range(tmp_path, gz):
    p = write(tmp_path / ("a.log.gz" if gz else "a.log"),
              ["PARAM robot_frontlaser_offset 0.1 host 0\n",
               robotlaser([1.0, 2.0, 81.83, 3.0, 4.0], laser=(1.1, 2.0, 0.5), robot=(1.0, 2.0, 0.5), t=3.5,
                          remissions=(0.5, 0.6, 0.0, 0.7, 0.9)),
               robotlaser([1.5, 50.0, 2.0], start=-1.0, fov=2.0, top=40.0, t=4.0)])
    report = ReadReport()
    a, b = read_scans(p, report=report)
    assert a.ranges.tolist() == [1.0, 2.0, 81.83, 3.0, 4.0]
    assert np.allclose(np.degrees(a.bearings), [-90, -45, 0, 45, 90], rtol=0, atol=1e-12)
    # the pose is the laser's (the robot's moved by the offset), and so is the odometry: both are
    # odometry in a robot's log, and the sensor's frame is the one the scan is in
    assert a.pose.tolist() == [1.1, 2.0, 0.5] and a.odometry.tolist() == [1.1, 2.0, 0.5]
    assert a.timestamp == 3.5 and a.source == f"{p.name}:2"
    # the maximum range is each line's own, not the log's largest range
    assert a.max_range == 81.83 and a.returns.tolist() == [True, True, False, True, True]
    assert b.max_range == 40.0 and b.returns.tolist() == [True, False, True]
    assert np.allclose(b.bearings, [-1.0, 0.0, 1.0], rtol=0, atol=1e-15)
    assert report.scans == 2 and report.max_range == 81.83


def test_robotlaser1_bearing_rules(tmp_path):
    # CARMEN writes six decimals: 360 steps of 0.008727 make 3.14172, not the field of view
    # 3.141593; the beams spread evenly over the field of view, both ends included
    line = robotlaser([2.0] * 361, start=-1.570796, fov=3.141593, res=0.008727)
    # a Hokuyo's 683 readings at 0.006136 rad from -2.094395 (within 4.18879)
    hokuyo = robotlaser([2.0] * 683, start=-2.094395, fov=4.18879, res=0.006136, top=5.6)
    # 180 readings 1° apart in a 180° field of view: start + i · step, the last at 89°
    short = robotlaser([2.0] * 180, fov=PI, res=PI / 180)
    a, b, c = read_carmen(write(tmp_path / "a.log", [line, hokuyo, short]))
    assert a.bearings[0] == -1.570796 and math.isclose(a.bearings[-1], 1.570797, abs_tol=1e-12)
    assert np.allclose(np.diff(a.bearings), 3.141593 / 360)
    assert b.bearings[0] == -2.094395 and math.isclose(b.bearings[-1], -2.094395 + 682 * 0.006136, abs_tol=1e-12)
    assert math.isclose(np.degrees(c.bearings[-1]), 89.0) and math.isclose(np.degrees(c.bearings[0]), -90.0)


@pytest.mark.parametrize(
    "line, field, cls, words",
    [
        (robotlaser([1.0, 2.0]).replace(" 2 1.0 2.0 ", " two 1.0 2.0 "), "num_readings", ScanFormatError,
         "'two' is not an integer"),
        (robotlaser([1.0, 2.0], start=float("nan")), "start_angle", ScanValueError, "'nan' is not finite"),
        (robotlaser([1.0, 2.0], res=0.0), "angular_resolution", ScanValueError, "0.0 must be positive"),
        (robotlaser([1.0, 2.0, 3.0], fov=1.0, res=1.0), "angular_resolution", ScanFormatError,
         "3 readings 1.0 rad apart span 2 rad, more than the field of view 1.0 rad"),
        (robotlaser([1.0, 2.0, 3.0], fov=2 * PI, res=PI), "field_of_view", ScanFormatError, "a full turn or more"),
        (robotlaser([1.0, -2.0]), "range_2", ScanValueError, "range '-2.0' is negative"),
        (robotlaser([1.0, 2.0], top=float("inf")), "maximum_range", ScanValueError, "'inf' is not finite"),
        (robotlaser([1.0, 2.0], laser=(1.0, "x", 0.5)), "laser_pose_y", ScanFormatError, "'x' is not a number"),
        (robotlaser([1.0, 2.0], remissions=(0.1,)).replace(" 1 0.1 ", " 3 0.1 "), "num_readings", ScanFormatError,
         "num_readings 2 and num_remissions 3 do not match the line: where the timestamp should end it, there is "
         "the host 'host'"),
        (robotlaser([1.0, 2.0], remissions=(0.1, 0.2, 0.3)).replace(" 3 0.1 ", " 0 0.1 "), "num_readings",
         ScanFormatError, "num_readings 2 and num_remissions 0 do not match the line's 29 fields (a ROBOTLASER1 line "
                          "with 2 readings and 0 remissions has 26, or 24 without host and logger timestamp)"),
        (robotlaser([1.0, 2.0, 3.0]).replace(" 3 1.0 2.0 3.0 ", " 2 1.0 2.0 3.0 "), "num_remissions",
         ScanFormatError, "'3.0' is not an integer (is num_readings 2 the number of ranges?)"),
        (" ".join(robotlaser([1.0, 2.0]).split()[:11]) + "\n", None, ScanFormatError,
         "truncated: 11 fields, a ROBOTLASER1 line with 2 readings has at least 24"),
        (robotlaser([1.0, 2.0], host=False).replace("\n", " host\n"), None, ScanFormatError,
         "truncated: 25 fields, ending at the host 'host'"),
        ("ROBOTLASER1 0 -1.5 3.1\n", None, ScanFormatError, "truncated: 4 fields"),
    ],
)
def test_robotlaser1_bad_lines_name_file_line_and_field(tmp_path, line, field, cls, words):
    p = write(tmp_path / "bad.log", [robotlaser([1.0, 2.0]), line])
    with pytest.raises(cls) as e:
        read_carmen(p)
    assert e.value.path == str(p) and e.value.line == 2 and e.value.field == field
    assert words in str(e.value) and str(e.value).startswith(f"{p}, line 2")
    # the CLI: one line, exit status 2
    run = subprocess.run([*CLI, "build", str(p), "--out", str(tmp_path / "m.json")],
                         capture_output=True, text=True, timeout=60) if field == "num_readings" else None
    if run is not None:
        assert run.returncode == 2 and len(run.stderr.strip().splitlines()) == 1 and "bad.log, line 2" in run.stderr
    report = ReadReport()
    assert len(read_carmen(p, skip_bad=True, report=report)) == 1 and report.skipped == 1


def test_robotlaser1_without_host_and_a_maximum_range_of_zero(tmp_path):
    # old loggers leave out host and logger timestamp; 0 as maximum_range: not recorded, so the
    # log's largest range, as for FLASER
    p = write(tmp_path / "a.log", [robotlaser([1.0, 7.5, 2.0], top=0, host=False), robotlaser([3.0, 1.0], top=0)])
    report = ReadReport()
    a, b = read_carmen(p, report=report)
    assert a.max_range == b.max_range == 7.5 and a.returns.tolist() == [True, False, True]
    assert any("no maximum_range" in n for n in report.notes)
    assert read_carmen(p, max_range=9.0)[0].max_range == 9.0


def test_one_message_type_per_log(tmp_path):
    # the same three scans as FLASER and ROBOTLASER1: read once, as ROBOTLASER1 (as many)
    scans = [([1.0, 2.0, 3.0], (k, 0.0, 0.0), float(k)) for k in range(3)]
    both = [line for r, pose, t in scans for line in (flaser(r, pose, t), robotlaser(r, laser=pose, t=t, top=5.0))]
    report = ReadReport()
    got = read_carmen(write(tmp_path / "both.log", both), report=report)
    assert len(got) == 3 and [s.source for s in got] == ["both.log:2", "both.log:4", "both.log:6"]
    assert got[0].max_range == 5.0 and report.notes[0].startswith("read the 3 ROBOTLASER1 scans, not the 3 FLASER")
    # more FLASER scans than ROBOTLASER1 ones: the FLASER scans, the complete stream
    more = both + [flaser([1.0, 2.0, 3.0], (3.0, 0.0, 0.0), 3.0)]
    got = read_carmen(write(tmp_path / "more.log", more))
    assert len(got) == 4 and all(s.odometry is not None for s in got) and got[-1].source == "more.log:7"
    # RAWLASER1 beside ROBOTLASER1 (what newer CARMEN writes): the posed scans, never both
    raw = [line for r, pose, t in scans for line in (rawlaser(r, t), odom(*pose, t), robotlaser(r, laser=pose, t=t))]
    raw += [rawlaser([1.0, 1.0, 1.0], 3.0)]
    got = read_carmen(write(tmp_path / "raw.log", raw))
    assert len(got) == 3 and all(s.source.endswith((":3", ":6", ":9")) for s in got)


def test_rawlaser1_is_placed_by_the_odom_stream(tmp_path):
    # the ODOM stream turns through ±π between 1 s and 2 s: theta is interpolated the short way
    lines = [odom(0.0, 0.0, 3.0, 1.0), rawlaser([1.0, 2.0, 3.0], 1.5), odom(1.0, 2.0, -3.0, 2.0),
             rawlaser([1.0, 2.0, 3.0], 2.0), rawlaser([2.0, 2.0, 2.0], 2.5), odom(2.0, 2.0, -3.0, 3.0),
             rawlaser([2.0, 2.0, 2.0], 3.4)]  # 0.4 s after the last ODOM message: held at its pose
    a, b, c, d = read_carmen(write(tmp_path / "raw.log", lines))
    assert np.allclose(a.pose[:2], [0.5, 1.0]) and math.isclose(abs(a.pose[2]), PI)
    assert np.allclose(b.pose, [1.0, 2.0, -3.0]) and np.allclose(c.pose, [1.5, 2.0, -3.0])
    assert np.allclose(d.pose, [2.0, 2.0, -3.0]) and d.odometry is not None and np.allclose(d.odometry, d.pose)
    assert a.max_range == 81.83 and np.allclose(np.degrees(a.bearings), [-90, 0, 90])


def test_rawlaser1_errors_name_the_line_and_field(tmp_path):
    # no ODOM at all
    p = write(tmp_path / "none.log", [rawlaser([1.0, 2.0], 1.0)])
    with pytest.raises(ScanFormatError, match=r"none.log: the 1 RAWLASER1 scans carry no pose, and the log has no "
                                              r"ODOM line"):
        read_carmen(p)
    # a scan far outside the stream
    p = write(tmp_path / "far.log", [odom(0, 0, 0, 10.0), odom(1, 0, 0, 11.0), rawlaser([1.0, 2.0], 15.0)])
    with pytest.raises(ScanFormatError) as e:
        read_carmen(p)
    assert e.value.line == 3 and e.value.field == "timestamp" and "4 s after the last ODOM message" in str(e.value)
    # a damaged ODOM line matters where the scans need the stream, and names its line and field
    bad_odom = "ODOM 0 0 zero 0 0 0 1.0 host 1.0\n"
    p = write(tmp_path / "odom.log", [odom(0, 0, 0, 0.5), bad_odom, rawlaser([1.0, 2.0], 0.7)])
    with pytest.raises(ScanFormatError) as e:
        read_carmen(p)
    assert e.value.line == 2 and e.value.field == "theta" and "'zero' is not a number" in str(e.value)
    report = ReadReport()
    assert len(read_carmen(p, skip_bad=True, report=report)) == 1 and report.skipped == 1
    # ... and nowhere else: a FLASER log's ODOM lines are not its odometry
    assert len(read_carmen(write(tmp_path / "f.log", [bad_odom, flaser([1.0, 2.0])]))) == 1


def _as_robotlaser(line: str, top: float) -> str:
    """A FLASER line of a shared log as the ROBOTLASER1 line of the same scan (and its RAWLASER1)."""
    p = line.split()
    n = int(p[1])
    ranges, rest = p[2 : 2 + n], p[2 + n :]
    laser, robot, t, host, lt = rest[0:3], rest[3:6], rest[6], rest[7], rest[8]
    head = ["0", repr(-PI / 2), repr(PI), repr(PI / (n - 1)), repr(top), "0.01", "0", str(n), *ranges, "0"]
    return (" ".join(["RAWLASER1", *head, t, host, lt]) + "\n"
            + " ".join(["ROBOTLASER1", *head, *laser, *robot, "0", "0", "0", "0", "0", t, host, lt]) + "\n")


def test_build_reads_a_robotlaser1_log_as_its_flaser_log(tmp_path):
    src = log_path("intel")
    with gzip.open(src, "rt") as f:
        flasers = [line for line in f if line.startswith("FLASER")][:60]
    top = max(float(r) for line in flasers for r in line.split()[2 : 2 + int(line.split()[1])])
    (tmp_path / "flaser.log").write_text("".join(flasers))
    # what newer CARMEN writes: RAWLASER1 and ROBOTLASER1 of every scan (and ODOM between)
    (tmp_path / "robot.log").write_text("".join(_as_robotlaser(line, top) for line in flasers))
    maps = {}
    for name in ("flaser", "robot"):
        run = subprocess.run([*CLI, "build", str(tmp_path / f"{name}.log"), "--out",
                              str(tmp_path / f"{name}.json")], capture_output=True, text=True, timeout=120)
        assert run.returncode == 0, run.stderr
        maps[name] = json.loads((tmp_path / f"{name}.json").read_text())
    assert "read the 60 ROBOTLASER1 scans, not the 60 RAWLASER1 ones" in run.stderr
    f, r = maps["flaser"], maps["robot"]
    assert r["scans"] == f["scans"] and r["regions"] == f["regions"]
    assert r["membership_functions"] == f["membership_functions"]
    assert len(f["scans"]["poses"]) == 60
