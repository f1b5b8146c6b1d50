"""Truthful free space: what other scans saw, and when, decides how far each ray is free."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import shapely
import shapely.affinity
from hypothesis import given, settings
from hypothesis import strategies as st
from _synthetic import room, scan_of

from fuzzybrep.mapping import bridge, evidence
from fuzzybrep.mapping.own_surface import own_margins
from fuzzybrep.mapping import build
from fuzzybrep.mapping.build import BuildConfig, build_map, rays_of
from fuzzybrep.errors import GeometryError
from fuzzybrep.mapping.scan_polygon import PolygonConfig
from fuzzybrep.scans.filters import BeamConfig, classify_all
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


def occupied_by_definition(rays, ev, cfg) -> np.ndarray:
    """Steps 1-3 of the evidence, ray by ray with sets and dicts: hits with the time last seen;
    every ray's distinct cells short of its end, counted, and those newer than the newest hit in
    the 3 x 3 neighbourhood; occupied = hit, not cleared, solid. The cells of a ray's samples are
    gather's own (_sample_cells), so that this checks what is counted, not the sampling."""
    ranks = evidence.time_ranks(rays.origin_time)
    rank = rays.spread(ranks)
    hits, last = {}, {}
    for c, r in zip(ev.cell_index(rays.hx, rays.hy), rank[rays.hit]):
        hits[int(c)] = hits.get(int(c), 0) + 1
        last[int(c)] = max(last.get(int(c), 0), int(r))
    g = evidence._grid_rays(rays, ev, cfg.step)
    count = evidence._sample_counts(rays.length, cfg.step)
    short = evidence._samples_short_of(rays.length - cfg.cross_margin, cfg.step, count)
    ray, k, cells = evidence._sample_cells(g, ev.cells, count, 0, len(count))
    crossings = {}  # ray -> its distinct cells short of its end
    for r, kk, c in zip(ray, k, cells):
        if kk < short[r]:
            crossings.setdefault(int(r), set()).add(int(c))
    occupied = np.zeros(len(ev.hits), bool)
    for c, h in hits.items():
        if c < evidence.TILE**2:  # the scratch tile: far from every ray
            continue
        (cx,), (cy,) = ev.cells.xy(np.array([c]))
        around = [int(ev.cells.index(np.array([cx + dx]), np.array([cy + dy]))[0])
                  for dx in (-1, 0, 1) for dy in (-1, 0, 1)]
        newest = max(last.get(n, 0) for n in around)
        near_hits = sum(hits.get(n, 0) for n in set(around))
        crossed = sum(c in cs for cs in crossings.values())
        after = sum(c in cs and rank[r] > newest for r, cs in crossings.items())
        cleared = after >= cfg.clear_crossings and after > near_hits
        solid = h >= cfg.solid_hits or h >= cfg.block_ratio * crossed
        occupied[c] = not cleared and solid
    return occupied


def test_gather_counts_what_clears_a_cell_as_its_definition_does():
    # the person who walks away and the box put down later, with pose noise: every hit cell's
    # crossings, those newer than the hits near it, and the solid test, cell by cell
    scans = walk_by(obstacle_times=range(0, 5)) + walk_by(obstacle_times=range(20, 30))[12:]
    rng = np.random.default_rng(3)
    scans = [dataclasses.replace(s, pose=s.pose + rng.normal(0, 0.01, 3), timestamp=float(i))
             for i, s in enumerate(scans[::2])]
    cfg = evidence.EvidenceConfig()
    rays = rays_of(scans, classify_all(scans, BeamConfig()))
    ev = evidence.gather(rays, cfg)
    want = occupied_by_definition(rays, ev, cfg)
    assert want.sum() > 50 and (ev.hits > 0).sum() > want.sum()  # some hit cells were cleared or not solid
    np.testing.assert_array_equal(ev.occupied, want)


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


@settings(deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(3, 14), st.integers(3, 14), st.floats(0.05, 0.6))
def test_bridged_is_every_segment_between_two_occupied_cells_within_the_span(seed, nx, ny, span):
    # the definition, pair by pair: each segment from the cell first in row order to the other,
    # rounded at every half cell along its longer axis; cells on the grid's edges included
    rng = np.random.default_rng(seed)
    occupied = rng.random(nx * ny) < rng.uniform(0.02, 0.3)
    ev = evidence.Evidence(np.zeros(2), 0.05, (ny, nx), occupied.astype(np.int32), occupied)
    assert np.array_equal(evidence.bridged(ev, span), bridge_by_pairs(occupied, nx, span))


def bridge_by_pairs(occupied: np.ndarray, nx: int, span: float, cell: float = 0.05) -> np.ndarray:
    """bridged's definition, pair by pair: each segment from the cell first in row order to the
    other, rounded at every half cell along its longer axis."""
    want = occupied.copy()
    iy, ix = np.divmod(np.flatnonzero(occupied), nx)
    for i in range(len(ix)):
        for j in range(i + 1, len(ix)):
            dx, dy = ix[j] - ix[i], iy[j] - iy[i]
            n = 2 * max(abs(dx), abs(dy))
            if n > 2 and np.hypot(dx, dy) <= span / cell:
                t = np.arange(1, n) / n
                want[np.rint(iy[i] + t * dy).astype(int) * nx + np.rint(ix[i] + t * dx).astype(int)] = True
    return want


@pytest.mark.parametrize("seed, threads", [(0, False), (1, False), (2, True), (3, True)])
def test_bridged_is_its_definition_over_a_metre_where_halves_round_unevenly(seed, threads, monkeypatch):
    # a 1 m span is 20 cells: displacements of 11, 13 and 19 cells have steps t·d that are a
    # half only to within rounding (15/22 · 11 = 7.4999...), which bridged rounds cell by cell;
    # a wide frame (the occupied cells far from 0) and both parities of the first cell
    rng = np.random.default_rng(seed)
    ny, nx = 50, 300
    occupied = np.zeros(ny * nx, bool)
    occupied[rng.choice(ny * nx, 140, replace=False)] = True
    for x0, y0 in ((250, 3), (251, 4), (40, 7), (41, 8)):  # pairs 11, 13, 19 apart along both axes and diagonally
        for d in (11, 13, 19):
            occupied[[y0 * nx + x0, y0 * nx + x0 + d, (y0 + d) * nx + x0, (y0 + d) * nx + x0 + d]] = True
    ev = evidence.Evidence(np.zeros(2), 0.05, (ny, nx), occupied.astype(np.int32), occupied)
    if threads:  # the displacements split between two threads, as for a large log's many cells
        monkeypatch.setattr(evidence.os, "cpu_count", lambda: 2)
        monkeypatch.setattr(bridge, "THREADS_FROM", 0)
    assert np.array_equal(evidence.bridged(ev, 1.0), bridge_by_pairs(occupied, nx, 1.0))


def test_scans_that_see_nothing_are_refused_clearly():
    # every beam without a return (or ending within cross_margin of the sensor) crosses no cell:
    # gather once failed on the empty batch with an IndexError, not the map's own error
    bearings = np.linspace(-np.pi / 2, np.pi / 2, 181)
    no_footprint = dataclasses.replace(BuildConfig(), polygon=PolygonConfig(footprint=0.0))
    for r in (81.83, 0.1):
        scans = [Scan(np.full(181, r), bearings, np.zeros(3), float(t), 81.83) for t in range(3)]
        with pytest.raises(GeometryError, match="no free space"):
            build_map(scans, no_footprint)
    # with the robot's footprint (the default) where it stood is free, and nothing else
    assert build_map(scans).crisp.area == pytest.approx(np.pi / 2 * (0.1 ** 2 + 0.3 ** 2), rel=0.1)


# ------------------------------------------------------------------------- the rules of steps 2-5, by hand
# Rays along +x on the row y = 0.025; with a ray from x = 0 the grid's origin is (-0.1, ...) and cell
# k spans x in [0.05 (k - 2), 0.05 (k - 1)): the obstacle O is the cell [2.0, 2.05), hit at x = 2.02.


def row_rays(*specs):
    """Rays along +x: each (time, hit_at or None, length, ox, y); a None hit claims ``length`` free."""
    t, hit_at, length, ox, y = (np.array(z, dtype=object) for z in zip(*specs))
    hit = np.array([h is not None for h in hit_at])
    hit_range = np.array([h - o if h is not None else 8.0 for h, o in zip(hit_at, ox)], float)
    n = len(specs)
    return evidence.Rays(ox.astype(float), y.astype(float), np.ones(n), np.zeros(n), length.astype(float),
                         t.astype(float), hit, hit_range)


def hit_at(x, t, y=0.025):
    return (t, x, x, 0.0, y)


def passing(t, end=4.0, ox=0.0, y=0.025):
    return (t, end, end - ox, ox, y)


def occupied_at(rays, cfg, x, y=0.025) -> bool:
    ev = evidence.gather(rays, cfg)
    return bool(ev.occupied[ev.cell_index(np.array([x]), np.array([y]))][0])


def test_an_obstacle_is_cleared_by_clear_crossings_later_rays_and_more_than_its_hits():
    cfg = evidence.EvidenceConfig()
    assert cfg.clear_crossings == 3
    # one hit, then 2 or 3 later rays through it
    assert occupied_at(row_rays(hit_at(2.02, 0), *(passing(t) for t in (1, 2))), cfg, 2.02)
    assert not occupied_at(row_rays(hit_at(2.02, 0), *(passing(t) for t in (1, 2, 3))), cfg, 2.02)
    # four hits need more than four later crossings, even though 3 reach clear_crossings
    four = [hit_at(2.02, 0)] * 4
    assert occupied_at(row_rays(*four, *(passing(t) for t in (1, 2, 3, 4))), cfg, 2.02)
    assert not occupied_at(row_rays(*four, *(passing(t) for t in (1, 2, 3, 4, 5))), cfg, 2.02)
    # hits and crossings are counted exactly: the 3 x 3 hit sum was a float mean × 9, and 11 hits
    # came to 10.999999999999998, so that 11 crossings cleared them
    eleven = [hit_at(2.02, 0)] * 11
    assert occupied_at(row_rays(*eleven, *(passing(t) for t in range(1, 12))), cfg, 2.02)
    assert not occupied_at(row_rays(*eleven, *(passing(t) for t in range(1, 13))), cfg, 2.02)


def test_only_crossings_after_the_last_hit_nearby_clear():
    cfg = evidence.EvidenceConfig()
    # rays of the same time as the hit (the same scan) are not "afterwards"
    assert occupied_at(row_rays(hit_at(2.02, 5), *(passing(5) for _ in range(4))), cfg, 2.02)
    # a newer hit in the 3 x 3 neighbourhood (the cell above, y = 0.075) keeps O: the rays grazed it
    rays = row_rays(hit_at(2.02, 0), hit_at(2.02, 9, y=0.075), *(passing(t) for t in (1, 2, 3, 4)))
    assert occupied_at(rays, cfg, 2.02)
    assert not occupied_at(row_rays(hit_at(2.02, 0), hit_at(2.02, 9, y=0.175), *(passing(t) for t in (1, 2, 3, 4))),
                           cfg, 2.02)  # two cells away is not next to it


def test_a_ray_crosses_a_cell_once_however_many_samples_it_has_there():
    # sampled every 1 cm, one later ray has 5 samples in O: still one crossing, short of clear_crossings
    fine = evidence.EvidenceConfig(step=0.01)
    assert occupied_at(row_rays(hit_at(2.02, 0), passing(1)), fine, 2.02)
    assert not occupied_at(row_rays(hit_at(2.02, 0), *(passing(t) for t in (1, 2, 3))), fine, 2.02)
    # three rays one after another that each cross only O (the robot has driven onto the spot) are
    # three crossings, not one
    cfg = evidence.EvidenceConfig()
    short = [passing(t, end=2.2, ox=2.01) for t in (1, 2, 3)]  # 0.19 long: only their first sample crosses
    assert not occupied_at(row_rays(hit_at(2.02, 0), *short), cfg, 2.02)


def test_a_cell_within_cross_margin_of_a_rays_end_is_not_crossed_by_it():
    cfg = evidence.EvidenceConfig()
    # later rays returning at x = 2.13: O's near face is 0.13 < cross_margin (0.15) before their end
    assert occupied_at(row_rays(hit_at(2.02, 0), *(passing(t, end=2.13) for t in (1, 2, 3, 4))), cfg, 2.02)
    assert not occupied_at(row_rays(hit_at(2.02, 0), *(passing(t, end=2.25) for t in (1, 2, 3, 4))), cfg, 2.02)


def test_evidence_of_standing_is_solid_hits_or_block_ratio_of_its_crossings():
    cfg = evidence.EvidenceConfig()
    assert (cfg.solid_hits, cfg.block_ratio) == (3, 0.05)
    before = [passing(t) for t in range(40)]  # crossings before the hits: they clear nothing
    # 1 hit < 0.05 x 40 crossings: noise; 2 hits >= 0.05 x 40: standing
    assert not occupied_at(row_rays(*before, hit_at(2.02, 50)), cfg, 2.02)
    assert occupied_at(row_rays(*before, *[hit_at(2.02, 50)] * 2), cfg, 2.02)
    # 3 hits stand however many rays crossed first
    many = [passing(t) for t in range(100)]
    assert not occupied_at(row_rays(*many, *[hit_at(2.02, 150)] * 2), cfg, 2.02)
    assert occupied_at(row_rays(*many, *[hit_at(2.02, 150)] * 3), cfg, 2.02)


def test_a_return_is_clipped_short_of_the_occupied_cell_it_would_enter():
    cfg = evidence.EvidenceConfig(clear=False)
    rays = row_rays(hit_at(2.02, 0), passing(1, ox=0.03))
    free = evidence.clip(rays, evidence.gather(rays, cfg), cfg)
    assert free[0] == pytest.approx(2.02)  # its own return: no conflict
    end = 0.03 + free[1]
    assert 2.0 - 2 * cfg.step <= end <= 2.0  # stops at O's near face [2.0, 2.05), never inside it


def test_the_bridge_stops_only_beams_without_a_return():
    # a returned beam through the gap in a pane is judged on the cells it crossed, also when a
    # no-return beam elsewhere makes the bridge be built
    cfg = evidence.EvidenceConfig(clear=False, no_return_bridge=1.0)
    pane = [(t, 2.0, 2.0, 0.0, y) for t, y in enumerate((-0.6, -0.3, 0.3, 0.6))]
    rays = row_rays(*pane, (10, 3.0, 3.0, 0.0, 0.0), (11, None, 3.5, 0.0, 0.01))
    free = evidence.clip(rays, evidence.gather(rays, cfg), cfg)
    assert free[4] == 3.0
    assert 1.9 <= free[5] <= 2.05


def test_samples_short_of_counts_k_with_k_step_below_x():
    # ceil(x / step) is one too many where x / step rounds up past an integer: 3 · 0.05 / 0.05 = 3.0000000000000004
    for step in (0.05, 0.1, 0.03):
        x = np.r_[np.arange(200) * step, np.arange(200) * step + step / 2, -1.0]
        count = np.full(len(x), 150)
        want = [min(sum(k * step < xi for k in range(150)), 150) for xi in x]
        np.testing.assert_array_equal(evidence._samples_short_of(x, step, count), want)


def test_carve_cuts_out_only_solidly_hit_occupied_cells_deep_inside_the_free_space():
    cell = 0.05
    ev = evidence.Evidence(np.zeros(2), cell, (40, 40), np.zeros(1600, np.int32), np.zeros(1600, bool))
    free = shapely.box(0.0, 0.0, 2.0, 2.0)
    centre = lambda ix, iy: ((ix + 0.5) * cell, (iy + 0.5) * cell)  # noqa: E731
    for (ix, iy), h in {(20, 20): 3, (10, 10): 2, (30, 1): 5, (5, 30): 9}.items():
        ev.hits[iy * 40 + ix] = h
        ev.occupied[iy * 40 + ix] = True
    cfg = evidence.EvidenceConfig()
    assert (cfg.carve_hits, cfg.carve_depth) == (3, 0.10)
    cut = evidence.carve(free, ev, cfg)
    # (20, 20) hit carve_hits times, deep inside: cut; (10, 10) hit twice: kept; (30, 1) 0.075 from
    # the edge y = 0 (less than carve_depth): kept; (5, 30) deep inside: cut
    assert cut.area == pytest.approx(2 * cell**2)
    for c in ((20, 20), (5, 30)):
        assert cut.contains(shapely.Point(*centre(*c)))
    for c in ((10, 10), (30, 1)):
        assert not cut.intersects(shapely.Point(*centre(*c)))


@settings(deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 30), st.integers(0, 200), st.floats(0.01, 2.0))
def test_within_is_the_distance_to_the_nearest_point_below_the_radius(seed, k, n, radius):
    # carve's footprint test (scipy's KD-tree before), against every pair; points on a 0.05 grid
    # put some at exactly the radius, which is not within it
    rng = np.random.default_rng(seed)
    points = np.round(rng.uniform(-2, 2, (k, 2)) / 0.05) * 0.05
    x, y = (np.round(rng.uniform(-2.5, 2.5, (2, n)) / 0.05) * 0.05)
    d = np.hypot(x[:, None] - points[None, :, 0], y[:, None] - points[None, :, 1]) if k else np.full((n, 1), np.inf)
    np.testing.assert_array_equal(evidence.within(points, x, y, radius), (d < radius).any(axis=1))
    assert not evidence.within(np.zeros((1, 2)), np.array([0.3]), np.array([0.0]), 0.3).any()


def test_time_ranks_order_times_whether_sorted_or_not():
    t = np.array([3.5, 3.5, 7.0, 1.0, 7.0, 2.0])
    assert evidence.time_ranks(t).tolist() == [3, 3, 4, 1, 4, 2]
    s = np.sort(t)
    assert evidence.time_ranks(s).tolist() == [1, 2, 3, 3, 4, 4]  # the sorted path, no np.unique
    assert evidence.time_ranks(s).dtype == np.int32 and len(evidence.time_ranks(np.zeros(0))) == 0


@pytest.mark.parametrize("step", [0.05, 0.0002])  # 0.0002: rays of more than 32767 samples keep int32 steps
def test_clip_is_the_same_with_samples_cached_or_sampled_again(step):
    # a room with a pillar, scans from three places, every fourth beam with no return (claiming 8 m
    # of free space, so all its samples are kept): free ranges must not depend on what was cached
    world = room(6, 4).difference(shapely.box(2.9, 1.9, 3.1, 2.1))
    scans = [scan_of(world, (x, y, 0.2), n=91, fov=2 * np.pi * 90 / 91, t=float(k))
             for k, (x, y) in enumerate([(1, 1), (5, 3), (1.5, 3)])]
    scans = [dataclasses.replace(s, ranges=np.where(np.arange(len(s.ranges)) % 4 == 0, 60.0, s.ranges), max_range=60.0)
             for s in scans]
    rays = rays_of(scans, classify_all(scans, BeamConfig(no_return_free=8.0), PolygonConfig()))
    base = evidence.EvidenceConfig(step=step, chunk=200_000)
    free = [evidence.clip(rays, evidence.gather(rays, c), c)
            for c in (base, dataclasses.replace(base, cache=0), dataclasses.replace(base, cache=10**12))]
    assert (free[0] < rays.length).any()  # something was clipped
    np.testing.assert_array_equal(free[0], free[1])
    np.testing.assert_array_equal(free[0], free[2])


def test_rays_hold_a_scan_origin_and_time_once_and_give_the_same_evidence_as_rays_one_by_one():
    # scans of different beam counts, out of time order, one of them a person who leaves: the
    # evidence and free ranges of rays that share their scan's origin and time are those of the
    # same rays each with its own copy
    world = room(6, 4)
    person = world.difference(shapely.box(2.8, 1.8, 3.2, 2.2))
    spec = [(person, (1, 1), 91, 2.0), (world, (5, 3), 181, 0.0), (world, (1.5, 3), 46, 1.0), (world, (4, 1), 120, 3.0)]
    scans = [scan_of(w, (x, y, 0.3), n=n, fov=2 * np.pi * (n - 1) / n, t=t) for w, (x, y), n, t in spec]
    rays = rays_of(scans, classify_all(scans, BeamConfig(no_return_free=8.0), PolygonConfig()))
    assert len(rays.origin_x) == 4 and rays.per_scan.tolist() == [91, 181, 46, 120]
    assert rays.ox.tolist() == np.repeat([1.0, 5, 1.5, 4], [91, 181, 46, 120]).tolist()
    assert rays.time.tolist() == np.repeat([2.0, 0, 1, 3], [91, 181, 46, 120]).tolist()
    one_by_one = dataclasses.replace(rays, origin_x=rays.ox, origin_y=rays.oy, origin_time=rays.time, per_scan=None)
    cfg = evidence.EvidenceConfig()
    ev, ev1 = evidence.gather(rays, cfg), evidence.gather(one_by_one, cfg)
    assert ev.hits.sum() > 0 and ev.occupied.any()
    np.testing.assert_array_equal(ev.hits, ev1.hits)
    np.testing.assert_array_equal(ev.occupied, ev1.occupied)
    np.testing.assert_array_equal(evidence.clip(rays, ev, cfg), evidence.clip(one_by_one, ev1, cfg))


@pytest.mark.parametrize("no_return_free", [0.0, 8.0])
def test_rays_in_batches_give_the_evidence_and_free_ranges_of_all_rays_at_once(no_return_free):
    # 200 scans of 361 beams (72 200 rays) round a room with a pillar and a person who leaves,
    # every fourth beam of the first 100 without a return: made in batches of a few scans each (rays indexed by
    # two bytes in their batch), or in one batch of more than 65 536 rays (four bytes), the
    # evidence and each ray's free range are those of all rays at once
    world = room(6, 4).difference(shapely.box(2.9, 1.9, 3.1, 2.1))
    person = world.difference(shapely.box(1.4, 0.4, 1.6, 0.6))
    rng = np.random.default_rng(3)
    poses = np.column_stack((rng.uniform(0.8, 5.2, 200), rng.uniform(0.8, 3.2, 200), rng.uniform(-np.pi, np.pi, 200)))
    scans = [scan_of(person if k < 60 else world, p, n=361, fov=2 * np.pi * 360 / 361, t=float(k))
             for k, p in enumerate(poses)]
    scans = [dataclasses.replace(s, ranges=np.where((np.arange(len(s.ranges)) % 4 == 0) & (k < 100), 60.0, s.ranges),
                                 max_range=60.0) for k, s in enumerate(scans)]
    beams = classify_all(scans, BeamConfig(no_return_free=no_return_free, no_return_chord=no_return_free > 0),
                         PolygonConfig())
    cfg = evidence.EvidenceConfig(chunk=20_000)
    whole = rays_of(scans, beams)
    ev = evidence.gather(whole, cfg)
    free = evidence.clip(whole, ev, cfg)
    assert (free < whole.length - 1e-9).sum() > 100  # much was clipped
    for chunk in (20_000, 10**9):  # many small batches; one batch of all 72 200 rays
        c = dataclasses.replace(cfg, chunk=chunk)
        batches = build.ray_batches(scans, beams, c)
        assert (len(batches) > 10) if chunk == 20_000 else (len(batches) == 1)
        assert np.array_equal(np.concatenate([b.time for b in batches]), whole.time)
        ev_b = evidence.gather(batches, c, evidence.grid_frame(batches, c.cell))
        np.testing.assert_array_equal(ev_b.hits, ev.hits)
        np.testing.assert_array_equal(ev_b.occupied, ev.occupied)
        assert ev_b.claims == (no_return_free > 0) and ev_b.samples
        np.testing.assert_array_equal(evidence.clip(batches, ev_b, c), free)


@pytest.mark.parametrize("no_return_free", [0.0, 8.0])
def test_the_grid_stored_where_rays_pass_gives_the_evidence_of_the_whole_grid(monkeypatch, no_return_free):
    # two rooms 60 m apart, seen from inside, with returns 70 m out through a window (a far wall
    # no ray reaches, as outdoors): the frame spans all of it, the tiles only the rooms; hits,
    # occupied cells, edge-kind evidence and every free range are those of the whole grid
    world = shapely.union_all([room(6, 4).difference(shapely.box(2.9, 1.9, 3.1, 2.1)),
                               shapely.affinity.translate(room(6, 4), 60, 0), shapely.box(5, 1.9, 61, 2.1)])
    rng = np.random.default_rng(5)
    poses = np.column_stack((rng.uniform(0.8, 5.2, 60), rng.uniform(0.8, 3.2, 60), rng.uniform(-np.pi, np.pi, 60)))
    poses[30:, 0] += 60
    scans = [scan_of(world, p, n=181, fov=2 * np.pi * 180 / 181, t=float(k)) for k, p in enumerate(poses)]
    # a window: some beams of every scan return from 70 m away
    scans = [dataclasses.replace(s, ranges=np.where(np.arange(181) % 15 == 0, 70.0 + k % 3, s.ranges), max_range=81.0)
             for k, s in enumerate(scans)]
    beams = classify_all(scans, BeamConfig(no_return_free=no_return_free), PolygonConfig())
    cfg = evidence.EvidenceConfig(chunk=20_000)
    rays = build.ray_batches(scans, beams, cfg)
    frame = evidence.grid_frame(rays, cfg.cell)
    tiled = evidence.gather(rays, cfg, frame)
    free = evidence.clip(rays, tiled, cfg)
    with monkeypatch.context() as mp:
        mp.setattr(evidence.Cells, "where_rays_pass", classmethod(lambda cls, shape, *a: cls(shape)))
        whole = evidence.gather(rays, cfg, frame)
        np.testing.assert_array_equal(evidence.clip(rays, whole, cfg), free)
    assert whole.cells.tiles is None and tiled.cells.tiles is not None
    ny, nx = whole.shape
    assert tiled.cells.size < 0.3 * nx * ny  # the rooms and the tiles round them, not the 80 m frame
    cx, cy = np.meshgrid(np.arange(nx), np.arange(ny))
    k = tiled.cells.index(cx.ravel(), cy.ravel())
    stored = k >= evidence.TILE**2
    assert (free < np.concatenate([b.length for b in rays]) - 1e-9).sum() > 50  # evidence clipped rays
    # what is not stored are returns more than a tile from every ray (its free range)
    lost = np.flatnonzero((whole.hits > 0) & ~stored)
    xy = whole.origin + (np.c_[lost % nx, lost // nx] + 0.5) * cfg.cell
    ends = [np.c_[b.ox, b.oy, b.ox + b.length * b.cos, b.oy + b.length * b.sin] for b in rays]
    swept = shapely.multilinestrings(np.concatenate(ends).reshape(-1, 2, 2))
    assert len(lost) and shapely.distance(swept, shapely.points(xy)).min() > evidence.TILE * cfg.cell
    for name in ("hits", "occupied"):
        np.testing.assert_array_equal(getattr(tiled, name)[k][stored], getattr(whole, name)[stored])
    # beside the rays' ends (where the map's edges are) the hits nearby are the same
    e = np.concatenate(ends)[:, 2:]
    np.testing.assert_array_equal(tiled.hits_within(0.1)[tiled.cell_index(*e.T)], whole.hits_within(0.1)[whole.cell_index(*e.T)])
    assert not tiled.occupied[: evidence.TILE**2].any()  # the scratch tile


@pytest.mark.parametrize("no_return_free", [0.0, 3.0])
def test_the_bridge_looks_only_where_claiming_beams_pass_and_clips_them_the_same(no_return_free):
    # a room with a pillar, scans from many places, every fifth beam without a return: the claims
    # (the segments between neighbours, and no_return_free) are clipped by the bridge over the
    # blocks they pass through exactly as by the bridge over every occupied cell
    world = room(6, 4).difference(shapely.box(2.9, 1.9, 3.1, 2.1))
    rng = np.random.default_rng(5)
    scans = [scan_of(world, (x, y, h), n=181, t=float(k))
             for k, (x, y, h) in enumerate(zip(rng.uniform(0.8, 5.2, 60), rng.uniform(0.8, 3.2, 60), rng.uniform(-3, 3, 60)))]
    scans = [dataclasses.replace(s, ranges=np.where(np.arange(181) % 5 == 0, 8.0, s.ranges)) for s in scans]
    beams = classify_all(scans, BeamConfig(no_return_free=no_return_free))
    cfg = evidence.EvidenceConfig()
    rays = rays_of(scans, beams)
    ev = evidence.gather(rays, cfg)
    assert ev.claims and ev.claimed is not None and len(ev.claimed) > 0
    local = evidence.clip(rays, ev, cfg)
    ev = evidence.gather(rays, cfg)
    ev.claimed = None  # every occupied cell
    everywhere = evidence.clip(rays, ev, cfg)
    np.testing.assert_array_equal(local, everywhere)
    assert (local < rays.length - 1e-9).any()


POST = shapely.box(3.9, 2.65, 4.05, 2.75)


def grazing_beams(a: Scan, lo: float = 3.0, hi: float = 5.9) -> np.ndarray:
    """A's beams that end on the corridor's wall (y = 3) between x = lo and hi: 54° down to 10°
    incidence (below λ = 10° a surface is not taken for one, and they stop short as before)."""
    ang = a.pose[2] + a.bearings
    x, y = a.pose[0] + a.ranges * np.cos(ang), a.pose[1] + a.ranges * np.sin(ang)
    return np.flatnonzero((np.abs(y - 3.0) < 1e-6) & (x > lo) & (x < hi))


def corridor_passes(post: bool) -> tuple[list[Scan], Scan]:
    """Scan A, 0.7 m from a corridor's wall (y = 3), sees it at grazing angles; a later pass down
    the middle whose poses are 6 cm off towards A puts a copy of the wall 6 cm inside A's free
    space, and with ``post`` a post 0.3 m off the wall that stood only then."""
    corridor = shapely.box(0, 0, 20, 3)
    a = scan_of(corridor, (2.0, 2.3, 0.0), n=361, fov=np.pi, max_range=20.0, t=0)
    later = corridor.difference(POST) if post else corridor
    passes = [shifted(scan_of(later, (x, 1.5, np.pi / 2), n=361, fov=np.pi, max_range=20.0, t=1 + i), 0.0, -0.06)
              for i, x in enumerate(np.arange(3.0, 16.0, 0.5))]
    return [a, *passes], a


GRAZING = evidence.EvidenceConfig(own_margin=0.12, own_incidence=np.radians(10.0))


def free_ranges(scans: list[Scan], cfg: evidence.EvidenceConfig = GRAZING) -> np.ndarray:
    rays = rays_of(scans, classify_all(scans, BeamConfig(), PolygonConfig()))
    return evidence.clip(rays, evidence.gather(rays, cfg), cfg)


def test_a_wall_seen_at_a_grazing_angle_is_the_beams_own_surface():
    scans, a = corridor_passes(post=False)
    wall = grazing_beams(a)
    assert len(wall) > 20
    # the default, a margin along the beam, stops the grazing ones short
    plain = free_ranges(scans, evidence.EvidenceConfig())[: len(a.ranges)]
    assert (plain[wall] < a.ranges[wall] - 0.1).sum() > 5
    free = free_ranges(scans)[: len(a.ranges)]
    # the later pass's copy of the wall, 6 cm in front of it across (up to 0.35 m along these
    # beams), is the wall itself: every beam reaches it. With a margin of 0.15 m along the beam
    # the beams under 23° stopped short
    np.testing.assert_allclose(free[wall], a.ranges[wall], atol=1e-9)
    short = own_margins(rays_of([a], classify_all([a], BeamConfig(), PolygonConfig())),
                                 0.12, np.radians(10.0))[wall]
    ang = np.abs(a.bearings[wall])  # the wall runs along +x: the incidence is the bearing
    np.testing.assert_allclose(short, 0.12 / np.maximum(np.sin(ang), np.sin(np.radians(10.0))), rtol=0.02)


def test_what_stands_off_the_surface_still_stops_a_grazing_beam():
    scans, a = corridor_passes(post=True)
    free = free_ranges(scans)[: len(a.ranges)]
    ang = a.pose[2] + a.bearings
    wall = grazing_beams(a)
    ray = {i: shapely.LineString([a.pose[:2], a.pose[:2] + a.ranges[i] * np.array([np.cos(ang[i]), np.sin(ang[i])])])
           for i in wall}
    # the beams whose ray crosses the post where the later pass saw it (0.3 m off the wall,
    # put there after A) stop before it
    seen = shapely.affinity.translate(POST, 0.0, -0.06)
    through = [i for i in wall if seen.intersects(ray[i])]
    assert len(through) >= 2
    for i in through:
        end = a.pose[:2] + free[i] * np.array([np.cos(ang[i]), np.sin(ang[i])])
        assert end[0] <= 3.9 + 1e-9, (i, free[i], a.ranges[i])
    # the rest of the wall is reached
    rest = [i for i in wall if seen.distance(ray[i]) > 0.1]
    assert len(rest) > 10
    np.testing.assert_allclose(free[rest], a.ranges[rest], atol=1e-9)


def test_a_beam_without_a_neighbour_on_its_surface_keeps_the_plain_margin():
    # three rays of one scan: the middle one's neighbours see nothing; two scans' rays never
    # count as neighbours
    rays = evidence.Rays(np.zeros(2), np.zeros(2), np.cos([0.0, 0.01, 0.02, 0.0]), np.sin([0.0, 0.01, 0.02, 0.0]),
                         np.full(4, 5.0), np.zeros(2), np.array([False, True, False, True]),
                         np.array([8.0, 5.0, 8.0, 5.0]), np.array([3, 1]))
    np.testing.assert_array_equal(own_margins(rays, 0.12, np.radians(10.0)), np.full(4, 0.12))


def test_carve_close_makes_a_thin_wall_seen_from_both_sides_one_hole():
    # a free-standing 2 cm partition in a hall; the two sides' poses are 4 cm off towards it, so
    # their free space overlaps across it and only the carve keeps it. Cell by cell (the default),
    # its carved cells are a string of 5 cm boxes, most too small to stay holes: the wall is lost
    hall = shapely.box(0, 0, 8, 6)
    world = hall.difference(shapely.box(1.5, 2.99, 6.5, 3.01))
    rng = np.random.default_rng(1)
    south = [shifted(scan_of(world, (x, y, 0.0), n=721, fov=FULL, t=t), 0, 0.04)
             for t, (x, y) in enumerate(rng.uniform((1, 1), (7, 2.5), (8, 2)))]
    north = [shifted(scan_of(world, (x, y, 0.0), n=721, fov=FULL, t=10 + t), 0, -0.04)
             for t, (x, y) in enumerate(rng.uniform((1, 3.5), (7, 5), (8, 2)))]
    on_wall = shapely.points([(x, 3.0) for x in np.linspace(1.6, 6.4, 25)])

    def mapped(close):
        cfg = dataclasses.replace(BuildConfig(), evidence=evidence.EvidenceConfig(carve_close=close))
        return build_map(south + north, cfg).crisp

    cells = mapped(0.0)
    assert shapely.contains(cells.to_shapely(), on_wall).sum() > 10 and cells.n_holes > 20
    closed = mapped(0.10)
    assert not shapely.contains(closed.to_shapely(), on_wall).any()
    wall = max((shapely.Polygon(r.vertices) for reg in closed.regions for r in reg.holes), key=lambda h: h.area)
    assert wall.contains(on_wall).all() and closed.n_holes <= 3
    assert wall.area < 5.0 * 0.2  # a thin hole along the wall, not a block of the hall


def test_own_margins_take_scans_of_no_rays_in_their_stride():
    # per_scan with empty scans first, between and last: no neighbour across a scan's end
    cos, sin = np.cos([0.0, 0.01, 0.02, 0.0, 0.01]), np.sin([0.0, 0.01, 0.02, 0.0, 0.01])
    rays = evidence.Rays(np.zeros(5), np.zeros(5), cos, sin, np.full(5, 5.0), np.arange(5.0),
                         np.ones(5, bool), np.full(5, 5.0), np.array([0, 3, 0, 2, 0]))
    m = own_margins(rays, 0.12, np.radians(10.0))
    assert m.shape == (5,) and np.isfinite(m).all() and (m >= 0.12).all()
