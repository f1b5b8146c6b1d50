"""Truthful free space: what other scans saw, and when, decides how far each ray is free."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import shapely
from _synthetic import scan_of

from fuzzybrep import evidence
from fuzzybrep.build import BuildConfig, build_map
from fuzzybrep.errors import GeometryError
from fuzzybrep.scans.scan import Scan

FULL = 2 * np.pi - np.radians(1)


def shifted(scan: Scan, dx: float, dy: float = 0.0) -> Scan:
    """The same ranges with a pose that is off by (dx, dy): what an imperfect localisation gives."""
    p = scan.pose + np.array([dx, dy, 0.0])
    return Scan(scan.ranges, scan.bearings, p, scan.timestamp, scan.max_range)


def no_evidence(cfg: BuildConfig) -> BuildConfig:
    return dataclasses.replace(cfg, use_evidence=False)


def test_thin_wall_between_two_rooms_survives_pose_error():
    # two rooms side by side, a 2 cm wall between them; room B's poses are 6 cm off towards A,
    # so B's free space pokes through the wall into A's
    room_a = shapely.box(0, 0, 4.0, 4)
    room_b = shapely.box(4.02, 0, 8, 4)
    rng = np.random.default_rng(0)
    spots_a = rng.uniform((1, 1), (3, 3), (10, 2))
    spots_b = rng.uniform((5, 1), (7, 3), (10, 2))
    scans = [scan_of(room_a, (x, y, 0.0), n=361, fov=FULL, t=t) for t, (x, y) in enumerate(spots_a)]
    scans += [shifted(scan_of(room_b, (x, y, 0.0), n=361, fov=FULL, t=10 + t), -0.06) for t, (x, y) in enumerate(spots_b)]
    wall = shapely.points([(4.01, y) for y in np.linspace(0.5, 3.5, 7)])
    naive = build_map(scans, no_evidence(BuildConfig())).crisp.to_shapely()
    assert shapely.contains(naive, wall).all()  # the plain union lost the wall
    truthful = build_map(scans).crisp.to_shapely()
    assert not shapely.contains(truthful, wall).any()
    # both rooms are still mapped
    assert truthful.contains(shapely.Point(2, 2)) and truthful.contains(shapely.Point(6, 2))


def walk_by(obstacle_times, t_end=30):
    """A robot in a corridor; a box stands at (4, 2) while t is in obstacle_times."""
    corridor = shapely.box(0, 0, 9, 4)
    with_box = shapely.Polygon(corridor.exterior, [shapely.box(3.85, 1.85, 4.15, 2.15).exterior])
    scans = []
    for t in range(t_end):
        x = 0.5 + 7.5 * t / (t_end - 1)
        pose = (x, 1.0 + 2.0 * (t % 2), 0.0)
        scans.append(scan_of(with_box if t in obstacle_times else corridor, pose, n=361, fov=FULL, t=float(t)))
    return scans


def test_an_obstacle_later_crossed_by_free_rays_does_not_stay():
    scans = walk_by(obstacle_times=range(0, 5))  # a person standing at first, then gone
    # evidence is what the laser saw: the face towards the robot (x = 3.85) while it stood there
    face = shapely.Point(3.85, 2.0)
    assert build_map(scans).crisp.to_shapely().boundary.distance(face) > 0.5  # gone: no boundary near
    static = BuildConfig()
    static = dataclasses.replace(static, evidence=dataclasses.replace(static.evidence, clear=False))
    assert build_map(scans, static).crisp.to_shapely().boundary.distance(face) <= 0.05


def test_an_obstacle_that_appears_later_wins_over_older_free_space():
    scans = walk_by(obstacle_times=range(20, 30))  # a box put down behind the robot
    # the robot, past it by then, saw its far face (x = 4.15); earlier rays had crossed it freely
    face = shapely.Point(4.15, 2.0)
    truthful = build_map(scans).crisp.to_shapely()
    assert truthful.boundary.distance(face) <= 0.05  # the newer obstacle bounds the free space
    # the naive union keeps the older free space for ever: no boundary anywhere near
    assert build_map(scans, no_evidence(BuildConfig())).crisp.to_shapely().boundary.distance(face) > 0.5


def test_edges_are_tagged_obstacle_or_frontier():
    # a room seen through its open door: walls seen are obstacles, the view's limits frontiers
    room = shapely.Polygon([(0, 0), (6, 0), (6, 4), (3.5, 4), (3.5, 8), (2.5, 8), (2.5, 4), (0, 4)])
    scans = [scan_of(room, (x, 2.0, 0.0), n=361, fov=FULL, t=float(x), max_range=8.0) for x in (1.0, 3.0, 5.0)]
    m = build_map(scans).crisp
    kinds = np.concatenate([r.kinds for r in m.rings])
    assert (kinds == 0).any() and (kinds == 1).any()
    # the long wall y = 0 is an obstacle edge
    v = m.principal.vertices
    w = np.roll(v, -1, axis=0)
    on_floor = (np.abs(v[:, 1]) < 0.05) & (np.abs(w[:, 1]) < 0.05) & (np.abs(v[:, 0] - w[:, 0]) > 1.0)
    assert on_floor.any() and (m.principal.kinds[on_floor] == 0).all()


def pane_rays(gap_ys, through_hit: bool, through_length: float = 3.5):
    """Returns from a pane at x = 2 at heights ``gap_ys``, then one beam from (0, 0) along +x through
    its gap at y = 0: with no return (``through_hit`` False, claiming ``through_length``) or
    returning from x = 3."""
    n = len(gap_ys)
    oy = np.r_[np.asarray(gap_ys, float), 0.0]
    hit = np.r_[np.ones(n, bool), through_hit]
    hit_range = np.r_[np.full(n, 2.0), 3.0 if through_hit else 8.0]
    length = np.r_[np.full(n, 2.0), 3.0 if through_hit else through_length]
    return evidence.Rays(np.zeros(n + 1), oy, np.ones(n + 1), np.zeros(n + 1), length, np.arange(n + 1.0), hit, hit_range)


def free_through_the_gap(gap_ys, through_hit: bool, bridge: float) -> float:
    cfg = evidence.EvidenceConfig(clear=False, no_return_bridge=bridge)
    rays = pane_rays(gap_ys, through_hit)
    return float(evidence.clip(rays, evidence.gather(rays, cfg), cfg)[-1])


def test_a_no_return_beam_stops_at_the_pane_between_sparse_returns():
    pane = [-0.6, -0.3, 0.3, 0.6]  # glass answered these beams; ours went through the 0.6 m gap
    assert 1.9 <= free_through_the_gap(pane, through_hit=False, bridge=1.0) <= 2.05
    # without the bridge it claims its whole no_return_free through the pane
    assert free_through_the_gap(pane, through_hit=False, bridge=0.0) == 3.5
    # returns more than the bridge apart are not one surface: a doorway
    assert free_through_the_gap([-0.6, 0.6], through_hit=False, bridge=1.0) == 3.5
    # a beam that returned from behind the gap saw free space: it is judged on the cells it crossed
    assert free_through_the_gap(pane, through_hit=True, bridge=1.0) == 3.0


def test_bridged_joins_occupied_cells_closer_than_the_span():
    ev = evidence.Evidence(np.zeros(2), 0.05, (40, 40), np.zeros(1600, np.int32), np.zeros(1600, bool))
    ev.occupied[10 * 40 + 10] = ev.occupied[10 * 40 + 24] = True  # 0.7 m apart along a row
    ev.occupied[30 * 40 + 5] = True  # 1 m from both
    row = evidence.bridged(ev, 0.8).reshape(40, 40)
    assert row[10, 10:25].all() and row.sum() == 15 + 1
    assert evidence.bridged(ev, 0.5).sum() == 3


def test_scans_that_see_nothing_are_refused_clearly():
    # every beam without a return (or ending within cross_margin of the sensor) crosses no cell:
    # gather once failed on the empty batch with an IndexError, not the map's own error
    bearings = np.linspace(-np.pi / 2, np.pi / 2, 181)
    for r in (81.83, 0.1):
        scans = [Scan(np.full(181, r), bearings, np.zeros(3), float(t), 81.83) for t in range(3)]
        with pytest.raises(GeometryError, match="no free space"):
            build_map(scans)
