"""export --nav2: the map, the keepout and speed masks and their parameters, loaded as Nav2 loads them.

The reader (``_nav2``) implements nav2_map_server's loading rules, both the Humble-era and the 2025
ones, independently of fuzzybrep's writer. On every shared log (FUZZYBREP_BIG_LOGS=1; the Intel lab
always) the free, occupied and unknown areas it reads back match the map's within 2 %.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
import shapely

import _nav2
from _floor import floor_map
from conftest import datasets_dir
from fuzzybrep.cli import main
from fuzzybrep.formats.nav2 import (FREE_MAX, keepout_values, map_values, raw_pgm, scale_png, speed_filter_coefficients,
                                    speed_values, write_nav2)
from fuzzybrep.formats.raster import membership_raster, occupied_region

MODES = ("scale", "raw")


def run(*argv) -> int:
    return main([str(a) for a in argv])


@pytest.fixture(scope="module")
def floor():
    return floor_map()


@pytest.mark.parametrize("release", _nav2.RELEASES)
def test_every_value_comes_back_exactly_in_both_modes(tmp_path, release):
    from fuzzybrep.formats.rosmap import map_yaml

    values = np.arange(-1, 101, dtype=np.int8).reshape(6, 17)
    for mode, data, ext, (occ, free) in (("scale", scale_png(values), "png", (1.0, 0.0)),
                                         ("raw", raw_pgm(values), "pgm", (0.65, 0.196))):
        (tmp_path / f"v.{ext}").write_bytes(data)
        (tmp_path / f"{mode}.yaml").write_text(map_yaml(f"v.{ext}", 0.05, (0, 0, 0), False, occ, free, mode))
        g = _nav2.load(tmp_path / f"{mode}.yaml", release)
        np.testing.assert_array_equal(g.data[::-1], values)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("release", _nav2.RELEASES)
def test_floor_map_and_masks_load_as_written(floor, tmp_path, mode, release):
    r = membership_raster(floor, 0.05, "exact")
    files = write_nav2(tmp_path, "floor", r, mode=mode, alpha=0.5, min_speed=20)
    g = _nav2.load(files.map_yaml, release)
    assert g.mode == mode and g.resolution == 0.05 and g.origin == (*r.origin, 0.0)
    np.testing.assert_array_equal(g.data[::-1], map_values(r))
    # classes: 100 occupied, −1 unknown, 0..99 free with μ kept: round(99 μ)
    np.testing.assert_array_equal(g.data[::-1] == 100, r.occupied)
    np.testing.assert_array_equal(g.data[::-1] == -1, r.unknown)
    free = g.data[::-1][r.free]
    np.testing.assert_allclose(free / FREE_MAX, r.mu[r.free], atol=0.5 / FREE_MAX + 1e-12)
    assert 0 < np.count_nonzero((free > 0) & (free < FREE_MAX))
    # the keepout mask: 100 where the free space is outside the inner α-cut, nothing elsewhere
    k = _nav2.load(files.keepout_yaml, release)
    assert k.mode == "trinary"
    np.testing.assert_array_equal(k.data[::-1], keepout_values(r, 0.5))
    assert set(np.unique(k.data)) == {-1, 100}
    # which is the exact α-cut's band, up to the cells its boundary crosses
    cut = floor.alpha_cut(0.5, "exact")
    kept = shapely.difference(floor.crisp_geometry, cut.inner).area
    assert k.area(100) == pytest.approx(kept, rel=0.1)
    # the speed mask: 0 where μ = 0, 1..100 by μ in the band, 100 off the free space
    sp = _nav2.load(files.speed_yaml, release)
    np.testing.assert_array_equal(sp.data[::-1], speed_values(r))
    base, mult = files.speed_base, files.speed_multiplier
    assert (base, mult) == speed_filter_coefficients(20) == (100.0, -0.8)
    limit = base + mult * sp.data[::-1][r.free & (r.mu > 0)]
    np.testing.assert_allclose(limit, 100 - 80 * r.mu[r.free & (r.mu > 0)], atol=0.8 * 0.5 + 1e-9)
    assert (sp.data[::-1][~r.free] == 100).all() and (sp.data[::-1][r.free & (r.mu == 0)] == 0).all()


def test_params_snippet_is_yaml_with_the_filter_info(floor, tmp_path):
    from ruamel.yaml import YAML

    r = membership_raster(floor, 0.05, "exact")
    files = write_nav2(tmp_path / "nav 2", "floor", r, alpha=0.25, min_speed=40)
    p = YAML(typ="safe").load(files.params.read_text())
    keep = p["keepout_costmap_filter_info_server"]["ros__parameters"]
    speed = p["speed_costmap_filter_info_server"]["ros__parameters"]
    assert (keep["type"], keep["base"], keep["multiplier"]) == (0, 0.0, 1.0)
    assert (speed["type"], speed["base"], speed["multiplier"]) == (1, 100.0, -0.6)
    assert keep["mask_topic"] == p["keepout_filter_mask_server"]["ros__parameters"]["topic_name"]
    assert speed["mask_topic"] == p["speed_filter_mask_server"]["ros__parameters"]["topic_name"]
    assert p["map_server"]["ros__parameters"]["yaml_filename"] == str(files.map_yaml.resolve())
    assert p["speed_filter_mask_server"]["ros__parameters"]["yaml_filename"] == str(files.speed_yaml.resolve())
    costmap = p["global_costmap"]["global_costmap"]["ros__parameters"]
    assert costmap["filters"] == ["keepout_filter", "speed_filter"]
    assert costmap["keepout_filter"]["filter_info_topic"] == keep["filter_info_topic"]
    assert "alpha = 0.25" in files.params.read_text()


def test_export_nav2_command(floor, tmp_path, capsys):
    path = tmp_path / "floor.json"
    floor.save(path)
    assert run("export", path, "--nav2", tmp_path / "n", "--keepout-alpha", 0.5, "--min-speed", 25) == 0
    out = capsys.readouterr().out
    assert "Nav2 map (scale)" in out and "α = 0.5" in out and "100 -0.75·mask %" in out
    assert sorted(p.name for p in (tmp_path / "n").iterdir()) == [
        "floor.png", "floor.yaml", "floor_keepout.pgm", "floor_keepout.yaml", "floor_nav2_params.yaml",
        "floor_speed.png", "floor_speed.yaml"]
    assert run("export", path, "--nav2", tmp_path / "r", "--nav2-mode", "raw") == 0
    assert (tmp_path / "r" / "floor.pgm").is_file() and _nav2.load(tmp_path / "r" / "floor.yaml").mode == "raw"
    with pytest.raises(SystemExit):  # a usage error, before any work
        run("export", path, "--nav2", tmp_path / "x", "--min-speed", 100)
    assert "must be a percentage in [0, 100)" in capsys.readouterr().err


def areas_match(fz, out, mode: str, release: str, rel: float = 0.02) -> dict:
    """Load ``out/NAME.yaml`` as Nav2 does and compare its areas with the map's own (metres)."""
    g = _nav2.load(out, release)
    free = g.area(0) + float(np.count_nonzero((g.data > 0) & (g.data < 100))) * g.resolution ** 2
    occupied, unknown = g.area(100), g.area(-1)
    h, w = g.data.shape
    box = shapely.box(g.origin[0], g.origin[1], g.origin[0] + w * g.resolution, g.origin[1] + h * g.resolution)
    map_free = fz.crisp_geometry.area
    map_occupied = occupied_region(fz).area
    map_unknown = box.area - map_free - map_occupied
    assert free == pytest.approx(map_free, rel=rel)
    assert occupied == pytest.approx(map_occupied, rel=rel)
    assert unknown == pytest.approx(map_unknown, rel=rel)
    return {"free": (free, map_free), "occupied": (occupied, map_occupied), "unknown": (unknown, map_unknown)}


@pytest.mark.reallog
@pytest.mark.parametrize("mode", MODES)
def test_intel_nav2_areas_match_the_map(built_map, tmp_path, mode):
    path, fz = built_map("intel")
    assert run("export", path, "--nav2", tmp_path, "--nav2-mode", mode) == 0
    for release in _nav2.RELEASES:
        areas_match(fz, tmp_path / "intel.yaml", mode, release)
    # and the keepout mask, read as Nav2 reads it, is the free space outside the inner α-cut at 0
    k = _nav2.load(tmp_path / "intel_keepout.yaml")
    band = shapely.difference(fz.crisp_geometry, fz.alpha_cut(0.0).inner).area  # the default (safe) cut
    assert k.area(100) == pytest.approx(band, rel=0.05)


ALL = ["intel", "aces", "freiburg-079", "freiburg-campus", "fhw", "orebro"]


@pytest.mark.reallog
@pytest.mark.skipif(not os.environ.get("FUZZYBREP_BIG_LOGS"),
                    reason="every shared log takes minutes (freiburg-campus alone 3): set FUZZYBREP_BIG_LOGS=1")
@pytest.mark.parametrize("name", ALL)
def test_every_shared_log_nav2_areas_match_the_map(name, tmp_path):
    d = datasets_dir()
    log = d / "carmen" / f"{name}-corrected.log.gz" if d else None
    if log is None or not log.is_file():
        pytest.skip(f"{name}: log not found (FUZZYBREP_DATASETS or ../shared/datasets)")
    from fuzzybrep.fuzzy.map import FuzzyBRepMap

    path = tmp_path / f"{name}.json"
    assert run("build", log, "--out", path, "--quiet") == 0
    fz = FuzzyBRepMap.load(path)
    for mode in MODES:
        assert run("export", path, "--nav2", tmp_path / mode, "--nav2-mode", mode) == 0
        for release in _nav2.RELEASES:
            areas = areas_match(fz, tmp_path / mode / f"{name}.yaml", mode, release)
            print(name, mode, release, {k: (round(a, 1), round(b, 1)) for k, (a, b) in areas.items()})
