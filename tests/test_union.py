"""The union into the global map (thesis 3.2.2, 3.2.3) and the map's own file."""

from __future__ import annotations

import json

import numpy as np
import pytest
import shapely
from hypothesis import given, settings, strategies as st

from fuzzybrep import BRepMap, GeometryError, MapFileError, Ring
from fuzzybrep import brep
from fuzzybrep.mapping import union
from fuzzybrep.formats.export import crisp_features, write_geojson
from fuzzybrep.formats.mapfile import MapFile, read_map, write_map


def ring(coords) -> Ring:
    return Ring(np.asarray(coords, dtype=float))


def unite(*rings) -> BRepMap:
    return BRepMap.from_shapely(union.union(brep.rings_to_shapely(list(rings))))


def octagon(cx, cy, r):
    a = np.radians(22.5 + 45 * np.arange(8))
    return ring(np.column_stack((cx + r * np.cos(a), cy + r * np.sin(a))))


def check_tables(m: BRepMap):
    """Orientation and indexing of every vertex and edge table."""
    for k, region in enumerate(m.regions):
        assert region.shell.signed_area > 0  # principal / piece: counter-clockwise
        for h in region.holes:
            assert h.signed_area < 0  # holes: clockwise
    for r in m.rings:
        n = len(r)
        assert np.array_equal(r.edges, np.column_stack((np.arange(n), (np.arange(n) + 1) % n)))
        assert len(r.kinds) == n and len(r.fm) == n
    m.validate()


def test_convex_union_figures_3_9_to_3_11():
    a, b = octagon(0, 0, 2), octagon(2.5, 0.5, 2)
    m = unite(a, b)
    check_tables(m)
    assert len(m.regions) == 1 and m.n_holes == 0
    ga, gb = shapely.Polygon(a.vertices), shapely.Polygon(b.vertices)
    assert np.isclose(m.area, ga.area + gb.area - ga.intersection(gb).area)
    # the two new vertices where the boundaries cross (the red points of Figure 3.9)
    crossings = shapely.get_coordinates(ga.boundary.intersection(gb.boundary))
    for p in crossings:
        assert np.min(np.hypot(*(m.principal.vertices - p).T)) < 1e-9
    # 8 + 8 edges, minus those inside the other polygon, plus the new vertices: 10 + 10 - ...
    assert len(m.principal) == len(shapely.get_coordinates(ga.union(gb).exterior)) - 1


def test_union_that_creates_a_hole_figures_3_12_3_13():
    # two U-shapes facing each other close around a courtyard no scan saw: a hole
    a = ring([(0, 0), (6, 0), (6, 1), (1, 1), (1, 4), (6, 4), (6, 5), (0, 5)])
    b = ring([(5, 0), (10, 0), (10, 5), (5, 5), (5, 4), (9, 4), (9, 1), (5, 1)])
    m = unite(a, b)
    check_tables(m)
    assert len(m.regions) == 1 and m.n_holes == 1
    hole = shapely.Polygon(m.holes[0].vertices)
    assert np.isclose(hole.area, 8 * 3) and hole.equals(shapely.box(1, 1, 9, 4))
    assert len(m.ring_names()) == 2 and m.ring_names()[1] == "hole 1"


def test_disjoint_polygons_keep_both_largest_is_principal():
    small, big = ring([(10, 0), (11, 0), (11, 1), (10, 1)]), ring([(0, 0), (4, 0), (4, 4), (0, 4)])
    m = unite(small, big)
    check_tables(m)
    assert len(m.regions) == 2 and np.isclose(m.regions[0].area, 16) and np.isclose(m.regions[1].area, 1)
    assert m.ring_names() == ["principal", "piece 2"]


def test_polygons_sharing_an_edge_merge():
    m = unite(ring([(0, 0), (2, 0), (2, 2), (0, 2)]), ring([(2, 0), (4, 0), (4, 2), (2, 2)]))
    check_tables(m)
    assert len(m.regions) == 1 and m.n_holes == 0 and np.isclose(m.area, 8)
    assert shapely.Polygon(m.principal.vertices).equals(shapely.box(0, 0, 4, 2))


def test_polygons_sharing_a_vertex_stay_two_pieces():
    m = unite(ring([(0, 0), (2, 0), (2, 2), (0, 2)]), ring([(2, 2), (3, 2), (3, 3), (2, 3)]))
    check_tables(m)
    assert len(m.regions) == 2 and np.isclose(m.area, 5)


def test_identical_polygons():
    a = octagon(1, 1, 3)
    m = unite(a, a)
    check_tables(m)
    assert np.isclose(m.area, shapely.Polygon(a.vertices).area) and len(m.principal) == 8


def test_union_one_by_one_equals_all_at_once():
    # the thesis unites each new scan polygon with the map in turn; the union of all at once gives
    # the same set in any order (to Clipper2's nanometre: a part in 10^9 of the area here)
    rng = np.random.default_rng(0)
    rings = [octagon(*rng.uniform(0, 6, 2), rng.uniform(0.5, 2)) for _ in range(12)]
    together = union.union(brep.rings_to_shapely(rings))
    g = shapely.Polygon()
    for r in rings[::-1]:
        g = shapely.union(g, shapely.Polygon(r.vertices))
    assert shapely.symmetric_difference(together, g).area < 1e-9 * g.area
    assert shapely.symmetric_difference(union.union(brep.rings_to_shapely(rings), engine="geos"), g).area < 1e-9


def test_degenerate_rings_are_refused_naming_the_vertex():
    with pytest.raises(GeometryError, match="at least 3 vertices"):
        brep.validate_ring(np.array([(0, 0), (1, 1)]), "principal")
    with pytest.raises(GeometryError, match="zero area"):
        brep.validate_ring(np.array([(0, 0), (1, 1), (2, 2)]), "principal")
    with pytest.raises(GeometryError) as e:
        brep.validate_ring(np.array([(0, 0), (2, 2), (2, 0), (0, 2)]), "hole 3")  # a bow tie
    assert e.value.ring == "hole 3" and e.value.vertex is not None and "self-intersecting" in str(e.value)
    with pytest.raises(GeometryError, match="repeats vertex"):
        brep.validate_ring(np.array([(0, 0), (1, 0), (1, 0), (0, 1)]))


def test_validate_names_the_ring_of_a_second_piece():
    """Errors in piece 2 name piece 2's own rings and number vertices within the ring."""
    from fuzzybrep.brep import Region

    sq = lambda x0, y0, s: [(x0, y0), (x0 + s, y0), (x0 + s, y0 + s), (x0, y0 + s)]  # counter-clockwise
    principal = Region(ring(sq(0, 0, 10)), (ring(sq(2, 2, 2)[::-1]),))
    # piece 2's second hole pokes out of its shell; GEOS names where it crosses the shell (y = 4),
    # 0.3 from the hole's vertex 2 or 3 and at least 0.8 from any vertex of the shell
    outside = Region(ring(sq(20, 0, 4)), (ring(sq(21, 1, 1)[::-1]), ring([(22.4, 3), (22.4, 4.3), (23.2, 4.3), (23.2, 3)])))
    with pytest.raises(GeometryError, match="invalid region") as e:
        BRepMap((principal, outside)).validate()
    assert e.value.ring == "piece 2 hole 2" and e.value.vertex in (2, 3)
    # a counter-clockwise hole in piece 2 is named as piece 2's hole, not the principal's
    wrong_way = Region(ring(sq(20, 0, 4)), (ring(sq(21, 1, 1)),))
    with pytest.raises(GeometryError, match="piece 2 hole 1: hole must run clockwise"):
        BRepMap((principal, wrong_way)).validate()


def test_validate_refuses_a_clockwise_outer_boundary_and_names_a_repeated_vertex():
    square = [(0, 0), (4, 0), (4, 4), (0, 4)]
    with pytest.raises(GeometryError, match="principal: outer boundary must run counter-clockwise"):
        BRepMap((brep.Region(ring(square[::-1])),)).validate()
    # vertices 2 and 3 are the same point: vertex 2 is named, as repeating vertex 3
    with pytest.raises(GeometryError, match="repeats vertex 3") as e:
        brep.validate_ring(np.array([(0, 0), (1, 0), (1, 0), (0, 1)]))
    assert e.value.vertex == 2
    with pytest.raises(GeometryError, match="repeats vertex 1") as e:  # the last vertex closes onto the first
        brep.validate_ring(np.array([(0, 0), (1, 0), (0, 1), (0, 0)]))
    assert e.value.vertex == 4


def test_locate_vertex_numbers_vertices_within_their_own_ring():
    rings = [np.array([(0, 0), (10, 0), (10, 10), (0, 10)], float), np.array([(2, 2), (2, 4), (4, 4), (4, 2)], float)]
    assert brep.locate_vertex(rings, ["principal", "hole 1"], "Self-intersection[4.1 3.9]") == ("hole 1", 3)
    assert brep.locate_vertex(rings, ["principal", "hole 1"], "Self-intersection[2 2]") == ("hole 1", 1)
    assert brep.locate_vertex(rings, ["principal", "hole 1"], "Self-intersection[0 9]") == ("principal", 4)
    assert brep.locate_vertex(rings, ["principal", "hole 1"], "Too few points") == (None, None)


def test_from_shapely_keeps_only_pieces_and_holes_with_area():
    with pytest.raises(GeometryError, match="no free space with area"):
        BRepMap.from_shapely(shapely.Polygon([(0, 0), (1, 1), (2, 2)]))
    # a hole collapsed onto a line bounds nothing
    g = shapely.Polygon([(0, 0), (4, 0), (4, 4), (0, 4)], [[(1, 1), (2, 1), (3, 1)]])
    m = BRepMap.from_shapely(g)
    assert m.n_holes == 0 and np.isclose(m.area, 16)
    m.validate()


def test_union_repairs_invalid_polygons_and_simplifies_within_the_tolerance():
    bow_tie = shapely.Polygon([(0, 0), (2, 2), (2, 0), (0, 2)])  # two triangles of area 1 meeting at (1, 1)
    for simplify in (0.0, 0.01):  # simplified, both triangles too (GEOS's own mend keeps one)
        g = union.union([bow_tie, shapely.box(10, 10, 11, 11)], simplify=simplify)
        assert g.is_valid and np.isclose(g.area, 3.0)
    # a notch 2 mm wide reaching down to 4 mm above a bottom edge that dips 8 mm under it:
    # simplified within 1 cm the dip goes and the edge would cross the notch; the union is valid
    # and differs from the exact one only within 1 cm of its boundary
    notched = shapely.Polygon([(0, 0.008), (6.001, 0), (10, 0.008), (10, 2), (6.002, 2), (6.002, 0.004),
                               (6, 0.004), (6, 2), (0, 2)])
    g = union.union([notched, shapely.box(20, 0, 21, 1)], simplify=0.01)
    exact = shapely.union(notched, shapely.box(20, 0, 21, 1))
    assert g.is_valid and shapely.symmetric_difference(g, exact).difference(exact.boundary.buffer(0.0101)).area < 1e-12
    bumpy = shapely.Polygon([(0, 0), (2, 0), (2, 1), (2.01, 2), (2, 3), (0, 3)])  # 1 cm off the line x = 2
    assert len(shapely.get_coordinates(union.union([bumpy]))) == 7
    simple = union.union([bumpy], simplify=0.05)
    assert simple.equals(shapely.box(0, 0, 2, 3))


def test_clean_drops_pieces_and_holes_of_at_most_the_given_areas():
    big = shapely.Polygon([(0, 0), (10, 0), (10, 10), (0, 10)],
                          [shapely.box(1, 1, 2, 2).exterior.coords, shapely.box(4, 4, 6, 6).exterior.coords])
    g = shapely.MultiPolygon([big, shapely.box(20, 0, 21, 1), shapely.box(30, 0, 32, 2)])
    out = union.clean(g, min_piece_area=1.0, min_hole_area=1.0)
    # the 1 m² piece and the 1 m² hole go; the 4 m² piece and hole stay
    assert np.isclose(out.area, 100 - 4 + 4)
    parts = shapely.get_parts(out)
    assert len(parts) == 2 and sum(len(p.interiors) for p in parts) == 1
    assert shapely.get_parts(out)[0].interiors[0].envelope.equals(shapely.box(4, 4, 6, 6))


def test_clean_simplifies_and_drops_holes_too_small_for_the_tolerance():
    # a vertex 1 cm off a wall is simplified away at 5 cm
    bumpy = shapely.Polygon([(0, 0), (2, 0), (2, 1), (2.01, 2), (2, 3), (0, 3)])
    assert union.clean(bumpy, simplify=0.05).equals(shapely.box(0, 0, 2, 3))
    # a 7 cm square hole (49 cm²) is under (1 m / 10)² = 100 cm²: nothing at a 1 m tolerance
    room = shapely.Polygon([(0, 0), (20, 0), (20, 20), (0, 20)], [shapely.box(10, 10, 10.07, 10.07).exterior.coords])
    out = union.clean(room, simplify=1.0)
    assert len(out.interiors) == 0 and np.isclose(out.area, 400)
    assert len(union.clean(room, simplify=0.01).interiors) == 1  # (1 mm)² is smaller: kept


def test_map_file_round_trips_exactly(tmp_path):
    a = ring([(0, 0), (6, 0), (6, 1), (1, 1), (1, 4), (6, 4), (6, 5), (0, 5)])
    b = ring([(5, 0), (10, 0), (10, 5), (5, 5), (5, 4), (9, 4), (9, 1), (5, 1)])
    m = unite(a, b, ring([(20, 0), (21.123456789, 0.1), (20.5, 1 / 3)]))
    rings = [Ring(r.vertices, np.arange(len(r)) % 2, np.arange(len(r)) % 3 + 1) for r in m.rings]
    m = m.with_rings(rings)
    poses = np.array([[0.1, 0.2, 0.3, 1e9 + 0.123]])
    p = tmp_path / "map.json"
    write_map(p, MapFile(m, [{"index": 1, "type": "triangular", "tme": 0.2}], poses, {"source": "test"}))
    back = read_map(p)
    assert back.crisp.equals_exactly(m) and np.array_equal(back.poses, poses)
    assert back.metadata == {"source": "test"} and back.membership_functions[0]["tme"] == 0.2
    assert not list(tmp_path.glob(".*tmp"))  # no temporary left behind
    # readable like any file the user writes, not private like a temporary file
    from fuzzybrep.formats.files import FILE_MODE

    assert p.stat().st_mode & 0o777 == FILE_MODE


def test_map_file_errors_name_the_file(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text("{not json")
    with pytest.raises(MapFileError, match="bad.json.*not valid JSON"):
        read_map(p)
    p.write_text(json.dumps({"format": "fuzzybrep-map", "version": 99}))
    with pytest.raises(MapFileError, match="version 99"):
        read_map(p)
    p.write_text(json.dumps({"format": "fuzzybrep-map", "version": 1, "regions": [{"shell": {"x": [0, 1], "y": [0]}}]}))
    with pytest.raises(MapFileError, match="malformed.*region 0 shell"):
        read_map(p)
    with pytest.raises(MapFileError, match="cannot read"):
        read_map(tmp_path / "missing.json")


def test_failed_write_leaves_the_old_map_intact(tmp_path, monkeypatch):
    m = unite(octagon(0, 0, 1))
    p = tmp_path / "map.json"
    write_map(p, MapFile(m))
    before = p.read_bytes()

    def boom(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("fuzzybrep.formats.files.os.replace", boom)
    with pytest.raises(MapFileError, match="No space left"):
        write_map(p, MapFile(unite(octagon(5, 5, 2))))
    assert p.read_bytes() == before and not list(tmp_path.glob(".*tmp"))


def test_geojson_export_is_the_crisp_free_space(tmp_path):
    a = ring([(0, 0), (6, 0), (6, 1), (1, 1), (1, 4), (6, 4), (6, 5), (0, 5)])
    b = ring([(5, 0), (10, 0), (10, 5), (5, 5), (5, 4), (9, 4), (9, 1), (5, 1)])
    m = unite(a, b, ring([(20, 0), (21, 0), (20, 1)]))
    p = tmp_path / "m.geojson"
    write_geojson(p, crisp_features(m))
    d = json.loads(p.read_text())
    assert d["type"] == "FeatureCollection" and d["features"][0]["properties"]["role"] == "crisp"
    g = shapely.geometry.shape(d["features"][0]["geometry"])
    assert g.geom_type == "MultiPolygon" and g.is_valid and np.isclose(g.area, m.area)
    assert sum(len(p.interiors) for p in g.geoms) == 1


def test_pockets_no_ray_entered_and_narrower_than_tme_are_taken_into_the_free_space():
    # a room with three holes: a thin pocket bounded by frontier edges only (the shadow between
    # two rays), a wide frontier pocket, and a thin obstacle (a wall edge: a return was seen)
    from fuzzybrep.brep import FRONTIER, OBSTACLE, Region
    from fuzzybrep.mapping.build import fill_pockets

    def hole(poly, kind):
        v = np.asarray(poly.exterior.coords)[:-1][::-1]
        return Ring(v, np.full(len(v), kind, np.uint8))

    shell = Ring(np.asarray(shapely.box(0, 0, 10, 10).exterior.coords)[:-1])
    thin = hole(shapely.box(2, 2, 2.15, 6), FRONTIER)
    wide = hole(shapely.box(5, 5, 7, 7), FRONTIER)
    wall = hole(shapely.box(8, 2, 8.1, 6), OBSTACLE)
    crisp = BRepMap((Region(shell, (thin, wide, wall)),))
    out = fill_pockets(crisp, 0.2)
    assert [len(r) for r in out.regions[0].holes] == [4, 4]
    assert out.regions[0].holes[0] is wide and out.regions[0].holes[1] is wall
    assert out.area == pytest.approx(crisp.area + 0.15 * 4)
    assert fill_pockets(crisp, 0.1).regions[0].holes == crisp.regions[0].holes  # 0.15 m is not narrower than 0.1
    assert fill_pockets(crisp, 0.0) is crisp


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 40))
def test_clipper_union_is_geos_union(seed, n):
    # star-shaped fans round random poses, overlapping, enclosing courtyards (holes) and, inside
    # those, islands: Clipper2's union is GEOS's to a part in 10^8 of the area, and valid
    rng = np.random.default_rng(seed)
    polys = []
    for _ in range(n):
        c = rng.uniform(0, 10, 2)
        a = np.sort(rng.uniform(0, 2 * np.pi, 30))
        r = rng.uniform(0.2, 3) * rng.uniform(0.3, 1, 30)
        polys.append(shapely.make_valid(shapely.Polygon(c + np.c_[r * np.cos(a), r * np.sin(a)])))
    ring = shapely.box(-5, -5, 15, 15).difference(shapely.box(-4, -4, 14, 14))  # a courtyard round them all
    island = shapely.box(4.9, 4.9, 5.1, 5.1)
    polys = np.array([*polys, ring, island], dtype=object)
    geos = union.union(polys, engine="geos")
    clip = union.union(polys, engine="clipper")
    assert clip.is_valid
    assert shapely.symmetric_difference(geos, clip).area <= 1e-8 * geos.area
    assert len(shapely.get_parts(clip)) == len(shapely.get_parts(geos))


def test_clipper_hands_coordinates_too_large_for_its_integers_to_geos(monkeypatch):
    far = [shapely.box(1e12, 0, 1e12 + 2, 2), shapely.box(1e12 + 1, 1, 1e12 + 3, 3)]
    monkeypatch.setattr(union, "clipper_union", lambda *a: pytest.fail("Clipper2 was given coordinates of 1e12"))
    assert np.isclose(union.union(far).area, 7.0)


def test_the_clipper_tree_split_between_two_processes_is_the_tree_in_one(monkeypatch):
    # pyclipr holds the GIL while it unites: a long log's first half goes to a forked process
    rng = np.random.default_rng(7)
    polys = np.array([shapely.box(x, y, x + rng.uniform(0.5, 3), y + rng.uniform(0.5, 3))
                      for x, y in rng.uniform(0, 20, (60, 2))], dtype=object)
    monkeypatch.setattr(union, "PROCESS_FROM", 10**9)
    one = union.clipper_union(polys)
    monkeypatch.setattr(union, "PROCESS_FROM", 10)
    monkeypatch.setattr(union.os, "cpu_count", lambda: 2)
    two = union.clipper_union(polys)
    assert two.is_valid and shapely.symmetric_difference(one, two).area <= 1e-9 * one.area
