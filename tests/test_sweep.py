"""The sweep by the single normal vertex method (thesis 4.1.2): Table 4.1, lines, proper polygons."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from _fuzzy_shapes import TABLE_4_1, TABLE_4_1_VERTICES, dumbbell
from fuzzybrep.errors import GeometryError
from fuzzybrep.fuzzy.sweep import (band_folds, band_parameter, in_hull, normal_vertices, parametric_lines,
                                   proper_polygon, swept_hulls)
from fuzzybrep.geometry import clean, free_space, nests, orientation


def table_columns(lines):
    return np.column_stack((lines.vout, lines.vin, lines.T, lines.U, lines.V, lines.W))


def test_table_4_1_is_reproduced_from_its_eight_crisp_vertices():
    lines = parametric_lines(TABLE_4_1_VERTICES, 200.0, 200.0)
    np.testing.assert_allclose(table_columns(lines), TABLE_4_1, atol=0.05)


def test_table_4_1_in_either_vertex_order():
    """The thesis lists V1..V8 clockwise; IN is the ring's inside whatever the order."""
    rev = parametric_lines(TABLE_4_1_VERTICES[::-1], 200.0, 200.0)
    np.testing.assert_allclose(table_columns(rev)[::-1], TABLE_4_1, atol=0.05)
    poly = shapely.Polygon(TABLE_4_1_VERTICES)
    assert shapely.contains_xy(poly, *rev.vin.T).all()
    assert not shapely.intersects_xy(poly, *rev.vout.T).any()


def test_parametric_line_convention():
    """x = U + T·t, y = W + V·t: t = 0 inner support, 1 crisp vertex, 2 outer support."""
    lines = parametric_lines(TABLE_4_1_VERTICES, 200.0, 200.0)
    np.testing.assert_allclose(lines.at(0), lines.vin)
    assert np.array_equal(lines.at(1), TABLE_4_1_VERTICES)  # exactly the core
    np.testing.assert_allclose(lines.at(2), lines.vout)
    t = 0.3
    np.testing.assert_allclose(lines.at(t), np.column_stack((lines.U + lines.T * t, lines.W + lines.V * t)))
    # distance along the bisector, not perpendicular to the edges: V1 moves 141.42·√2 = 200
    assert np.hypot(*(lines.vin - TABLE_4_1_VERTICES).T) == pytest.approx(np.full(8, 200.0))


def test_asymmetric_supports_keep_one_line():
    v = np.array([(0, 0), (10, 0), (10, 10), (0, 10)], float)
    lines = parametric_lines(v, 1.0, 3.0)
    assert lines.t_out == pytest.approx(np.full(4, 4.0))  # 1 + 3/1
    np.testing.assert_allclose(lines.at(lines.t_out), lines.vout)
    np.testing.assert_allclose(lines.outer(1.5), v - 1.5 * lines.bisector)
    np.testing.assert_allclose(lines.inner(0.5), v + 0.5 * lines.bisector)
    assert np.hypot(*(lines.vout - v).T) == pytest.approx(np.full(4, 3.0))


def test_collinear_vertex_moves_along_the_edge_normal():
    v = np.array([(0, 0), (5, 0), (10, 0), (10, 10), (0, 10)], float)
    b = normal_vertices(v)
    np.testing.assert_allclose(b[1], [0, 1], atol=1e-15)
    np.testing.assert_allclose(normal_vertices(v[::-1])[3], [0, 1], atol=1e-15)


def test_sharp_and_reflex_corners():
    # a 2° spike and a reflex notch: the bisector points into the polygon at both
    a = np.radians(1.0)
    spike = np.array([(0, 0), (10, 0), (10 - 10 * np.cos(a), 10 * np.sin(2 * a) / 2 + 0.2)], float)
    b = normal_vertices(spike)
    poly = shapely.Polygon(spike)
    assert shapely.contains_xy(poly, *(spike + 1e-3 * b).T).all()
    notch = np.array([(0, 0), (4, 0), (4, 4), (2, 1), (0, 4)], float)  # (2, 1) is reflex
    b = normal_vertices(notch)
    np.testing.assert_allclose(b[3], [0, -1], atol=1e-12)
    assert shapely.contains_xy(shapely.Polygon(notch), *(notch + 1e-3 * b).T).all()


def test_degenerate_rings_are_refused():
    with pytest.raises(GeometryError, match="no area"):
        normal_vertices(np.array([(0, 0), (1, 1), (2, 2)], float))
    with pytest.raises(GeometryError, match="vertex 2: repeats vertex 3") as e:
        normal_vertices(np.array([(0, 0), (1, 0), (1, 0), (0, 1)], float))
    assert e.value.vertex == 2
    with pytest.raises(GeometryError, match="positive"):
        parametric_lines(np.array([(0, 0), (1, 0), (0, 1)], float), 0.0, 1.0)


def test_simple_offset_is_its_own_proper_polygon():
    v = np.array([(0, 0), (10, 0), (10, 10), (0, 10)], float)
    lines = parametric_lines(v, 1.0, 1.0)
    pp = proper_polygon(v, lines.vin, +1, +1, kept=True)
    assert pp.simple and pp.vertex_kept.all() and pp.edge_kept.all()
    np.testing.assert_allclose(np.asarray(pp.geometry.exterior.coords)[:-1], lines.vin)


def test_self_intersecting_offset_is_made_proper():
    """A short edge between two convex corners inverts: the loop is removed, vertices are NULL."""
    v = np.array([(0, 0), (10, 0), (10, 9.5), (9.5, 10), (0, 10)], float)  # 0.7-long chamfer
    lines = parametric_lines(v, 2.0, 2.0)
    ring = shapely.LinearRing(lines.vin)
    assert not ring.is_simple  # the thesis's self-intersection test
    pp = proper_polygon(v, lines.vin, +1, +1, kept=True)
    assert not pp.simple
    g = pp.geometry
    assert g.is_valid and g.geom_type == "Polygon"
    assert g.within(shapely.Polygon(v))
    # no inverted loop survives: every point of the result is at least ~the offset inside
    assert shapely.Polygon(v).exterior.distance(g) >= 2.0 / np.sqrt(2) - 1e-9
    assert not pp.vertex_kept[2] and not pp.vertex_kept[3]  # the chamfer's ends: NULL
    assert pp.vertex_kept[[0, 1, 4]].all()
    assert not pp.edge_kept[2]  # the inverted chamfer edge is gone
    assert pp.edge_kept[[0, 4]].all()


def test_an_edge_that_only_touches_the_proper_polygon_does_not_survive():
    """Table 4.3: an offset edge survives where a stretch of it is proper boundary. Here the
    proper polygon is a triangle on inner edges 2 and 4; inner edge 1 ends at its surviving
    corner VIN2 at 4° to the triangle's third side, and none of it is boundary."""
    v = np.array([(10, 7), (2, 7), (2, 4), (0, 1)], float)
    lines = parametric_lines(v, 3.0, 3.0)
    pp = proper_polygon(v, lines.vin, +1, +1, kept=True)
    assert pp.geometry.geom_type == "Polygon" and len(pp.geometry.exterior.coords) == 4
    assert pp.vertex_kept.tolist() == [False, True, False, False]
    assert pp.edge_kept.tolist() == [False, True, False, True]


def test_offset_that_splits_gives_two_pieces():
    """Figure 4.9: the inner offset of two rooms joined by a narrow corridor splits."""
    room = dumbbell(0.5)
    v = np.asarray(room.exterior.coords)[:-1]
    lines = parametric_lines(v, 0.6, 0.6)
    pp = proper_polygon(v, lines.vin, +1, +1)
    assert pp.geometry.geom_type == "MultiPolygon" and len(pp.geometry.geoms) == 2
    assert pp.geometry.is_valid


def test_band_folds_where_the_normal_lines_cross():
    v = np.array([(0, 0), (10, 0), (10, 9.5), (9.5, 10), (0, 10)], float)
    lines = parametric_lines(v, 2.0, 2.0)
    folds = band_folds(v, lines.vin, +1)
    assert folds.tolist() == [False, False, True, False, False]
    assert not band_folds(v, lines.inner(0.2), +1).any()


def test_swept_hulls_shrink_as_the_offset_returns():
    v = np.array([(0, 0), (10, 0), (10, 9.5), (9.5, 10), (0, 10)], float)
    lines = parametric_lines(v, 2.0, 2.0)
    far, near = swept_hulls(v, lines.inner(2.0)), swept_hulls(v, lines.inner(1.0))
    assert all(n.difference(f).area < 1e-12 for f, n in zip(far, near))


def test_free_space_assembles_holes_without_overlay_when_valid():
    shell = shapely.box(0, 0, 10, 10)
    hole = shapely.box(4, 4, 5, 5)
    g = free_space([shell], [[hole]])
    assert g.equals(shapely.Polygon(shell.exterior, [hole.exterior]))
    touching = shapely.box(-1, 4, 5, 5)  # grown hole crosses the wall
    g = free_space([shell], [[touching]])
    assert g.is_valid and g.area == pytest.approx(100 - 5)


def test_band_parameter_solves_the_bilinear_band():
    c0, c1 = np.array([[0.0, 0.0]]), np.array([[4.0, 0.0]])
    a0, a1 = np.array([[1.0, 1.0]]), np.array([[-1.0, 1.0]])
    pts = np.array([[2.0, 0.5], [2.0, 0.0], [2.0, 1.0], [2.0, 1.5], [-1.0, 0.5]])
    u = band_parameter(pts, *(np.repeat(a, len(pts), 0) for a in (c0, c1, a0, a1)))
    np.testing.assert_allclose(u[:3], [0.5, 0.0, 1.0])
    assert np.isnan(u[3:]).all()


def test_in_hull():
    quad = np.array([[[0, 0], [4, 0], [3, 1], [1, 1]]], float)
    pts = np.array([[2, 0.5], [2, 0], [0, 0.5], [4, 1], [2, 1]])
    assert in_hull(pts, np.repeat(quad, len(pts), 0)).tolist() == [True, True, False, False, True]


def one(*arrays):
    return [np.array([a], float) for a in arrays]


def test_at_a_spike_the_bisector_points_back_along_the_spike():
    # a wall 2 long sticking out of the top of a square and back: at its tip (2, 6) the two
    # edge normals cancel and IN is back down the spike, towards the room
    v = np.array([(0, 0), (4, 0), (4, 4), (2, 4), (2, 6), (2, 4), (0, 4)], float)
    np.testing.assert_allclose(normal_vertices(v)[4], [0, -1], atol=1e-15)


def test_a_folded_band_with_a_simple_offset_ring_is_still_made_proper():
    # the inner offset (3 along the bisectors) of this small quadrilateral is a simple,
    # positively wound ring, but its bands fold over: taken as it is, 0.2 of it would lie
    # outside the crisp polygon; the proper polygon (crisp minus what the edges swept) lies within
    v = np.array([(3, 4), (4, 0), (7, 2), (4, 3)], float)
    own = orientation(v)
    lines = parametric_lines(v, 1.0, 1.0)
    p = lines.inner(3.0)
    assert shapely.LinearRing(p).is_simple and band_folds(v, p, own).any()
    pp = proper_polygon(v, p, own, +1)
    assert not pp.simple
    assert pp.geometry.is_empty or pp.geometry.within(shapely.Polygon(v))


def test_band_parameter_takes_the_first_pass_where_the_band_folds():
    # the segment from (3u, u) to (4 − 3u, 2u) passes through (1.5, 0.5) at u = 4/9 (λ = 1/8)
    # and again at u = 1/2 (λ = 0): 9u² − 8.5u + 2 = 0
    u = band_parameter(*one((1.5, 0.5), (0, 0), (4, 0), (3, 1), (-3, 2)))
    assert u[0] == pytest.approx(4 / 9)


def test_band_parameter_where_the_segment_collapses_to_a_point():
    # from (3u, u) to (4 − 3u, u): at u = 2/3 the segment is the point (2, 2/3); a point on its
    # line but off the band is not swept
    band = ((0, 0), (4, 0), (3, 1), (-3, 1))
    assert band_parameter(*one((2, 2 / 3), *band))[0] == pytest.approx(2 / 3)
    assert np.isnan(band_parameter(*one((5, 2 / 3), *band))[0])


def test_in_hull_of_a_degenerate_quad_is_its_segment():
    quad = np.array([[[0, 0], [1, 0], [2, 0], [3, 0]]], float)
    pts = np.array([[5, 0], [-1, 0], [1.5, 0], [1.5, 1e-3]])
    assert in_hull(pts, np.repeat(quad, len(pts), 0)).tolist() == [False, False, True, False]


def test_clean_repairs_nested_shells_and_drops_slivers():
    nested = shapely.MultiPolygon([shapely.box(0, 0, 10, 10), shapely.box(2, 2, 3, 3)])
    assert not nested.is_valid
    g = clean(nested)
    assert g.is_valid and g.area == pytest.approx(100)
    sliver = shapely.Polygon(shapely.box(0, 0, 10, 10).exterior.coords, [[(2, 2), (5, 2), (8, 2 + 1e-12)]])
    g = clean(sliver)
    assert g.geom_type == "Polygon" and len(g.interiors) == 0


def test_nests_needs_holes_strictly_inside():
    shell = shapely.box(0, 0, 10, 10)
    assert nests(shell, [shapely.box(1, 4, 2, 5), shapely.box(3, 4, 4, 5)])
    assert not nests(shell, [shapely.box(0, 4, 1, 5)])  # shares an edge with the shell
    assert not nests(shell, [shapely.box(1, 4, 3, 5), shapely.box(2, 4, 4, 5)])  # holes overlap


def test_free_space_keeps_valid_nested_rings_bit_for_bit():
    shell = shapely.Polygon([(0, 0), (10, 0), (10, 10), (0, 10)])
    hole = shapely.Polygon([(4, 4), (4, 5), (5, 5), (5, 4)])
    g = free_space([shell], [[hole]])
    assert np.array_equal(shapely.get_coordinates(g), shapely.get_coordinates(shapely.Polygon(shell.exterior, [hole.exterior])))
