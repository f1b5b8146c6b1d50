"""The vertex reduction ring by ring (union.simplify_rings): each ring reduced on its own, and every
clash between rings (a crossing, a touch, a hole leaving its shell) mended, so that the map keeps
its topology as GEOS's whole-polygon simplification does, without its cost in holes."""

from __future__ import annotations

import numpy as np
import shapely
from hypothesis import given, settings, strategies as st

from fuzzybrep.geometry import polygonal
from fuzzybrep.mapping import union


def rings_of(g):
    return [shapely.get_coordinates(r) for p in shapely.get_parts(g) for r in shapely.get_rings(p)]


def check_topology(before, after, tol):
    """Valid, the same rings in the same order, every ring's vertices a subset of its original's,
    each as close to its original as tol (or as GEOS's reduction of that ring alone, whose ring
    end can move it farther: up to 1.7 tol seen), and each ring on the same side of every other."""
    assert after.is_valid, shapely.is_valid_reason(after)
    rb, ra = rings_of(before), rings_of(after)
    assert len(rb) == len(ra)
    for b, a in zip(rb, ra):
        assert {tuple(p) for p in a} <= {tuple(p) for p in b}
        alone = shapely.simplify(shapely.Polygon(b), tol, preserve_topology=True).exterior
        far = lambda ring: shapely.distance(shapely.points(b), ring).max()  # noqa: E731
        assert far(shapely.LinearRing(a)) <= max(tol, far(alone)) * (1 + 1e-9)
    fb, fa = np.array([shapely.Polygon(r) for r in rb]), np.array([shapely.Polygon(r) for r in ra])
    for k in range(len(rb)):
        pt = shapely.points(ra[k][0])
        assert np.array_equal(shapely.contains_properly(fb, pt), shapely.contains_properly(fa, pt))


def test_a_hole_in_a_bay_the_shell_would_cut_off_stays_inside():
    # a shallow bay 4 cm deep holds a hole: reduced alone, the shell drops the bay (within 5 cm)
    # and the hole would lie outside it; the shell keeps enough of the bay to hold it
    shell = [(0, 0), (10, 0), (10, 5), (6, 5), (5, 5.04), (4, 5), (0, 5)]
    hole = [(4.9, 5.01), (5.1, 5.01), (5.1, 5.03), (4.9, 5.03)][::-1]
    g = shapely.Polygon(shell, [hole])
    alone = shapely.simplify(shapely.Polygon(shell), 0.05, preserve_topology=True)
    assert not alone.contains(shapely.Polygon(hole))  # the clash the repair must find
    out = union.simplify_rings(g, 0.05)
    check_topology(g, out, 0.05)
    assert len(out.interiors) == 1


def test_a_hole_beside_a_zigzag_wall_does_not_cross_it():
    # the wall's reduced chord would cut through the hole; a thin hole 2 cm from the wall
    zig = [(x, 0.04 * (k % 2)) for k, x in enumerate(np.linspace(0, 4, 41))]
    shell = [*zig, (4, 3), (0, 3)]
    hole = [(1.0, 0.05), (1.0, 0.3), (3.0, 0.3), (3.0, 0.05)]
    g = shapely.Polygon(shell, [hole])
    out = union.simplify_rings(g, 0.05)
    check_topology(g, out, 0.05)
    assert len(shapely.get_coordinates(out.exterior)) < len(shell) / 2  # still reduced away from the hole


def test_holes_touching_at_a_vertex_neither_cross_nor_part():
    # two jagged holes that share one vertex; reduced, they still meet there and nowhere else
    a = [(1, 1), (2, 1), (2.02, 1.5), (2, 2), (1.5, 2.03), (1, 2)]
    b = [(2, 2), (3, 2), (3.03, 2.5), (3, 3), (2.5, 2.97), (2, 3), (1.98, 2.5)]
    g = shapely.Polygon([(0, 0), (5, 0), (5, 5), (0, 5)], [a[::-1], b[::-1]])
    assert g.is_valid
    out = union.simplify_rings(g, 0.05)
    check_topology(g, out, 0.05)
    assert len(out.interiors) == 2


def test_a_piece_inside_a_hole_stays_inside_it():
    outer = shapely.Polygon([(0, 0), (10, 0), (10, 10), (0, 10)],
                            [[(2, 2), (2, 8), (5, 8.03), (8, 8), (8, 2)]])
    piece = shapely.Polygon([(4, 6), (6, 6), (6, 7.99), (5, 8.01), (4, 7.99)])
    g = shapely.MultiPolygon([outer, piece])
    assert g.is_valid
    out = union.simplify_rings(g, 0.05)
    check_topology(g, out, 0.05)


def test_the_same_map_as_geos_whole_polygon_simplification_where_nothing_clashes():
    rng = np.random.default_rng(3)
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    shell = np.c_[20 * np.cos(t), 20 * np.sin(t)] + rng.normal(0, 0.01, (400, 2))
    holes = [np.c_[x + 0.5 * np.cos(t[::20]), y + 0.5 * np.sin(t[::20])][::-1] + rng.normal(0, 0.01, (20, 2))
             for x in range(-10, 11, 4) for y in range(-10, 11, 4)]
    g = shapely.Polygon(shell, holes)
    out = union.simplify_rings(g, 0.05)
    whole = shapely.simplify(g, 0.05, preserve_topology=True)
    check_topology(g, out, 0.05)
    assert shapely.symmetric_difference(out, whole).area <= 1e-9 * g.area


@st.composite
def crowded(draw):
    """A jagged room crowded with jagged holes, many of them within the tolerance of each other
    and of the walls: where ring-by-ring reduction clashes most."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n = draw(st.integers(1, 30))
    side = 4.0
    t = np.linspace(0, 1, 60, endpoint=False)
    edge = lambda a, b: a + (b - a) * t[:, None]  # noqa: E731
    corners = np.array([(0, 0), (side, 0), (side, side), (0, side)], float)
    shell = np.vstack([edge(corners[k], corners[(k + 1) % 4]) for k in range(4)]) + rng.normal(0, 0.015, (240, 2))
    g = max(shapely.get_parts(shapely.make_valid(shapely.Polygon(shell))), key=lambda p: p.area)
    for _ in range(n):
        c = rng.uniform(0.05, side - 0.05, 2)
        a = np.sort(rng.uniform(0, 2 * np.pi, 12))
        r = rng.uniform(0.03, 0.3) * (1 + rng.normal(0, 0.1, 12))
        h = shapely.Polygon(c + np.c_[r * np.cos(a), r * np.sin(a)])
        if h.is_valid and g.is_valid and g.buffer(-0.005).contains(h):
            g = g.difference(h)
    return g


@settings(max_examples=60, deadline=None)
@given(crowded(), st.sampled_from([0.02, 0.05, 0.1]))
def test_any_crowded_map_keeps_its_topology(g, tol):
    g = polygonal(shapely.make_valid(g))
    out = union.simplify_rings(g, tol)
    check_topology(g, out, tol)


def test_a_hole_touching_another_at_a_vertex_is_not_swallowed_by_it():
    # hole A keeps its corner V, where hole B touches it; reduced alone, A's edge from V swings
    # over the shallow bay B lies in (3 cm deep at 5 cm), and B would lie inside A though no
    # edge crosses another (the folding the repair must find at a shared vertex)
    a = [(0, 1), (1, 0), (1.5, 0.03), (2, 0), (3, 1)]
    b = [(1, 0), (1.3, 0.01), (1.2, 0.004)]
    g = shapely.Polygon([(-1, -1), (4, -1), (4, 2), (-1, 2)], [a, b])
    assert g.is_valid
    assert shapely.simplify(shapely.Polygon(a), 0.05, preserve_topology=True).contains(shapely.Polygon(b).centroid)
    out = union.simplify_rings(g, 0.05)
    check_topology(g, out, 0.05)
    assert len(out.interiors) == 2


def test_a_swallowed_hole_is_given_back_even_when_one_step_is_not_enough():
    # hole B lies in a shallow bay of hole A's wall: A's reduced wall swallows it; the bay's
    # farthest vertex (3, 0.04) does not give it back, the next step (0.5, 0.03) does
    a = [(0, 0), (0.5, 0.03), (1, 0.035), (1.5, 0.03), (3, 0.04), (4, 0), (4, 1), (0, 1)][::-1]
    b = [(0.95, 0.018), (1.05, 0.018), (1.0, 0.025)]
    g = shapely.Polygon([(-1, -1), (5, -1), (5, 2), (-1, 2)], [a, b])
    assert g.is_valid
    alone = shapely.simplify(shapely.Polygon(a), 0.05, preserve_topology=True)
    assert alone.contains(shapely.Polygon(b))
    out = union.simplify_rings(g, 0.05)
    check_topology(g, out, 0.05)
    assert len(out.interiors) == 2
