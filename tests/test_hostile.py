"""Hostile input (issue 19): every reader and writer gives a one-line error naming the file (exit
status 2) or works; none leaves a traceback, a quadratic decode, an injected script or a partial file.

The mutation fuzzer over every format is ``tests/fuzz.py`` (``test_fuzz.py`` runs it); these are
the defects it and an adversarial review found, one test each."""

from __future__ import annotations

import json

import pytest

from fuzzybrep import cli

from _cli import fails


def square(path, **changes) -> dict:
    """A 4 × 4 square map file at ``path``, with top-level keys changed as given; its JSON."""
    from fuzzybrep.brep import BRepMap, Region, Ring
    from fuzzybrep.fuzzy.map import fuzzify

    fuzzify(BRepMap((Region(Ring([(0, 0), (4, 0), (4, 4), (0, 4)])),)), tme=0.1).save(path, poses=[[1, 1, 0, 0]])
    d = json.loads(path.read_text())
    d.update(changes)
    path.write_text(json.dumps(d))
    return d


# ------------------------------------------------------------------------- 1, 2: JSON no reader can take


@pytest.mark.parametrize("command", [["tables"], ["alpha-cut", "--alpha", "0.5", "--out", "cut.geojson"],
                                     ["fuzzify", "--tme", "0.1", "--out", "f.json"], ["view", "--html", "v.html"]])
def test_deeply_nested_json_is_not_valid_json(tmp_path, capsys, command):
    # before: RecursionError traceback from json.loads, exit 1
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    argv = [command[0], deep, *[str(tmp_path / a) if "." in a and a[0].isalpha() else a for a in command[1:]]]
    fails(capsys, argv, "deep.json: not valid JSON (nested more than")


def test_deeply_nested_path_for_the_viewer(tmp_path, capsys):
    m, p = tmp_path / "m.json", tmp_path / "p.json"
    square(m)
    p.write_text('{"path":' + "[" * 50_000 + "]" * 50_000 + "}")
    fails(capsys, ["view", m, "--path", p, "--html", tmp_path / "v.html"], "p.json: not valid JSON (nested")


def test_a_lone_surrogate_in_a_string_is_refused_where_it_is_read(tmp_path, capsys):
    # before: the map read, then view, export --compact and export --svg raised UnicodeEncodeError
    m = tmp_path / "m.json"
    square(m, unit="\ud800")
    for argv in (["view", m, "--html", tmp_path / "v.html"], ["export", m, "--compact", tmp_path / "c.fbrc"],
                 ["export", m, "--svg", tmp_path / "s.svg"], ["tables", m]):
        fails(capsys, argv, "m.json: not valid JSON", "lone UTF-16 surrogate")
    g = tmp_path / "g.geojson"  # fuzzified, then view crashed
    g.write_text('{"type": "Polygon", "unit": "\\ud800", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 0]]]}')
    fails(capsys, ["fuzzify", g, "--tme", "0.1", "--out", tmp_path / "f.json"], "g.geojson: not valid JSON", "surrogate")
    assert not list(tmp_path.glob("[vcsf].*"))


def test_a_surrogate_pair_is_text(tmp_path, capsys):
    m = tmp_path / "m.json"
    square(m, unit="\U0001f600")  # json.dumps writes it as the pair \ud83d\ude00
    assert "\\ud83d\\ude00" in m.read_text()
    assert cli.main(["export", str(m), "--compact", str(tmp_path / "c.fbrc"), "--svg", str(tmp_path / "s.svg")]) == 0
    assert cli.main(["tables", str(tmp_path / "c.fbrc")]) == 0
    assert "unit \U0001f600" in capsys.readouterr().out


# ------------------------------------------------------------------------- 3-6: the compact map


def compact_header(unit: bytes = b"m", n_mf: bytes = b"\x00") -> bytes:
    import numpy as np

    from fuzzybrep.formats.compact import FM_FROM_KINDS, MAGIC, VERSION

    return MAGIC + bytes([VERSION, len(unit)]) + unit + np.float64(0.001).tobytes() + bytes([FM_FROM_KINDS]) + n_mf


def test_a_unit_or_fm_index_the_compact_map_cannot_hold(tmp_path, capsys):
    # before: a bare ValueError traceback ("bytes must be in range(0, 256)", "FM indices above 255")
    m = tmp_path / "m.json"
    square(m, unit="u" * 300)
    fails(capsys, ["export", m, "--compact", tmp_path / "c.fbrc", "--geojson", tmp_path / "g.geojson"],
          "c.fbrc: cannot write a compact map: the unit is 300 bytes long; the compact map holds at most 255")
    d = square(m)
    mf = d["membership_functions"][0]
    d["membership_functions"] = [dict(mf, index=k) for k in range(1, 257)]
    d["regions"][0]["shell"]["fm"] = [1, 256, 2, 3]
    m.write_text(json.dumps(d))
    fails(capsys, ["export", m, "--compact", tmp_path / "c.fbrc", "--geojson", tmp_path / "g.geojson"],
          "c.fbrc: cannot write a compact map: FM index 256 does not fit the compact map (at most 255)")
    assert not list(tmp_path.glob("[cg].*"))  # checked before any output is written


def test_coordinates_beyond_what_the_compact_map_holds_are_refused(tmp_path, capsys):
    # before: 1e16 wrapped round int64 with a RuntimeWarning, and the square read back mirrored
    m = tmp_path / "m.json"
    d = square(m)
    d["regions"][0]["shell"].update(x=[0, 1e16, 1e16, 0], y=[0, 0, 1e16, 1e16])
    m.write_text(json.dumps(d))
    err = fails(capsys, ["export", m, "--compact", tmp_path / "c.fbrc"],
                "c.fbrc: cannot write a compact map: principal, vertex 2: coordinate [1e+16, 0.0] is beyond ±9.0072e+12")
    assert "Warning" not in err and not (tmp_path / "c.fbrc").exists()
    d["regions"][0]["shell"].update(x=[0, 9e12, 9e12, 0], y=[0, 0, 9e12, 9e12])  # within: exact
    m.write_text(json.dumps(d))
    assert cli.main(["export", str(m), "--compact", str(tmp_path / "c.fbrc")]) == 0
    from fuzzybrep.formats.compact import read_compact

    assert read_compact(tmp_path / "c.fbrc")[0].principal.vertices.max() == 9e12


def test_compact_steps_that_sum_beyond_the_limit_are_refused(tmp_path, capsys):
    from fuzzybrep.formats.compact import encode_varints

    # each step fits int64, their sum does not fit MAX_QUANTA (and 2**62 four times wraps to 0)
    for step, vertex in ((2**52, 3), (2**62, 1)):
        body = encode_varints([1, 0, 4]) + encode_varints([step, 0] * 4) + b"\x00"
        c = tmp_path / "c.fbrc"
        c.write_bytes(compact_header() + body)
        fails(capsys, ["tables", c], f"c.fbrc: not a valid compact map: ring 1, vertex {vertex}: coordinate beyond "
                                     f"±9007199254740992 quanta")


def test_hole_counts_that_wrap_round_int64_are_refused(tmp_path, capsys):
    # before: four regions of 2**62 holes each summed to 0 in int64, passed, and tables died in StopIteration
    from fuzzybrep.formats.compact import encode_varints

    c = tmp_path / "c.fbrc"
    c.write_bytes(compact_header() + encode_varints([4] + [2**62] * 4) + b"\x00" * 60)
    assert len(c.read_bytes()) < 150
    fails(capsys, ["tables", c], "c.fbrc: not a valid compact map: truncated", "the hole counts (a count of 4611686018427387904")


def test_a_varint_of_more_than_64_bits_is_refused(tmp_path, capsys):
    c = tmp_path / "c.fbrc"
    c.write_bytes(compact_header(n_mf=b"\xff" * 12 + b"\x01"))
    fails(capsys, ["tables", c], "c.fbrc: not a valid compact map: the membership-function count: the varint at byte 16 holds more than 64 bits")


def empty_functions(n: int) -> bytes:
    from fuzzybrep.formats.compact import encode_varints

    return compact_header(n_mf=encode_varints([n])) + (encode_varints([2]) + b"{}") * n  # then it ends: truncated


def empty_rings(n: int) -> bytes:
    from fuzzybrep.formats.compact import encode_varints

    return compact_header() + encode_varints([n] + [0] * n) + b"\x00" * n  # n regions of no vertices, no holes


@pytest.mark.parametrize("make", [empty_functions, empty_rings])
def test_compact_decoding_is_linear(make, monkeypatch):
    # before: every varint read scanned the rest of the file for its end (np.flatnonzero): 100,000
    # empty functions took 16 s, 300,000 150 s, a file of 100,000 rings 122 s before its error.
    # Counted here: the bytes searched for varint ends, ten times the file -> ten times the bytes
    import numpy as np

    from fuzzybrep.errors import MapFileError
    from fuzzybrep.formats import compact

    searched = []

    class CountingNumPy:
        def __getattr__(self, name):
            return getattr(np, name)

        @staticmethod
        def flatnonzero(a):
            searched.append(np.size(a))
            return np.flatnonzero(a)

    monkeypatch.setattr(compact, "np", CountingNumPy())

    def bytes_searched(n: int) -> int:
        searched.clear()
        with pytest.raises(MapFileError):
            compact.compact_from_bytes(make(n), "c.fbrc")
        return sum(searched)

    small, large = bytes_searched(2000), bytes_searched(20_000)
    assert large < 12 * small, (small, large)


def test_compact_decoding_time_is_linear():
    from _linear import assert_linear

    from fuzzybrep.errors import MapFileError
    from fuzzybrep.formats.compact import compact_from_bytes

    def run(data):
        with pytest.raises(MapFileError):
            compact_from_bytes(data, "c.fbrc")

    assert_linear(empty_rings, run, 1000)


# ------------------------------------------------------------------------- 7: regions that share an edge


def test_regions_sharing_an_edge_are_refused_and_meeting_at_a_point_is_a_map(tmp_path, capsys):
    # before: read, the crisp geometry invalid, and alpha-cut --alpha 1 --method exact wrote invalid polygons
    m = tmp_path / "m.json"
    d = square(m)
    piece = {"shell": {"x": [4, 8, 8, 4], "y": [1, 1, 3, 3], "kind": [0] * 4, "fm": [1] * 4}, "holes": []}
    d["regions"].append(piece)
    m.write_text(json.dumps(d))
    fails(capsys, ["alpha-cut", m, "--alpha", "1", "--method", "exact", "--out", tmp_path / "a.geojson"],
          "m.json: piece 2, vertex 1: shares an edge with principal near (4, 1)")
    assert not (tmp_path / "a.geojson").exists()
    piece["shell"].update(x=[4, 8, 8], y=[4, 4, 8], kind=[0] * 3, fm=[1] * 3)  # meets the square at a corner
    m.write_text(json.dumps(d))
    assert cli.main(["alpha-cut", str(m), "--alpha", "1", "--method", "exact", "--out", str(tmp_path / "a.geojson")]) == 0


# ------------------------------------------------------------------------- 13: interrupted writes


def test_a_replaced_file_keeps_its_mode(tmp_path):
    # before: a completed write reset an existing file's 0600 to 0644
    import os
    import stat

    from fuzzybrep.formats.files import FILE_MODE, write_atomic

    m = tmp_path / "m.json"
    m.write_text("old")
    os.chmod(m, 0o600)
    write_atomic(m, b"new")
    assert m.read_bytes() == b"new" and stat.S_IMODE(m.stat().st_mode) == 0o600
    write_atomic(tmp_path / "n.json", b"new")
    assert stat.S_IMODE((tmp_path / "n.json").stat().st_mode) == FILE_MODE


def test_what_a_killed_writer_left_is_removed_by_the_next_write(tmp_path, capsys):
    # before: a kill while the temporary file existed left .NAME.<random>.tmp for ever
    import signal
    import subprocess
    import sys

    m = tmp_path / "m.json"
    square(m)
    writer = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    try:
        killed = tmp_path / f".m.fbrc.{dead.pid}.k1ll3d.tmp"  # what a writer killed before its rename leaves
        alive = tmp_path / f".m.fbrc.{writer.pid}.wr1t1n.tmp"  # another writer of the same name, still at work
        other = tmp_path / ".m.fbrc.notours.tmp"
        for p in (killed, alive, other):
            p.write_bytes(b"partial")
        assert cli.main(["export", str(m), "--compact", str(tmp_path / "m.fbrc")]) == 0
        left = sorted(p.name for p in tmp_path.iterdir())
        assert left == sorted([alive.name, other.name, "m.fbrc", "m.json"])
    finally:
        writer.send_signal(signal.SIGKILL)
        writer.wait()


def test_a_writer_killed_mid_write_leaves_the_old_file(tmp_path):
    # a real kill: the child writes a large map and is killed while its temporary file exists
    import signal
    import subprocess
    import sys
    import time

    m = tmp_path / "m.json"
    m.write_bytes(b"the old map")
    code = ("import sys, time, os; from fuzzybrep.formats import files\n"
            "real = os.fsync\n"
            "def slow(fd):\n    print('writing', flush=True); time.sleep(60)\n"
            "os.fsync = slow\n"
            f"files.write_atomic({str(m)!r}, b'x' * 10**6)\n")
    child = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "writing"
    child.send_signal(signal.SIGKILL)
    child.wait()
    temps = list(tmp_path.glob(".m.json.*.tmp"))
    assert m.read_bytes() == b"the old map" and len(temps) == 1 and f".{child.pid}." in temps[0].name
    from fuzzybrep.formats.files import write_atomic

    t0 = time.time()
    while time.time() - t0 < 5 and not _gone(child.pid):
        time.sleep(0.05)
    write_atomic(m, b"the new map")
    assert m.read_bytes() == b"the new map" and not list(tmp_path.glob(".m.json.*.tmp"))


def _gone(pid: int) -> bool:
    import os

    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


# ------------------------------------------------------------------------- 14, 15: writers and hostile strings

#: strings an attacker (or an unlucky user) puts in a map's unit or file name
HOSTILE_STRINGS = ["a\x01b\x1bc", "<!--<script>", "]]><x>&amp;", "'\"", "a\nb: c #d", "\u2028\ufeff\uffff", "é ü"]


def hostile_square(path, unit: str) -> None:
    import shapely

    from fuzzybrep.brep import BRepMap
    from fuzzybrep.fuzzy.map import fuzzify

    fuzzify(BRepMap.from_shapely(shapely.box(0, 0, 4, 4), unit), tme=0.1).save(path, poses=[[1, 1, 0, 0]])


@pytest.mark.parametrize("hostile", HOSTILE_STRINGS)
def test_svg_holds_any_unit_and_file_name_as_text(tmp_path, hostile):
    # before: a control character in the unit made the SVG ill-formed XML
    import xml.etree.ElementTree as ET

    m = tmp_path / f"{hostile}.json"
    hostile_square(m, hostile)
    assert cli.main(["export", str(m), "--svg", str(tmp_path / "s.svg")]) == 0
    root = ET.parse(tmp_path / "s.svg").getroot()
    ns = "{http://www.w3.org/2000/svg}"
    assert [e.tag for e in root] == [f"{ns}{t}" for t in ("title", "desc", "style", "rect", "g", "g", "g", "g")]
    from fuzzybrep.formats.escape import xml_text

    shown = xml_text(hostile).replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&")
    assert root.find(f"{ns}title").text == f"{shown}.json"
    assert f"unit {shown}, y up" in root.find(f"{ns}desc").text
    # the legend (issue 20) names the unit too, as text, and its scale bar's length
    legend = [t.text for t in root.iter(f"{ns}text")]
    assert any(t.endswith(f"unit {shown}") for t in legend) and any(t.endswith(f" {shown}") for t in legend[-1:])


@pytest.mark.parametrize("hostile", HOSTILE_STRINGS)
def test_ros_yaml_names_its_image_whatever_the_file_name(tmp_path, hostile):
    # before: a map file name with a newline wrote an image: value over two lines (read_ros_map
    # refused it, other YAML readers read something else) while export reported success; a unit
    # beyond ASCII was a UnicodeEncodeError in the PGM comment
    from fuzzybrep.formats.rosmap import read_ros_map

    m = tmp_path / f"{hostile}.json"
    hostile_square(m, hostile)
    assert cli.main(["export", str(m), "--ros", str(tmp_path / "r"), "--resolution", "0.5"]) == 0
    yaml = tmp_path / "r" / f"{hostile}.yaml"
    text = yaml.read_text(encoding="utf-8")
    assert len(text.splitlines()) == 7 and text.splitlines()[0].startswith("image: ")  # one line per key
    ros = read_ros_map(yaml)
    assert ros.image_path == tmp_path / "r" / f"{hostile}.pgm" and ros.image.shape == (12, 12)
    try:
        import yaml as pyyaml
    except ImportError:
        return
    assert pyyaml.safe_load(text)["image"] == f"{hostile}.pgm"


def test_yaml_scalars_read_back_as_the_same_string():
    from hypothesis import given
    from hypothesis import strategies as st

    from fuzzybrep.formats.escape import yaml_scalar
    from fuzzybrep.formats.rosmap import parse_map_yaml

    @given(st.text(st.characters(blacklist_categories=("Cs",)), min_size=1))
    def round_trip(s):
        assert parse_map_yaml(f"image: {yaml_scalar(s)}  # a comment\n")["image"] == s

    round_trip()


# ------------------------------------------------------------------------- 8: one line, and nothing before it


def cli_run(*argv) -> tuple[int, str]:
    """The CLI in a fresh process, as a user runs it: (exit status, all it wrote to stderr,
    warnings included, which pytest would otherwise catch)."""
    import subprocess
    import sys

    p = subprocess.run([sys.executable, "-m", "fuzzybrep.cli", *map(str, argv)], capture_output=True, text=True,
                       timeout=120)
    return p.returncode, p.stderr


@pytest.mark.parametrize("argv, words", [
    (["alpha-cut", "M", "--alpha", "2", "--out", "c.geojson"], "fuzzybrep alpha-cut: error: argument --alpha: α must lie in [0, 1], got 2"),
    (["grid", "LOG", "--resolution", "0", "--out", "g"], "fuzzybrep grid: error: argument --resolution: 0 must be a positive number"),
    (["plan", "M", "--start", "nan", "3", "--goal", "1", "1"], "fuzzybrep plan: error: argument --start: nan must be a finite number"),
    (["export", "M", "--nosuch"], "fuzzybrep: error: unrecognized arguments: --nosuch"),
    (["nosuch"], "fuzzybrep: error: argument COMMAND: invalid choice: 'nosuch'"),
    ([], "fuzzybrep: error: the following arguments are required: COMMAND"),
])
def test_usage_errors_are_one_line(capsys, argv, words):
    # before: 4 to 14 lines of usage before the message
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.count("\n") == 1 and words in err and "--help)" in err, err


def test_help_still_shows_the_usage(capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(["export", "--help"])
    out = capsys.readouterr().out
    assert e.value.code == 0 and out.startswith("usage: fuzzybrep export") and "--compact OUT.fbrc" in out


def test_no_warning_before_the_error(tmp_path):
    # before: NumPy's and GEOS's RuntimeWarnings (overflow in is_simple, in the sweep's area, in the
    # evidence grid's and the occupancy grid's size) printed before the one-line error; a ring
    # reaching 1e308 that was simple passed the map check altogether
    m = tmp_path / "m.json"
    d = square(m)
    d["regions"][0]["shell"].update(x=[0, 1e308, 1e308, 0], y=[0, 0, 1, 1])
    m.write_text(json.dumps(d))
    log = tmp_path / "w.log"
    log.write_text("".join(f"FLASER 10 {' '.join(['1.5'] * 9)} 9.0 {x} 0 0 {x} 0 0 {k} host {k}\n"
                           for k, x in enumerate((0.0, -1e308))))
    for argv, words in ((["tables", m], "m.json: principal, vertex 2: coordinate [1e+308, 0.0] is beyond ±1e+60"),
                        (["build", log, "--out", tmp_path / "b.json", "--quiet"], "w.log:2: the scan's position (-1e+308, 0)"),
                        (["grid", log, "--out", tmp_path / "g", "--quiet"], "the scan's position (-1e+308, 0) in w.log:2")):
        status, err = cli_run(*argv)
        assert status == 2 and err.count("\n") == 1 and words in err, err


def test_a_membership_function_numbered_beyond_any_table(tmp_path, capsys):
    # before (found by the fuzzer): a Table 4.2 index of 2**40 made a lookup table of 2**40
    # entries, an "array is too big" traceback; now the largest index an FM can hold (2**31 - 1)
    # works, looked up by sorted index, and a larger one is refused as no FM could name it
    m = tmp_path / "m.json"
    d = square(m)
    mf = d["membership_functions"][0]
    d["membership_functions"].append(dict(mf, index=2**31 - 1))
    m.write_text(json.dumps(d))
    assert cli.main(["view", str(m), "--html", str(tmp_path / "v.html")]) == 0
    assert cli.main(["tables", str(m)]) == 0
    d["membership_functions"][1]["index"] = 2**40
    m.write_text(json.dumps(d))
    fails(capsys, ["view", m, "--html", tmp_path / "w.html"], "m.json", "membership function 2: index 1099511627776 is not")


# ------------------------------------------------------------------------- 9: the right scan is blamed


@pytest.mark.parametrize("n", [2, 3, 4])
def test_the_corrupt_scan_is_named_when_the_median_lies_halfway(tmp_path, capsys, n):
    # before: with two scans, scan 2's x = -1e308 put the median halfway, and line 1 was named
    log = tmp_path / "w.log"
    log.write_text("".join(f"FLASER 10 {' '.join(['1.5'] * 9)} 9.0 {x} 0 0 {x} 0 0 {k} host {k}\n"
                           for k, x in enumerate([0.1 * k if k != 1 else -1e308 for k in range(n)])))
    fails(capsys, ["build", log, "--out", tmp_path / "m.json", "--quiet"], "w.log:2: the scan's position (-1e+308, 0)")


# ------------------------------------------------------------------------- 10: gzip bombs, long lines


def gzip_bomb(path, block: bytes, size: int) -> None:
    """``size`` bytes of ``block`` repeated, gzipped (written a MiB at a time: fast, and tiny)."""
    import zlib

    c = zlib.compressobj(9, zlib.DEFLATED, 31)
    chunk = block * (2**20 // len(block))
    with open(path, "wb") as f:
        for _ in range(size // len(chunk)):
            f.write(c.compress(chunk))
        f.write(c.flush())


@pytest.mark.parametrize("name, block, words", [
    # before: MemoryError at 4.3 GB after 29 s (a CARMEN line of NUL bytes), a gzipped CSV
    # decompressed whole (MemoryError), 4 GiB of blank lines still running after 300 s
    ("nul.log.gz", b"\0", "nul.log.gz, line 1: line is longer than 8388608 bytes, the most a line of a log may be"),
    ("blank.log.gz", b"\n", "blank.log.gz: the gzip stream expands more than 100 times"),
    ("blank.csv.gz", b"\n", "blank.csv.gz: the gzip stream expands more than 100 times"),
    ("nul.csv.gz", b"\0", "nul.csv.gz, line 1: line is longer than 8388608 bytes"),
    ("rows.csv.gz", b"0,0,0,0,0,0,1\n", "rows.csv.gz: the gzip stream expands more than 100 times"),
])
def test_gzip_bombs_are_refused_naming_the_limit(tmp_path, capsys, name, block, words):
    bomb = tmp_path / name
    if name.startswith("rows"):
        bomb.write_bytes(b"")
        gzip_bomb(bomb, block, 64 * 2**20)
        body = bomb.read_bytes()
        import gzip
        bomb.write_bytes(gzip.compress(b"scan,time,x,y,theta,bearing,range\n") + body)  # gzip members concatenate
    else:
        gzip_bomb(bomb, block, 64 * 2**20)
    assert bomb.stat().st_size < 2**20
    fails(capsys, ["build", bomb, "--out", tmp_path / "m.json", "--quiet"], words)


def test_a_plain_log_with_a_line_beyond_the_limit(tmp_path, capsys):
    log = tmp_path / "long.log"
    log.write_bytes(b"FLASER 1 1.0 0 0 0 0 0 0 0 h 0\n" + b"FLASER " + b"1 " * (2**22 + 1) + b"\n")
    fails(capsys, ["build", log, "--out", tmp_path / "m.json", "--quiet"], "long.log, line 2: line is longer than 8388608")


def test_long_lines_of_a_real_sensor_are_read(tmp_path):
    # a spinning lidar's scan of 100,000 beams: 400 kB a line, far below the limit
    from fuzzybrep.scans.carmen import read_carmen

    n = 100_000
    ranges = " ".join(["2.5"] * n)
    log = tmp_path / "dense.log"
    log.write_text("".join(f"FLASER {n} {ranges} {k} 0 0 {k} 0 0 {k} host {k}\n" for k in range(3)))
    assert len(log.read_bytes()) > 3 * 400_000
    scans = read_carmen(log)
    assert len(scans) == 3 and all(len(s.ranges) == n for s in scans)


# ------------------------------------------------------------------------- reading any input is linear


def _room_scans(n: int):
    from test_rosbag import room_scans

    scans = room_scans(8)
    return [scans[k % 8].__class__(scans[k % 8].ranges, scans[k % 8].bearings, scans[k % 8].pose,
                                   float(k), scans[k % 8].max_range) for k in range(n)]


def _carmen(tmp_path, n):
    p = tmp_path / f"scans{n}.log"
    p.write_text("".join(f"FLASER {len(s.ranges)} {' '.join(f'{r:.3f}' for r in s.ranges)} {s.pose[0]} {s.pose[1]} "
                         f"{s.pose[2]} 0 0 0 {s.timestamp} host {s.timestamp}\nODOM 0 0 0 0 0 0 {s.timestamp} h 0\n\n"
                         for s in _room_scans(n)))
    return p


def _csv(tmp_path, n):
    from fuzzybrep.scans.csvscans import write_csv

    p = tmp_path / f"scans{n}.csv"
    write_csv(p, _room_scans(n))
    return p


def _bag(tmp_path, n):
    from test_rosbag import bag_of

    return bag_of(tmp_path / f"scans{n}.bag", _room_scans(n))


def _ros2(tmp_path, n):
    from test_rosbag import bag_of

    return bag_of(tmp_path / f"scans{n}", _room_scans(n), ros1=False, storage="mcap")


def _ring(n):
    import numpy as np

    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack((10 * np.cos(a), 10 * np.sin(a)))


def _map_json(tmp_path, n):
    from fuzzybrep.brep import BRepMap, Region, Ring
    from fuzzybrep.fuzzy.map import fuzzify

    p = tmp_path / f"map{n}.json"
    fuzzify(BRepMap((Region(Ring(_ring(n))),)), tme=0.01).save(p)
    return p


def _compact(tmp_path, n):
    from fuzzybrep.brep import BRepMap, Region, Ring
    from fuzzybrep.formats.compact import write_compact

    p = tmp_path / f"map{n}.fbrc"
    write_compact(p, BRepMap((Region(Ring(_ring(n))),)), [])
    return p


def _geojson(tmp_path, n):
    ring = _ring(n).tolist()
    p = tmp_path / f"plan{n}.geojson"
    p.write_text(json.dumps({"type": "Polygon", "coordinates": [ring + ring[:1]]}))
    return p


def _read_scans(p):
    from fuzzybrep.scans.read import read_scans

    assert read_scans(p)


def _read_map(p):
    from fuzzybrep.formats.mapfile import read_map

    read_map(p)


def _read_geojson(p):
    from fuzzybrep.formats.geojson import read_geojson

    read_geojson(p)


@pytest.mark.parametrize("make, read, n", [(_carmen, _read_scans, 40), (_csv, _read_scans, 20), (_bag, _read_scans, 30),
                                           (_ros2, _read_scans, 30), (_map_json, _read_map, 2000),
                                           (_compact, _read_map, 2000), (_geojson, _read_geojson, 2000)],
                         ids=["carmen", "csv", "ros1", "ros2", "map-json", "compact", "geojson"])
def test_reading_is_linear_in_the_input(tmp_path, make, read, n):
    from _linear import assert_linear

    assert_linear(lambda k: make(tmp_path, k), read, n)


# ------------------------------------------------------------------------- 11: huge GeoJSON


def test_geojson_too_large_is_refused_before_it_is_parsed(tmp_path, capsys, monkeypatch):
    # before: a ring of 10**7 vertices (289 MB) peaked at 6.1 GB and ended in GEOSException: std::bad_alloc
    from fuzzybrep.commands import _maps
    from fuzzybrep.formats import geojson
    from fuzzybrep.sim import world

    parsed = []
    for module in (geojson, world, _maps):  # refused before it is parsed
        monkeypatch.setattr(module, "loads_json", lambda raw, real=module.loads_json: parsed.append(1) or real(raw))
    g = tmp_path / "huge.geojson"
    g.write_bytes(b'{"type": "Polygon", "coordinates": [[' + b"[0.5,0.5]," * 5_001_000 + b"[0.5,0.5]]]}")
    fails(capsys, ["fuzzify", g, "--tme", "0.1", "--out", tmp_path / "f.json"],
          "huge.geojson: the file holds about 5001003 positions; GeoJSON is read with up to 5000000")
    fails(capsys, ["demo", "--world", g, "--out", tmp_path / "d"], "huge.geojson: the file holds about 5001003 positions")
    with open(g, "r+b") as f:  # sparse: 600 MiB that take no disk
        f.truncate(600 * 2**20)
    fails(capsys, ["fuzzify", g, "--tme", "0.1", "--out", tmp_path / "f.json"],
          "huge.geojson: the file is 600 MiB; a map file or GeoJSON is read up to 512 MiB")
    assert not parsed and not (tmp_path / "f.json").exists()


# ------------------------------------------------------------------------- 16: ROS bags
# (the fuzzer's "bag-messages" cases draw these at random; here each once, by name)


def _bag_with(tmp_path, name, each, ros1=True, storage="sqlite3"):
    """A bag of six room scans at odometry poses, ``each(bag, k, scan)`` writing scan k's messages."""
    from test_rosbag import Bag, room_scans

    b = Bag(tmp_path / name, ros1=ros1, storage=storage)
    for k, s in enumerate(room_scans(6)):
        each(b, k, s)
    b.close()
    return tmp_path / name


@pytest.mark.parametrize("ros1, storage, cut, words", [
    (True, "", 0.5, "cut.bag: cannot read as a ROS bag: AnyReaderError: Bag index looks damaged"),
    (False, "sqlite3", 0.5, "cut: cannot read as a ROS bag: AnyReaderError: Cannot open database"),
    (False, "mcap", 0.5, "cut: cannot read as a ROS bag: AnyReaderError:"),
])
def test_a_truncated_bag(tmp_path, capsys, ros1, storage, cut, words):
    from test_rosbag import bag_of, room_scans

    bag = bag_of(tmp_path / ("cut.bag" if ros1 else "cut"), room_scans(6), ros1=ros1, storage=storage or "sqlite3")
    f = bag if ros1 else next(p for p in bag.iterdir() if p.suffix in (".db3", ".mcap"))
    f.write_bytes(f.read_bytes()[: int(f.stat().st_size * cut)])
    fails(capsys, ["build", bag, "--out", tmp_path / "m.json", "--quiet"], words)


def test_bags_with_messages_wrong_in_kind_or_content(tmp_path, capsys):
    import numpy as np

    from test_rosbag import LASER

    def wrong_bytes(b, k, s):
        b.odom(s.timestamp, *s.pose)
        b.raw(s.timestamp, "/scan", LASER, b"\x01\x02\x03")

    def odometry_on_scan(b, k, s):
        b.odom(s.timestamp, *s.pose)
        b.odom(s.timestamp, *s.pose, topic="/scan")

    def all_nan(b, k, s):
        b.odom(s.timestamp, *s.pose)
        b.scan(s.timestamp, np.full(181, np.nan))

    def empty(b, k, s):
        b.odom(s.timestamp, *s.pose)
        b.scan(s.timestamp, s.ranges if k else [])

    def tf_loop(b, k, s):  # odom -> laser -> odom: each frame one parent, and no root
        b.tf(s.timestamp, "odom", "laser", s.pose[0], s.pose[1], s.pose[2])
        b.tf(s.timestamp, "laser", "odom", 0, 0, 0)
        b.scan(s.timestamp, s.ranges)

    out = tmp_path / "m.json"
    for each, words in (
            (wrong_bytes, "wrong_bytes.bag, topic /scan, message 0: cannot decode sensor_msgs/msg/LaserScan"),
            (odometry_on_scan, "odometry_on_scan.bag: no sensor_msgs/LaserScan topic in this bag"),
            (all_nan, "all_nan.bag: no beam has a return"),
            (empty, "empty.bag, topic /scan, message 0, field ranges: no ranges"),
            # before: "cannot read as a ROS bag: ValueError: tf has a loop"
            (tf_loop, "tf_loop.bag: tf has a loop through frame 'laser': a frame is its own ancestor")):
        bag = _bag_with(tmp_path, f"{each.__name__}.bag", each)
        fails(capsys, ["build", bag, "--out", out, "--quiet"], words)
    assert cli.main(["build", str(tmp_path / "empty.bag"), "--out", str(out), "--quiet", "--skip-bad"]) == 0
    assert not list(tmp_path.glob(".*.tmp"))


def test_a_bag_of_many_tiny_messages_reads_in_linear_time(tmp_path):
    # a bag of 10**6 tiny messages (empty scans between real ones) is read in time linear in its
    # size: here 10**3 and 10**4 (the 10**6 run is in the report)
    from _linear import assert_linear

    from fuzzybrep.scans.read import read_scans
    from fuzzybrep.scans.report import ReadReport
    from test_rosbag import Bag, room_scans

    ranges = room_scans(1)[0].ranges

    def make(n):
        b = Bag(tmp_path / f"tiny{n}.bag")
        for k in range(n):
            t = 1 + k * 1e-3
            if k % 100 == 0:
                b.odom(t, 0.01 * k, 0.0, 0.0)
            b.scan(t, ranges if k % 100 == 0 else [])
        b.close()
        return tmp_path / f"tiny{n}.bag"

    def run(bag):
        report = ReadReport()
        assert read_scans(bag, skip_bad=True, report=report) and report.skipped

    assert_linear(make, run, 1000)


@pytest.mark.parametrize("index", [{"a": 1}, [1], "1", 1.5, True, 0, 2**31])
def test_a_membership_function_index_that_is_no_whole_number(tmp_path, capsys, index):
    # found by the fuzzer: an index that was a JSON object ended in "TypeError: unhashable type: 'dict'"
    m = tmp_path / "m.json"
    d = square(m)
    d["membership_functions"][0]["index"] = index
    m.write_text(json.dumps(d))
    fails(capsys, ["view", m, "--html", tmp_path / "v.html"], "m.json", "membership function 1: index",
          "is not a whole number from 1 up")


def test_export_makes_every_output_before_it_writes_any(tmp_path, capsys):
    # found by the fuzzer: export --svg --ros wrote the SVG, then found the ROS grid too large
    m = tmp_path / "m.json"
    d = square(m)
    d["regions"][0]["shell"].update(x=[0, 2e9, 2e9, 0])
    m.write_text(json.dumps(d))
    fails(capsys, ["export", m, "--svg", tmp_path / "s.svg", "--geojson", tmp_path / "g.geojson", "--ros", tmp_path / "r"],
          "m.yaml: a grid of", "is too large (limit 40000000 cells)")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json"]


def test_a_tme_near_the_largest_float_warns_of_nothing(tmp_path):
    # found by the fuzzer: TME = 1e308 overflowed (a RuntimeWarning) in the criteria check before the error
    m = tmp_path / "m.json"
    d = square(m)
    d["membership_functions"][0]["tme"] = 1e308
    m.write_text(json.dumps(d))
    status, err = cli_run("memory", m, "--cell", "0.5")
    assert status == 2 and err.count("\n") == 1 and "support ±1e+308 m reaches beyond" in err, err
