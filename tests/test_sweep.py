"""The sweep by the single normal vertex method (thesis 4.1.2): Table 4.1, lines, proper polygons."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from _fuzzy_shapes import TABLE_4_1, TABLE_4_1_VERTICES, dumbbell
from fuzzybrep.errors import GeometryError
from fuzzybrep.sweep import (band_folds, band_parameter, free_space, in_hull, normal_vertices, parametric_lines,
                             proper_polygon, swept_hulls)


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
