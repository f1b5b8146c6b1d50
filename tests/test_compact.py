"""The compact encoding: a small robot's copy of the map, back within half a quantum."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st

from fuzzybrep import BRepMap, MapFileError, Region, Ring
from fuzzybrep.formats.compact import (FM_EXPLICIT, FM_FROM_KINDS, decode, decode_varints, encode, encode_varints,
                                       fm_from_kinds, quantised, read_compact, snap_rounded, write_compact)
from fuzzybrep.fuzzy.map import FuzzyBRepMap, fuzzify
from fuzzybrep.fuzzy.memory import compact_bytes
from fuzzybrep.brep import validate_map
from fuzzybrep.fuzzy.membership import Triangular


@given(st.lists(st.integers(-(2**62), 2**62), max_size=200))
def test_varints_round_trip(values):
    data = encode_varints(np.array(values, dtype=np.int64))
    back, end = decode_varints(data, len(values))
    assert back.tolist() == values and end == len(data)


def test_small_steps_take_one_byte():
    assert len(encode_varints(np.array([0, 1, -1, 63, -64]))) == 5
    assert len(encode_varints(np.array([64, 8191, -8192]))) == 6


def sample_map() -> BRepMap:
    rng = np.random.default_rng(2)
    shell = Ring(np.array([(0, 0), (12.3456, 0), (12.3456, 8.9), (0, 8.9)]), [0, 1, 0, 0])
    holes = []
    for k in range(5):
        c = rng.uniform(2, 7, 2)
        a = np.linspace(0, 2 * np.pi, 7, endpoint=False)[::-1]  # clockwise
        holes.append(Ring(c + 0.4 * np.column_stack((np.cos(a), np.sin(a))), rng.integers(0, 2, 7)))
    piece = Ring(np.array([(20, 0), (21, 0), (21, 1)]))
    return BRepMap((Region(shell, tuple(holes)), Region(piece)), "m")


@pytest.mark.parametrize("frontier", [False, True])
def test_round_trip_within_half_a_quantum(tmp_path, frontier):
    fz = fuzzify(sample_map(), Triangular(0.19913), frontier_mf=Triangular(0.3) if frontier else None)
    p = tmp_path / "m.fbrc"
    n = write_compact(p, fz.crisp, fz.table.to_dicts())
    assert n == p.stat().st_size == compact_bytes(fz)
    crisp, mfs = read_compact(p)
    assert mfs == fz.table.to_dicts() and crisp.unit == "m"
    assert [len(r.holes) for r in crisp.regions] == [len(r.holes) for r in fz.crisp.regions]
    for a, b in zip(fz.crisp.rings, crisp.rings):
        assert np.abs(a.vertices - b.vertices).max() <= 0.0005 + 1e-12
        assert np.array_equal(a.kinds, b.kinds) and np.array_equal(a.fm, b.fm)
    # encode checks the map read back without decoding it: quantised() must be that map, bit for bit
    for a, b in zip(quantised(fz.crisp, 0.001).rings, crisp.rings):
        assert np.array_equal(a.vertices, b.vertices)


def test_explicit_fm_when_it_does_not_follow_the_kinds():
    m = sample_map()
    rings = [Ring(r.vertices, r.kinds, (np.arange(len(r)) % 3) + 1) for r in m.rings]
    m = m.with_rings(rings)
    data = encode(m, [{"type": "triangular", "tme": 0.2}] * 3)
    back, _ = decode(data)
    assert all(np.array_equal(a.fm, b.fm) for a, b in zip(m.rings, back.rings))


def test_compact_is_far_smaller_than_the_json_map(tmp_path):
    fz = fuzzify(sample_map())
    assert compact_bytes(fz) < 300
    # about 2 to 4 bytes per vertex: two small varints
    assert compact_bytes(fz) < 4 * fz.crisp.n_vertices + 120


def test_bad_compact_files(tmp_path):
    p = tmp_path / "bad.fbrc"
    p.write_bytes(b"NOPE")
    with pytest.raises(MapFileError, match="bad.fbrc.*magic"):
        read_compact(p)
    data = encode(sample_map(), [])
    p.write_bytes(data[:-5])
    with pytest.raises(MapFileError, match="not a valid compact map"):
        read_compact(p)


def test_export_writes_the_compact_map(tmp_path, capsys):
    from fuzzybrep import cli

    fz = fuzzify(sample_map(), Triangular(0.19913))
    m, out = tmp_path / "m.json", tmp_path / "m.fbrc"
    fz.save(m)
    assert cli.main(["export", str(m), "--compact", str(out)]) == 0
    crisp, mfs = read_compact(out)
    assert out.stat().st_size == compact_bytes(fz) and mfs == fz.table.to_dicts()
    assert all(np.abs(a.vertices - b.vertices).max() <= 0.0005 for a, b in zip(fz.crisp.rings, crisp.rings))


def test_compact_file_cut_anywhere_says_truncated_and_where(tmp_path):
    # before: "buffer is smaller than requested size", "index out of range" or a JSON parser's complaint
    data = encode(sample_map(), [Triangular(0.2).to_dict() | {"index": 1}])
    p = tmp_path / "cut.fbrc"
    for n in range(1, len(data)):
        p.write_bytes(data[:n])
        with pytest.raises(MapFileError, match=r"cut.fbrc: not a valid compact map: truncated"):
            read_compact(p)
    p.write_bytes(data[:30])
    with pytest.raises(MapFileError, match="truncated: the data ends at byte 30, in membership function 1"):
        read_compact(p)


@pytest.mark.parametrize("damage, words", [
    (lambda d: d[:7] + np.float64(-0.001).tobytes() + d[15:], "quantum -0.001 is not a positive number"),  # before: a mirrored map
    (lambda d: d[:7] + np.float64(np.nan).tobytes() + d[15:], "quantum nan"),  # before: NaN vertices
    (lambda d: d[:15] + bytes([7]) + d[16:], "FM mode 7 is neither"),  # before: read as FM from the kinds
])
def test_compact_header_with_impossible_values(tmp_path, damage, words):
    data = encode(sample_map(), [])
    assert data[5] == 1 and data[6:7] == b"m"  # unit "m": the quantum at bytes 7-14, the FM mode at 15
    p = tmp_path / "bad.fbrc"
    p.write_bytes(damage(data))
    with pytest.raises(MapFileError, match="bad.fbrc: not a valid compact map: " + words):
        read_compact(p)


def test_compact_map_with_a_self_intersecting_ring_names_file_and_vertex(tmp_path):
    bowtie = BRepMap((Region(Ring([(0, 0), (4, 4), (0, 4), (4, 0)])),))
    p = tmp_path / "bow.fbrc"
    p.write_bytes(encode(bowtie, []))
    with pytest.raises(MapFileError, match="bow.fbrc: principal, vertex .*self-intersecting"):
        read_compact(p)


def notched_map() -> BRepMap:
    """Two valid rooms with features finer than 1 mm: a V-shaped notch whose tip ends 0.4 mm
    above the floor, and two ceiling vertices 0.3 mm apart. Rounded to 1 mm, the notch's tip
    lands on the floor (a ring touching itself) and the two vertices become one."""
    notch = Ring(np.array([(0, 0), (10, 0), (10, 10), (6, 10), (5, 0.0004), (4, 10), (0, 10)]), [0, 1, 0, 0, 1, 0, 0])
    close = Ring(np.array([(20, 0), (30, 0), (30, 10), (25.0003, 10), (25, 10), (20, 10)]), [0, 1, 0, 0, 0, 1])
    return BRepMap((Region(notch), Region(close)), "m")


def test_features_finer_than_the_quantum_still_decode_to_a_valid_map(tmp_path):
    m = notched_map()
    validate_map(m)
    p = tmp_path / "notch.fbrc"
    write_compact(p, m, [])
    crisp, _ = read_compact(p)  # a map that cannot be read back is no map
    validate_map(crisp)
    a, b = m.to_shapely(), crisp.to_shapely()
    assert abs(a.area - b.area) < 0.01 and shapely.hausdorff_distance(a.boundary, b.boundary) <= 0.001
    # every edge keeps the kind of the edge it came from: the frontier (1) edges are still there
    assert {int(k) for r in crisp.rings for k in r.kinds} == {0, 1}


def test_fm_survives_the_round_trip_whatever_the_number_of_functions():
    m = sample_map()
    follows = m.with_rings([Ring(r.vertices, r.kinds, fm_from_kinds(r.kinds)) for r in m.rings])
    ones = m.with_rings([Ring(r.vertices, r.kinds, np.ones(len(r))) for r in m.rings])
    assert any((r.kinds == 1).any() for r in m.rings)  # so the two FM columns differ
    mf = {"type": "triangular", "tme": 0.2}
    # FM that follows the kinds, but with three functions (index 2 need not be the frontier's); all 1 with two
    for crisp, mfs in ((follows, [mf] * 3), (ones, [mf] * 2), (follows, [mf] * 2), (ones, [mf])):
        back, _ = decode(encode(crisp, mfs))
        assert all(np.array_equal(a.fm, b.fm) for a, b in zip(crisp.rings, back.rings))


def test_bytes_after_the_last_ring_are_refused(tmp_path):
    p = tmp_path / "long.fbrc"
    p.write_bytes(encode(sample_map(), []) + b"\x00\x00")
    with pytest.raises(MapFileError, match="long.fbrc: not a valid compact map: 2 unexpected bytes after the last ring"):
        read_compact(p)


def edge_midpoints(ring):
    v = ring.vertices
    return (v + np.roll(v, -1, axis=0)) / 2


def test_snap_rounding_keeps_each_edges_kind_and_each_vertexs_fm():
    m = notched_map()
    m = m.with_rings([Ring(r.vertices, r.kinds, np.arange(len(r)) + 1 + 10 * k) for k, r in enumerate(m.rings)])
    s = snap_rounded(m, 0.001, FM_EXPLICIT)
    validate_map(s)
    crisp_edges = [shapely.LineString([a, b]) for r in m.rings for a, b in zip(r.vertices, np.roll(r.vertices, -1, 0))]
    crisp_kinds = np.concatenate([r.kinds for r in m.rings])
    crisp_v = np.vstack([r.vertices for r in m.rings])
    crisp_fm = np.concatenate([r.fm for r in m.rings])
    for r in s.rings:
        # every snapped edge lies on (within half a quantum of) the crisp edge it came from, one only
        for mid, kind in zip(edge_midpoints(r), r.kinds):
            d = shapely.distance(crisp_edges, shapely.Point(mid))
            near = np.flatnonzero(d <= 0.0005 + 1e-12)
            assert len(near) == 1 and kind == crisp_kinds[near[0]]
        # every snapped vertex within half a quantum of a crisp vertex keeps that vertex's FM
        for p, f in zip(r.vertices, r.fm):
            d = np.hypot(*(crisp_v - p).T)
            if d.min() <= 0.0005 * np.sqrt(2) + 1e-12:
                assert f == crisp_fm[np.argmin(d)]
    # FM from the kinds: 1 everywhere for a map of one function, else as the kinds give it
    ones = snap_rounded(m, 0.001, FM_FROM_KINDS, uniform=True)
    assert all((r.fm == 1).all() for r in ones.rings)
    two = snap_rounded(m, 0.001, FM_FROM_KINDS)
    assert all(np.array_equal(r.fm, fm_from_kinds(r.kinds)) for r in two.rings)
    assert any((r.fm == 2).any() for r in two.rings)


def test_compact_maps_of_the_real_logs_read_back(built_map, tmp_path):
    for name in ("intel", "aces"):
        path, fz = built_map(name)
        p = tmp_path / f"{name}.fbrc"
        write_compact(p, fz.crisp, fz.table.to_dicts())
        crisp, mfs = read_compact(p)
        assert mfs == fz.table.to_dicts()
        assert abs(crisp.area - fz.crisp.area) < 1e-4 * fz.crisp.area
        fuzzify(crisp, fz.table).alpha_cut(0.0)


def test_export_says_how_many_vertices_the_file_holds(tmp_path, capsys):
    # before: it printed the map's count (Intel: 5678) where the snap-rounded file held 5499
    from fuzzybrep import cli

    m, out = tmp_path / "m.json", tmp_path / "m.fbrc"
    fz = fuzzify(notched_map(), Triangular(0.19913))
    # the ceiling's 0.3 mm edge is merged away when the map is fuzzified (brep.min_edge)
    assert fz.crisp.n_vertices == notched_map().n_vertices - 1
    fz.save(m)
    assert cli.main(["export", str(m), "--compact", str(out)]) == 0
    crisp, _ = read_compact(out)
    out = capsys.readouterr().out
    assert f"({crisp.n_vertices} vertices, {crisp.n_holes} holes)" in out
    assert f"changed the map: {fz.crisp.n_vertices} -> {crisp.n_vertices} vertices" in out


def test_map_commands_read_the_compact_map(tmp_path, capsys):
    # before: every command that reads a map said "not valid JSON ('utf-8' codec can't decode ...)"
    import json

    from fuzzybrep import cli

    fz = fuzzify(sample_map(), Triangular(0.19913), frontier_mf=Triangular(0.3))
    m, out = tmp_path / "m.json", tmp_path / "m.fbrc"
    fz.save(m)
    assert cli.main(["export", str(m), "--compact", str(out)]) == 0
    capsys.readouterr()
    assert cli.main(["memory", str(out)]) == 0
    assert f"{out}: 42 vertices, 42 edges in 7 rings" in capsys.readouterr().out  # 4 + 5 × 7 + 3
    assert cli.main(["alpha-cut", str(out), "--alpha", "0.5"]) == 0
    cut = shapely.geometry.shape(json.loads(capsys.readouterr().out)["features"][1]["geometry"])
    assert cut.symmetric_difference(fz.alpha_cut(0.5).inner).area < 0.01  # vertices within half a millimetre
    assert cli.main(["plan", str(out), "--start", "1", "1", "--goal", "11", "8", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["length"] == pytest.approx(np.hypot(10, 7), abs=0.5)
    again = tmp_path / "again.json"  # and fuzzify takes its crisp map, as from a map file
    assert cli.main(["fuzzify", str(out), "--tme", "0.25", "--out", str(again)]) == 0
    got = FuzzyBRepMap.load(again)
    assert got.table[1].tme_in == 0.25
    assert all(np.array_equal(a.vertices, b.vertices) for a, b in zip(read_compact(out)[0].rings, got.crisp.rings))
