"""``localise --global`` (issue 36 item 8): the filter updates only after the robot moved (AMCL's
update_min_d and update_min_a), and the search gives up after a bound of filter updates with a
one-line error, exit status 2 and nothing written."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from fuzzybrep import cli
from fuzzybrep.brep import BRepMap
from fuzzybrep.errors import LocalisationError
from fuzzybrep.fuzzy.map import fuzzify
from fuzzybrep.scans.carmen import write_carmen
from fuzzybrep.scans.scan import Scan
from fuzzybrep.use.localise import CONFIG, SEARCHING, localise

ROOM = (0.0, 0.0, 3.0, 2.0)  # a tiny room, 3 × 2 m
BEARINGS = np.linspace(-math.pi / 2, math.pi / 2, 91)


@pytest.fixture(scope="module")
def room():
    return fuzzify(BRepMap.from_shapely(shapely.box(*ROOM), "m"), tme=0.2)


def room_ranges(pose) -> np.ndarray:
    """The ranges a laser at ``pose`` sees in the room (ray to the box's walls)."""
    x, y, th = pose
    a = th + BEARINGS
    c, s = np.cos(a), np.sin(a)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (ROOM[2] - x) / c, np.where(c < 0, (ROOM[0] - x) / c, np.inf))
        ty = np.where(s > 0, (ROOM[3] - y) / s, np.where(s < 0, (ROOM[1] - y) / s, np.inf))
    return np.minimum(tx, ty)


def scans_at(odometry, ranges=None) -> list[Scan]:
    return [Scan(room_ranges(p) if ranges is None else ranges, BEARINGS, p, float(i), 20.0, odometry=np.array(p))
            for i, p in enumerate(odometry)]


def test_a_standing_robot_updates_the_filter_once(room):
    odo = [(1.2, 0.8, 0.3)] * 12
    track = localise(room, scans_at(odo), global_search=True)
    assert track.search_updates == 1
    assert (track.status == SEARCHING).all()  # a symmetric room: it cannot tell which way round
    assert np.allclose(track.poses, track.poses[0])  # the odometry's prediction: where it stood


def test_the_filter_updates_every_update_distance_or_update_turn(room):
    assert CONFIG.update_distance == 0.2 and CONFIG.update_turn == pytest.approx(math.pi / 6)
    creep = [(0.8 + 0.06 * i, 0.8, 0.0) for i in range(9)]  # 0.48 m in 0.06 m steps: updates at 0, 0.24, 0.48 m
    assert localise(room, scans_at(creep), global_search=True).search_updates == 3
    turn = [(1.5, 1.0, 0.1 * i) for i in range(8)]  # 0.7 rad in 0.1 rad steps: updates at 0 and 0.6 rad
    assert localise(room, scans_at(turn), global_search=True).search_updates == 2


def test_the_bound_stops_the_search_with_a_one_line_error(room, tmp_path, capsys):
    # a ring of returns 0.6 m around the laser: no place of the room looks like that
    odo = [(0.5 + 0.3 * i, 1.0, 0.0) for i in range(8)]
    scans = scans_at(odo, np.full(len(BEARINGS), 0.6))
    with pytest.raises(LocalisationError, match="did not converge in 2 filter updates"):
        localise(room, scans, global_search=True, config=__import__("dataclasses").replace(CONFIG, max_updates=2))
    room.save(tmp_path / "room.json")
    write_carmen(tmp_path / "ring.log", scans)
    out = tmp_path / "track.csv"
    code = cli.main(["localise", str(tmp_path / "room.json"), str(tmp_path / "ring.log"), "--global",
                     "--max-updates", "2", "--max-range", "20", "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and not out.exists() and not list(tmp_path.glob(".track.csv*"))
    assert len(err) == 1 and "ring.log" in err[0] and "did not converge in 2 filter updates (the bound" in err[0]


def test_max_updates_must_be_a_whole_number(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(["localise", "m.json", "l.log", "--global", "--max-updates", "0", "--out", str(tmp_path / "t.csv")])
    assert e.value.code == 2 and "--max-updates must be ≥ 1" in capsys.readouterr().err
