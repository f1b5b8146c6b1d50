"""The fuzzy B-rep commands and GeoJSON input: fuzzify, tables, alpha-cut, membership, memory."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
import shapely

from _fuzzy_shapes import TABLE_4_1, TABLE_4_1_VERTICES
from fuzzybrep.cli import main
from fuzzybrep.errors import GeometryError, MapFileError
from fuzzybrep.fuzzy.map import FuzzyBRepMap
from fuzzybrep.formats.geojson import crisp_from_geojson, read_geojson
from fuzzybrep.formats.points import read_points


def polygon(shell, *holes):
    return {"type": "Polygon", "coordinates": [[list(p) for p in (*r, r[0])] for r in (shell, *holes)]}


SQUARE = [(0, 0), (10, 0), (10, 10), (0, 10)]
HOLE = [(4, 4), (4, 6), (6, 6), (6, 4)]


@pytest.fixture
def plan(tmp_path):
    """A floor plan in mm: the thesis's Figure 4.10 polygon."""
    p = tmp_path / "plan.geojson"
    p.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"name": "E1"}, "geometry": polygon(TABLE_4_1_VERTICES.tolist())}]}))
    return p


def run(*argv) -> int:
    return main([str(a) for a in argv])


def test_fuzzify_then_tables_reproduce_table_4_1(plan, tmp_path, capsys):
    out = tmp_path / "map.json"
    assert run("fuzzify", plan, "--unit", "mm", "--tme", 200, "--out", out) == 0
    assert "8 vertices" in capsys.readouterr().out
    assert run("tables", out, "--csv", tmp_path / "t", "--per-ring") == 0
    with open(tmp_path / "t" / "vertices_principal.csv") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["VERTEX", "X", "Y", "XOUT", "YOUT", "XIN", "YIN", "T", "U", "V", "W", "FM"]
    got = {(float(r[1]), float(r[2])): [float(c) for c in r[3:11]] for r in rows[1:]}
    for v, expected in zip(TABLE_4_1_VERTICES, TABLE_4_1):  # the map file orders the ring CCW
        np.testing.assert_allclose(got[tuple(v)], expected, atol=0.05)
    assert all(r[11] == "1" for r in rows[1:])
    with open(tmp_path / "t" / "edges_principal.csv") as fh:
        edges = list(csv.reader(fh))
    assert edges[0][:9] == ["EDGE", "VSTART", "VEND", "EDGE_OUT", "VOUT_START", "VOUT_END", "EDGE_IN", "VIN_START",
                            "VIN_END"]
    assert edges[1][:9] == ["E1", "V1", "V2", "EO1", "VO1", "VO2", "EI1", "VI1", "VI2"]
    with open(tmp_path / "t" / "membership_functions.csv") as fh:
        mf = list(csv.reader(fh))
    assert mf[1][:2] == ["1", "triangular"] and "TME = 200" in mf[1][2]


def test_tables_with_holes_and_null_vertices(tmp_path, capsys):
    chamfered = [(0, 0), (10, 0), (10, 9.5), (9.5, 10), (0, 10)]
    src = tmp_path / "c.geojson"
    src.write_text(json.dumps(polygon(chamfered, HOLE)))
    out = tmp_path / "m.json"
    assert run("fuzzify", src, "--tme", 2.0, "--out", out) == 0
    assert run("tables", out, "--csv", tmp_path / "p", "--per-ring") == 0
    assert sorted(p.name for p in (tmp_path / "p").iterdir()) == [
        "edges_hole_1.csv", "edges_principal.csv", "membership_functions.csv", "vertices_hole_1.csv",
        "vertices_principal.csv"]
    # by default one file per table, every ring in it (issue 20: a file per ring and table)
    assert run("tables", out, "--csv", tmp_path / "t") == 0
    assert sorted(p.name for p in (tmp_path / "t").iterdir()) == ["edges.csv", "membership_functions.csv",
                                                                   "vertices.csv"]
    for table in ("vertices", "edges"):
        together = list(csv.reader(open(tmp_path / "t" / f"{table}.csv")))
        assert together[0][0] == "RING" and {r[0] for r in together[1:]} == {"principal", "hole_1"}
        for ring in ("principal", "hole_1"):
            alone = list(csv.reader(open(tmp_path / "p" / f"{table}_{ring}.csv")))
            assert [r[1:] for r in together[1:] if r[0] == ring] == alone[1:] and together[0][1:] == alone[0]
    rows = list(csv.reader(open(tmp_path / "p" / "vertices_principal.csv")))
    nulls = [r[0] for r in rows[1:] if r[5] == "" and r[6] == ""]
    assert len(nulls) == 2 and all(r[7] != "" for r in rows[1:])  # VIN NULL, line kept
    capsys.readouterr()
    assert run("tables", out) == 0
    text = capsys.readouterr().out
    assert "Fuzzy vertex table (Table 4.1): principal" in text and "hole 1" in text and "NULL" in text


def test_alpha_cut_writes_roles_and_alpha(plan, tmp_path):
    m = tmp_path / "map.json"
    run("fuzzify", plan, "--unit", "mm", "--tme", 200, "--out", m)
    cut = tmp_path / "cut.geojson"
    assert run("alpha-cut", m, "--alpha", 0, "--alpha", 0.5, "--alpha", 1, "--out", cut) == 0
    fc = json.loads(cut.read_text())
    assert fc["type"] == "FeatureCollection"
    props = [(f["properties"]["role"], f["properties"]["alpha"]) for f in fc["features"]]
    assert props == [("crisp", 1.0), ("inner", 0.0), ("outer", 0.0), ("inner", 0.5), ("outer", 0.5),
                     ("inner", 1.0), ("outer", 1.0)]
    geoms = [shapely.from_geojson(json.dumps(f["geometry"])) for f in fc["features"]]
    crisp = geoms[0]
    assert all(g.is_valid for g in geoms)
    assert geoms[1].within(geoms[3]) and geoms[4].within(geoms[2])  # nesting
    assert geoms[5].equals(crisp) and geoms[6].equals(crisp)
    assert run("alpha-cut", m, "--alpha", 0.2, "--method", "exact", "--out", cut) == 0
    assert json.loads(cut.read_text())["features"][1]["properties"]["method"] == "exact"


def test_alpha_cut_refuses_bad_alpha(plan, tmp_path, capsys):
    m = tmp_path / "map.json"
    run("fuzzify", plan, "--unit", "mm", "--tme", 200, "--out", m)
    with pytest.raises(SystemExit) as e:
        run("alpha-cut", m, "--alpha", 1.5, "--out", tmp_path / "c.geojson")
    assert e.value.code == 2 and "[0, 1]" in capsys.readouterr().err
    # a negative number with an exponent is a value for every command, not only plan's coordinates
    with pytest.raises(SystemExit):
        run("alpha-cut", m, "--alpha", "-1e-3", "--out", tmp_path / "c.geojson")
    assert "argument --alpha: α must lie in [0, 1], got -1e-3" in capsys.readouterr().err


def test_membership_command(tmp_path, capsys):
    src = tmp_path / "sq.geojson"
    src.write_text(json.dumps(polygon(SQUARE)))
    m = tmp_path / "m.json"
    run("fuzzify", src, "--tme", 1, "--out", m)
    pts = tmp_path / "pts.csv"
    pts.write_text("x,y\n5,0\n5,0.5\n5,5\n# comment\n5,-3\n")
    capsys.readouterr()
    assert run("membership", m, "--points", pts, "--method", "both") == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0] == "x,y,mu_safe,mu_exact"
    mu = np.array([[float(c) for c in ln.split(",")[2:]] for ln in lines[1:]])
    np.testing.assert_allclose(mu[:, 1], [1, 0.5, 0, 0])
    np.testing.assert_allclose(mu[:, 0], [1, 0.5, 0, 0], atol=1e-6)  # the safe μ: the exact one along a wall
    assert run("membership", m, "--points", pts, "--method", "all") == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0] == "x,y,mu_safe,mu_thesis,mu_exact"
    mu = np.array([[float(c) for c in ln.split(",")[2:]] for ln in lines[1:]])
    np.testing.assert_allclose(mu[:, 1], [1, 1 - 0.5 * 2 ** 0.5, 0, 0], atol=1e-6)  # the thesis's sweep
    bad = tmp_path / "bad.csv"
    bad.write_text("1,2\n3,oops\n")
    assert run("membership", m, "--points", bad) == 2
    assert "bad.csv: line 2: x,y must be numbers" in capsys.readouterr().err


def test_memory_command(tmp_path, capsys):
    src = tmp_path / "sq.geojson"
    src.write_text(json.dumps(polygon(SQUARE, HOLE)))
    m = tmp_path / "m.json"
    run("fuzzify", src, "--tme", 0.2, "--out", m)
    capsys.readouterr()
    assert run("memory", m, "--cell", 0.3, "--cell", 0.1) == 0
    text = capsys.readouterr().out
    assert "| fuzzy B-rep, thesis accounting (10 per vertex + 6 per edge) | 128 | 512 |" in text
    assert "over the map's area (96 m²) | 1067 | 4268 |" in text  # ceil(96 / 0.09)
    assert "0.1×0.1 m over the map's area (96 m²) | 9600 | 38400 |" in text


def test_memory_command_defaults_to_the_thesis_grids_in_the_map_unit(tmp_path, capsys):
    # before: the default cells were 0.3, 0.2 and 0.1 in the map's unit, so a map in millimetres
    # (the thesis's unit) was compared with 0.1 mm grids of 38 million cells a square metre
    m = tmp_path / "mm.json"
    for unit, scale in (("m", 1.0), ("mm", 1000.0)):
        src = tmp_path / f"{unit}.geojson"
        src.write_text(json.dumps(polygon([(x * scale, y * scale) for x, y in SQUARE])))  # 100 m²
        run("fuzzify", src, "--tme", 0.2 * scale, "--unit", unit, "--out", m)
        capsys.readouterr()
        assert run("memory", m) == 0
        text = capsys.readouterr().out
        size = {0.3: 300, 0.2: 200, 0.1: 100}
        for c, n in ((0.3, 1112), (0.2, 2500), (0.1, 10000)):  # ceil(100 m² / c²)
            label = f"{c:g}×{c:g} m" if unit == "m" else f"{size[c]}×{size[c]} mm"
            assert f"occupancy grid {label} over the map's area" in text
            assert f"| {n} | {4 * n} |" in text
        # the box in the map's unit as a reader writes it (before: "1e+04×1e+04 mm" for 10000 mm)
        assert f"over the bounding box ({10 * scale:g}×{10 * scale:g} {unit})" in text
    ft = tmp_path / "ft.geojson"
    ft.write_text(json.dumps(polygon(SQUARE)))
    run("fuzzify", ft, "--tme", 0.5, "--unit", "ft", "--out", m)
    capsys.readouterr()
    assert run("memory", m) == 2  # no thesis grid in feet: asked for, not guessed
    assert "mm.json: no default grid cells for unit 'ft': give them with --cell" in capsys.readouterr().err
    assert run("memory", m, "--cell", 1) == 0


def test_fuzzify_needs_a_tme_and_checks_the_function(plan, tmp_path, capsys):
    out = tmp_path / "m.json"
    assert run("fuzzify", plan, "--out", out) == 2
    assert "give --tme" in capsys.readouterr().err
    assert run("fuzzify", plan, "--tme", 200, "--mf", "A2:p=0.001", "--out", out) == 2
    assert "criterion 1" in capsys.readouterr().err
    assert run("fuzzify", plan, "--laser-error", 15, "--odometry-error", 184.13, "--unit", "mm", "--out", out) == 0
    assert FuzzyBRepMap.load(out).table[1].tme_in == pytest.approx(199.13)
    assert run("fuzzify", plan, "--tme", 200, "--mf", "A2:p=0.001,truncate", "--frontier-mf", "tri:tme=400",
               "--out", out) == 0
    assert FuzzyBRepMap.load(out).table.indices == [1, 2]


def test_commands_on_a_crisp_map_file_need_tme(tmp_path, capsys):
    from fuzzybrep.brep import BRepMap
    from fuzzybrep.formats.mapfile import MapFile, write_map
    m = tmp_path / "crisp.json"
    write_map(m, MapFile(BRepMap.from_shapely(shapely.box(0, 0, 5, 5))))
    assert run("memory", m) == 2
    err = capsys.readouterr().err
    assert "no membership-function table" in err and "give its TME (--tme)" in err  # the option to use
    assert run("memory", m, "--tme", 0.2) == 0
    out = tmp_path / "fz.json"
    assert run("fuzzify", m, "--tme", 0.3, "--out", out) == 0  # a crisp map file is a valid input
    assert FuzzyBRepMap.load(out).table[1].tme_in == 0.3
    # a map with its own functions: --tme would be ignored, so it is refused, by every map command
    capsys.readouterr()
    (tmp_path / "pts.csv").write_text("1,1\n")
    for cmd in (["memory"], ["tables"], ["view", "--html", tmp_path / "v.html"], ["plan", "--start", 1, 1, "--goal", 2, 2],
                ["export", "--geojson", tmp_path / "e.geojson"], ["alpha-cut", "--alpha", 0.5, "--out", tmp_path / "c.geojson"],
                ["membership", "--points", tmp_path / "pts.csv"]):
        assert run(cmd[0], out, *cmd[1:], "--tme", 0.5) == 2
        assert "fz.json: the map has its own membership functions (Table 4.2), so --tme 0.5 would not be used" \
            in capsys.readouterr().err
    assert not any((tmp_path / f).exists() for f in ("v.html", "e.geojson", "c.geojson"))
    # the command it suggests fuzzifies with the TME asked for, not one rounded to 6 digits
    assert run("memory", out, "--tme", 0.1234567) == 2
    assert f"`fuzzybrep fuzzify {out} --tme 0.1234567 --out NEW.json`" in capsys.readouterr().err


def test_fuzzify_a_fuzzy_map_file_again(tmp_path, capsys):
    # a built map gives its frontier vertices FM 2; before, refuzzifying it with one function
    # failed with "principal, vertex 2: FM index 2 has no membership function in the table",
    # and then gave every vertex FM 1, losing the frontier's own index. Now, as `build`: FM 2
    # with the new function, or the one --frontier-mf names
    from fuzzybrep.brep import BRepMap, Region, Ring
    from fuzzybrep.fuzzy.map import fuzzify
    from fuzzybrep.fuzzy.membership import Triangular

    ring = Ring([(0, 0), (5, 0), (5, 5), (0, 5)], kinds=[0, 1, 0, 0])
    built = tmp_path / "built.json"
    fuzzify(BRepMap((Region(ring),)), Triangular(0.2), frontier_mf=Triangular(0.4)).save(built)
    out = tmp_path / "again.json"
    assert run("fuzzify", built, "--tme", 0.3, "--out", out) == 0, capsys.readouterr().err
    again = FuzzyBRepMap.load(out)
    assert again.crisp.principal.kinds.tolist() == [0, 1, 0, 0]
    assert again.table.indices == [1, 2] and [again.table[k].support_in for k in (1, 2)] == [0.3, 0.3]
    assert again.crisp.principal.fm.tolist() == [1, 2, 2, 1]  # vertices 2 and 3 end the frontier edge
    assert run("fuzzify", built, "--tme", 0.3, "--frontier-mf", "triangular:in=0.5,out=0.5", "--out", out) == 0
    again = FuzzyBRepMap.load(out)
    assert [again.table[k].support_in for k in (1, 2)] == [0.3, 0.5] and again.crisp.principal.fm.tolist() == [1, 2, 2, 1]
    # a map without frontier edges keeps one function
    plain = tmp_path / "plain.json"
    fuzzify(BRepMap((Region(Ring([(0, 0), (5, 0), (5, 5), (0, 5)])),)), Triangular(0.2)).save(plain)
    assert run("fuzzify", plain, "--tme", 0.3, "--out", out) == 0
    assert FuzzyBRepMap.load(out).table.indices == [1]


# -- GeoJSON input -----------------------------------------------------------------------------


def test_geojson_kinds():
    g = crisp_from_geojson(polygon(SQUARE, HOLE))
    assert len(g.holes) == 1 and g.principal.signed_area > 0 and g.holes[0].signed_area < 0
    mp = {"type": "MultiPolygon", "coordinates": [polygon(SQUARE)["coordinates"],
                                                   polygon([(20, 0), (22, 0), (22, 2)])["coordinates"]]}
    g = crisp_from_geojson(mp, unit="mm")
    assert len(g.regions) == 2 and g.unit == "mm" and g.regions[0].area == 100
    fc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "geometry": polygon(SQUARE)},
        {"type": "Feature", "geometry": polygon([(5, 5), (15, 5), (15, 8), (5, 8)])},  # overlaps: united
        {"type": "Feature", "geometry": None}]}
    g = crisp_from_geojson(fc)
    assert len(g.regions) == 1 and g.area == pytest.approx(100 + 15)
    unclosed = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1, 5.0]]]}  # 3-D, unclosed: fine
    assert len(crisp_from_geojson(unclosed).principal) == 3


def test_a_floor_plan_in_the_simulators_scheme_reads_as_its_free_space(tmp_path, capsys):
    # before: the route and glass lines were refused ("a LineString has no area"), and without
    # them the obstacle polygons were united with the free space (a pillar mapped as floor) and
    # the file's "unit" ignored (a plan in mm read as metres)
    mm = lambda ring: [[1000 * x, 1000 * y] for x, y in (*ring, ring[0])]  # noqa: E731
    plan = tmp_path / "room.geojson"
    plan.write_text(json.dumps({"type": "FeatureCollection", "unit": "mm", "features": [
        {"type": "Feature", "properties": {"role": "free"},
         "geometry": {"type": "Polygon", "coordinates": [mm([(0, 0), (10, 0), (10, 6), (0, 6)])]}},
        {"type": "Feature", "properties": {"role": "obstacle"},
         "geometry": {"type": "Polygon", "coordinates": [mm([(4, 2.5), (5, 2.5), (5, 3.5), (4, 3.5)])]}},
        {"type": "Feature", "properties": {"material": "glass"},
         "geometry": {"type": "LineString", "coordinates": [[0, 0], [10000, 0]]}},
        {"type": "Feature", "properties": {"role": "route", "spacing": 2},
         "geometry": {"type": "LineString", "coordinates": [[1000, 1000], [9000, 1000]]}}]}))
    out = tmp_path / "room.json"
    assert run("fuzzify", plan, "--tme", 200, "--out", out) == 0
    fz = FuzzyBRepMap.load(out)
    assert fz.unit == "mm" and fz.crisp.n_holes == 1 and fz.crisp.area == 60e6 - 1e6
    assert run("fuzzify", plan, "--tme", 0.2, "--unit", "m", "--out", out) == 2
    assert "room.geojson: the file's unit is 'mm', but 'm' was given" in capsys.readouterr().err
    # the demo's own floorplan.geojson: the built-in floor's free space, its block a hole
    from fuzzybrep.sim.simulate import builtin_floor, builtin_route

    world = builtin_floor()
    world.write_geojson(tmp_path / "floorplan.geojson", builtin_route())
    crisp = read_geojson(tmp_path / "floorplan.geojson")
    assert crisp.unit == "m" and crisp.to_shapely().symmetric_difference(world.free).area < 1e-9


@pytest.mark.parametrize("obj, error, match", [
    ({"type": "Polygon", "coordinates": [[[0, 0], [4, 0], [0, 4], [6, 4], [0, 0]]]}, GeometryError,
     r"polygon outer ring, vertex \d: self-intersecting"),
    ({"type": "FeatureCollection", "features": [{"type": "Feature", "geometry": polygon(SQUARE)},
                                                {"type": "Feature", "geometry": polygon(SQUARE, [(4, 4), (14, 4), (4, 6)])}]},
     GeometryError, r"feature 2 polygon (outer ring|hole 1), vertex \d+: invalid polygon"),
    ({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], ["a", 1], [0, 0]]]}, GeometryError,
     r"polygon outer ring, vertex 3: position \['a', 1\] is not \[x, y\] numbers"),
    ({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1], [0, 0]]]}, GeometryError,
     r"polygon outer ring, vertex 3: position \[1\] is not \[x, y\]"),
    ({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 0]]]}, GeometryError, "at least 3 vertices"),
    ({"type": "LineString", "coordinates": [[0, 0], [1, 1]]}, ValueError, "LineString has no area"),
    ({"type": "Circle"}, ValueError, "unknown GeoJSON type 'Circle'"),
    ({"type": "FeatureCollection", "features": []}, ValueError, "no Polygon"),
])
def test_invalid_geojson_is_refused_naming_where(obj, error, match):
    with pytest.raises(error, match=match):
        crisp_from_geojson(obj)


def test_read_geojson_file_errors(tmp_path):
    p = tmp_path / "x.geojson"
    p.write_text("{not json")
    with pytest.raises(MapFileError, match="x.geojson: not valid JSON"):
        read_geojson(p)
    p.write_text(json.dumps({"type": "Point", "coordinates": [0, 0]}))
    with pytest.raises(MapFileError, match="x.geojson: a Point has no area"):
        read_geojson(p)
    with pytest.raises(MapFileError, match="cannot read"):
        read_geojson(tmp_path / "missing.geojson")
    p.write_bytes(b'{"type": "Polygon\xff"}')
    with pytest.raises(MapFileError, match="x.geojson: cannot read"):
        read_geojson(p)


def test_fuzzify_cli_names_the_bad_vertex(tmp_path, capsys):
    p = tmp_path / "bow.geojson"
    p.write_text(json.dumps({"type": "Polygon", "coordinates": [[[0, 0], [4, 0], [0, 4], [6, 4], [0, 0]]]}))
    assert run("fuzzify", p, "--tme", 0.1, "--out", tmp_path / "m.json") == 2
    err = capsys.readouterr().err
    assert f"fuzzybrep fuzzify: error: {p}: polygon outer ring, vertex" in err and "self-intersecting" in err
    with pytest.raises(MapFileError, match=r"bow.geojson: polygon outer ring, vertex \d: self-intersecting"):
        read_geojson(p)


def test_read_points(tmp_path):
    p = tmp_path / "p.csv"
    p.write_text("x,y,label\n1,2,a\n\n3.5,-4,b\n")
    assert read_points(p).tolist() == [[1, 2], [3.5, -4]]
    p.write_text("1\n")
    with pytest.raises(MapFileError, match="line 1: expected x,y"):
        read_points(p)
    p.write_text("x,y\n\n")
    with pytest.raises(MapFileError, match="p.csv: no x,y points in the file"):
        read_points(p)
    # a header naming x and y places them (before: the first two columns whatever their names,
    # so "id,x,y" read the ids as x and "y,x" swapped every point without a word)
    p.write_text("id,X,Y\n7,1,2\n8,3.5,-4\n")
    assert read_points(p).tolist() == [[1, 2], [3.5, -4]]
    p.write_text("y,x\n2,1\n")
    assert read_points(p).tolist() == [[1, 2]]
    p.write_text("id,x,y\n7,1\n")
    with pytest.raises(MapFileError, match="line 2: expected x,y, got '7,1'"):
        read_points(p)
    p.write_text("x,y\n1,2\nfoo,bar\n")  # a header is the first line only
    with pytest.raises(MapFileError, match="p.csv: line 3: x,y must be numbers, got 'foo', 'bar'"):
        read_points(p)
    p.write_text("1,2\nnan,3\n")
    with pytest.raises(MapFileError, match="p.csv: line 2: x,y must be finite"):
        read_points(p)


def test_fuzzify_reads_back_the_crisp_map_of_exported_alpha_cuts(tmp_path, capsys):
    # before: export --geojson (and alpha-cut) write the crisp map with its inner and outer α-cuts,
    # and fuzzify united them all, so the map read back was the α = 0 outer cut (10×10 m square:
    # 100 m² became 108 m²), and the crisp feature's "unit" was ignored (a map in mm read as m)
    src = tmp_path / "sq.geojson"
    mm = lambda ring: [(1000 * x, 1000 * y) for x, y in ring]  # noqa: E731
    src.write_text(json.dumps(polygon(mm(SQUARE), mm(HOLE))))
    first, again = tmp_path / "a.json", tmp_path / "b.json"
    assert run("fuzzify", src, "--unit", "mm", "--tme", 200, "--out", first) == 0
    for cmd in (("export", first, "--geojson", tmp_path / "cuts.geojson"),
                ("alpha-cut", first, "--alpha", 0, "--out", tmp_path / "cuts.geojson")):
        assert run(*cmd) == 0
        assert run("fuzzify", tmp_path / "cuts.geojson", "--tme", 200, "--out", again) == 0
        a, b = FuzzyBRepMap.load(first), FuzzyBRepMap.load(again)
        assert b.unit == "mm" and b.crisp.area == a.crisp.area == 96e6 and b.crisp.n_holes == 1
    # α-cuts without their crisp map are not one: refused, naming the feature
    fc = json.loads((tmp_path / "cuts.geojson").read_text())
    fc["features"] = fc["features"][1:]
    with pytest.raises(ValueError, match=r"feature 1 polygon: an α-cut \(role 'inner', alpha 0"):
        crisp_from_geojson(fc)
