"""Ground-truth scoring on hand-made geometry where the answers are known."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from fuzzybrep.sim.simulate import World
from fuzzybrep.sim.truth import (_merge_intervals, fraction_inside, fraction_within, hausdorff, length_inside, score,
                                 seen_walls)

# a 2 m wide, 0.1 m thick block 2 m in front of a robot at the origin facing +y; the room's own
# walls are 20 m away, beyond the laser's 8 m
BLOCK = shapely.box(-1, 2, 1, 2.1)
FACING_BLOCK = np.array([[0.0, 0.0, math.pi / 2]])
#: the outermost 1° beams hitting the block's face are at ±26°: tan 26.57° = 1/2
SEEN_FACE = 4 * math.tan(math.radians(26))


def block_world(glass: bool = False, at: float = 0.0) -> World:
    block = shapely.affinity.translate(BLOCK, yoff=at) if at else BLOCK
    free = shapely.orient_polygons(shapely.box(-20, -20, 20, 20).difference(block))
    return World(free, block.boundary if glass else shapely.MultiLineString())


def test_seen_walls_is_the_face_between_the_outermost_hits():
    seen = seen_walls(block_world(), FACING_BLOCK)
    assert seen.length == pytest.approx(SEEN_FACE, abs=1e-12)
    assert len(seen.geoms) == 1  # neighbouring beams' pieces merge into one
    x0, y0, x1, y1 = seen.bounds
    assert (y0, y1) == (2.0, 2.0) and (x0, x1) == pytest.approx((-SEEN_FACE / 2, SEEN_FACE / 2))


def test_seen_walls_limits_range_direction_and_glass():
    assert seen_walls(block_world(), np.array([[0.0, 0.0, -math.pi / 2]])).length == 0  # facing away
    assert seen_walls(block_world(at=6.5), FACING_BLOCK).length == 0  # face at 8.5 m: out of range
    assert seen_walls(block_world(glass=True), FACING_BLOCK).length == pytest.approx(SEEN_FACE)
    assert seen_walls(block_world(glass=True), FACING_BLOCK, glass="transparent").length == 0


def test_seen_walls_from_several_poses_counts_overlap_once():
    poses = np.array([[0.0, 0.0, math.pi / 2], [0.0, 0.0, math.pi / 2], [0.3, 0.0, math.pi / 2]])
    once = seen_walls(block_world(), poses[:1]).length
    both = seen_walls(block_world(), poses).length
    assert once < both < once + 0.3 + 0.05  # the shifted pose adds at most its shift and a beam gap


def test_fraction_inside_band():
    seen = seen_walls(block_world(), FACING_BLOCK)
    band = shapely.box(-0.5, 1.9, 2.0, 2.2)
    assert fraction_inside(seen, band) == pytest.approx((SEEN_FACE / 2 + 0.5) / SEEN_FACE)
    assert fraction_inside(seen, shapely.box(-5, 1.9, 5, 2.1)) == pytest.approx(1.0)
    assert math.isnan(fraction_inside(shapely.MultiLineString(), band))


def test_length_inside_counts_the_interior_only():
    walls = block_world().walls
    # the block's east half: 1 m of the south face, the 0.1 m east face, 1 m of the north face
    assert length_inside(walls, shapely.box(0, 1, 5, 3)) == pytest.approx(2.1)
    # a region whose edge runs along the block's south face holds none of it
    assert length_inside(walls, shapely.box(-1, 0, 1, 2)) == pytest.approx(0.0)


def test_fraction_within_distance():
    square = shapely.box(0, 0, 1, 1).boundary
    truth = shapely.LineString([(-5, -0.1), (5, -0.1)])
    # the bottom edge (1 m) and the lowest 0.1 m of both sides lie within 0.2 m of the truth
    assert fraction_within(square, truth, 0.2) == pytest.approx(1.2 / 4)
    assert fraction_within(square, truth, 5.0) == pytest.approx(1.0)


def test_hausdorff_finds_the_farthest_point_between_vertices():
    a = shapely.LineString([(0, 0), (10, 0)])
    b = shapely.MultiLineString([[(0, 1), (0, 2)], [(10, 1), (10, 2)]])
    # the farthest point of a is its middle, (5, 0), √26 from b; vertices alone see only 2
    assert shapely.hausdorff_distance(a, b) == pytest.approx(2.0)
    assert hausdorff(a, b) == pytest.approx(math.sqrt(26), abs=0.01)
    offset = shapely.LineString([(0, 0.3), (10, 0.3)])
    assert hausdorff(a, offset) == pytest.approx(0.3)
    assert hausdorff(a, shapely.LineString([(0, 0), (1, 0)])) == pytest.approx(9.0)
    # symmetric: the farthest point of either from the other
    assert hausdorff(shapely.LineString([(0, 0), (1, 0)]), a) == pytest.approx(9.0)


def test_pieces_of_wall_seen_apart_stay_apart():
    # on segment 3, [0, 0.3] and [0.2, 0.4] overlap: one piece; [0.6, 0.8] lies apart; segment 5 is its own
    ids, lo, hi = _merge_intervals(np.array([3, 5, 3, 3]), np.array([0.2, 0.1, 0.0, 0.6]), np.array([0.4, 0.2, 0.3, 0.8]))
    assert ids.tolist() == [3, 3, 5] and lo.tolist() == [0.0, 0.6, 0.1] and hi.tolist() == [0.4, 0.8, 0.2]


def test_score_perfect_and_shifted_maps():
    world = World(shapely.box(0, 0, 4, 4))
    poses = np.array([[2.0, 2.0, 0.0], [2.0, 2.0, math.pi]])
    perfect = score(world, poses, world.free, world.free.boundary.buffer(0.2), world.free.buffer(-0.2), 0.2)
    # all but, at each corner, the piece between the 44° beam and the corner on one wall (the 45°
    # beam hits the corner itself): 2 m · (1 - tan 44°), twice per corner side
    assert perfect.seen_wall_length == pytest.approx(16 - 8 * (1 - math.tan(math.radians(44))))
    assert perfect.support_coverage == pytest.approx(1.0)
    assert perfect.unsafe_wall_length == 0.0
    assert perfect.boundary_within_tme == pytest.approx(1.0)
    assert perfect.hausdorff < 0.1  # only the corner gaps

    shifted = shapely.affinity.translate(world.free, xoff=0.1)
    s = score(world, poses, shifted, shifted.boundary.buffer(0.05), shifted.buffer(-0.05), 0.2)
    # with a ±5 cm band, the side walls (0.1 m off) fall outside, the top and bottom mostly inside
    assert 0.4 < s.support_coverage < 0.5
    # the safe region now reaches past the true east wall: 3.9 m of it lies inside
    assert s.unsafe_wall_length == pytest.approx(3.9)
    assert s.boundary_within_tme == pytest.approx(1.0)
    assert s.hausdorff == pytest.approx(0.1, abs=0.1)
    assert s.hausdorff >= 0.1 - 1e-9
