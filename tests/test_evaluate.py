"""Held-out scoring: a violation no scan of the map ever saw is told apart from one the map could know."""

from __future__ import annotations

import numpy as np
import shapely
from _synthetic import room, scan_of

from fuzzybrep import evaluate as E
from fuzzybrep.build import BuildConfig


def test_seen_near_finds_returns_of_other_scans_only_within_the_distance():
    scan = scan_of(room(6, 4), (3.0, 2.0, 0.0), n=181)
    wall = np.array([[6.0, 2.0], [5.9, 2.0], [5.7, 2.0]])  # on the wall, 0.1 and 0.3 in front of it
    assert E.seen_near(wall, [scan], 0.2).tolist() == [True, True, False]
    assert not E.seen_near(wall, [], 0.2).any()


def test_a_person_seen_by_the_held_out_scans_alone_is_an_unseen_violation():
    empty = room(6, 4)
    person = shapely.box(2.8, 1.8, 3.2, 2.2)  # in the middle of the room
    poses = [(1.0 + 0.5 * k, 1.0 + 0.2 * k, 0.4 * k) for k in range(8)]
    # every second scan is held out: only those see the person
    scans = [scan_of(empty.difference(person) if k % 2 else empty, p, n=361, fov=2 * np.pi - 0.02, t=float(k))
             for k, p in enumerate(poses)]
    e = E.evaluate_log(scans, 2, BuildConfig())
    assert e.exact.violations > 0.01  # the person is in the free space the kept scans saw
    assert e.violations_unseen == e.exact.violations  # and no kept scan saw anything there
    # the person standing there in every scan: the map has an obstacle, nothing is violated
    still = [scan_of(empty.difference(person), p, n=361, fov=2 * np.pi - 0.02, t=float(k)) for k, p in enumerate(poses)]
    e = E.evaluate_log(still, 2, BuildConfig())
    assert e.exact.violations < 0.005 and e.violations_unseen == 0.0
