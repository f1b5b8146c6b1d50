"""Issue 36, items 7, 9 and 10: hostile input that was a traceback, read without bound, noisy, or
accepted silently. Each case through the command line: a one-line error naming where (exit
status 2), or it works."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fuzzybrep import cli

from _cli import fails


def square(path, **changes) -> dict:
    """A 4 × 4 square map file at ``path`` with two scan poses; ``changes`` applied to its JSON."""
    from fuzzybrep.brep import BRepMap, Region, Ring
    from fuzzybrep.fuzzy.map import fuzzify

    fuzzify(BRepMap((Region(Ring([(0, 0), (4, 0), (4, 4), (0, 4)])),)), tme=0.1).save(
        path, poses=[[1, 1, 0, 0], [2, 1, 0, 1]])
    d = json.loads(path.read_text())
    for change in changes.values():
        change(d)
    path.write_text(json.dumps(d))
    return d


def csv_scans(path, header="scan,time,x,y,theta,bearing,range", n=4):
    rows = [header]
    for k in range(n):
        for j in range(19):
            rows.append(f"{k},{k},{0.1 * k},0,0,{-math.pi / 2 + j * math.pi / 18},2.0")
    path.write_text("\n".join(rows) + "\n")
    return path


# ------------------------------------------------------------------------- 7: tracebacks


def test_point_field_over_the_csv_modules_limit_names_the_line(tmp_path, capsys):
    # before: _csv.Error: field larger than field limit (131072)
    square(tmp_path / "m.json")
    pts = tmp_path / "pts.csv"
    pts.write_text("x,y\n1,2\n1," + "9" * 140_000 + "\n")
    fails(capsys, ["membership", tmp_path / "m.json", "--points", pts], "pts.csv: line 3", "field larger")


@pytest.mark.parametrize("command", ["fuzzify", "tables", "membership"])
def test_a_device_is_read_with_a_bound(tmp_path, capsys, monkeypatch, command):
    # before: /dev/zero has size 0, which passed the size check, and was read until memory ran out
    from fuzzybrep.commands import _maps
    from fuzzybrep.formats import files

    monkeypatch.setattr(files, "MAX_INPUT_BYTES", 2**20)
    monkeypatch.setattr(_maps, "MAX_GEOJSON_BYTES", 2**20)
    square(tmp_path / "m.json")
    argv = {"fuzzify": ["fuzzify", "/dev/zero", "--tme", "0.1", "--out", tmp_path / "f.json"],
            "tables": ["tables", "/dev/zero"],
            "membership": ["membership", tmp_path / "m.json", "--points", "/dev/zero"]}[command]
    fails(capsys, argv, "/dev/zero: more than 1 MiB (not a regular file")
    assert not (tmp_path / "f.json").exists()


def test_a_fifo_is_read_once(tmp_path, capsys):
    # fuzzify read its input twice (as a map file, then as GeoJSON): a FIFO's second reader waits forever
    import os
    import threading

    fifo = tmp_path / "plan.geojson"
    os.mkfifo(fifo)
    text = json.dumps({"type": "Polygon", "coordinates": [[[0, 0], [4, 0], [4, 4], [0, 4], [0, 0]]]})
    writer = threading.Thread(target=lambda: fifo.write_text(text))
    writer.start()
    assert cli.main(["fuzzify", str(fifo), "--tme", "0.1", "--out", str(tmp_path / "f.json")]) == 0
    writer.join()
    assert json.loads((tmp_path / "f.json").read_text())["format"]


def test_out_of_memory_is_one_line(tmp_path, capsys, monkeypatch):
    # before: numpy's _ArrayMemoryError (a MemoryError) was a traceback
    from fuzzybrep.mapping import build

    monkeypatch.setattr(build, "build_map", lambda *a, **k: np.empty(2**45, dtype=np.uint8))
    log = csv_scans(tmp_path / "s.csv")
    err = fails(capsys, ["build", log, "--out", tmp_path / "m.json", "--quiet"],
                "fuzzybrep build: error:", "s.csv: out of memory: Unable to allocate 32.0 TiB")
    assert "_ArrayMemoryError" not in err and not (tmp_path / "m.json").exists()


# ------------------------------------------------------------------------- 10: accepted silently


def test_csv_header_naming_a_column_twice(tmp_path, capsys):
    log = csv_scans(tmp_path / "s.csv", header="scan,time,x,y,x,bearing,range")
    fails(capsys, ["build", log, "--out", tmp_path / "m.json", "--quiet"],
          "s.csv, line 1, field x: header names column 'x' twice")
    pts = tmp_path / "pts.csv"
    pts.write_text("x,y,y\n1,2,3\n")
    square(tmp_path / "m.json")
    fails(capsys, ["membership", tmp_path / "m.json", "--points", pts], "pts.csv: line 1", "'y' twice")


def test_underscores_are_not_digits(tmp_path, capsys):
    # Python's float (and NumPy) read "1_0" as 10
    rs = " ".join(["2.0"] * 8 + ["1_0"])
    log = tmp_path / "u.log"
    log.write_text("".join(f"FLASER 9 {rs} {0.1 * k} 0 0 {0.1 * k} 0 0 {k} host {k}\n" for k in range(4)))
    fails(capsys, ["build", log, "--out", tmp_path / "m.json", "--quiet"], "u.log, line 1, field r_9", "'1_0'")
    log.write_text("".join(f"FLASER 1_0 {' '.join(['2.0'] * 10)} 0 0 0 0 0 0 {k} host {k}\n" for k in range(4)))
    fails(capsys, ["build", log, "--out", tmp_path / "m.json", "--quiet"], "u.log, line 1", "'1_0'")
    s = csv_scans(tmp_path / "s.csv")
    s.write_text(s.read_text().replace(",2.0\n", ",2_0\n", 1))
    fails(capsys, ["build", s, "--out", tmp_path / "m.json", "--quiet"], "s.csv, line 2, field range", "'2_0'")
    pts = tmp_path / "pts.csv"
    pts.write_text("1_0,2\n")
    square(tmp_path / "m.json")
    fails(capsys, ["membership", tmp_path / "m.json", "--points", pts], "pts.csv: line 1")


def _set(*keys, value):
    def change(d):
        for k in keys[:-1]:
            d = d[k]
        d[keys[-1]] = value
    return change


@pytest.mark.parametrize("change, words", [
    (_set("regions", 0, "shell", "x", 1, value=True), "region 0 shell, vertex 2: x True is not a number"),
    (_set("regions", 0, "shell", "y", 2, value="4"), "vertex 3: y '4' is not a number"),
    (_set("regions", 0, "shell", "kind", 0, value=False), "vertex 1: edge kind False is not a number"),
    (_set("regions", 0, "shell", "fm", 3, value=True), "vertex 4: FM index True is not a number"),
    (_set("scans", "poses", 1, 2, value=True), "scans.poses row 2 is not a list of numbers"),
    (_set("membership_functions", 0, "tme", value=True), "membership function 1: triangular: tme must be a number"),
    (_set("membership_functions", 0, "tme", value="0.1"), "tme must be a number, got '0.1'"),
    (_set("scans", "count", value=3), "scans.count is 3, but scans.poses holds 2 poses"),
    (_set("scans", "count", value=True), "scans.count is True"),
], ids=["x-bool", "y-string", "kind-bool", "fm-bool", "pose-bool", "mf-bool", "mf-string", "count", "count-bool"])
def test_map_file_holds_numbers_where_numbers_belong(tmp_path, capsys, change, words):
    square(tmp_path / "m.json", c=change)
    fails(capsys, ["tables", tmp_path / "m.json"], "m.json", words)


def test_a_map_file_as_written_still_reads(tmp_path, capsys):
    square(tmp_path / "m.json")
    assert cli.main(["tables", str(tmp_path / "m.json")]) == 0


# ------------------------------------------------------------------------- 9: noise before errors


@pytest.mark.filterwarnings("error")  # a NumPy warning fails the test
def test_an_infinite_tf_translation_is_named_as_inf(tmp_path, capsys):
    # before: a RuntimeWarning (inf - inf while interpolating), then "pose is not finite: [nan, ...]"
    from test_rosbag import Bag

    b = Bag(tmp_path / "tf.bag")
    for k in range(4):
        b.tf(k, "odom", "base_link", math.inf if k == 2 else 0.1 * k, 0.0, 0.0)
        b.tf(k, "base_link", "laser", 0.0, 0.0, 0.0)
        b.scan(k + 0.5, [1.0, 2.0, 2.0, 1.0])
    b.close()
    err = fails(capsys, ["build", tmp_path / "tf.bag", "--out", tmp_path / "m.json", "--quiet"],
                "tf.bag, topic /tf, message 4: transform odom -> base_link: translation (inf, 0.0) is not finite")
    assert "nan" not in err


def test_a_folder_named_like_a_stale_temporary_file_does_not_block_the_write(tmp_path, capsys):
    # before: _remove_stale unlinked it, and every write of m.json failed with "Is a directory"
    stale = tmp_path / ".f.json.999999999.abcdefgh.tmp"
    stale.mkdir()
    (stale / "keep").write_text("x")
    file = tmp_path / ".f.json.999999998.abcdefgh.tmp"  # a dead writer's file: still removed
    file.write_text("partial")
    square(tmp_path / "m.json")
    assert cli.main(["fuzzify", str(tmp_path / "m.json"), "--tme", "0.1", "--out", str(tmp_path / "f.json")]) == 0
    assert json.loads((tmp_path / "f.json").read_text())["format"]
    assert (stale / "keep").read_text() == "x" and not file.exists()


# ------------------------------------------------------------------------- 8: tables linear in rings


def test_tables_lists_the_rings_once_and_every_table_is_its_rings(tmp_path, capsys, monkeypatch):
    # before: every table asked BRepMap.rings, which lists all rings anew: quadratic in rings
    # (16,000 holes 15.5 s); benchmarks/tables.py times it against alpha-cut
    import sys
    from pathlib import Path

    from fuzzybrep.brep import BRepMap
    from fuzzybrep.fuzzy.map import FuzzyBRepMap

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from tables import holes_map

    holes_map(60).save(tmp_path / "h.json")
    fz = FuzzyBRepMap.load(tmp_path / "h.json")
    listed = []
    real = BRepMap.rings
    monkeypatch.setattr(BRepMap, "rings", property(lambda self: listed.append(1) or real.fget(self)))
    assert cli.main(["tables", str(tmp_path / "h.json")]) == 0
    out = capsys.readouterr().out
    assert len(listed) <= 5, len(listed)
    assert out.count("Fuzzy vertex table (Table 4.1)") == 61 and "Fuzzy edge table (Table 4.3): hole 60\n" in out
    for k, ring in enumerate(fz.crisp.rings):
        t = fz.vertex_table(k)
        np.testing.assert_array_equal(np.column_stack((t["X"], t["Y"])), ring.vertices)
        assert len(fz.edge_table(k)["EDGE"]) == len(ring)


def test_geojson_positions_must_be_json_numbers(tmp_path):
    """A boolean or a string where GeoJSON holds a coordinate is refused naming the vertex
    (Python's float() takes true and "1.5")."""
    import json as _json

    from fuzzybrep.errors import MapFileError
    from fuzzybrep.formats.geojson import read_geojson

    ring = [[0, 0], [4, 0], [4, 3], [0, 3], [0, 0]]
    for bad, vertex in ((True, 2), ("1.5", 3)):
        r = [list(p) for p in ring]
        r[vertex - 1][0] = bad
        f = tmp_path / "plan.geojson"
        f.write_text(_json.dumps({"type": "Polygon", "coordinates": [r]}))
        with pytest.raises(MapFileError, match=rf"vertex {vertex}"):
            read_geojson(f)
    f.write_text(_json.dumps({"type": "Polygon", "coordinates": [ring]}))
    assert read_geojson(f).area == pytest.approx(12.0)


def test_geojson_from_a_device_is_read_with_a_bound(monkeypatch):
    """demo --world /dev/zero: the size (0) says nothing; the read stops past the limit."""
    from fuzzybrep.formats import geojson as G

    monkeypatch.setattr(G, "MAX_GEOJSON_BYTES", 2**20)
    with pytest.raises(G.MapFileError, match="more than 1 MiB"):
        G.geojson_text("/dev/zero")
