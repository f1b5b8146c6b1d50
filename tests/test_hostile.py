"""Hostile input (issue 19): every reader and writer gives a one-line error naming the file (exit
status 2) or works; none leaves a traceback, a quadratic decode, an injected script or a partial file.

The mutation fuzzer over every format is ``tests/fuzz.py`` (``test_fuzz.py`` runs it); these are
the defects it and an adversarial review found, one test each."""

from __future__ import annotations

import copy
import json

import pytest

from fuzzybrep import cli


def fails(capsys, argv, *words) -> str:
    """Run the CLI, expect exit status 2 and one error line holding every word, nothing before it."""
    assert cli.main([str(a) for a in argv]) == 2
    out = capsys.readouterr()
    assert out.err.count("\n") == 1 and "Traceback" not in out.err, out.err
    for w in words:
        assert w in out.err, out.err
    return out.err


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
