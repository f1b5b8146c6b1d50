"""The conservative sweep (``fuzzy.safe_sweep``, the default α-cut): its promise checked analytically
(``_safe_oracle``: no boundary segment of inner or outer closer to a crisp half-edge than that
half-edge's distance on its side), nesting across α, α = 1 the crisp map, valid polygons, and μ
consistent with the cut; on random maps with holes, spikes down to 5°, reflex corners, narrow
corridors, sided and per-vertex membership functions (2000 cases in all)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from _fuzzy_shapes import corridor_map, star_map
from _safe_oracle import check_cut, violations
from fuzzybrep.brep import BRepMap, Region, Ring
from fuzzybrep.fuzzy import safe_sweep
from fuzzybrep.fuzzy.map import fuzzify
from fuzzybrep.fuzzy.membership import A4, MembershipTable, Triangular

STAR = Path("/work/shared/reference/sweep-star-counterexample.geojson")
#: the star of issue 18 (the file in ../shared/reference, copied here so the test needs no share)
STAR_COORDS = [[0.75, 5e-324], [0.0294578609178812, 0.005677537330812305], [0.1392551899524109, 0.05574936834904914],
               [0.610660069112773, 1.3371590331711418], [0.0353638403264141, 0.14577173524853126],
               [0.0071372873735613615, 0.14983010087745122], [-0.20920281226172896, 1.4550375195649712],
               [-0.04906019449761326, 0.14175012280720029], [-1.4932078838596268, 0.14258406495627432],
               [-0.7466039419298134, -0.07129203247813698], [-0.14392394604217465, -0.04225988352621442],
               [-0.13332531729823857, -0.0687339782591115], [-0.9626452788995687, -1.11095187430076],
               [-0.04906019449761329, -0.14175012280720029], [0.035363840326414125, -0.14577173524853126],
               [1.0856010571576051, -1.035118517223168], [0.6309401496233855, -0.4054806130916987],
               [0.6962759497620543, -0.27874684174524605]]


def scale_of(fz) -> float:
    return float(np.ptp(fz.stack["V"], axis=0).max())


@st.composite
def spike_map(draw):
    """A polygon with thin spikes of free space (apex 5-40°) and thin notches of obstacle cut into
    it, and perhaps a hole: the sharpest corners a scan union leaves."""
    base = shapely.Polygon(draw(st.sampled_from([[(0, 0), (6, 0), (6, 4), (0, 4)],
                                                 [(0, 0), (6, 0), (6, 4), (3, 2), (0, 4)]])))
    geom = base
    for _ in range(draw(st.integers(1, 4))):
        t = draw(st.floats(0.05, 0.95))
        p = base.exterior.interpolate(t, normalized=True)
        apex = math.radians(draw(st.floats(5.0, 40.0)))
        length = draw(st.floats(0.3, 3.0))
        ang = draw(st.floats(0, 2 * math.pi))
        w = length * math.tan(apex / 2)
        d = np.array([math.cos(ang), math.sin(ang)])
        n = np.array([-d[1], d[0]])
        c = np.array([p.x, p.y])
        tri = shapely.Polygon([c + w * n, c + length * d, c - w * n])
        geom = shapely.union(geom, tri) if draw(st.booleans()) else shapely.difference(geom, tri)
    geom = geom if geom.geom_type == "Polygon" else max(shapely.get_parts(geom), key=lambda g: g.area)
    if draw(st.booleans()):
        h = shapely.Polygon([(2.5, 1.5), (3.5, 1.7), (2.9, 2.6)])
        if h.within(geom) and geom.exterior.distance(h) > 1e-2:
            geom = shapely.Polygon(geom.exterior, [*geom.interiors, h.exterior])
    return shapely.orient_polygons(shapely.make_valid(geom) if not geom.is_valid else geom)


def crisp_maps():
    return (st.one_of(star_map(), corridor_map(), spike_map())
            .filter(lambda g: g.geom_type == "Polygon" and g.is_valid and g.area > 1e-3)
            .map(BRepMap.from_shapely))


def alphas():
    return st.tuples(st.sampled_from([0.0, 0.0, 0.3, 0.5, 0.9]), st.floats(0.0, 1.0)).map(sorted)


def check_pair(fz, a1: float, a2: float) -> None:
    """Both cuts contain what they must, nest, are valid; α = 1 is the crisp map."""
    tol = 1e-9 * scale_of(fz)
    perimeter = float(shapely.length(fz.crisp_geometry))
    c1, c2 = fz.alpha_cut(a1), fz.alpha_cut(a2)
    for c in (c1, c2):
        assert c.method == "safe"
        assert c.inner.is_valid and c.outer.is_valid
        check_cut(fz, c, tol)
    assert shapely.difference(c1.inner, c2.inner).area <= tol * perimeter
    assert shapely.difference(c2.outer, c1.outer).area <= tol * perimeter
    one = fz.alpha_cut(1.0)
    assert one.inner.equals(fz.crisp_geometry) and one.outer.equals(fz.crisp_geometry)


@settings(max_examples=800, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(crisp_maps(), st.floats(0.02, 2.0), alphas())
def test_one_symmetric_function(crisp, tme, a):
    """The O(n) raw-curve path: every map fuzzybrep builds has one symmetric function."""
    fz = fuzzify(crisp, tme=tme)
    assert fz.safe["function"] is not None
    check_pair(fz, *a)


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(crisp_maps(), st.floats(0.02, 1.5), st.floats(0.02, 1.5), alphas())
def test_sided_function(crisp, tme_in, tme_out, a):
    fz = fuzzify(crisp, Triangular(tme_in=tme_in, tme_out=tme_out))
    check_pair(fz, *a)


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(crisp_maps(), st.floats(0.02, 1.0), st.floats(0.02, 1.0), st.floats(1.0, 20.0), st.data())
def test_per_vertex_functions(crisp, t1, t2, p, data):
    """Every vertex its own function among three (one asymmetric, one of another shape)."""
    table = MembershipTable({1: Triangular(t1), 2: Triangular(tme_in=t2, tme_out=t1), 3: A4(p)})
    rings = [Ring(r.vertices, r.kinds, data.draw(st.lists(st.integers(1, 3), min_size=len(r), max_size=len(r))))
             for r in crisp.rings]
    fz = fuzzify(crisp.with_rings(rings), table)
    check_pair(fz, *data.draw(alphas()))


def star_map_of_issue_18():
    return fuzzify(BRepMap((Region(Ring(np.array(STAR_COORDS))),)), tme=1.5)


def test_the_star_of_issue_18():
    """At α = 0.75 the thesis's outer cut leaves out 0.018 m² of the crisp polygon (its cuts do not
    nest: outer(1) ⊄ outer(0.75)); the safe cut holds the crisp map and the exact band."""
    if STAR.is_file():  # the copy above is the shared file's polygon
        assert np.allclose(json.loads(STAR.read_text())["coordinates"][0][:-1], STAR_COORDS)
    fz = star_map_of_issue_18()
    thesis = fz.alpha_cut(0.75, "thesis")
    assert shapely.difference(fz.crisp_geometry, thesis.outer).area == pytest.approx(0.0176, abs=5e-4)
    assert violations(fz, 0.75, thesis.outer, 0.0) > 0.3
    for a in (0.0, 0.5, 0.75, 0.9):
        cut = fz.alpha_cut(a)
        check_cut(fz, cut, 1e-9 * scale_of(fz))
        assert shapely.difference(fz.crisp_geometry, cut.outer).area == 0.0
    # nine spikes, each fan at most 10.3 % larger than its sector: the band is 5 % wider here
    exact = fz.alpha_cut(0.0, "exact").band.area
    assert exact < fz.alpha_cut(0.0).band.area < 1.1 * exact


def square(side: float) -> BRepMap:
    return BRepMap((Region(Ring(np.array([(0, 0), (side, 0), (side, side), (0, side)], float))),))


def test_square_is_the_exact_cut_with_bevelled_corners():
    """Inside a square the erosion is the square L − 2d exactly (mitres inside the turn); outside,
    each right-angle corner is two tangent segments round the quarter disc (a bevel): the area
    grows by 4Ld + 4·d²·2·tan(22.5°) against the exact 4Ld + πd²."""
    fz = fuzzify(square(10), tme=1.0)
    c = fz.alpha_cut(0.0)
    assert c.inner.area == pytest.approx(64.0, rel=1e-9)
    assert c.outer.area == pytest.approx(100 + 40 + 8 * math.tan(math.pi / 8), rel=1e-9)
    exact = fz.alpha_cut(0.0, "exact")
    assert shapely.difference(c.inner, exact.inner).area < 1e-9
    assert shapely.difference(exact.outer, c.outer).area < 1e-9
    half = fz.alpha_cut(0.5)
    assert half.inner.area == pytest.approx(81.0, rel=1e-9)


def test_membership_agrees_with_the_cut():
    """μ ≥ α exactly where the α-cut's band is (away from its boundary), and μ ≥ the exact μ."""
    fz = star_map_of_issue_18()
    rng = np.random.default_rng(1)
    p = rng.uniform(-3, 3, (20000, 2))
    mu = fz.membership(p)
    assert mu.min() >= 0 and mu.max() <= 1
    assert np.all(mu >= fz.membership(p, "exact") - 1e-9)
    for a in (0.0, 0.4, 0.75):
        band = fz.alpha_cut(a).band
        pts = shapely.points(p)
        inside = shapely.contains(band, pts)
        far = shapely.distance(shapely.boundary(band), pts) > 1e-6
        assert np.all((mu >= a)[far & inside]) if a > 0 else np.all((mu > 0)[far & inside])
        assert not np.any((mu > a + 1e-9)[far & ~inside])
    assert fz.membership(np.array(STAR_COORDS)).min() == pytest.approx(1.0)


def test_sided_and_several_functions_take_the_stadiums():
    fz = fuzzify(square(10), Triangular(tme_in=0.5, tme_out=1.0))
    assert fz.safe["function"] is None
    c = fz.alpha_cut(0.0)
    check_cut(fz, c, 1e-8)
    # every edge's stadium has the larger distance on both sides
    assert c.inner.area == pytest.approx(64.0, rel=1e-9)
    p = np.array([[5.0, 0.5], [5.0, -0.5], [5.0, 5.0], [5.0, -2.0]])
    assert np.allclose(fz.membership(p), [0.5, 0.5, 0.0, 0.0])


def test_spikes_of_zero_width_are_covered_on_both_sides():
    """A needle doubling back on its own edge: which side its tip lies on is not known from the
    turn, so a circumscribed disc covers it on both sides."""
    v = np.array([(0, 0), (4, 0), (4, 2), (2, 2), (2, 5), (2, 2), (0, 2)], float)
    lines = safe_sweep.safe_lines(v, np.array([len(v)]))
    for side in (0, 1):  # the ring and one disc loop, each side
        assert len(safe_sweep.cut_paths(lines, side, 0.5, 1e6)[1]) == 2
    fz = fuzzify(BRepMap((Region(Ring(v)),)), tme=0.5, validate=False)
    for a in (0.0, 0.5):
        check_cut(fz, fz.alpha_cut(a), 1e-8)


def test_safe_is_the_default_and_sweep_means_the_thesis():
    fz = fuzzify(square(10), tme=1.0)
    assert fz.alpha_cut(0.0).method == "safe"
    assert fz.alpha_cut(0.0, "sweep").method == "thesis"
    assert fz.alpha_cut(0.0, "sweep").inner.equals(fz.alpha_cut(0.0, "thesis").inner)
    with pytest.raises(ValueError, match="safe, thesis, exact"):
        fz.alpha_cut(0.0, "bisector")


def test_rings_the_offset_swallows_are_left_out_without_changing_the_cut():
    """A hole with no disc of radius d inside is all band (the outer cut fills it), a piece of
    explored space that narrow has no inner cut: their rings are left out of the union, which
    then gives the same region (Lemma 1 covers what their rectangles did beyond them). A thin
    diagonal wall is such a hole although its box is wide."""
    wall = [(1, 2.5), (2.5, 3.5), (2.45, 3.57), (0.95, 2.57)]  # 8.6 cm thick, its box 1.55 × 1.07 m
    room = shapely.Polygon([(0, 0), (6, 0), (6, 4), (0, 4)], [[(1, 1), (1, 1.3), (1.3, 1.3), (1.3, 1)],
                                                              [(3, 1), (3, 3), (5, 3), (5, 1)], wall])
    islet = shapely.Polygon([(3.5, 1.5), (4.5, 1.5), (4.5, 1.8), (3.5, 1.8)])  # inside the big hole
    fz = fuzzify(BRepMap.from_shapely(shapely.MultiPolygon([room, islet])), tme=0.4)
    sf = fz.safe
    for a in (0.0, 0.5):
        d = float(sf["function"].d_in(a))
        for side in (0, 1):
            drop = safe_sweep.vanishing(sf["inradius"], sf["region"], sf["shell"], side, d)
            assert drop.any()
            if side == 1:  # the wall's ring: the one whose box is over 1 m on both sides
                V, st = sf["V"], sf["start"]
                box = np.minimum(np.maximum.reduceat(V[:, 0], st) - np.minimum.reduceat(V[:, 0], st),
                                 np.maximum.reduceat(V[:, 1], st) - np.minimum.reduceat(V[:, 1], st))
                assert drop[(box > 1.0) & (box < 1.1) & ~sf["shell"]].all()
            kept = safe_sweep.proper(safe_sweep.cut_paths(sf["lines"], side, d, sf["scale"], drop), sf["centre"], sf["scale"])
            whole = safe_sweep.proper(safe_sweep.cut_paths(sf["lines"], side, d, sf["scale"]), sf["centre"], sf["scale"])
            assert shapely.symmetric_difference(kept, whole).area < 1e-9
        check_cut(fz, fz.alpha_cut(a), 1e-8)
