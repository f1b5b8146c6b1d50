"""The command line: build, export and evaluate, and what the user sees when input is bad."""

from __future__ import annotations

import json

import numpy as np
import shapely
from _synthetic import l_room, scan_of

from fuzzybrep import cli
from fuzzybrep.fuzzy.map import FuzzyBRepMap
from fuzzybrep.formats.mapfile import read_map
from fuzzybrep.scans.csvscans import write_csv


def scans_csv(tmp_path, n=12):
    rng = np.random.default_rng(4)
    scans = []
    for k in range(n):
        x, y = rng.uniform(0.8, 3.2), rng.uniform(0.8, 1.2) if k % 2 else rng.uniform(2.5, 5.2)
        if y > 2 and x > 3.5:
            x = 2.0
        scans.append(scan_of(l_room(), (x, y, rng.uniform(-3, 3)), n=181, sigma=0.005, seed=k, t=float(k)))
    p = tmp_path / "scans.csv"
    write_csv(p, scans)
    return p, scans


def test_build_writes_a_fuzzy_map_and_a_picture(tmp_path, capsys):
    log, scans = scans_csv(tmp_path)
    out, png = tmp_path / "map.json", tmp_path / "map.png"
    assert cli.main(["build", str(log), "--out", str(out), "--plot", str(png)]) == 0
    err = capsys.readouterr().err
    assert "12 scans" in err and "vertices" in err and "holes" in err and "scans/s" in err
    # one line, also when standard error is no terminal (before: wrapped at 80 columns, mid-path)
    (summary,) = [line for line in err.splitlines() if "vertices" in line]
    assert summary.startswith("scans.csv: 12 scans") and f"-> {out}, " in summary and summary.endswith("scans/s)")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the picture shows the band it built (issue 20: it drew the crisp map only)
    from PIL import Image

    from fuzzybrep.plot import BAND

    with Image.open(png) as im:
        img = np.asarray(im.convert("RGB"), dtype=np.int16)
    band = np.array([int(BAND[i:i + 2], 16) for i in (1, 3, 5)])
    assert (np.abs(img - band).sum(axis=2) < 60).mean() > 0.002
    m = read_map(out)
    assert len(m.poses) == 12 and m.metadata["scans"] == 12
    # fuzzified with the default TME; frontier edges have their own membership function
    assert [f["index"] for f in m.membership_functions] == [1, 2]
    fz = FuzzyBRepMap.load(out)
    assert fz.crisp.equals_exactly(m.crisp)
    # the map is the L-shaped room, give or take the band
    room = l_room()
    g = fz.crisp.to_shapely()
    assert g.difference(room.buffer(0.05)).area < 0.05 and g.area > 0.8 * room.area


def test_build_with_iepf_and_a_theta_step(tmp_path):
    log, _ = scans_csv(tmp_path)
    out = tmp_path / "m.json"
    assert cli.main(["build", str(log), "--out", str(out), "--lines", "iepf", "--quiet"]) == 0
    assert cli.main(["build", str(log), "--out", str(out), "--theta-step", "0.5", "--tme", "0.1", "--quiet"]) == 0
    assert read_map(out).membership_functions[0]["tme"] == 0.1


def test_build_tme_sets_the_vertex_reduction_as_in_evaluate(tmp_path):
    # README: boundaries are simplified within TME/4. Before, build's --tme reached only the
    # membership function (evaluate's reached both): a 10 cm notch survived --tme 0.8
    from dataclasses import replace

    from fuzzybrep.mapping.build import BuildConfig, build_map
    from fuzzybrep.scans.csvscans import read_csv

    notched = shapely.Polygon([(0, 0), (6, 0), (6, 4), (3.2, 4), (3.2, 4.1), (2.8, 4.1), (2.8, 4), (0, 4)])
    poses = [(1, 1, 0), (3, 2, 1), (5, 3, 2), (2, 3, -1), (4, 1, 0.5)]
    log = tmp_path / "notch.csv"
    write_csv(log, [scan_of(notched, p, n=361, fov=2 * np.pi * 359 / 360, t=float(k)) for k, p in enumerate(poses)])
    out = tmp_path / "m.json"
    inside = shapely.Point(3.0, 4.05)  # in the notch
    for tme in (None, 0.8):  # the notch kept within 5 cm, gone within 20 cm
        assert cli.main(["build", str(log), "--out", str(out), "--quiet"] + (["--tme", str(tme)] if tme else [])) == 0
        want = build_map(read_csv(log), replace(BuildConfig(), tme=tme) if tme else BuildConfig()).crisp
        assert read_map(out).crisp.equals_exactly(want)
        assert want.to_shapely().contains(inside) == (tme is None)
        assert want.n_vertices > 4 if tme is None else want.n_vertices == 4


def test_export_geojson_has_the_crisp_free_space(tmp_path):
    log, _ = scans_csv(tmp_path)
    out, gj = tmp_path / "m.json", tmp_path / "m.geojson"
    cli.main(["build", str(log), "--out", str(out), "--quiet"])
    assert cli.main(["export", str(out), "--geojson", str(gj)]) == 0
    d = json.loads(gj.read_text())
    crisp = [f for f in d["features"] if f["properties"]["role"] == "crisp"]
    assert len(crisp) == 1
    g = shapely.geometry.shape(crisp[0]["geometry"])
    assert g.is_valid and np.isclose(g.area, read_map(out).crisp.area)


def test_bad_log_exits_2_naming_file_and_line(tmp_path, capsys):
    bad = tmp_path / "bad.log"
    bad.write_text("FLASER 3 1.0 -2.0 1.0 0 0 0 0 0 0 1.0 h 1.0\n")
    assert cli.main(["build", str(bad), "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert "bad.log, line 1, field r_2" in err and "negative" in err
    assert not (tmp_path / "m.json").exists()


def test_skip_bad_says_how_many(tmp_path, capsys):
    log, _ = scans_csv(tmp_path, n=6)
    text = log.read_text().splitlines()
    text[5] = text[5].rsplit(",", 1)[0] + ",nan"
    log.write_text("\n".join(text) + "\n")
    out = tmp_path / "m.json"
    assert cli.main(["build", str(log), "--out", str(out)]) == 2
    assert "not finite" in capsys.readouterr().err
    assert cli.main(["build", str(log), "--out", str(out), "--skip-bad"]) == 0
    assert "skipped 1 bad line" in capsys.readouterr().err
    # evaluate --skip-bad said nothing of what it skipped (before: its report was dropped); on
    # standard error, so that --json stays one JSON document
    assert cli.main(["evaluate", str(log), "--skip-bad", "--json"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["scans_used"] == 3
    assert f"skipped 1 bad line(s) or message(s); first: {log}, line 6, field range: 'nan' is not finite" in err


def test_unreadable_map_file(tmp_path, capsys):
    p = tmp_path / "broken.json"
    p.write_text('{"format": "fuzzybrep-map", "version": 1')
    assert cli.main(["export", str(p), "--geojson", str(tmp_path / "x.geojson")]) == 2
    assert "broken.json" in capsys.readouterr().err


def test_evaluate_prints_scores(tmp_path, capsys):
    log, _ = scans_csv(tmp_path, n=10)
    assert cli.main(["evaluate", str(log), "--holdout", "2", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["scans_used"] == 5 and d["scans_held_out"] == 5
    assert 0.9 <= d["exact"]["explained"] <= 1 and d["exact"]["violations"] <= 0.01
    assert 0 <= d["violations_unseen"] <= d["exact"]["violations"]
    assert 0 <= d["violations_came_and_went"] <= d["exact"]["violations"]
    assert cli.main(["evaluate", str(log), "--holdout", "2"]) == 0
    text = capsys.readouterr().out
    assert "explained" in text and "no kept scan saw any return within TME" in text and "violations that came and went" in text


def test_consolidate_says_when_no_pair_was_found(tmp_path, capsys):
    # before: --consolidate on a log without back-to-back opposite scans did nothing, silently;
    # the summary shows "(N pairs consolidated)" only for N > 0, so the user could not tell
    log, scans = scans_csv(tmp_path)
    out = tmp_path / "m.json"
    assert cli.main(["build", str(log), "--out", str(out), "--consolidate"]) == 0
    err = capsys.readouterr().err
    assert "note: --consolidate: no two consecutive scans" in err and "pairs consolidated" not in err
    # a log that has such pairs is merged and says so
    from fuzzybrep.scans.scan import Scan

    turned = [x for s in scans[:4] for x in (s, Scan(s.ranges, s.bearings, s.pose + [0, 0, np.pi], s.timestamp + 0.5,
                                                       s.max_range))]
    write_csv(log, turned)
    assert cli.main(["build", str(log), "--out", str(out), "--consolidate"]) == 0
    err = capsys.readouterr().err
    assert "(4 pairs consolidated)" in err and "note: --consolidate" not in err


def test_a_command_imports_only_what_it_needs():
    # start-up counts in every command's time: the parser of `build` alone, without the other
    # commands' modules (the planner's SciPy Voronoi, the simulator) or SciPy at all
    import subprocess
    import sys

    code = ("import sys\nfrom fuzzybrep import cli\ntry:\n    cli.main(['build', '--help'])\nexcept SystemExit:\n    pass\n"
            "from fuzzybrep.mapping.build import build_map\n"
            "print(sorted(m for m in ('scipy', 'matplotlib', 'fuzzybrep.use.plan', 'fuzzybrep.sim.world') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "[]"


def test_a_whole_build_imports_neither_scipy_nor_matplotlib(tmp_path):
    # what a build runs, not only its parser: importing scipy.spatial (the footprint's KD-tree)
    # took 0.2 s and 38 MB, as long as building a small log; a quiet build shows nothing, so it
    # needs no rich either (30 ms)
    import subprocess
    import sys

    log, _ = scans_csv(tmp_path)
    code = ("import sys\nfrom fuzzybrep import cli\n"
            f"assert cli.main(['build', {str(log)!r}, '--out', {str(tmp_path / 'map.json')!r}, '--quiet']) == 0\n"
            "print(sorted(m for m in ('scipy', 'matplotlib', 'rich') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "[]"


def test_long_commands_show_their_steps_on_a_terminal_only(capsys, monkeypatch):
    import rich.console

    from fuzzybrep.commands._progress import steps

    with steps(2) as step:  # standard error is no terminal here: nothing on it
        step("reading the map")
        step("α-cut at α = 0.5")
    assert capsys.readouterr().err == ""
    monkeypatch.setattr(rich.console.Console, "is_terminal", property(lambda self: True))
    with steps(2) as step:
        step("reading the map")
        step("α-cut at α = 0.5")
    assert "α-cut at α = 0.5" in capsys.readouterr().err
    with steps(2, quiet=True) as step:
        step("reading the map")
    assert capsys.readouterr().err == ""
