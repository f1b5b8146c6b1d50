"""The occupancy-grid baseline: inverse sensor model, exact traversal, clamping, ROS map out."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import example, given, settings
from hypothesis import strategies as st

from fuzzybrep import cli
from fuzzybrep.mapping import grid
from fuzzybrep.mapping.grid import (CLAMP, FREE, L_FREE, L_OCC, OCCUPIED, UNKNOWN, OccupancyGrid, cell_runs, logit,
                                    occupancy_grid, traverse_counts)
from fuzzybrep.formats.rosmap import grid_image, read_ros_map, write_grid
from fuzzybrep.scans.read import read_scans
from fuzzybrep.scans.scan import Scan
from fuzzybrep.sim.simulate import World, cast_rays

RES = 0.05
NO_CLAMP = (-math.inf, math.inf)
# walls through cell centres (x = 0.025 + 0.05 k), so no return lands on a cell boundary
BOX = (-1.975, -0.975, 2.025, 1.025)


def box_scans(poses, n=181, fov=2 * math.pi * 359 / 360, max_range=8.0, box=BOX):
    """Noise-free scans from inside a rectangular room (full turn unless fov says otherwise)."""
    world = World(shapely.box(*box), shapely.MultiLineString())
    b = np.linspace(-fov / 2, fov / 2, n)
    out = []
    for k, p in enumerate(poses):
        p = np.asarray(p, float)
        r, _ = cast_rays(world, np.tile(p[:2], (n, 1)), p[2] + b, max_range)
        out.append(Scan(np.minimum(r, max_range), b, p, float(k), max_range))
    return out


def walk_cells(ou, ov, eu, ev):
    """Reference traversal, Amanatides and Woo's loop: the cells from (ou, ov) to (eu, ev) in order."""
    ix, iy = math.floor(ou), math.floor(ov)
    ex, ey = math.floor(eu), math.floor(ev)
    du, dv = eu - ou, ev - ov
    sx, sy = (1 if du > 0 else -1), (1 if dv > 0 else -1)
    tx = ((ix + (sx > 0)) - ou) / du if du else math.inf
    ty = ((iy + (sy > 0)) - ov) / dv if dv else math.inf
    dx, dy = (abs(1 / du) if du else math.inf), (abs(1 / dv) if dv else math.inf)
    cells = [(ix, iy)]
    while (ix, iy) != (ex, ey):
        if tx < ty:
            ix, tx = ix + sx, tx + dx
        else:
            iy, ty = iy + sy, ty + dy
        cells.append((ix, iy))
        assert len(cells) < 100_000
    return cells


def reference_counts(scans, grid: OccupancyGrid, max_usable=8.0, no_return_free=0.0):
    """(hits, free passes) per cell by a loop over beams: the inverse sensor model read literally."""
    ny, nx = grid.shape
    hits, free = np.zeros((ny, nx), int), np.zeros((ny, nx), int)
    i0, j0 = grid.origin / grid.resolution
    for s in scans:
        for r, a, ret in zip(s.ranges, s.world_angles(), s.returns):
            hit = bool(ret and r <= max_usable)
            length = min(r, max_usable) if ret else min(no_return_free, max_usable)
            if not hit and length <= 0:
                continue
            ex, ey = s.pose[0] + length * math.cos(a), s.pose[1] + length * math.sin(a)
            cells = walk_cells(s.pose[0] / grid.resolution - i0, s.pose[1] / grid.resolution - j0,
                               ex / grid.resolution - i0, ey / grid.resolution - j0)
            if hit:
                hits[cells[-1][1], cells[-1][0]] += 1
                cells = cells[:-1]
            for ix, iy in cells:
                free[iy, ix] += 1
    return hits, free


# ------------------------------------------------------------------------- traversal


segments = st.tuples(st.floats(20, 80), st.floats(20, 80), st.floats(-math.pi, math.pi), st.floats(0, 15))


def floor(z):
    return np.floor(np.asarray(z, float)).astype(np.int64)


def runs_cells(ou, ov, eu, ev, xy: bool) -> list[tuple[int, int]]:
    """The (x, y) cells of one segment, from its runs of columns (``xy``) or of rows."""
    d = np.array([eu - ou, ev - ov]) / (math.hypot(eu - ou, ev - ov) or 1.0)
    u, v, du, dv, e = ((ou, ov, d[0], d[1], (eu, ev)) if xy else (ov, ou, d[1], d[0], (ev, eu)))
    line, lo, hi = cell_runs(*(np.array([z]) for z in (u, v, du, dv)), floor([u]), floor([v]), floor([e[0]]),
                             floor([e[1]]), xy=xy)
    cells = [(int(i), j) for i, a, b in zip(line, lo, hi) for j in range(int(a), int(b) + 1)]
    return cells if xy else [(j, i) for i, j in cells]


def assert_chain(cells, ou, ov, eu, ev):
    """A 4-connected chain from the start cell to the end cell, each cell once, each within
    rounding of the segment: what any exact traversal must give."""
    (x0, y0), (x1, y1) = (math.floor(ou), math.floor(ov)), (math.floor(eu), math.floor(ev))
    sx, sy = (1 if x1 >= x0 else -1), (1 if y1 >= y0 else -1)
    # along a monotone chain each step moves one cell towards the end
    ordered = sorted(cells, key=lambda c: sx * (c[0] - x0) + sy * (c[1] - y0))
    assert [sx * (x - x0) + sy * (y - y0) for x, y in ordered] == list(range(abs(x1 - x0) + abs(y1 - y0) + 1))
    assert ordered[0] == (x0, y0) and ordered[-1] == (x1, y1)
    assert all(abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1 for a, b in zip(ordered, ordered[1:]))
    seg = shapely.LineString([(ou, ov), (eu, ev)]) if (ou, ov) != (eu, ev) else shapely.Point(ou, ov)
    for x, y in cells:
        assert shapely.box(x, y, x + 1, y + 1).distance(seg) < 1e-9


def near_a_corner(ou, ov, eu, ev, eps=1e-9) -> bool:
    """Whether the segment passes within eps of a cell corner, where which boundary it crosses
    first is down to rounding (in the reference walk as much as in the code under test)."""
    xs = np.arange(math.floor(min(ou, eu)), math.floor(max(ou, eu)) + 2)
    ys = np.arange(math.floor(min(ov, ev)), math.floor(max(ov, ev)) + 2)
    corners = shapely.points(np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2))
    seg = shapely.LineString([(ou, ov), (eu, ev)]) if (ou, ov) != (eu, ev) else shapely.Point(ou, ov)
    return bool((shapely.distance(corners, seg) < eps).any())


@settings(max_examples=300, deadline=None)
@given(st.lists(segments, min_size=1, max_size=20))
# starts on the line x = 20 within 1.4e-14 of the corner (20, 21): the textbook traversal, crossings
# of vertical and horizontal lines computed apart, gave the broken chain (20,20), (19,20), (20,21)
@example([(20.0, 20.999999999999986, 1.625, 1.0)])
@example([(47.0, 79.0000000001, -1.5707963267948977, 9.679958150012899)])  # x = 47 - 7e-15 at the end
def test_cell_runs_are_an_unbroken_chain_and_match_the_reference_walk(segs):
    ou, ov, a, length = (np.array(c, float) for c in zip(*segs))
    eu, ev = ou + length * np.cos(a), ov + length * np.sin(a)
    for k in range(len(segs)):
        want = walk_cells(ou[k], ov[k], eu[k], ev[k])
        for xy in (True, False):  # by columns and by rows
            got = runs_cells(ou[k], ov[k], eu[k], ev[k], xy)
            assert_chain(got, ou[k], ov[k], eu[k], ev[k])
            if not near_a_corner(ou[k], ov[k], eu[k], ev[k]):
                assert sorted(got) == sorted(want)


@settings(max_examples=100, deadline=None)
@given(st.lists(segments, min_size=1, max_size=40), st.sampled_from([1, 2]))
def test_traverse_counts_add_up_every_segments_cells(segs, workers):
    ou, ov, a, length = (np.array(c, float) for c in zip(*segs))
    du, dv = np.cos(a), np.sin(a)
    eu, ev = ou + length * du, ov + length * dv
    nx = ny = 100
    want = np.zeros(nx * ny, np.int64)
    for k in range(len(segs)):
        xy = abs(floor(ev[k]) - floor(ov[k])) > abs(floor(eu[k]) - floor(ou[k]))  # as traverse_counts takes it
        for x, y in runs_cells(ou[k], ov[k], eu[k], ev[k], bool(xy)):
            want[y * nx + x] += 1
    old, grid._CHUNK = grid._CHUNK, 7  # many batches, shared by the threads
    try:
        got = traverse_counts(ou, ov, eu, ev, du, dv, nx, ny, workers)
    finally:
        grid._CHUNK = old
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("xy", [True, False])
def test_cell_runs_stay_in_the_segments_cells_when_the_direction_is_off_by_rounding(xy):
    # as occupancy_grid gives them: direction (cos a, sin a), end = start + length·direction. From the
    # corner (55, 32) at 135° for 7√2 the end lands on the corner (48, 39), but (cos a, sin a) is not
    # exactly parallel to the segment, so where the runs end by the direction can stray past the end
    # cell's column: each cell must still be the segment's, once
    ou, ov, a, length = 55.0, 32.0, 2.3561944901923453, 9.899494936611665  # 135° (to 2e-16), 7√2
    du, dv = np.cos([a]), np.sin([a])
    eu, ev = ou + length * du, ov + length * dv
    u, v, du_, dv_, e = ((ou, ov, du, dv, (eu, ev)) if xy else (ov, ou, dv, du, (ev, eu)))
    line, lo, hi = cell_runs(np.array([u]), np.array([v]), du_, dv_, floor([u]), floor([v]), floor(e[0]),
                             floor(e[1]), xy=xy)
    cells = [(int(i), j) for i, p, q in zip(line, lo, hi) for j in range(int(p), int(q) + 1)]
    cells = cells if xy else [(j, i) for i, j in cells]
    assert len(set(cells)) == len(cells) == 15
    assert_chain(cells, ou, ov, eu[0], ev[0])


def test_segment_through_cell_corners_gives_a_four_connected_path_without_repeats():
    # from a cell corner at 45° the segment meets only corners: each is crossed as two steps,
    # the horizontal boundary first, whether the segment is taken by columns or by rows
    for xy in (True, False):
        cells = runs_cells(10.0, 10.0, 13.0, 13.0, xy)
        assert sorted(cells) == [(10, 10), (10, 11), (11, 11), (11, 12), (12, 12), (12, 13), (13, 13)]
        assert sorted(runs_cells(13.0, 13.0, 10.0, 10.0, xy)) == [(10, 10), (11, 10), (11, 11), (12, 11), (12, 12),
                                                                   (13, 12), (13, 13)]


# ------------------------------------------------------------------------- inverse sensor model


def test_cells_match_the_inverse_sensor_model_read_literally():
    scans = box_scans([(0.1, 0.05, 0.3), (-1.0, 0.4, 2.0), (1.3, -0.5, -1.2)], n=90)
    g = occupancy_grid(scans, RES, clamp=NO_CLAMP)
    hits, free = reference_counts(scans, g)
    assert hits.sum() == sum(int(s.returns.sum()) for s in scans)
    np.testing.assert_array_equal(g.logodds, (hits * L_OCC + free * L_FREE).astype(np.float32))


def test_room_is_free_inside_occupied_on_walls_unknown_outside():
    poses = [(x, y, h) for x in (-1.2, 0.0, 1.2) for y in (-0.4, 0.4) for h in (0.0, 1.0)]
    g = occupancy_grid(box_scans(poses), RES)
    x0, y0, x1, y1 = BOX
    xs, ys = np.meshgrid(np.arange(x0 + 0.1, x1 - 0.1, RES / 2), np.arange(y0 + 0.1, y1 - 0.1, RES / 2))
    assert (g.state_at(xs, ys) == FREE).all()
    # the walls are occupied: never free, and occupied nearly everywhere (a wall cell that rays
    # graze on their way to a neighbouring wall cell collects free passes as well as hits)
    t = np.linspace(0, 1, 200)[1:-1]
    walls = [(x0 + t * (x1 - x0), np.full_like(t, y0)), (x0 + t * (x1 - x0), np.full_like(t, y1)),
             (np.full_like(t, x0), y0 + t * (y1 - y0)), (np.full_like(t, x1), y0 + t * (y1 - y0))]
    on_walls = np.concatenate([g.state_at(wx, wy) for wx, wy in walls])
    assert not (on_walls == FREE).any()
    assert (on_walls == OCCUPIED).mean() > 0.95
    # just outside the walls nothing is known; far outside the grid neither
    assert (g.state_at(np.full_like(t, x1 + 0.06), y0 + t * (y1 - y0)) == UNKNOWN).all()
    assert g.state_at(100.0, 100.0) == UNKNOWN and g.probability_at(100.0, 100.0) == 0.5
    # free area is the room less its wall cells, to within one cell's width around
    inner = (x1 - x0 - RES) * (y1 - y0 - RES)
    assert g.free_area() == pytest.approx(inner, abs=2 * (x1 - x0 + y1 - y0) * RES)


def test_masks_partition_the_grid_and_memory_counts_cells():
    g = occupancy_grid(box_scans([(0.0, 0.0, 0.0), (0.5, 0.2, 1.0)]), RES)
    free, occ, unk = g.free(), g.occupied(), g.unknown()
    assert ((free.astype(int) + occ + unk) == 1).all()
    p = g.probability()
    assert (p[free] < g.free_thresh).all() and (p[occ] > g.occupied_thresh).all()
    assert ((p[unk] >= g.free_thresh) & (p[unk] <= g.occupied_thresh)).all()
    assert g.free_area() == pytest.approx(free.sum() * RES**2)
    ny, nx = g.shape
    assert g.cells == nx * ny and g.nbytes() == 4 * nx * ny and g.nbytes(1) == nx * ny
    np.testing.assert_array_equal(g.trinary() == FREE, free)
    # the origin lies on the lattice of cell corners, so grids of different logs line up
    np.testing.assert_allclose(g.origin / RES, np.round(g.origin / RES), atol=1e-9)


def test_log_odds_are_clamped():
    scans = box_scans([(0.0, 0.0, 0.0)] * 40)
    g = occupancy_grid(scans, RES)
    unclamped = occupancy_grid(scans, RES, clamp=NO_CLAMP)
    assert g.logodds.min() == np.float32(CLAMP[0]) and g.logodds.max() == np.float32(CLAMP[1])
    assert unclamped.logodds.min() < CLAMP[0] - 5 and unclamped.logodds.max() > CLAMP[1] + 5
    np.testing.assert_array_equal(g.logodds, unclamped.logodds.clip(*CLAMP))
    tight = occupancy_grid(scans, RES, clamp=(-1.0, 1.0))
    assert tight.logodds.min() == -1.0 and tight.logodds.max() == 1.0


def test_no_return_beams_mark_nothing_unless_asked():
    # a 10 m corridor seen with an 8 m laser: the beams along it have no return
    box = (-1.975, -0.975, 9.025, 1.025)
    scans = box_scans([(0.0, 0.0, 0.0)], n=361, box=box)
    along = scans[0].ranges[180]
    assert along == 8.0 and not scans[0].returns[180]
    g = occupancy_grid(scans, RES, clamp=NO_CLAMP)
    # straight ahead at 3 m: only the no-return beam passes there (its neighbours diverge)
    assert g.probability_at(3.0, 0.0) == 0.5
    assert g.state_at(7.9, 0.0) == UNKNOWN
    g2 = occupancy_grid(scans, RES, clamp=NO_CLAMP, no_return_free=5.0)
    assert g2.logodds[g2.cell_index(3.0, 0.0)[:2]] == np.float32(L_FREE)
    assert g2.probability_at(6.0, 0.0) == 0.5  # free only as far as claimed
    # no_return_free is capped at max_usable
    g3 = occupancy_grid(scans, RES, clamp=NO_CLAMP, no_return_free=50.0, max_usable=4.0)
    assert g3.probability_at(3.9, 0.0) < 0.5 and g3.probability_at(4.1, 0.0) == 0.5


def test_returns_beyond_max_usable_mark_free_space_up_to_it_and_no_hit():
    scans = [Scan(np.array([10.0]), np.array([0.0]), np.array([0.0, 0.0, 0.0]), 0.0, 80.0)]
    g = occupancy_grid(scans, RES, max_usable=8.0, clamp=NO_CLAMP)
    assert not g.occupied().any()
    assert g.probability_at(7.9, 0.0) < 0.5 and g.probability_at(8.1, 0.0) == 0.5
    assert g.probability_at(10.0, 0.0) == 0.5
    near = occupancy_grid(scans, RES, max_usable=12.0, clamp=NO_CLAMP)
    assert near.logodds[near.cell_index(10.0 + 1e-6, 0.0)[:2]] == np.float32(L_OCC)
    assert near.state_at(10.0 + RES / 2, 0.0) == OCCUPIED  # one hit (p = 0.7) is above occupied_thresh


def test_bad_parameters_and_scans_that_mark_nothing_are_refused():
    scans = box_scans([(0.0, 0.0, 0.0)])
    with pytest.raises(ValueError, match="resolution"):
        occupancy_grid(scans, 0.0)
    with pytest.raises(ValueError, match="max_usable"):
        occupancy_grid(scans, RES, max_usable=0.0)
    with pytest.raises(ValueError, match="clamp"):
        occupancy_grid(scans, RES, clamp=(0.5, 2.0))
    with pytest.raises(ValueError, match="l_occ"):
        occupancy_grid(scans, RES, l_occ=-1.0)
    blind = [Scan(np.full(5, 8.0), np.linspace(-1, 1, 5), np.zeros(3), 0.0, 8.0)]
    with pytest.raises(ValueError, match="no beam marks anything"):
        occupancy_grid(blind, RES)
    with pytest.raises(ValueError, match=r"cells at resolution 1e-05 is too large \(limit"):
        occupancy_grid(scans, 1e-5)  # before: NumPy asked for terabytes
    with pytest.raises(ValueError, match="free_thresh"):
        OccupancyGrid(np.zeros((2, 2)), (0, 0), RES, free_thresh=0.7)


def test_logit_and_thresholds():
    assert logit(0.5) == 0.0
    g = OccupancyGrid(np.array([[logit(0.1), 0.0, logit(0.9)]]), (0.0, 0.0), 1.0)
    np.testing.assert_array_equal(g.trinary(), [[FREE, UNKNOWN, OCCUPIED]])
    np.testing.assert_allclose(g.probability_at([0.5, 1.5, 2.5], [0.5] * 3), [0.1, 0.5, 0.9], rtol=1e-6)


def test_points_outside_the_grid_are_unknown_even_beside_a_known_edge_cell():
    # every edge cell known: a point just past an edge must not borrow the nearest edge cell's value
    g = OccupancyGrid(np.full((2, 3), logit(0.9)), (0.0, 0.0), 1.0)
    xs = np.array([3.0, 3.5, -0.5, 1.5, 1.5, 2.5])
    ys = np.array([0.5, 1.5, 0.5, 2.0, -0.01, 2.5])
    np.testing.assert_array_equal(g.probability_at(xs, ys), 0.5)
    assert (g.state_at(xs, ys) == UNKNOWN).all()
    assert (g.state_at([2.99, 0.0], [1.99, 0.0]) == OCCUPIED).all()  # the last cells are still inside


def test_the_grid_has_exactly_one_spare_unmarked_cell_on_each_side():
    g = occupancy_grid(box_scans([(0.1, 0.05, 0.3), (-1.0, 0.4, 2.0)]), RES, clamp=NO_CLAMP)
    marked = g.logodds != 0
    for edge in (marked[0], marked[-1], marked[:, 0], marked[:, -1]):
        assert not edge.any()
    for inner in (marked[1], marked[-2], marked[:, 1], marked[:, -2]):
        assert inner.any()


def test_a_return_exactly_at_max_usable_is_a_hit():
    # "beyond max_usable" is r > max_usable: a return at 8 m with max_usable = 8 m still hits
    scans = [Scan(np.array([8.0]), np.array([0.0]), np.array([0.0125, 0.0125, 0.0]), 0.0, 80.0)]
    g = occupancy_grid(scans, RES, max_usable=8.0, clamp=NO_CLAMP)
    assert g.logodds[g.cell_index(8.0125, 0.0125)[:2]] == np.float32(L_OCC)
    assert g.occupied().sum() == 1


# ------------------------------------------------------------------------- command


def test_grid_command_writes_the_map_server_pair(tmp_path, capsys):
    from fuzzybrep.scans.csvscans import write_csv

    scans = box_scans([(x, 0.0, 0.5 * x) for x in (-1.0, 0.0, 1.0)])
    write_csv(tmp_path / "room.csv", scans)
    rc = cli.main(["grid", str(tmp_path / "room.csv"), "--out", str(tmp_path / "out"), "--name", "room",
                   "--resolution", "0.05"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "cells" in out and "free area" in out and "bytes" in out
    m = read_ros_map(tmp_path / "out" / "room.yaml")
    g = occupancy_grid(read_scans(tmp_path / "room.csv"), 0.05)
    np.testing.assert_array_equal(m.image, grid_image(g))
    assert m.resolution == 0.05 and m.origin == (g.origin[0], g.origin[1], 0.0)
    assert (tmp_path / "out" / "room.pgm").is_file()


def test_grid_names_its_files_after_the_log_as_export_after_the_map(tmp_path, capsys):
    # issue 20: grid wrote map.pgm whatever the log, export NAME.pgm after the map file
    from fuzzybrep.commands.grid import log_stem
    from fuzzybrep.scans.csvscans import write_csv

    write_csv(tmp_path / "room-2.csv.gz", box_scans([(0.0, 0.0, 0.0)]))
    assert cli.main(["grid", str(tmp_path / "room-2.csv.gz"), "--out", str(tmp_path / "out")]) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["room-2.pgm", "room-2.yaml"]
    assert read_ros_map(tmp_path / "out" / "room-2.yaml").image_path.name == "room-2.pgm"
    assert [log_stem(n) for n in ("intel-corrected.log.gz", "run.bag", "b/metadata.yaml", "x.txt", ".gz")] == [
        "intel-corrected", "run", "b", "x", ".gz"]


def test_grid_command_refuses_bag_options_for_other_formats(tmp_path, capsys):
    from fuzzybrep.scans.csvscans import write_csv

    write_csv(tmp_path / "room.csv", box_scans([(0.0, 0.0, 0.0)]))
    assert cli.main(["grid", str(tmp_path / "room.csv"), "--out", str(tmp_path), "--scan-topic", "/scan"]) == 2
    assert "--scan-topic" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main(["grid", str(tmp_path / "room.csv"), "--out", str(tmp_path), "--resolution", "0"])


# ------------------------------------------------------------------------- real log

#: free area of the Intel lab's crisp B-rep map built from the same log with the same 8 m usable
#: range (fuzzybrep build at 01cabcc: 474.6 m²): the grid must tell the same story about free space
INTEL_FREE_AREA = 475.0


@pytest.mark.reallog
def test_intel_grid_free_area_and_round_trip(real_scans, tmp_path):
    scans = real_scans("intel")
    g = occupancy_grid(scans, 0.05)
    assert g.free_area() == pytest.approx(INTEL_FREE_AREA, rel=0.10)
    assert g.occupied().sum() > 5000  # walls all round the lab
    yaml_path, pgm_path = write_grid(tmp_path / "intel.yaml", g)
    m = read_ros_map(yaml_path)
    np.testing.assert_array_equal(m.image, grid_image(g))
    np.testing.assert_array_equal(m.occupancy(), g.trinary())
    assert pgm_path.stat().st_size < g.cells + 200  # one byte a cell plus the header


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(-3.2, 3.2)), min_size=1, max_size=4),
       st.floats(0.05, 0.5), st.floats(0.5, 4.0))
def test_the_grid_commands_size_check_agrees_with_the_grid_it_guards(poses, resolution, max_usable):
    # before: the check counted span / r + 3 cells where the grid can need + 4, so a grid one cell
    # over the limit passed the check and ended in occupancy_grid's bare ValueError
    from fuzzybrep.mapping import grid as grid_module
    from fuzzybrep.formats import rosmap
    from fuzzybrep.commands.grid import check_grid_size
    from fuzzybrep.errors import ScanValueError

    scans = [Scan(np.array([1.0, 2.5, 6.0, 3.0]), np.linspace(-1.5, 1.5, 4), np.array(p), float(k), 80.0)
             for k, p in enumerate(poses)]
    cells = occupancy_grid(scans, resolution, max_usable=max_usable).cells
    with pytest.MonkeyPatch.context() as mp:
        for module in (rosmap, grid_module):
            mp.setattr(module, "MAX_CELLS", cells)
        check_grid_size("a.log", scans, resolution, max_usable)
        occupancy_grid(scans, resolution, max_usable=max_usable)
        for module in (rosmap, grid_module):
            mp.setattr(module, "MAX_CELLS", cells - 1)
        with pytest.raises(ScanValueError, match="a.log: a grid at resolution .* over these scans would have"):
            check_grid_size("a.log", scans, resolution, max_usable)
