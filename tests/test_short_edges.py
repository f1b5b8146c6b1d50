"""No map has an edge shorter than ``brep.min_edge`` (issue 36, item 1): built, fuzzified or loaded.

Unions and simplification left edges of 1e-15 m to under 1 mm (an 8.9e-16 m edge in Intel's map);
at the viewer's millimetre rounding such an edge had no direction and its corner was NaN."""

from __future__ import annotations

import json

import numpy as np
import pytest
import shapely

from fuzzybrep.brep import OBSTACLE, FRONTIER, BRepMap, Region, Ring, drop_short_edges, min_edge, shortest_edge
from fuzzybrep.cli import main
from fuzzybrep.errors import GeometryError, MapFileError
from fuzzybrep.formats.mapfile import read_map
from fuzzybrep.fuzzy.map import FuzzyBRepMap, fuzzify
from fuzzybrep.mapping.build import build_map

#: a square room whose principal ring has an edge of 1e-12 m at (5, 0)
ROOM = [(0, 0), (5, 0), (5 + 1e-12, 0), (10, 0), (10, 10), (0, 10)]
HOLE = [(4, 4), (4, 6), (6, 6), (6, 4)]


def test_tolerance_is_a_millimetre_in_the_maps_unit():
    assert (min_edge("m"), min_edge("cm"), min_edge("mm")) == (1e-3, 0.1, 1.0)


def test_ring_with_a_1e_12_edge_is_cleaned():
    r = Ring(ROOM, kinds=[OBSTACLE, FRONTIER, FRONTIER, OBSTACLE, OBSTACLE, OBSTACLE], fm=[1, 2, 3, 4, 5, 6])
    c = r.without_short_edges(1e-3)
    assert len(c) == 5
    np.testing.assert_array_equal(c.vertices, [(0, 0), (5, 0), (10, 0), (10, 10), (0, 10)])
    # the merged edge (5, 0) → (10, 0) is the long one's: frontier; the kept vertex keeps its FM
    assert c.kinds.tolist() == [OBSTACLE, FRONTIER, OBSTACLE, OBSTACLE, OBSTACLE]
    assert c.fm.tolist() == [1, 2, 4, 5, 6]
    assert r.without_short_edges(1e-13) is r


def test_short_edge_closing_the_ring_and_runs_of_short_edges():
    # the closing edge is short, and a run of 0.4 mm steps: every edge left is at least 1 mm
    v = [(0, 0), (1, 0), (1, 1)] + [(1 - 0.0004 * k, 1) for k in range(1, 8)] + [(0, 1), (0, 0.0002)]
    c = Ring(v).without_short_edges(1e-3)
    steps = np.hypot(*(np.roll(c.vertices, -1, axis=0) - c.vertices).T)
    assert steps.min() >= 1e-3 * (1 - 1e-6)
    assert shapely.Polygon(c.vertices).is_valid
    assert shapely.Polygon(c.vertices).area == pytest.approx(1.0, abs=1e-3)


def test_from_shapely_fuzzify_and_load_drop_them(tmp_path):
    crisp = BRepMap.from_shapely(shapely.Polygon(ROOM, [HOLE]))
    assert crisp.n_vertices == 9 and crisp.n_holes == 1
    assert shortest_edge(crisp) >= 1e-3
    # a map made by hand keeps them until it is fuzzified
    raw = BRepMap((Region(Ring(ROOM), (Ring(HOLE),)),))
    assert shortest_edge(raw) < 1e-11
    fz = fuzzify(raw, tme=0.2)
    assert shortest_edge(fz.crisp) >= 1e-3 and fz.crisp.n_vertices == 9
    # a map file written before (or by hand) with such an edge: merged away on load
    m = tmp_path / "old.json"
    fz.save(m)
    d = json.loads(m.read_text())
    d["regions"][0]["shell"] = {"x": [p[0] for p in ROOM], "y": [p[1] for p in ROOM], "kind": [0] * 6, "fm": [1] * 6}
    m.write_text(json.dumps(d))
    assert shortest_edge(read_map(m).crisp) >= 1e-3
    assert shortest_edge(FuzzyBRepMap.load(m).crisp) >= 1e-3
    assert main(["tables", str(m)]) == 0


def test_map_whose_ring_is_all_short_edges_is_refused_on_load(tmp_path, capsys):
    fz = fuzzify(BRepMap.from_shapely(shapely.Polygon(ROOM, [HOLE])), tme=0.2)
    m = tmp_path / "tiny.json"
    fz.save(m)
    d = json.loads(m.read_text())
    tiny = [(2, 2), (2.0004, 2.0004), (2.0004, 2)]  # a clockwise hole 0.4 mm across
    d["regions"][0]["holes"].append({"x": [p[0] for p in tiny], "y": [p[1] for p in tiny], "kind": [0] * 3, "fm": [1] * 3})
    m.write_text(json.dumps(d))
    with pytest.raises(MapFileError, match=r"hole 2: made of edges shorter than 0\.001 m"):
        read_map(m)
    assert main(["tables", str(m)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "hole 2" in err and str(m) in err
    with pytest.raises(GeometryError, match="hole 1"):
        drop_short_edges(BRepMap((Region(Ring(ROOM), (Ring(tiny),)),)))


def test_merge_that_would_cross_a_hole_falls_back_to_snap_rounding(monkeypatch):
    # the shell dips 0.3 mm at (5.0005, −0.0003) along a 0.58 mm edge, and a hole's corner sits in
    # the dip: merging the edge away would leave the corner outside the shell
    hole = [(5.0005, -0.0001), (5.6, 0.5), (5.3, 1.0)]
    g = shapely.Polygon([(0, 0), (5, 0), (5.0005, -0.0003), (10, 0), (10, 10), (0, 10)], [hole])
    assert g.is_valid
    snapped = []
    monkeypatch.setattr(shapely, "set_precision", lambda *a, _f=shapely.set_precision, **k: snapped.append(1) or _f(*a, **k))
    crisp = BRepMap.from_shapely(g)
    assert snapped  # the merge was refused, the fallback taken
    crisp.validate()
    assert shortest_edge(crisp) >= 1e-3 * (1 - 1e-6)
    assert crisp.area == pytest.approx(g.area, abs=1e-2)


@pytest.mark.reallog
def test_map_built_from_intel_has_no_short_edge(real_scans, tmp_path):
    crisp = build_map(real_scans("intel")).crisp
    assert shortest_edge(crisp) >= min_edge("m")
    # and once saved and read back
    fz = fuzzify(crisp)
    fz.save(tmp_path / "intel.json")
    assert shortest_edge(FuzzyBRepMap.load(tmp_path / "intel.json").crisp) >= min_edge("m")
