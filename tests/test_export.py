"""fuzzybrep export: the ROS map_server pair, GeoJSON α-cuts and the SVG picture."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import shapely

from _floor import TME, floor_map, floor_poses
from fuzzybrep import BRepMap, Region, Ring
from fuzzybrep.brep import FRONTIER
from fuzzybrep.cli import main
from fuzzybrep.formats.export import (FREE_GREY, FREE_STEPS, FREE_THRESH, OCCUPIED_STEPS, OCCUPIED_THRESH,
                                      UNKNOWN_GREY, crisp_features, grey_levels, membership_raster, mu_from_grey,
                                      write_ros)
from fuzzybrep.formats.geojson import geometry_json
from fuzzybrep.formats.rosmap import RosMap, read_ros_map

SVG = "{http://www.w3.org/2000/svg}"


def run(*argv) -> int:
    return main([str(a) for a in argv])


@pytest.fixture(scope="module")
def floor():
    return floor_map()


@pytest.fixture
def floor_file(floor, tmp_path):
    path = tmp_path / "floor.json"
    floor.save(path, poses=floor_poses())
    return path


# ------------------------------------------------------------------------- ROS grey levels


def test_every_grey_level_keeps_its_class_in_map_server_trinary_mode():
    mu = np.linspace(0, 1, 1001)
    n = len(mu)
    free = grey_levels(mu, np.ones(n, bool), np.zeros(n, bool))
    occupied = grey_levels(mu, np.zeros(n, bool), np.ones(n, bool))
    unknown = grey_levels(mu, np.zeros(n, bool), np.zeros(n, bool))
    assert free.min() == FREE_GREY - FREE_STEPS == 206 and free.max() == FREE_GREY == 254
    assert occupied.min() == 0 and occupied.max() == OCCUPIED_STEPS == 88
    assert (unknown == UNKNOWN_GREY).all()
    img = np.stack((free, occupied, unknown))
    occ = RosMap(img, 0.05, (0.0, 0.0, 0.0), occupied_thresh=OCCUPIED_THRESH, free_thresh=FREE_THRESH).occupancy()[::-1]
    assert (occ[0] == 0).all() and (occ[1] == 100).all() and (occ[2] == -1).all()
    # μ comes back from the shade to the grey levels' precision
    np.testing.assert_allclose(mu_from_grey(free), mu, atol=0.5 / FREE_STEPS + 1e-12)
    np.testing.assert_allclose(mu_from_grey(occupied), mu, atol=0.5 / OCCUPIED_STEPS + 1e-12)
    assert np.isnan(mu_from_grey(unknown)).all()
    # 255 (white, as an editor paints free space) is free deep inside: μ 0, never below
    assert mu_from_grey(np.array([255, 254])).tolist() == [0.0, 0.0]


def test_raster_classes_and_membership_on_the_floor(floor):
    r = membership_raster(floor, 0.05, "sweep")
    h, w = r.shape
    ox, oy = r.origin
    cx = ox + (np.arange(w) + 0.5) * 0.05
    cy = oy + (np.arange(h)[::-1] + 0.5) * 0.05  # row 0 at the top
    X, Y = np.meshgrid(cx, cy)
    # classes at cell centres: free = crisp free space; occupied = the obstacle edges' band; unknown the rest
    np.testing.assert_array_equal(r.free, shapely.contains_xy(floor.crisp_geometry, X, Y))
    at = lambda x, y: (int(np.argmin(np.abs(cy - y))), int(np.argmin(np.abs(cx - x))))  # noqa: E731
    # the desk (1.2 × 0.6 m): its edges' band 0.2 m deep is occupied, its middle, 0.3 m from every
    # edge, was never seen: unknown, as the grid mapper has it (before: all occupied)
    assert r.image[at(1.4, 1.1)] == UNKNOWN_GREY and not r.occupied[at(1.4, 1.1)]
    assert r.occupied[at(0.9, 1.1)] and 0 < r.image[at(0.9, 1.1)] <= OCCUPIED_STEPS
    assert r.occupied[at(7.7, 2.7)]  # the pillar (0.4 m) is thinner than two bands: occupied through
    assert r.image[at(1.5, 6.1)] == UNKNOWN_GREY  # just beyond the frontier edge at y = 6
    assert r.occupied[at(0.5, -0.05)] and 0 < r.image[at(0.5, -0.05)] <= OCCUPIED_STEPS  # wall band, outside
    assert r.image[at(0.5, -1.0)] == UNKNOWN_GREY  # farther out nothing was seen
    assert r.image[at(2.0, 2.0)] == FREE_GREY  # far from every boundary
    # μ is the map's μ at every cell centre (the raster evaluates it only near the boundary)
    mu = floor.membership(np.column_stack((X.ravel(), Y.ravel())), "sweep").reshape(X.shape)
    np.testing.assert_allclose(r.mu, mu, atol=1e-12)
    known = r.free | r.occupied
    np.testing.assert_allclose(mu_from_grey(r.image)[known], mu[known], atol=0.5 / FREE_STEPS + 1e-9)
    assert 0.9 < mu.max() <= 1 and (mu[~known & (mu > 0)] > 0).any()
    assert (Y[~known & (mu > 0)] > 6).all()  # the unknown band with μ > 0 is the frontier's


def test_occupied_is_the_obstacle_side_of_the_band_edge_by_edge(floor):
    # the rule (formats/raster.py): within the support of an obstacle edge, on its obstacle side,
    # outside the free space; nothing beyond a frontier edge, nothing deeper
    from fuzzybrep.formats.raster import obstacle_depths, occupied_region

    occ = occupied_region(floor)
    assert occ.is_valid and not occ.intersects(shapely.Point(1.5, 6.1).buffer(0.05))
    assert shapely.intersection(occ, floor.crisp_geometry).area < 1e-9
    depth = obstacle_depths(floor)
    kinds = np.concatenate([r.kinds for r in floor.crisp.rings])
    # an obstacle edge reaches as deep as the wider of its two vertices' functions: TME, or 0.35 m
    # next to the frontier edge, whose vertices carry the wider function
    assert (depth[kinds == FRONTIER] == 0).all()
    assert set(np.round(depth[kinds != FRONTIER], 9)) == {TME, 0.35} and (depth[kinds != FRONTIER] == 0.35).sum() == 2
    # every occupied point lies within TME of an obstacle edge, and the band is TME deep
    rng = np.random.default_rng(0)
    x0, y0, x1, y1 = occ.bounds
    p = rng.uniform((x0, y0), (x1, y1), (20000, 2))
    inside = shapely.contains_xy(occ, p[:, 0], p[:, 1])
    a = np.vstack([r.vertices for r in floor.crisp.rings])
    b = np.vstack([np.roll(r.vertices, -1, axis=0) for r in floor.crisp.rings])
    obst = kinds != FRONTIER
    from fuzzybrep.geometry import segment_distance

    d = np.array([segment_distance(np.repeat(q[None], obst.sum(), 0), a[obst], b[obst]).min() for q in p[inside]])
    assert d.max() <= 0.35 + 1e-9 and np.quantile(d, 0.9) <= TME + 1e-9
    outside_free = ~shapely.contains_xy(floor.crisp_geometry, p[:, 0], p[:, 1]) & ~inside
    d_out = np.array([segment_distance(np.repeat(q[None], obst.sum(), 0), a[obst], b[obst]).min()
                      for q in p[outside_free][:3000]])
    # what is not occupied outside the free space is farther than TME from obstacle edges, or lies
    # beyond the frontier (a flat cap where the wall meets the frontier edge)
    assert ((d_out >= TME - 1e-9) | (p[outside_free][:3000, 1] > 5.6)).all()
    # the band's area: about the obstacle edges' length outside the free space times TME
    length = sum(float(np.hypot(*(b - a)[obst].T).sum()) for _ in [0])
    assert 0.8 * length * TME < occ.area < 1.05 * length * TME


def test_ros_pair_round_trips_through_standard_readers(floor, tmp_path):
    from PIL import Image
    from ruamel.yaml import YAML

    r = membership_raster(floor, 0.05, "exact")
    yaml_path, pgm_path = write_ros(tmp_path / "ros", "floor", r)
    assert yaml_path.name == "floor.yaml" and pgm_path.name == "floor.pgm"
    # map_server's YAML keys, read by a general YAML reader
    y = YAML(typ="safe").load(yaml_path.read_text())
    assert y["image"] == "floor.pgm" and y["mode"] == "trinary" and y["negate"] == 0
    assert y["resolution"] == 0.05 and y["occupied_thresh"] == 0.65 and y["free_thresh"] == 0.196
    assert y["origin"] == [r.origin[0], r.origin[1], 0.0]
    # the PGM, read by Pillow: 8-bit grey, row 0 at the top
    with Image.open(pgm_path) as im:
        assert im.mode == "L" and im.size == (r.shape[1], r.shape[0])
        np.testing.assert_array_equal(np.asarray(im), r.image)
    # and as map_server reads it
    m = read_ros_map(yaml_path)
    np.testing.assert_array_equal(m.image, r.image)
    occ = m.occupancy()
    free_area = np.count_nonzero(occ == 0) * m.resolution ** 2
    assert free_area == pytest.approx(floor.crisp_geometry.area, rel=0.05)
    assert free_area == pytest.approx(r.free_area())
    assert np.count_nonzero(occ == 100) > 0 and np.count_nonzero(occ == -1) > 0


def test_export_command_ros_free_area_matches_the_crisp_map(floor, floor_file, tmp_path, capsys):
    assert run("export", floor_file, "--ros", tmp_path / "out", "--resolution", 0.02, "--name", "f") == 0
    out = capsys.readouterr().out
    assert "free 34.62 m² (crisp map 34.62)" in out and "μ by safe" in out and "occupied" in out
    m = read_ros_map(tmp_path / "out" / "f.yaml")
    free = np.count_nonzero(m.occupancy() == 0) * m.resolution ** 2
    assert free == pytest.approx(floor.crisp_geometry.area, rel=0.01)


@pytest.mark.parametrize("stem", ["run #3", "a: b", "it's", "[x]"])
def test_ros_yaml_names_its_image_whatever_the_map_file_is_called(floor, tmp_path, stem, capsys):
    # before: the image name, by default the map file's, went into the YAML as a plain scalar, so
    # "run #3.json" gave "image: run #3.pgm", which YAML (map_server, read_ros_map) reads as
    # "run": map_server could not find the image; "a: b.pgm" was not even valid YAML
    path = tmp_path / f"{stem}.json"
    floor.save(path)
    assert run("export", path, "--ros", tmp_path / "ros") == 0
    m = read_ros_map(tmp_path / "ros" / f"{stem}.yaml")
    assert m.image_path.name == f"{stem}.pgm" and m.image.shape[0] > 0


def test_ros_export_of_a_map_in_millimetres_is_in_metres(tmp_path, capsys):
    from _fuzzy_shapes import thesis_map
    from fuzzybrep.fuzzy.map import fuzzify

    fz = fuzzify(thesis_map())  # Figure 4.10 in mm, TME 199.13 mm
    fz.save(tmp_path / "e1.json")
    assert run("export", tmp_path / "e1.json", "--ros", tmp_path, "--resolution", 0.02) == 0
    assert "cells of 0.02 m" in capsys.readouterr().out
    m = read_ros_map(tmp_path / "e1.yaml")
    assert m.resolution == 0.02
    x0, y0, _, _ = fz.crisp_geometry.bounds  # 300 mm
    assert -0.6 < m.origin[0] < x0 / 1000 and -0.6 < m.origin[1] < y0 / 1000
    free = np.count_nonzero(m.occupancy() == 0) * m.resolution ** 2
    assert free == pytest.approx(fz.crisp_geometry.area / 1e6, rel=0.05)


@pytest.mark.reallog
def test_intel_ros_export_free_area_within_5_percent(built_map, tmp_path):
    path, fuzzy = built_map("intel")
    assert run("export", path, "--ros", tmp_path / "ros") == 0
    m = read_ros_map(tmp_path / "ros" / "intel.yaml")
    occ = m.occupancy()
    free = np.count_nonzero(occ == 0) * m.resolution ** 2
    assert free == pytest.approx(fuzzy.crisp_geometry.area, rel=0.05)
    assert m.resolution == 0.05 and m.mode == "trinary"
    # walls all round the lab, and the unexplored outside
    assert np.count_nonzero(occ == 100) > 10_000 and np.count_nonzero(occ == -1) > 10_000
    # the blocks the robot drove round, seen only from outside, are unknown inside (issue 20):
    # cells inside a hole farther than 0.5 m from every boundary
    from scipy import ndimage

    from fuzzybrep.formats.raster import membership_raster as raster_of

    r = raster_of(fuzzy, 0.05, "safe")
    h, w = r.shape
    X, Y = np.meshgrid(r.origin[0] + (np.arange(w) + 0.5) * 0.05, r.origin[1] + (np.arange(h)[::-1] + 0.5) * 0.05)
    shells = shapely.union_all([shapely.Polygon(g.shell.vertices) for g in fuzzy.crisp.regions])
    deep = shapely.contains_xy(shells, X, Y) & ~r.free & ~ndimage.binary_dilation(r.free | r.occupied, iterations=10)
    assert deep.sum() > 5_000 and (occ[::-1][deep] == -1).all()
    shade = np.count_nonzero((m.image > UNKNOWN_GREY) & (m.image < FREE_GREY))
    assert shade > 10_000  # the inner band is graded, not plain white


def test_raster_refuses_bad_resolutions(floor):
    with pytest.raises(ValueError, match="positive"):
        membership_raster(floor, 0.0)
    with pytest.raises(ValueError, match="too large"):
        membership_raster(floor, 1e-4)


# ------------------------------------------------------------------------- GeoJSON


def test_geojson_has_the_crisp_map_and_inner_and_outer_per_default_level(floor, floor_file, tmp_path):
    out = tmp_path / "cuts.geojson"
    assert run("export", floor_file, "--geojson", out) == 0
    fc = json.loads(out.read_text())
    feats = fc["features"]
    assert fc["type"] == "FeatureCollection"
    assert [f["properties"]["role"] for f in feats] == ["crisp"] + ["inner", "outer"] * 5
    assert [f["properties"]["alpha"] for f in feats[1::2]] == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert all(f["properties"]["unit"] == "m" for f in feats)
    geoms = [shapely.geometry.shape(f["geometry"]) for f in feats]
    crisp = geoms[0]
    assert crisp.area == pytest.approx(floor.crisp_geometry.area)
    inner, outer = geoms[1::2], geoms[2::2]
    for a, b in zip(inner, inner[1:]):  # inner cuts grow with α, outer ones shrink
        assert a.area <= b.area + 1e-9
    for a, b in zip(outer, outer[1:]):
        assert a.area >= b.area - 1e-9
    assert inner[-1].area == pytest.approx(crisp.area) and outer[-1].area == pytest.approx(crisp.area)


def test_geojson_levels_and_method_from_the_command_line(floor_file, tmp_path):
    out = tmp_path / "cuts.geojson"
    assert run("export", floor_file, "--geojson", out, "--alpha", 0.5, "--alpha", 0.1, "--method", "exact") == 0
    feats = json.loads(out.read_text())["features"]
    assert [(f["properties"]["role"], f["properties"]["alpha"]) for f in feats] == [
        ("crisp", 1.0), ("inner", 0.1), ("outer", 0.1), ("inner", 0.5), ("outer", 0.5)]
    assert feats[1]["properties"]["method"] == "exact"


def test_geojson_rings_follow_the_right_hand_rule(floor_file, tmp_path):
    """RFC 7946, 3.1.6: exterior rings counter-clockwise, holes clockwise, in every feature and
    for both α-cut methods (GEOS's buffers and overlays return them the other way round)."""
    for method in ("safe", "sweep", "exact"):
        for command in (("export", floor_file, "--geojson"), ("alpha-cut", floor_file, "--alpha", 0, "--out")):
            out = tmp_path / f"{method}.geojson"
            assert run(*command, out, "--method", method) == 0
            for f in json.loads(out.read_text())["features"]:
                g = f["geometry"]
                for polygon in [g["coordinates"]] if g["type"] == "Polygon" else g["coordinates"]:
                    ccw = [shapely.Polygon(ring).exterior.is_ccw for ring in polygon]
                    assert ccw[0] and not any(ccw[1:]), (method, command[0], f["properties"])
    # an empty cut: no ring at all (RFC 7946, 3.1.6: a linear ring has four or more positions)
    assert geometry_json(shapely.Polygon()) == {"type": "MultiPolygon", "coordinates": []}
    # a map file may list its rings either way round (Table 4.1 runs clockwise)
    clockwise = BRepMap((Region(Ring([(0, 0), (0, 4), (4, 4), (4, 0)]), (Ring([(1, 1), (2, 1), (2, 2)]),)),))
    ring, hole = crisp_features(clockwise)[0]["geometry"]["coordinates"]
    assert shapely.LinearRing(ring).is_ccw and not shapely.LinearRing(hole).is_ccw


# ------------------------------------------------------------------------- SVG


def svg_polylines(d: str) -> list[np.ndarray]:
    """The points of path data ``M x y l dx dy …[z]`` (what svg.path_data writes), one array a subpath."""
    import re

    out = []
    for sub in d.split("M")[1:]:
        head, _, rest = sub.rstrip("z").partition("l")
        v = [float(t) for t in re.findall(r"-?[0-9]*\.?[0-9]+(?:e-?[0-9]+)?", head + " " + rest)]
        xy = np.array(v).reshape(-1, 2)
        out.append(np.cumsum(xy, axis=0))
    return out


def test_svg_is_valid_xml_in_map_units_with_y_flipped(floor, floor_file, tmp_path):
    out = tmp_path / "floor.svg"
    assert run("export", floor_file, "--svg", out, "--alpha", 0, "--alpha", 0.5, "--alpha", 1) == 0
    root = ET.parse(out).getroot()
    assert root.tag == f"{SVG}svg"
    vx, vy, vw, vh = map(float, root.get("viewBox").split())
    x0, y0, x1, y1 = floor.crisp_geometry.bounds
    # the view holds the outer support; y is flipped, so its top is −(largest y)
    assert vx < x0 - TME and vx + vw > x1 + TME
    assert vy < -(y1 + TME) and vy + vh > -(y0 - TME)
    groups = {g.get("id"): g for g in root.iter(f"{SVG}g")}
    assert set(groups) == {"support", "alpha-cuts", "crisp", "legend"}
    assert [p.get("class") for p in groups["support"]] == ["support", "free"]
    cuts = [(p.get("class"), p.get("data-alpha")) for p in groups["alpha-cuts"]]
    assert cuts == [("cut inner", "0"), ("cut outer", "0"), ("cut inner", "0.5"), ("cut outer", "0.5")]
    assert [p.get("class") for p in groups["crisp"]] == ["crisp obstacle", "crisp frontier"]
    # the crisp outline, read back, is the map mirrored in y, to the millimetre
    d = groups["crisp"][0].get("d")
    rings = svg_polylines(d)
    poly = shapely.Polygon(rings[0] * [1, -1], [r * [1, -1] for r in rings[1:]])
    assert poly.area == pytest.approx(floor.crisp_geometry.area, rel=1e-4)
    assert poly.symmetric_difference(floor.crisp_geometry).area < 1e-3 * poly.area  # the map, not its mirror image
    # the frontier strokes are the crisp map's frontier edges
    strokes = [p * [1, -1] for p in svg_polylines(groups["crisp"][1].get("d"))]
    frontier = [r.vertices[[i, (i + 1) % len(r)]] for r in floor.crisp.rings for i in np.flatnonzero(r.kinds == FRONTIER)]
    assert len(strokes) == len(frontier)
    for s, f in zip(strokes, frontier):
        np.testing.assert_allclose(s, f, atol=5e-4)
    assert "matplotlib" not in out.read_text()


def test_export_needs_an_output(floor_file, capsys):
    assert run("export", floor_file) == 2
    assert "at least one of --geojson, --ros, --nav2, --bag, --mcap, --svg" in capsys.readouterr().err


def test_export_refuses_bad_options(floor_file, tmp_path, capsys):
    with pytest.raises(SystemExit):
        run("export", floor_file, "--ros", tmp_path, "--resolution", "-1")
    assert "resolution must be positive" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        run("export", floor_file, "--ros", tmp_path, "--name", "../x")
    assert "plain file name" in capsys.readouterr().err
    assert run("export", floor_file, "--ros", tmp_path, "--resolution", "0.00001") == 2
    assert "too large" in capsys.readouterr().err


def test_export_compact_says_when_snap_rounding_merged_holes(tmp_path, capsys):
    # issue 20: 813 holes became 715 without a word; two holes 0.3 mm apart meet on the 1 mm grid
    from fuzzybrep.fuzzy.map import fuzzify

    g = shapely.Polygon([(0, 0), (5, 0), (5, 4), (0, 4)], [[(1, 1), (1, 2), (2, 2), (2, 1)],
                                                          [(2.0003, 1), (2.0003, 2), (3, 2), (3, 1)]])
    path = tmp_path / "m.json"
    fuzzify(BRepMap.from_shapely(shapely.orient_polygons(g), "m"), tme=0.2).save(path)
    assert run("export", path, "--compact", tmp_path / "m.fbrc") == 0
    out = capsys.readouterr().out
    assert "holes)" in out and "snap rounding onto the 0.001 m grid changed the map" in out
    assert "2 -> 1 holes" in out or "2 -> 0 holes" in out, out
    far = shapely.Polygon(g.exterior, [g.interiors[0], [(2.5, 1), (2.5, 2), (3, 2), (3, 1)]])
    fuzzify(BRepMap.from_shapely(shapely.orient_polygons(far), "m"), tme=0.2).save(path)
    assert run("export", path, "--compact", tmp_path / "m.fbrc") == 0
    assert "(12 vertices, 2 holes)" in (out := capsys.readouterr().out) and "snap rounding" not in out
