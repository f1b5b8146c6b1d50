"""The scans' order when their timestamps cannot give it (scans.order; issue 17)."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import shapely
from test_evidence import walk_by

from fuzzybrep import build_map
from fuzzybrep.scans.order import in_scan_order, timestamp_problem

DATA = Path(os.environ.get("FUZZYBREP_DATASETS", Path(__file__).resolve().parents[2] / "shared" / "datasets"))
INTEL = DATA / "carmen" / "intel-corrected.log.gz"


@pytest.mark.parametrize("times, problem", [
    ([0.0, 0.1, 0.2, 0.35], None),
    ([5.0], None),
    ([1.0, 1.0] + list(np.arange(2, 40.0)), None),  # one tie in 39 steps: the sequence orders it
    ([0.0] * 10, "every timestamp is 0"),
    ([3.5] * 10, "every timestamp is 3.5"),
    ([1.0] * 5 + [2.0] * 5, "10 scans share 2 distinct timestamps"),
    ([0.0, 1.0, 2.0, 1.5] + list(np.arange(3, 40.0)), None),  # one scan logged out of turn: time orders it
    ([0.0, 1.0, 2.0, -50.0] + list(np.arange(3, 40.0)), "run backwards 1 time (first at scan 4: -50 after 2)"),
    ([0.0, 1.0, 0.5, 2.0, 1.5, 3.0], "run backwards 2 times (first at scan 3: 0.5 after 1)"),
    ([-3.0, -2.0, -1.0, 4.29e9, 4.29e9 + 1], "jump by 4.29e+09 s at scan 4"),
])
def test_timestamps_that_cannot_order_the_scans_are_named(times, problem):
    got = timestamp_problem(times)
    if problem is None:
        assert got is None
    else:
        assert problem in got


def test_unusable_timestamps_become_the_scans_order_with_a_note():
    scans = walk_by(obstacle_times=range(0, 5))
    zero = [dataclasses.replace(s, timestamp=0.0) for s in scans]
    ordered, note = in_scan_order(zero, "walk.log")
    assert [s.timestamp for s in ordered] == list(range(len(scans)))
    assert note.startswith("walk.log: every timestamp is 0, so the scans are taken to come in the order")
    same, none = in_scan_order(scans)
    assert none is None and [s.timestamp for s in same] == [s.timestamp for s in scans]


def test_a_person_who_walked_away_is_cleared_whatever_the_timestamps():
    # every timestamp 0 made every scan as old as every other: the person stood in the map for ever
    scans = walk_by(obstacle_times=range(0, 5))
    face = shapely.Point(3.85, 2.0)
    for times in (None, 0.0, 7.0):
        run = scans if times is None else [dataclasses.replace(s, timestamp=times) for s in scans]
        result = build_map(run)
        assert result.crisp.to_shapely().boundary.distance(face) > 0.5
        assert bool(result.notes) == (times is not None)


@pytest.mark.reallog
@pytest.mark.skipif(not INTEL.exists(), reason=f"CARMEN logs not found at {DATA} (set FUZZYBREP_DATASETS)")
def test_intel_with_every_timestamp_zero_gives_intels_map_and_says_why(tmp_path):
    lines = []
    import gzip

    with gzip.open(INTEL, "rt") as f:
        for line in f:
            p = line.split()
            if p and p[0] == "FLASER":
                n = int(p[1])
                p[2 + n + 6] = "0"  # the timestamp after the ranges, the pose and the odometry
                line = " ".join(p) + "\n"
            lines.append(line)
    zero = tmp_path / "intel-zero.log"
    zero.write_text("".join(lines))
    areas = []
    for log in (INTEL, zero):
        out = tmp_path / f"{log.stem}.json"
        r = subprocess.run([sys.executable, "-m", "fuzzybrep.cli", "build", str(log), "--out", str(out)],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        notes = [line for line in r.stderr.splitlines() if line.startswith("note:")]
        if log is zero:
            assert len(notes) == 1 and "intel-zero.log" in notes[0] and "every timestamp is 0" in notes[0]
        else:
            assert not notes
        from fuzzybrep import FuzzyBRepMap

        areas.append(FuzzyBRepMap.load(out).crisp.area)
    assert abs(areas[1] - areas[0]) <= 0.005 * areas[0]
