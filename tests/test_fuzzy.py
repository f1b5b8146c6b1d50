"""The fuzzy B-rep map: fuzzify, Tables 4.1-4.3, α-cuts, membership, approximation error, Table 5.3."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from _fuzzy_shapes import TABLE_4_1, TABLE_4_1_VERTICES, crisp_maps, dumbbell, thesis_map
from fuzzybrep.brep import FRONTIER, OBSTACLE, BRepMap, Region, Ring
from fuzzybrep.errors import GeometryError, MapFileError, MembershipFunctionError
from fuzzybrep.fuzzy.map import FuzzyBRepMap, default_tme, fuzzify
from fuzzybrep.fuzzy.accuracy import approximation_error
from fuzzybrep.fuzzy.memory import memory_table
from fuzzybrep.formats.mapfile import MapFile, write_map
from fuzzybrep.fuzzy.membership import A4, DEFAULT_TME_M, MembershipTable, Triangular

AREA_TOL = 1e-7


def outside_area(a, b) -> float:
    """Area of a outside b, by snap-rounded overlay: a plain GEOS difference of two polygons equal
    up to the last bits was seen to return all of a."""
    if a.is_empty:
        return 0.0
    x0, y0, x1, y1 = shapely.union(a, b).bounds
    return float(shapely.area(shapely.difference(a, b, grid_size=1e-10 * max(x1 - x0, y1 - y0))))


def square(side=10.0, holes=()):
    return BRepMap.from_shapely(shapely.Polygon([(0, 0), (side, 0), (side, side), (0, side)], holes))


# -- fuzzify and the tables -------------------------------------------------------------------


def test_table_4_1_through_fuzzify():
    fz = fuzzify(thesis_map(), tme=200)
    t = fz.vertex_table(0)
    cols = np.column_stack([t[c] for c in ("XOUT", "YOUT", "XIN", "YIN", "T", "U", "V", "W")])
    np.testing.assert_allclose(cols, TABLE_4_1, atol=0.05)
    assert np.array_equal(np.column_stack((t["X"], t["Y"])), TABLE_4_1_VERTICES)
    assert t["FM"].tolist() == [1] * 8
    e = fz.edge_table(0)  # Table 4.3: no offset vertex deleted here
    assert e["VSTART"].tolist() == list(range(1, 9)) and e["VEND"].tolist() == [2, 3, 4, 5, 6, 7, 8, 1]
    assert e["EDGE_IN"].tolist() == e["EDGE_OUT"].tolist() == list(range(1, 9))
    assert fz.membership_table()[0]["PARAMETERS"].startswith("a = -200; b = 200; TME = 200")


def test_default_tme_is_the_thesis_one_in_the_map_unit():
    assert default_tme("m") == DEFAULT_TME_M
    assert default_tme("mm") == pytest.approx(199.13)
    fz = fuzzify(square())
    assert fz.table[1] == Triangular(DEFAULT_TME_M)
    with pytest.raises(MembershipFunctionError, match="no default TME for unit 'ft'"):
        fuzzify(BRepMap(square().regions, unit="ft"))
    with pytest.raises(MembershipFunctionError, match="either"):
        fuzzify(square(), Triangular(1), tme=1)


def test_fuzzify_refuses_invalid_maps_naming_the_vertex():
    bowtie = BRepMap((Region(Ring([(0, 0), (4, 0), (0, 4), (6, 4)])),))
    with pytest.raises(GeometryError, match="principal, vertex") as e:
        fuzzify(bowtie, tme=0.1)
    assert e.value.ring == "principal" and e.value.vertex in (2, 3)
    outside = BRepMap((Region(Ring([(0, 0), (4, 0), (4, 4), (0, 4)]), (Ring([(3, 3), (3, 5), (5, 5), (5, 3)]),)),))
    with pytest.raises(GeometryError, match="invalid region") as e:
        fuzzify(outside, tme=0.1)
    assert e.value.ring in ("principal", "hole 1") and e.value.vertex is not None
    bad_fm = BRepMap((Region(Ring([(0, 0), (4, 0), (4, 4), (0, 4)], fm=[1, 1, 2, 1])),))
    with pytest.raises(GeometryError, match="principal, vertex 3: FM index 2 has no membership function"):
        fuzzify(bad_fm, tme=0.1)


def test_tables_mark_deleted_vertices_null():
    v = np.array([(0, 0), (10, 0), (10, 9.5), (9.5, 10), (0, 10)], float)
    fz = fuzzify(BRepMap((Region(Ring(v)),)), tme=2.0)
    t = fz.vertex_table(0)
    assert np.isnan(t["XIN"][[2, 3]]).all() and np.isnan(t["YIN"][[2, 3]]).all()
    assert np.isfinite(t["XIN"][[0, 1, 4]]).all() and np.isfinite(t["XOUT"]).all()
    assert np.isfinite(t["T"]).all()  # the line stays: the vertex survives at higher α
    e = fz.edge_table(0)
    assert e["EDGE_IN"][2] == 0 and e["VIN_START"][2] == 0 and e["VIN_END"][1] == 0
    assert e["EDGE_IN"][0] == 1


def test_edge_table_4_3_of_inner_and_outer_deletions():
    # the 0.7-long chamfer between vertices 3 and 4 inverts in the inner offset (TME 2): its edge
    # and both its vertices are NULL, while edge 4, which starts at the deleted vertex 4, still
    # has a stretch on the inner boundary
    v = np.array([(0, 0), (10, 0), (10, 9.5), (9.5, 10), (0, 10)], float)
    e = fuzzify(BRepMap((Region(Ring(v)),)), tme=2.0).edge_table(0)
    assert e["EDGE_IN"].tolist() == [1, 2, 0, 4, 5]
    assert e["VIN_START"].tolist() == [1, 2, 0, 0, 5] and e["VIN_END"].tolist() == [2, 0, 0, 5, 1]
    # a notch 0.5 wide and 1 deep in the top wall is filled by the outer sweep (2 along the
    # bisectors): its bottom corners (vertices 5, 6) and its three edges are NULL in the outer table
    v = np.array([(0, 0), (10, 0), (10, 10), (5.5, 10), (5.5, 9), (5, 9), (5, 10), (0, 10)], float)
    e = fuzzify(BRepMap((Region(Ring(v)),)), tme=2.0).edge_table(0)
    assert e["EDGE_OUT"].tolist() == [1, 2, 3, 0, 0, 0, 7, 8]
    assert e["VOUT_START"].tolist() == [1, 2, 3, 4, 0, 0, 7, 8]
    assert e["VOUT_END"].tolist() == [2, 3, 4, 0, 0, 7, 8, 1]  # edge k ends where edge k + 1 starts
    assert e["EDGE_IN"].tolist() == list(range(1, 9))


def test_tables_of_a_long_folding_ring_take_linear_time():
    """Which offset vertices and edges survive is found through an index: a 24000-vertex wall
    whose bands fold everywhere (vertices 9 cm apart, ±3 cm of noise, TME 0.2) takes about a
    second; testing every edge against the whole boundary took a minute."""
    import time

    n = 24000
    angle = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = n * 0.094 / (2 * np.pi) + np.random.default_rng(1).uniform(-0.03, 0.03, n)
    fz = fuzzify(BRepMap((Region(Ring(np.column_stack((r * np.cos(angle), r * np.sin(angle))))),)), tme=0.2)
    t0 = time.perf_counter()
    t = fz.vertex_table(0)
    assert time.perf_counter() - t0 < 15
    assert np.isnan(t["XIN"]).any() and np.isfinite(t["XIN"]).any()  # the slow path was taken


def test_fuzzify_takes_linear_time_with_many_obstacles_along_a_long_wall():
    """A 100000-vertex wall round 12544 obstacles: checking each region with GEOS's is_valid
    (every hole against the whole wall) took 9 s; holes apart and inside the shell are valid
    and that is found through indexes, about half a second."""
    import time

    rng = np.random.default_rng(1)
    n, g = 100000, 112
    angle = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = g * 3 * 0.75 + rng.uniform(-0.03, 0.03, n)
    shell = Ring(np.column_stack((r * np.cos(angle), r * np.sin(angle))))
    a = (np.arange(8) + rng.uniform(0, 0.8, (g * g, 8))) * 2 * np.pi / 8
    rr = rng.uniform(0.2, 0.6, (g * g, 8))
    c = (np.stack(np.meshgrid(np.arange(g), np.arange(g)), -1).reshape(-1, 2) - g / 2) * 1.8
    holes = tuple(Ring(np.column_stack((cx + q * np.cos(t), cy + q * np.sin(t)))[::-1])
                  for (cx, cy), t, q in zip(c, a, rr))
    crisp = BRepMap((Region(shell, holes),))
    t0 = time.perf_counter()
    fuzzify(crisp, tme=0.2)
    assert time.perf_counter() - t0 < 2.5
    with pytest.raises(GeometryError, match="invalid region"):  # a hole across the wall is still found
        fuzzify(BRepMap((Region(shell, holes + (Ring([(0, r[0] - 1), (0, r[0] + 1), (1, r[0])]),)),)), tme=0.2)


def test_frontier_vertices_get_their_own_function():
    ring = Ring([(0, 0), (10, 0), (10, 10), (0, 10)], kinds=[OBSTACLE, FRONTIER, OBSTACLE, OBSTACLE])
    fz = fuzzify(BRepMap((Region(ring),)), tme=0.2, frontier_mf=Triangular(1.0))
    assert fz.table.indices == [1, 2]
    assert fz.crisp.principal.fm.tolist() == [1, 2, 2, 1]  # ends of the frontier edge
    assert fz.lines[0].support_in.tolist() == [0.2, 1.0, 1.0, 0.2]


# -- α-cuts ------------------------------------------------------------------------------------


def test_alpha_one_is_the_crisp_map():
    m = square(10, [[(2, 2), (2, 3), (3, 3), (3, 2)]])
    fz = fuzzify(m, tme=0.5)
    for method in ("sweep", "exact"):
        c = fz.alpha_cut(1.0, method)
        assert c.inner.equals(m.to_shapely()) and c.outer.equals(m.to_shapely())


def test_alpha_within_rounding_of_one_is_the_crisp_map():
    """At α = 1 − 2⁻⁵³ the offsets are 1e−16: the sweep moved the rings by an ulp, and GEOS then
    took the band (outer − inner) for the whole map, though μ < α off the crisp boundary."""
    tri = BRepMap((Region(Ring([(-0.5, 0.8660254), (-2, -3.4641016), (1, 0)])),))
    fz = fuzzify(tri, tme=1.0)
    for method in ("sweep", "exact"):
        c = fz.alpha_cut(np.nextafter(1.0, 0.0), method)
        assert c.inner.equals(tri.to_shapely()) and c.outer.equals(tri.to_shapely())
        assert c.band.area == 0
    assert fz.membership([[0.0, -0.5]])[0] < np.nextafter(1.0, 0.0)


def test_square_alpha_cuts_match_the_bisector_construction():
    fz = fuzzify(square(10), tme=1.0)
    c = fz.alpha_cut(0.0, "thesis")
    s = 1 / math.sqrt(2)  # perpendicular offset of a 90° corner moved 1 along its bisector
    assert c.inner.area == pytest.approx((10 - 2 * s) ** 2)
    assert c.outer.area == pytest.approx((10 + 2 * s) ** 2)
    e = fz.alpha_cut(0.0, "exact")
    assert e.inner.area == pytest.approx(64)
    assert e.outer.area == pytest.approx(100 + 40 + math.pi, rel=1e-3)


def test_holes_grow_into_free_space_in_the_inner_cut():
    m = square(10, [[(4, 4), (4, 6), (6, 6), (6, 4)]])
    fz = fuzzify(m, tme=0.5)
    c = fz.alpha_cut(0.0)
    hole_in_inner = shapely.Polygon(c.inner.interiors[0])
    hole_in_outer = shapely.Polygon(c.outer.interiors[0])
    assert hole_in_inner.area > 4 > hole_in_outer.area
    assert c.band.area == pytest.approx(c.outer.area - c.inner.area)


def test_narrow_corridor_splits_the_inner_cut_into_pieces():
    fz = fuzzify(BRepMap.from_shapely(dumbbell(0.5)), tme=0.6)
    c = fz.alpha_cut(0.0)
    assert c.inner.geom_type == "MultiPolygon" and len(c.inner.geoms) == 2
    pieces = c.inner_map()
    assert len(pieces.regions) == 2 and pieces.principal is not None
    assert fz.alpha_cut(0.9).inner.geom_type == "Polygon"  # at high α the corridor is open


def test_asymmetric_function_offsets_each_side_by_its_support():
    fz = fuzzify(square(10), Triangular(tme_in=1.0, tme_out=2.0))
    v = fz.crisp.principal.vertices
    shrink, grow = fz.offset_vertices(0.0)
    assert np.hypot(*(shrink - v).T) == pytest.approx(np.full(4, 1.0))
    assert np.hypot(*(grow - v).T) == pytest.approx(np.full(4, 2.0))
    shrink, grow = fz.offset_vertices(0.5)
    assert np.hypot(*(grow - v).T) == pytest.approx(np.full(4, 1.0))


def test_asymmetric_function_on_a_hole_offsets_each_side_by_its_support():
    # IN of a hole is into the obstacle, OUT into the free space: the inner cut grows the hole
    # by d_out, the outer cut shrinks it by d_in. Along the bisector of a square's corner a move
    # of d moves the edges by d/√2
    fz = fuzzify(square(10, holes=[[(4, 4), (6, 4), (6, 6), (4, 6)]]), Triangular(tme_in=0.5, tme_out=1.5))
    r = math.sqrt(2)
    for alpha in (0.0, 0.5):
        d_in, d_out = (1 - alpha) * 0.5, (1 - alpha) * 1.5
        cut = fz.alpha_cut(alpha, "thesis")
        assert cut.inner.area == pytest.approx((10 - r * d_in) ** 2 - (2 + r * d_out) ** 2)
        assert cut.outer.area == pytest.approx((10 + r * d_out) ** 2 - (2 - r * d_in) ** 2)


def test_sweep_membership_of_an_asymmetric_function_takes_each_side_from_its_support():
    # μ is the α whose α-cut edge passes through the point: inside, the wall's inner edge at α is
    # (1 − α)·0.5/√2 in, outside its outer edge (1 − α)·1.5/√2 out
    fz = fuzzify(square(10), Triangular(tme_in=0.5, tme_out=1.5))
    mu = fz.membership(np.array([[5, 0.25], [5, -0.25]]), "sweep")
    assert mu == pytest.approx([1 - 0.25 * math.sqrt(2) / 0.5, 1 - 0.25 * math.sqrt(2) / 1.5])


def assert_mu_is_the_bands(fz, pts, alphas):
    """μ ≥ α exactly where the α-cut's band is, for points not on the band's boundary."""
    mu = fz.membership(pts)
    for a in alphas:
        band = fz.alpha_cut(a).band
        clear = shapely.distance(shapely.boundary(band), shapely.points(pts)) > 1e-6
        inb = shapely.intersects_xy(band, pts[:, 0], pts[:, 1])
        assert np.array_equal((mu >= a)[clear], inb[clear])


def test_sweep_membership_agrees_with_the_alpha_cuts_where_bands_fold():
    # the chamfer's inner band folds over at TME 2: μ ≥ α exactly where the α-cut's band is
    v = np.array([(0, 0), (10, 0), (10, 9.5), (9.5, 10), (0, 10)], float)
    fz = fuzzify(BRepMap((Region(Ring(v)),)), tme=2.0)
    rng = np.random.default_rng(5)
    pts = rng.uniform(7, 11, (3000, 2))
    assert_mu_is_the_bands(fz, pts, (0.1, 0.3, 0.5))


def test_bad_alpha_and_method():
    fz = fuzzify(square(), tme=0.1)
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        fz.alpha_cut(1.2)
    with pytest.raises(ValueError, match="method"):
        fz.alpha_cut(0.5, "buffer")


def random_points(g, rng, n=300):
    x0, y0, x1, y1 = g.bounds
    pad = 0.3 * max(x1 - x0, y1 - y0)
    return rng.uniform([x0 - pad, y0 - pad], [x1 + pad, y1 + pad], (n, 2))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(m=crisp_maps(), tme=st.floats(0.02, 3.0), alphas=st.lists(st.floats(0, 1), min_size=2, max_size=2))
def test_alpha_cuts_nest_are_valid_and_end_at_the_crisp_map(m, tme, alphas):
    fz = fuzzify(m, tme=tme)
    crisp = m.to_shapely()
    levels = [0.0, *sorted(alphas), 1.0]
    for method in ("sweep", "exact"):
        cuts = [fz.alpha_cut(a, method) for a in levels]
        for c in cuts:
            for g in (c.inner, c.outer):
                assert g.geom_type in ("Polygon", "MultiPolygon") and g.is_valid, shapely.is_valid_reason(g)
            assert outside_area(c.inner, crisp) <= AREA_TOL * crisp.area
            assert outside_area(crisp, c.outer) <= AREA_TOL * crisp.area
        for lo, hi in zip(cuts, cuts[1:]):
            assert outside_area(lo.inner, hi.inner) <= AREA_TOL * crisp.area, (method, lo.alpha, hi.alpha)
            assert outside_area(hi.outer, lo.outer) <= AREA_TOL * crisp.area, (method, lo.alpha, hi.alpha)
        assert cuts[-1].inner.equals(crisp) and cuts[-1].outer.equals(crisp)


# -- membership --------------------------------------------------------------------------------


def boundary_points(m: BRepMap, rng, n=200) -> np.ndarray:
    lines = shapely.boundary(m.to_shapely())
    return shapely.get_coordinates(shapely.line_interpolate_point(lines, rng.uniform(0, 1, n), normalized=True))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(m=crisp_maps(), tme=st.floats(0.02, 3.0), seed=st.integers(0, 2**32 - 1), alpha=st.floats(0, 1))
def test_membership_properties(m, tme, seed, alpha):
    """μ = 1 on the crisp boundary, 0 beyond the support, in [0, 1], and μ ≥ α exactly on the
    band of the α-cut (away from its boundary), for both methods."""
    rng = np.random.default_rng(seed)
    fz = fuzzify(m, tme=tme)
    crisp = m.to_shapely()
    pts = random_points(crisp, rng)
    far = shapely.distance(shapely.boundary(crisp), shapely.points(pts)) > tme * (1 + 1e-9)
    on = boundary_points(m, rng)
    for method in ("sweep", "exact"):
        mu = fz.membership(pts, method)
        assert np.all((mu >= 0) & (mu <= 1))
        assert np.all(mu[far] == 0)
        assert fz.membership(on, method) == pytest.approx(np.ones(len(on)), abs=1e-9)
        band = fz.alpha_cut(alpha, method).band
        inb = shapely.intersects_xy(band, pts[:, 0], pts[:, 1])
        # exact cuts are buffers whose arcs are chords (32 per quarter circle): 3e-4 of the radius off
        margin = (1e-6 if method == "sweep" else 1e-3) * tme
        clear = shapely.distance(shapely.boundary(band), shapely.points(pts)) > margin if not band.is_empty \
            else np.ones(len(pts), bool)
        level = mu > 0 if alpha == 0 else mu >= alpha  # the 0-cut is the support: μ > 0
        assert np.array_equal(level[clear], inb[clear]), method


def test_membership_of_a_square():
    fz = fuzzify(square(10), tme=1.0)
    pts = np.array([[5, 0], [5, 0.5], [5, -0.5], [5, 5], [5, -2], [0, 0]])
    assert fz.membership(pts, "exact") == pytest.approx([1, 0.5, 0.5, 0, 0, 1])
    # the sweep's support edge is 1/√2 from the wall: μ = 1 − 0.5·√2 there
    assert fz.membership(pts, "sweep") == pytest.approx([1, 1 - 0.5 * math.sqrt(2), 1 - 0.5 * math.sqrt(2), 0, 0, 1])


def test_membership_with_mixed_functions_uses_each_vertex_function():
    ring = Ring([(0, 0), (10, 0), (10, 10), (0, 10)], fm=[1, 2, 2, 1])
    fz = fuzzify(BRepMap((Region(ring),)), {1: Triangular(1.0), 2: A4(0.5)})
    rng = np.random.default_rng(3)
    pts = rng.uniform(-3, 13, (2000, 2))
    assert_mu_is_the_bands(fz, pts, (0.2, 0.5, 0.8))


def test_exact_sides_of_an_asymmetric_function_are_those_of_each_boundarys_own_ring():
    """x < 0 is IN of the boundary's own ring: a point inside an obstacle near the outer wall is
    IN for that wall too, not OUT as the free space would have it."""
    hole = [(0.5, 2), (0.5, 8), (3, 8), (3, 2)]
    fz = fuzzify(square(10, [hole]), Triangular(tme_in=0.2, tme_out=2.0))
    p = np.array([[1.0, 5.0]])  # 0.5 into the hole, 1.0 inside the principal ring
    assert fz.membership(p, "exact") == pytest.approx([0.0])  # both walls beyond the IN support 0.2
    assert fz.membership(p, "sweep") == pytest.approx([0.0])
    assert not shapely.intersects_xy(fz.alpha_cut(0.2, "exact").outer, 1.0, 5.0)
    # a piece of explored space in a hole: its points are inside that hole's ring
    g = shapely.MultiPolygon([shapely.Polygon(shapely.box(0, 0, 10, 10).exterior, [shapely.box(3, 3, 7, 7).exterior]),
                              shapely.box(4, 4, 6, 6)])
    fz = fuzzify(BRepMap.from_shapely(g), Triangular(tme_in=0.5, tme_out=2.0))
    q = np.array([[5.0, 5.5]])  # 0.5 inside the island's wall, 1.5 inside the hole's
    assert fz.membership(q, "exact") == pytest.approx([0.0])
    assert shapely.intersects_xy(fz.alpha_cut(0.1, "exact").inner, 5.0, 5.5)


def test_exact_cut_with_asymmetric_functions_round_a_sharp_tip_is_valid():
    """Cutting the bands by their rings must not leave the crisp edges on the band's boundary:
    GEOS then took this map's support band for one not covering it (inner = the crisp map,
    outer = two nested shells)."""
    v = [(0.50540, 0.86289), (0.15074, 0.98857), (-1.95689, 0.41299), (-0.26159, -0.96518), (0.55577, -0.83134),
         (0.76958, -0.63855), (0.92921, -0.36955), (7.1875, 0.0)]
    ring = Ring(v, fm=[2, 1, 1, 1, 1, 2, 2, 1])
    fz = fuzzify(BRepMap((Region(ring),)), {1: Triangular(tme_in=3.0, tme_out=1.6171875),
                                            2: Triangular(tme_in=3.0, tme_out=2.25)})
    cut = fz.alpha_cut(0.0, "exact")
    assert cut.inner.is_empty  # nothing is farther than 3 inside
    assert cut.outer.geom_type == "Polygon" and cut.outer.is_valid and cut.outer.covers(fz.crisp_geometry)


def exact_mu_by_definition(fz, pts) -> np.ndarray:
    """μ(p) = max over edges of μ_FM(x), x the distance to the edge, negative inside the edge's
    own ring (an edge whose ends differ split at its middle), by brute force."""
    mu = np.zeros(len(pts))
    for ring in fz.crisp.rings:
        v, fm = ring.vertices, ring.fm
        inside = shapely.contains_xy(shapely.Polygon(v), pts[:, 0], pts[:, 1])
        for i in range(len(v)):
            j = (i + 1) % len(v)
            mid = (v[i] + v[j]) / 2
            halves = [(v[i], v[j], fm[i])] if fm[i] == fm[j] else [(v[i], mid, fm[i]), (mid, v[j], fm[j])]
            for a, b, k in halves:
                ab = b - a
                t = np.clip((pts - a) @ ab / (ab @ ab), 0, 1)
                d = np.hypot(*(pts - a - t[:, None] * ab).T)
                mu = np.maximum(mu, fz.table[k].mu(np.where(inside, -d, d)))
    return mu


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(m=crisp_maps(), tme=st.lists(st.floats(0.02, 3.0), min_size=3, max_size=3), seed=st.integers(0, 2**32 - 1),
       alpha=st.floats(0, 1))
def test_exact_membership_with_asymmetric_functions_is_its_definition(m, tme, seed, alpha):
    rng = np.random.default_rng(seed)
    table = {1: Triangular(tme_in=tme[0], tme_out=tme[1]), 2: Triangular(tme[2])}
    fz = fuzzify(m.with_rings([Ring(r.vertices, r.kinds, rng.integers(1, 3, len(r))) for r in m.rings]), table)
    pts = random_points(m.to_shapely(), rng)
    mu = fz.membership(pts, "exact")
    np.testing.assert_allclose(mu, exact_mu_by_definition(fz, pts), atol=1e-12)
    cut = fz.alpha_cut(alpha, "exact")
    for g in (cut.inner, cut.outer):
        assert g.geom_type in ("Polygon", "MultiPolygon") and g.is_valid, shapely.is_valid_reason(g)
    band = cut.band
    clear = shapely.distance(shapely.boundary(band), shapely.points(pts)) > 1e-3 * max(tme) if not band.is_empty \
        else np.ones(len(pts), bool)
    inb = shapely.intersects_xy(band, pts[:, 0], pts[:, 1])
    level = mu > 0 if alpha == 0 else mu >= alpha
    assert np.array_equal(level[clear], inb[clear])


def test_membership_input_checks():
    fz = fuzzify(square(), tme=0.1)
    assert fz.membership(np.zeros((0, 2))).shape == (0,)
    with pytest.raises(ValueError, match=r"\(m, 2\)"):
        fz.membership(np.zeros(3))
    with pytest.raises(ValueError, match="point 2 is not finite"):
        fz.membership([[0, 0], [np.nan, 1]])


def test_membership_checks_the_method_of_no_points_too():
    # an empty input returned zeros whatever the method, a misspelt one included
    fz = fuzzify(square(), tme=0.1)
    for points in (np.zeros((0, 2)), [[0.0, 0.0]]):
        with pytest.raises(ValueError, match=r"method must be one of safe, thesis, exact \(or sweep, the thesis's old name\), got 'exakt'"):
            fz.membership(points, "exakt")
    assert fz.membership(np.zeros((0, 2)), "exact").shape == (0,)


@pytest.mark.filterwarnings("error")
def test_membership_of_a_map_too_large_to_compute_with_is_refused():
    # the sweep multiplies four coordinates together: on a map 1e80 across μ came out wrong
    # (0.998 off), mostly without a warning
    pts = np.array([[5.0, 0.05], [4.97, 5.0], [5.0, 5.0], [12.0, 3.0], [10.02, 9.99]])
    fz = fuzzify(square(), tme=0.1)
    big = fuzzify(square(10 * 1e50), tme=0.1 * 1e50)
    for method in ("sweep", "exact"):
        np.testing.assert_allclose(big.membership(pts * 1e50, method), fz.membership(pts, method), atol=1e-9)
    # a map 1e81 across is refused where it is checked (validate_map, since issue 19 in its
    # vectorised pass too: before, only a ring suspect for other reasons was held to ±LARGEST)
    with pytest.raises(GeometryError, match=r"coordinate \[1e\+81, 0.0\] is beyond ±1e\+60"):
        fuzzify(square(10 * 1e80), tme=0.1 * 1e80)
    assert fz.membership([[1e300, -1e300], [1.7e308, 0.0]]).tolist() == [0, 0]  # far points are fine


# -- approximation error -----------------------------------------------------------------------


def test_approximation_error_of_a_square_has_a_closed_form():
    side, d = 10.0, 1.0
    rows = approximation_error(fuzzify(square(side), tme=d), [0.0, 0.5, 1.0])
    r = rows[0]
    s = math.sqrt(2)
    # inner: the sweep keeps a (side − √2 d) square where the exact cut keeps (side − 2d)
    assert r.inner_error == pytest.approx((side - s * d) ** 2 - (side - 2 * d) ** 2)
    # outer: sweep square (side + √2 d) inside the rounded square side² + 4 side d + π d²
    assert r.outer_error == pytest.approx((4 - 2 * s) * side * d + (math.pi - 2) * d * d, rel=1e-3)
    assert r.band_area == pytest.approx(4 * side * d + math.pi * d * d + 4 * side * d - 4 * d * d, rel=1e-3)
    assert rows[1].inner_error == pytest.approx((side - s * 0.5) ** 2 - (side - 1) ** 2)
    assert rows[2].inner_error == rows[2].outer_error == 0 and math.isnan(rows[2].relative)


def test_memory_table_5_3_from_the_thesis_figures():
    rows = memory_table(77, 77, 1050.0, [0.3, 0.2, 0.1])
    assert [(r.numbers, r.bytes) for r in rows] == [(1232, 4928), (11667, 46668), (26250, 105000), (105000, 420000)]
    assert [round(r.bytes / rows[0].bytes) for r in rows[1:]] == [9, 21, 85]  # "9, 21, and 85 times"


@pytest.mark.parametrize("cell", [1e-300, 5e-324, math.inf, 0.0, math.nan])
def test_memory_with_a_cell_size_that_counts_no_grid(cell):
    # before: ZeroDivisionError or OverflowError for a tiny cell; a grid of 0 cells for an infinite one
    with pytest.raises(GeometryError, match=f"occupancy grid of {cell:g} m cells: "):
        memory_table(77, 77, 1050.0, [cell])
    with pytest.raises(GeometryError, match=f"occupancy grid of {cell:g} m cells: "):
        fuzzify(square(), tme=0.1).memory([cell])



def test_memory_of_a_map():
    fz = fuzzify(square(10, [[(2, 2), (2, 3), (3, 3), (3, 2)]]), tme=0.2)
    rows = fz.memory([1.0])
    assert rows[0].numbers == 16 * 8 and rows[0].bytes == 4 * 16 * 8
    # compact: the encoder's own output, at most 4 bytes per vertex beyond its header and Table 4.2
    from fuzzybrep.formats.compact import encode

    assert rows[1].bytes == len(encode(fz.crisp, fz.table.to_dicts()))
    header = len(encode(square(10, []), fz.table.to_dicts())) - 2 - 4 * 2  # a map of one 4-vertex ring
    assert rows[1].bytes - header <= 2 + 4 * 8  # two ring sizes, then 2 short varints per vertex
    assert rows[2].numbers == 99  # area 99 at 1×1
    assert rows[3].numbers == 100  # bounding box 10×10


# -- files -------------------------------------------------------------------------------------


def test_save_and_load_round_trip(tmp_path):
    ring = Ring([(0, 0), (10, 0), (10, 10), (0, 10)], fm=[1, 2, 2, 1])
    fz = fuzzify(BRepMap((Region(ring),)), {1: Triangular(1.0), 2: A4(0.5)})
    fz.save(tmp_path / "m.json", metadata={"note": "x"})
    back = FuzzyBRepMap.load(tmp_path / "m.json")
    assert back.crisp.equals_exactly(fz.crisp)
    assert back.table.to_dicts() == fz.table.to_dicts()
    for k in fz.vertex_table(0):
        np.testing.assert_array_equal(back.vertex_table(0)[k], fz.vertex_table(0)[k])


@pytest.mark.parametrize("poses, words", [
    ([[0.0, 0.0, 0.5]], r"poses must be rows of x, y, heading, time; got shape \(1, 3\)"),  # Scan.pose alone
    ([[0.0, 0.0, 0.5, math.nan]], r"poses row 1 is not finite"),
    ([[0.0, 0.0, 0.5, "t"]], "could not convert string to float"),
])
def test_save_refuses_poses_its_map_file_could_not_hold(tmp_path, poses, words):
    # before: save wrote them, and every reader then refused the file it had just written
    # ("malformed map: scans.poses must be rows of x, y, heading, time")
    fz = fuzzify(square())
    with pytest.raises(ValueError, match=words):
        fz.save(tmp_path / "m.json", poses=poses)
    assert not (tmp_path / "m.json").exists()
    fz.save(tmp_path / "m.json", poses=[[0.0, 0.0, 0.5, 10.0]])
    assert FuzzyBRepMap.load(tmp_path / "m.json").crisp.equals_exactly(fz.crisp)


def test_loading_a_crisp_map_needs_a_tme(tmp_path):
    write_map(tmp_path / "crisp.json", MapFile(square()))
    with pytest.raises(MapFileError, match="no membership-function table"):
        FuzzyBRepMap.load(tmp_path / "crisp.json")
    assert FuzzyBRepMap.load(tmp_path / "crisp.json", tme=0.3).table[1] == Triangular(0.3)
    write_map(tmp_path / "bad.json", MapFile(square(), [{"index": 1, "type": "A2", "p": 1, "tme": 1}]))
    with pytest.raises(MapFileError, match="bad.json: membership function 1: A2.*criterion 1"):
        FuzzyBRepMap.load(tmp_path / "bad.json")


def test_table_from_mapping():
    fz = fuzzify(square(), MembershipTable({1: Triangular(0.1)}))
    assert fz.table.indices == [1]


def test_bad_arguments_raise_the_packages_errors():
    # before: bare ValueErrors (while offset_vertices already raised MembershipFunctionError for α)
    fz = fuzzify(square(), tme=0.1)
    for bad in (math.nan, 2.0, "x", None):
        with pytest.raises(MembershipFunctionError, match="α must"):
            fz.alpha_cut(bad)
    with pytest.raises(MembershipFunctionError, match=r"α must lie in \[0, 1\], got nan"):
        fz.approximation_error([math.nan])
    with pytest.raises(GeometryError, match="point 2 is not finite"):
        fz.membership([[1.0, 1.0], [math.nan, 1.0]])
    with pytest.raises(GeometryError, match=r"points must be an \(m, 2\) array, got shape \(2,\)"):
        fz.membership([1.0, 1.0])
    assert fz.membership([]).shape == (0,)  # no points: no grades (before: "got shape (0,)")
