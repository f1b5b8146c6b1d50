"""Held-out scoring: a violation no scan of the map ever saw is told apart from one the map could know."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import shapely
from _synthetic import room, scan_of

from fuzzybrep.use import evaluate as E
from fuzzybrep.mapping.build import BuildConfig
from fuzzybrep.scans.scan import Scan


def test_seen_near_finds_returns_of_other_scans_only_within_the_distance():
    scan = scan_of(room(6, 4), (3.0, 2.0, 0.0), n=181)
    wall = np.array([[6.0, 2.0], [5.9, 2.0], [5.7, 2.0]])  # on the wall, 0.1 and 0.3 in front of it
    assert E.seen_near(wall, [scan], 0.2).tolist() == [True, True, False]
    assert not E.seen_near(wall, [], 0.2).any()


def test_seen_free_needs_a_beam_passing_beyond_the_point_before_or_after_its_time():
    scans = [scan_of(room(6, 4), (3.0, 2.0, 0.0), n=181, t=t) for t in (0.0, 10.0)]
    free = [s.ranges for s in scans]
    pts = np.array([[5.0, 2.0],    # on a beam, 1 m short of the wall
                    [5.9, 2.0],    # 0.1 in front of the wall: not passed by the margin
                    [2.5, 2.0],    # behind the sensor (a 180° scan), though beams at ±90° reach further
                    [5.0, 2.01]])  # 1 cm off the beam at 2 m: within half a beam spacing
    before, after = E.seen_free(pts, np.full(4, 5.0), scans, free, margin=0.2)
    assert before.tolist() == after.tolist() == [True, False, False, True]
    before, after = E.seen_free(pts, np.full(4, 20.0), scans, free, margin=0.2)
    assert before.tolist() == [True, False, False, True] and not after.any()
    # a scan at the point's own time is neither before nor after it
    before, after = E.seen_free(pts, np.full(4, 10.0), scans[1:], free[1:], margin=0.2)
    assert not before.any() and not after.any()
    # a beam shortened by the map (the spike filter, say) no longer sees beyond its free range
    short = [np.minimum(f, 1.5) for f in free]
    assert not E.seen_free(pts, np.full(4, 5.0), scans, short, margin=0.2)[0].any()
    # a 360° scan of 1° beams from -179.5° to 179.5°: a point at -179.8° lies nearest the first beam
    full = scan_of(room(6, 4), (3.0, 2.0, 0.0), n=360, fov=2 * np.pi * 359 / 360)
    a = np.radians(-179.8)
    p = np.array([[3.0 + np.cos(a), 2.0 + np.sin(a)]])
    assert E.seen_free(p, np.array([1.0]), [full], [full.ranges], 0.2)[0].tolist() == [True]


def test_seen_free_asks_both_beams_of_a_point_on_the_boundary_between_them():
    # a point exactly half a beam spacing from two beams is within half a spacing of either: it
    # was judged by one of them alone (the later one, or the last at a 360° scan's seam), so it
    # was seen free by a long beam on one side and not by its mirror image
    two = np.array([0.0, np.pi / 2])  # the point (1, 1) lies at π/4, half way
    four = np.array([-0.75, -0.25, 0.25, 0.75]) * np.pi  # 360°: the point (-1, 0) lies at π, across the seam
    for b, p in ((two, [1.0, 1.0]), (four, [-1.0, 0.0])):
        for long in (0, len(b) - 1):
            s = Scan(np.where(np.arange(len(b)) == long, 5.0, 1.0), b, np.zeros(3))
            before, after = E.seen_free(np.array([p]), np.array([1.0]), [s], [s.ranges], 0.2)
            assert before.tolist() == [True] and not after.any(), (b, long)


def test_seen_free_takes_the_beam_within_half_a_spacing_only():
    # beams 10° apart, every other one long (-90°, -70°, ..., 10°, 30°, ...): a point 4° from a
    # long beam is seen free by it, one 6° from it lies nearer a short one; past the last beam too
    b = np.radians(np.arange(-90.0, 91.0, 10.0))
    s = Scan(np.where(np.arange(len(b)) % 2 == 0, 5.0, 1.0), b, np.zeros(3))
    a = np.radians([6.0, 4.0, -6.0, -4.0, 94.0, 96.0])
    pts = 2 * np.column_stack((np.cos(a), np.sin(a)))
    before, _ = E.seen_free(pts, np.ones(len(a)), [s], [s.ranges], 0.2)
    assert before.tolist() == [True, False, True, False, True, False]


def test_seen_free_of_scans_with_different_beams_a_few_pairs_at_a_time(monkeypatch):
    # 180° and 360° scans, each judged by its own beams, and the (scan, point) pairs taken all
    # at once, a few scans at a time or one: the same as each scan alone
    world = room(6, 4)
    scans = [scan_of(world, (3.0, 2.0, 0.3 * k), n=181, t=float(k)) for k in range(3)]
    scans += [scan_of(world, (2.0, 1.5, 0.5 * k), n=360, fov=2 * np.pi * 359 / 360, t=float(k)) for k in range(3, 6)]
    free = [s.ranges for s in scans]
    rng = np.random.default_rng(0)
    pts, times = rng.uniform((0, 0), (6, 4), (200, 2)), rng.uniform(0, 6, 200)
    alone = [E.seen_free(pts, times, [s], [f], 0.2) for s, f in zip(scans, free)]
    expected = [np.any([a[i] for a in alone], axis=0) for i in (0, 1)]
    assert 0 < expected[0].sum() < 200 and 0 < expected[1].sum() < 200
    for pairs in (E._PAIRS, 450, 1):
        monkeypatch.setattr(E, "_PAIRS", pairs)
        before, after = E.seen_free(pts, times, scans, free, 0.2)
        assert before.tolist() == expected[0].tolist() and after.tolist() == expected[1].tolist()


def test_a_person_seen_by_the_held_out_scans_alone_is_an_unseen_violation():
    empty = room(6, 4)
    person = shapely.box(2.8, 1.8, 3.2, 2.2)  # in the middle of the room
    # the robot passes the person no closer than 0.36 m: its footprint (0.3 m) is free by fact
    poses = [(1.0 + 0.5 * k, 0.6 + 0.2 * k, 0.4 * k) for k in range(9)]
    # every second scan is held out: only those see the person; a kept scan comes before and after each
    scans = [scan_of(empty.difference(person) if k % 2 else empty, p, n=361, fov=2 * np.pi - 0.02, t=float(k))
             for k, p in enumerate(poses)]
    e = E.evaluate_log(scans, 2, BuildConfig())
    assert e.exact.violations > 0.01  # the person is in the free space the kept scans saw
    assert e.violations_unseen == e.exact.violations  # and no kept scan saw anything there
    # kept beams passed through where it stood: no map true to the kept scans could avoid them
    assert e.violations_seen_through == e.violations_unseen
    # kept scans before and after looked through where the person stood: they came and went
    assert e.violations_came_and_went == e.exact.violations
    assert e.violations_rest == 0.0  # nothing a map of the kept scans could have known
    # the last scan held out: no kept scan after it, so its person came but did not go
    e = E.evaluate_log(scans[:-1], 2, BuildConfig())
    last = len(E.endpoints(scans[-2:-1]))
    assert e.exact.violated[-last:].any()
    assert e.violations_came_and_went == e.exact.violated[:-last].sum() / len(e.exact.violated) < e.exact.violations
    # and in reverse time, no kept scan before it: its person went but had not come
    rev = [dataclasses.replace(s, timestamp=-s.timestamp) for s in scans[:-1]]
    assert E.evaluate_log(rev, 2, BuildConfig()).violations_came_and_went == e.violations_came_and_went
    # the person standing there in every scan: the map has an obstacle, nothing is violated
    still = [scan_of(empty.difference(person), p, n=361, fov=2 * np.pi - 0.02, t=float(k)) for k, p in enumerate(poses)]
    e = E.evaluate_log(still, 2, BuildConfig())
    assert e.exact.violations < 0.005 and e.violations_unseen == 0.0 and e.violations_came_and_went == 0.0
    # the person stands through the first four scans, kept ones too, then leaves and later scans
    # see through the spot: the map calls it free (the newest evidence), and the held-out
    # endpoints on the person are neither unseen nor come and gone (nothing saw through it before)
    left = [scan_of(empty.difference(person) if k < 4 else empty, p, n=361, fov=2 * np.pi - 0.02, t=float(k))
            for k, p in enumerate(poses)]
    e = E.evaluate_log(left, 2, BuildConfig())
    assert e.exact.violations > 0.01 and e.violations_unseen == 0.0 and e.violations_seen_through == 0.0
    # (a beam of scan 0 grazing past the box's corner sees a few of them free before)
    assert e.violations_came_and_went < 0.1 * e.exact.violations
    assert e.violations_rest == pytest.approx(e.exact.violations - e.violations_came_and_went)


def test_a_person_the_map_saw_pass_by_stays_a_violation_of_its_own_scans():
    # the floor under held-out violations: the map from all scans drops a person whom later and
    # earlier scans saw through, so the person's own endpoints lie in its free space, and they
    # came and went; the scan that saw the person is neither before nor after itself
    from fuzzybrep.mapping.build import build_map
    from fuzzybrep.fuzzy.map import fuzzify

    empty = room(6, 4)
    person = shapely.box(2.8, 1.8, 3.2, 2.2)
    poses = [(1.0 + 0.5 * k, 1.0 + 0.2 * k, 0.4 * k) for k in range(5)]
    scans = [scan_of(empty.difference(person) if k == 2 else empty, p, n=361, fov=2 * np.pi - 0.02, t=float(k))
             for k, p in enumerate(poses)]
    cfg = BuildConfig()
    cut = fuzzify(build_map(scans, cfg).crisp, tme=cfg.tme).alpha_cut(0.0, "exact")
    pts, times = E.endpoints(scans), E.endpoint_times(scans)
    assert len(times) == len(pts) and set(times[E.seen_near(pts, [scans[2]], 1e-9)]) == {2.0}
    s = E.score(pts, cut.inner, cut.outer)
    on_person = shapely.intersects_xy(person, *pts.T)
    assert on_person.any() and s.violated[on_person].all()  # the map dropped the person
    went = E.came_and_went(pts, times, scans, cfg, cfg.tme)
    assert went[on_person].all()  # seen through before (scans 0, 1) and after (3, 4)
    assert not went[~on_person & shapely.intersects_xy(shapely.buffer(empty.exterior, 0.05), *pts.T)].any()
    # with the scans after it gone, the person came but did not go
    assert not E.came_and_went(pts, times, scans[:3], cfg, cfg.tme)[on_person].any()


def test_only_returns_closer_than_max_range_are_scored():
    # a return at 1 m, one at exactly max_range (5 m), one just short of it, and a beam with no return
    s = Scan(np.array([1.0, 5.0, 4.99, 80.0]), np.radians([-10.0, 0.0, 10.0, 20.0]), np.zeros(3), 0.0, 80.0)
    assert E.scored(s, 5.0).tolist() == [True, False, True, False]
    np.testing.assert_allclose(E.endpoints([s], 5.0), [[np.cos(np.radians(-10)), np.sin(np.radians(-10))],
                                                       [4.99 * np.cos(np.radians(10)), 4.99 * np.sin(np.radians(10))]])


def test_score_classes_by_hand_boundaries_included():
    safe, outer = shapely.box(1, 1, 3, 3), shapely.box(0, 0, 4, 4)
    pts = np.array([[2.0, 2.0],    # inside the safe region: a violation
                    [0.5, 0.5],    # in the band: explained
                    [1.0, 2.0],    # on the safe region's edge: not inside it, so in the band
                    [4.0, 2.0],    # on the outer polygon's edge: not outside it, so in the band
                    [5.0, 5.0]])   # past the outer polygon: beyond
    s = E.score(pts, safe, outer)
    assert (s.endpoints, s.violations, s.beyond) == (5, 0.2, 0.2) and np.isclose(s.explained, 0.6)
    assert s.violated.tolist() == [True, False, False, False, False]


def test_holdout_split_and_the_names_of_every_kth():
    scans = list(range(7))
    assert E.holdout_split(scans, 3) == ([0, 1, 3, 4, 6], [2, 5])
    for k in (1, 0):
        try:
            E.holdout_split(scans, k)
        except ValueError as e:
            assert "at least 2" in str(e)
        else:
            raise AssertionError(f"holdout {k} accepted")
    names = {2: "second", 3: "third", 4: "4th", 11: "11th", 12: "12th", 13: "13th", 21: "21st", 22: "22nd",
             23: "23rd", 101: "101st", 111: "111th", 112: "112th"}
    assert {k: E.ordinal(k) for k in names} == names


def test_small_objects_are_narrow_nearer_than_both_neighbours_and_not_the_whole_scan():
    b = np.radians(np.arange(-90.0, 91.0))  # 181 beams, 1° apart
    r = np.full(len(b), 3.0)
    r[100:103] = 1.0  # a pole 1 m away: 3 beams, about 3.5 cm across, walls behind on both sides
    r[20:80] = 1.0  # a cupboard 1 m away across 60 beams: over a metre wide, not small
    s = Scan(r, b, np.zeros(3), 0.0, 80.0)
    small = E.small_objects([s], 5.0)
    assert np.flatnonzero(small).tolist() == [100, 101, 102]
    # a scan that sees one small surface and nothing else has no neighbours to be nearer than
    tiny = Scan(np.full(3, 1.0), np.radians([-1.0, 0.0, 1.0]), np.zeros(3), 0.0, 80.0)
    assert not E.small_objects([tiny], 5.0).any()


def test_free_space_iou_counts_cells_by_their_centres():
    from fuzzybrep.mapping.grid import OccupancyGrid

    lo = np.zeros((4, 4))
    lo[:, :2] = -5.0  # the grid: the left two columns of 1 m cells are free
    g = OccupancyGrid(lo, (0.0, 0.0), 1.0)
    # the map: x < 1.2, so the left column's centres (x = 0.5) only: 4 shared cells out of 8
    assert E.free_space_iou(shapely.box(0, 0, 1.2, 4), g) == 0.5
    assert E.free_space_iou(shapely.box(0, 0, 2, 4), g) == 1.0
    assert np.isnan(E.free_space_iou(shapely.Polygon(), OccupancyGrid(np.zeros((2, 2)), (0.0, 0.0), 1.0)))


def test_endpoints_beyond_the_map_that_a_kept_scan_saw_are_told_from_those_none_did():
    from fuzzybrep.scans.filters import BeamConfig

    # two rooms joined by a 0.8 m door; the robot stays in the first, facing the door, and every
    # scan sees the second room's far wall through it (within 5 m)
    a, door, b = shapely.box(0, 0, 4, 4), shapely.box(4, 1.6, 4.3, 2.4), shapely.box(4.3, 0, 6, 4)
    rooms = shapely.union_all([a, door, b])
    poses = [(1.2 + 0.1 * k, 2.0 + 0.05 * (k % 3), 0.02 * k) for k in range(10)]
    scans = [scan_of(rooms, p, n=361, t=float(k)) for k, p in enumerate(poses)]
    # the held-out endpoints on the second room's far wall
    far = shapely.intersects_xy(shapely.buffer(shapely.LineString([(6, 0), (6, 4)]), 0.05), *E.endpoints(scans[1::2]).T)
    e = E.evaluate_log(scans, 2, BuildConfig())
    # the spike filter cuts the kept scans' fans back to the doorway (no needle through a door):
    # the held-out endpoints on the far wall lie beyond the map, and the kept scans saw it
    assert far.mean() > 0.05 and e.exact.outside[far].all()
    assert e.beyond_seen == pytest.approx(e.exact.beyond) and e.exact.beyond >= far.mean()
    # letting every opening through maps the fans: those endpoints are explained
    cfg = BuildConfig(beams=BeamConfig(min_gap=0.0))
    e_open = E.evaluate_log(scans, 2, cfg)
    assert not e_open.exact.outside[far].any() and e_open.exact.explained > e.exact.explained
    # the door shut while the kept scans were taken: what the held-out scans see through it no
    # kept scan saw, so it is beyond and unseen
    shut = [scan_of(rooms if k % 2 else a, p, n=361, t=float(k)) for k, p in enumerate(poses)]
    e = E.evaluate_log(shut, 2, BuildConfig())
    assert e.exact.outside[far].all() and e.beyond_seen < 0.2 * e.exact.beyond
