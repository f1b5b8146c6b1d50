"""GeoJSON's coordinate reference system (issue 36, item 2): the map's local frame declared with
JSON-FG's ``coordRefSys``, or ``--georef LON LAT HEADING`` for RFC 7946 lon/lat. Checked with GDAL
(Debian's gdal-bin) where ``ogrinfo`` is on the PATH."""

from __future__ import annotations

import json
import math
import shutil
import subprocess

import numpy as np
import pytest
import shapely

from fuzzybrep.brep import BRepMap
from fuzzybrep.cli import main
from fuzzybrep.errors import MapFileError
from fuzzybrep.formats.geojson import read_geojson
from fuzzybrep.formats.georef import CRS84, to_lonlat
from fuzzybrep.fuzzy.map import fuzzify

LON, LAT, HEADING = 7.85, 47.99, 30.0
gdal = pytest.mark.skipif(shutil.which("ogrinfo") is None or shutil.which("ogr2ogr") is None,
                          reason="GDAL's ogrinfo/ogr2ogr not found (Debian: apt-get install gdal-bin)")


def room(size=100.0, unit="m"):
    g = shapely.Polygon([(0, 0), (size, 0), (size, size / 2), (0, size / 2)],
                        [[(0.4 * size, 0.2 * size), (0.4 * size, 0.3 * size), (0.6 * size, 0.3 * size), (0.6 * size, 0.2 * size)]])
    return fuzzify(BRepMap.from_shapely(g, unit), tme=0.2 * size / 100)


@pytest.fixture
def room_file(tmp_path):
    p = tmp_path / "room.json"
    room().save(p)
    return p


def test_without_georef_the_local_frame_is_declared(room_file, tmp_path):
    out = tmp_path / "room.geojson"
    assert main(["export", str(room_file), "--geojson", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["type"] == "FeatureCollection"
    assert d["coordRefSys"] == {"type": "Reference", "href": "urn:fuzzybrep:crs:local-engineering:m"}
    assert d["fuzzybrepFrame"]["unit"] == "m"
    assert read_geojson(out).area == pytest.approx(room().crisp.area)  # still reads back
    assert main(["alpha-cut", str(room_file), "--alpha", "0.5", "--out", str(tmp_path / "cut.geojson")]) == 0
    assert json.loads((tmp_path / "cut.geojson").read_text())["coordRefSys"]["href"].endswith(":m")


def test_directions_of_the_axes():
    # heading 90: x points east, y north; heading 0: x north, y west
    ll = to_lonlat(np.array([[0, 0], [1000, 0], [0, 1000]]), LON, LAT, 90.0)
    assert ll[0] == pytest.approx([LON, LAT])
    assert ll[1, 0] > LON and ll[1, 1] == pytest.approx(LAT, abs=1e-6)
    assert ll[2, 1] > LAT and ll[2, 0] == pytest.approx(LON, abs=1e-9)
    ll = to_lonlat(np.array([[1000, 0], [0, 1000]]), LON, LAT, 0.0)
    assert ll[0, 1] > LAT and ll[1, 0] < LON
    # a degree of latitude is 111.2 km at 48° N (WGS 84), a degree of longitude 74.6 km
    ll = to_lonlat(np.array([[0, 1000], [1000, 0]]), LON, LAT, 90.0)
    # east along the plane leaves the parallel towards the equator: 9 cm over 1 km at 48° N
    assert (ll[1, 1] - LAT) * 111_180 == pytest.approx(-0.087, abs=0.002)
    assert 1000 / (ll[0, 1] - LAT) == pytest.approx(111_180, rel=1e-3)
    assert 1000 / (ll[1, 0] - LON) == pytest.approx(74_640, rel=1e-3)


def test_georef_writes_lon_lat_and_refuses_bad_values(room_file, tmp_path, capsys):
    out = tmp_path / "geo.geojson"
    assert main(["export", str(room_file), "--geojson", str(out), "--georef", str(LON), str(LAT), str(HEADING)]) == 0
    d = json.loads(out.read_text())
    assert d["coordRefSys"] == CRS84 and d["georef"]["heading_deg"] == HEADING
    xy = np.array(d["features"][0]["geometry"]["coordinates"][0])
    assert (np.abs(xy[:, 0] - LON) < 0.01).all() and (np.abs(xy[:, 1] - LAT) < 0.01).all()
    assert shapely.Polygon(xy).exterior.is_ccw  # RFC 7946's right-hand rule survives the turn
    with pytest.raises(MapFileError, match="georeferenced"):
        read_geojson(out)
    capsys.readouterr()
    with pytest.raises(SystemExit) as e:
        main(["export", str(room_file), "--geojson", str(out), "--georef", "7", "95", "0"])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "latitude must lie in (-90, 90), got 95" in err
    # a map in a unit of unknown length cannot be placed on the Earth
    odd = tmp_path / "odd.json"
    room(unit="ft").save(odd)
    assert main(["export", str(odd), "--geojson", str(out), "--georef", "7", "48", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "'ft' is not m, cm or mm" in err


def _ogr(*args) -> str:
    return subprocess.run(args, check=True, capture_output=True, text=True, timeout=60).stdout


@gdal
def test_gdal_reads_it_at_the_right_place_and_reprojects_every_feature(room_file, tmp_path):
    out = tmp_path / "geo.geojson"
    assert main(["export", str(room_file), "--geojson", str(out), "--georef", str(LON), str(LAT), str(HEADING)]) == 0
    info = _ogr("ogrinfo", "-so", "-al", str(out))
    assert "Feature Count: 11" in info and 'ID["EPSG",4326]' in info
    lo_lon, lo_lat, hi_lon, hi_lat = map(float, __import__("re").search(
        r"Extent: \(([-\d.]+), ([-\d.]+)\) - \(([-\d.]+), ([-\d.]+)\)", info).groups())
    assert LON - 0.002 < lo_lon < LON < hi_lon < LON + 0.002 and LAT - 0.001 < lo_lat <= LAT < hi_lat < LAT + 0.002
    merc = tmp_path / "merc.geojson"
    _ogr("ogr2ogr", "-t_srs", "EPSG:3857", "-f", "GeoJSON", str(merc), str(out))
    d = json.loads(merc.read_text())
    assert len(d["features"]) == 11 and all(f["geometry"] for f in d["features"])
    x, y = np.array(d["features"][0]["geometry"]["coordinates"][0][0])
    assert x == pytest.approx(6378137 * math.radians(LON), abs=0.01)
    assert y == pytest.approx(6378137 * math.log(math.tan(math.pi / 4 + math.radians(LAT) / 2)), abs=0.01)


@gdal
@pytest.mark.parametrize("size, tol", [(1000.0, 1.5e-3), (10_000.0, 0.15)])
def test_tangent_plane_against_proj(tmp_path, size, tol):
    """Back to east/north metres by PROJ's azimuthal equidistant projection about the origin: the
    documented accuracy (1 mm at 1 km, 10 cm at 10 km)."""
    p = tmp_path / "big.json"
    room(size).save(p)
    out = tmp_path / "geo.geojson"
    assert main(["export", str(p), "--geojson", str(out), "--alpha", "1", "--georef", str(LON), str(LAT), str(HEADING)]) == 0
    back = tmp_path / "aeqd.geojson"
    _ogr("ogr2ogr", "-t_srs", f"+proj=aeqd +lat_0={LAT} +lon_0={LON} +datum=WGS84 +units=m", "-lco",
         "COORDINATE_PRECISION=6", "-f", "GeoJSON", str(back), str(out))
    en = np.array(json.loads(back.read_text())["features"][0]["geometry"]["coordinates"][0])
    h = math.radians(HEADING)
    xy = np.array(room(size).crisp.principal.closed_coords())
    want = np.column_stack((xy[:, 0] * math.sin(h) - xy[:, 1] * math.cos(h), xy[:, 0] * math.cos(h) + xy[:, 1] * math.sin(h)))
    got = en[np.argmin(np.hypot(*(en[:, None, :] - want[None, :, :]).transpose(2, 0, 1)), axis=0)]
    assert np.hypot(*(got - want).T).max() < tol
