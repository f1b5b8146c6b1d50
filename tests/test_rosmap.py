"""ROS map_server maps: PGM (P5/P2) and YAML written and read to the map_server specification."""

from __future__ import annotations

import re

import numpy as np
import pytest

from fuzzybrep.errors import MapFileError
from fuzzybrep.mapping.grid import OccupancyGrid, logit
from fuzzybrep.formats.rosmap import (PIXEL_FREE, PIXEL_OCCUPIED, PIXEL_UNKNOWN, grid_image, map_yaml,
                                      parse_map_yaml, pgm_bytes, read_pgm, read_ros_map, write_grid, write_ros_map)

YAML = """image: m.pgm
resolution: 0.05
origin: [-1.5, 2.25, 0.0]
negate: 0
occupied_thresh: 0.65
free_thresh: 0.196
"""


def put(tmp_path, yaml=YAML, pgm: bytes | None = None, name="m"):
    (tmp_path / f"{name}.yaml").write_text(yaml)
    if pgm is not None:
        (tmp_path / f"{name}.pgm").write_bytes(pgm)
    return tmp_path / f"{name}.yaml"


# ------------------------------------------------------------------------- round trips


def test_any_image_round_trips_exactly(tmp_path):
    img = np.random.default_rng(3).integers(0, 256, (37, 53), dtype=np.uint8)
    y, p = write_ros_map(tmp_path / "a" / "m.yaml", img, 0.1 / 3, (-12.345678901234567, 1e-05, 0.25),
                         occupied_thresh=0.7, free_thresh=0.2, negate=True, mode="scale", comment="two\nlines")
    assert p == tmp_path / "a" / "m.pgm" and p.is_file()
    m = read_ros_map(y)
    np.testing.assert_array_equal(m.image, img)
    assert m.image.dtype == np.uint8 and m.maxval == 255
    assert m.resolution == 0.1 / 3 and m.origin == (-12.345678901234567, 1e-05, 0.25)
    assert (m.negate, m.occupied_thresh, m.free_thresh, m.mode) == (True, 0.7, 0.2, "scale")
    assert p.read_bytes().startswith(b"P5\n# two\n# lines\n53 37\n255\n")
    assert len(p.read_bytes()) == len(b"P5\n# two\n# lines\n53 37\n255\n") + 37 * 53


def test_yaml_is_standard_yaml_with_the_right_types(tmp_path):
    yaml = pytest.importorskip("ruamel.yaml")  # comes with rosbags: an independent YAML reader
    text = map_yaml("m.pgm", 0.05, (-10.0, 1e-05, 0.0))
    d = yaml.YAML(typ="safe").load(text)
    assert d == {"image": "m.pgm", "mode": "trinary", "resolution": 0.05, "origin": [-10.0, 1e-05, 0.0],
                 "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196}
    assert parse_map_yaml(text) == d
    # ROS 1 map_server and PyYAML read YAML 1.1, where a float needs a dot in its mantissa
    # (yaml.org/type/float.html): "1e-05" would be a string there
    yaml11_float = re.compile(r"[-+]?([0-9][0-9_]*)?\.[0-9.]*([eE][-+][0-9]+)?")
    for key in ("resolution", "origin", "occupied_thresh", "free_thresh"):
        value = next(line for line in text.splitlines() if line.startswith(key + ":")).split(":", 1)[1]
        for v in value.strip(" []").split(","):
            assert yaml11_float.fullmatch(v.strip()), (key, v)


def test_grid_image_is_trinary_and_upside_down():
    # bottom row (row 0 of the grid) is free, except an occupied cell at its left; top row unknown
    lo = np.array([[logit(0.9), logit(0.1), logit(0.1)], [0.0, 0.0, 0.0]])
    g = OccupancyGrid(lo, (0.0, 0.0), 0.5)
    img = grid_image(g)
    np.testing.assert_array_equal(img, [[PIXEL_UNKNOWN] * 3, [PIXEL_OCCUPIED, PIXEL_FREE, PIXEL_FREE]])
    assert (PIXEL_OCCUPIED, PIXEL_FREE, PIXEL_UNKNOWN) == (0, 254, 205)  # map_saver's grey levels


def test_grid_round_trips_through_map_server_semantics(tmp_path):
    rng = np.random.default_rng(0)
    lo = rng.choice([logit(0.05), 0.0, logit(0.3), logit(0.95), 2.0, -2.0], size=(20, 30))
    g = OccupancyGrid(lo, (-3.25, 4.5), 0.05)
    y, _ = write_grid(tmp_path / "g.yaml", g)
    m = read_ros_map(y)
    np.testing.assert_array_equal(m.occupancy(), g.trinary())  # what map_server would publish
    assert m.origin == (-3.25, 4.5, 0.0) and m.resolution == 0.05
    assert (m.free_thresh, m.occupied_thresh) == (g.free_thresh, g.occupied_thresh)


def test_map_server_reads_pixels_as_it_documents(tmp_path):
    img = np.array([[0, 254, 205, 255, 100, 180]], np.uint8)
    y, _ = write_ros_map(tmp_path / "m.yaml", img, 1.0, (0, 0))
    m = read_ros_map(y)
    np.testing.assert_allclose(m.probability(), (255 - img) / 255)
    np.testing.assert_array_equal(m.occupancy(), [[100, 0, -1, 0, -1, -1]])  # 180: p = 0.29
    neg = read_ros_map(write_ros_map(tmp_path / "n.yaml", img, 1.0, (0, 0), negate=True)[0])
    np.testing.assert_array_equal(neg.occupancy(), [[0, 100, 100, 100, -1, 100]])
    scale = read_ros_map(write_ros_map(tmp_path / "s.yaml", img, 1.0, (0, 0), mode="scale")[0])
    occ = scale.occupancy()
    assert occ[0, 0] == 100 and occ[0, 1] == 0 and 1 <= occ[0, 2] <= 99 and occ[0, 4] > occ[0, 2]
    raw = read_ros_map(write_ros_map(tmp_path / "r.yaml", img, 1.0, (0, 0), mode="raw")[0])
    np.testing.assert_array_equal(raw.occupancy(), [[0, -1, -1, -1, 100, -1]])
    # in every mode the published grid starts with the bottom row, the image with the top one
    raw = read_ros_map(write_ros_map(tmp_path / "r2.yaml", np.array([[7], [50]], np.uint8), 1.0, (0, 0), mode="raw")[0])
    np.testing.assert_array_equal(raw.occupancy(), [[50], [7]])


def test_thresholds_are_strict_and_scale_grades_between_them(tmp_path):
    """map_server: p > occupied_thresh is occupied, p < free_thresh free, anything else unknown; in
    scale mode the in-between cells get 1 + 98 (p - free) / (occ - free), truncated (ROS 1 map_server)."""
    img = np.array([[51, 204, 128, 0, 255]], np.uint8)  # p = 0.8, 0.2, 0.498, 1, 0
    y, _ = write_ros_map(tmp_path / "t.yaml", img, 1.0, (0, 0), occupied_thresh=0.8, free_thresh=0.2)
    np.testing.assert_array_equal(read_ros_map(y).occupancy(), [[-1, -1, -1, 100, 0]])
    y, _ = write_ros_map(tmp_path / "s.yaml", img, 1.0, (0, 0), occupied_thresh=0.8, free_thresh=0.2, mode="scale")
    m = read_ros_map(y)
    ratio = (m.probability()[0, :3] - 0.2) / (0.8 - 0.2)
    assert m.occupancy()[0].tolist() == [int(1 + 98 * r) for r in ratio] + [100, 0] == [99, 1, 49, 100, 0]


def test_a_map_without_mode_is_trinary(tmp_path):
    m = read_ros_map(put(tmp_path, pgm=bytes(b"P5\n3 1\n255\n") + bytes([100, 180, 254])))
    assert m.mode == "trinary" and m.occupancy().tolist() == [[-1, -1, 0]]


def test_the_image_is_written_before_the_yaml_that_names_it(tmp_path, monkeypatch):
    import fuzzybrep.formats.rosmap as rosmap

    write_atomic = rosmap.write_atomic

    def image_fails(path, data):
        if str(path).endswith(".pgm"):
            raise MapFileError(path, "cannot write: No space left on device")
        return write_atomic(path, data)

    monkeypatch.setattr(rosmap, "write_atomic", image_fails)
    with pytest.raises(MapFileError, match="m.pgm: cannot write"):
        write_ros_map(tmp_path / "m.yaml", np.zeros((2, 2), np.uint8), 0.05, (0.0, 0.0))
    assert list(tmp_path.iterdir()) == []  # no YAML naming an image that is not there


# ------------------------------------------------------------------------- PGM variants


def test_plain_p2_with_comments_everywhere(tmp_path):
    (tmp_path / "p2.pgm").write_bytes(b"P2\n# made by hand\n3 # width\n2\n# maxval next\n15\n0 7 15\n  1 2\n3\n")
    img, maxval = read_pgm(tmp_path / "p2.pgm")
    assert maxval == 15 and img.dtype == np.uint8
    np.testing.assert_array_equal(img, [[0, 7, 15], [1, 2, 3]])
    m = read_ros_map(put(tmp_path, pgm=(tmp_path / "p2.pgm").read_bytes()))
    # maxval 15: 15 is white (free), 0 black (occupied)
    np.testing.assert_allclose(m.probability()[0], [1.0, 8 / 15, 0.0])
    assert m.occupancy()[1].tolist() == [100, -1, 0]  # occupancy() is bottom row first


def test_binary_p5_with_comments_and_16_bit(tmp_path):
    body = bytes([0, 254, 205, 9])
    (tmp_path / "a.pgm").write_bytes(b"P5 #c1\n#c2\n2 2\n#c3\n255\n" + body)
    img, maxval = read_pgm(tmp_path / "a.pgm")
    np.testing.assert_array_equal(img, [[0, 254], [205, 9]])
    (tmp_path / "b.pgm").write_bytes(b"P5\n2 1\n65535\n" + np.array([1, 65535], ">u2").tobytes())
    img, maxval = read_pgm(tmp_path / "b.pgm")
    assert maxval == 65535 and img.dtype == np.uint16 and img.tolist() == [[1, 65535]]
    # a raster byte that looks like whitespace is still a pixel
    (tmp_path / "c.pgm").write_bytes(b"P5\n2 1\n255\n\n ")
    assert read_pgm(tmp_path / "c.pgm")[0].tolist() == [[10, 32]]
    # Netpbm: 2 bytes a sample when maxval is 256 or more
    (tmp_path / "d.pgm").write_bytes(b"P5\n2 1\n256\n" + np.array([256, 1], ">u2").tobytes())
    img, maxval = read_pgm(tmp_path / "d.pgm")
    assert maxval == 256 and img.tolist() == [[256, 1]]


@pytest.mark.parametrize("data", [b"P5\n2 1\n255\n\x00\xfe\nP5\n1 1\n255\n\x07", b"P2\n2 1\n255\n0 254\nP2\n1 1\n255\n7\n"])
def test_a_pgm_file_of_several_images_gives_the_first(tmp_path, data):
    (tmp_path / "m.pgm").write_bytes(data)  # Netpbm allows images one after another in a file
    assert read_pgm(tmp_path / "m.pgm")[0].tolist() == [[0, 254]]


def test_pgm_writer_refuses_what_is_not_8_bit_grey():
    with pytest.raises(ValueError, match="uint8"):
        pgm_bytes(np.zeros((2, 2), np.float32))
    with pytest.raises(ValueError, match="2-D"):
        pgm_bytes(np.zeros((2, 2, 3), np.uint8))


# ------------------------------------------------------------------------- bad files


@pytest.mark.parametrize("data, match", [
    (b"\x89PNG\r\n\x1a\n....", "not a PGM image \\(a PNG"),
    (b"P6\n2 2\n255\n" + bytes(12), "not a PGM image"),
    (b"P5\n2\n", "bad PGM header: no height"),
    (b"P5\n2 x\n255\n", "integers"),
    (b"P5\n0 2\n255\n", "size 0 x 2"),
    (b"P5\n2 2\n70000\n" + bytes(8), "maxval 70000"),
    (b"P5\n1 1\n0\n" + bytes(1), "maxval 0 must be 1..65535"),
    (b"P5\n4 4\n255\n" + bytes(10), "truncated PGM: 4 x 4 pixels need 16 bytes, 10 present"),
    (b"P5\n2 2\n255\n" + bytes(9), "image size mismatch"),
    (b"P2\n2 2\n255\n1 2 3\n", "truncated PGM"),
    (b"P2\n2 2\n255\n1 2 3 4 5\n", "image size mismatch"),
    (b"P2\n2 1\n100\n1 200\n", "exceeds maxval"),
    (b"P2\n2 1\n255\n1 x\n", "not an integer"),
])
def test_bad_pgm_names_file_and_fault(tmp_path, data, match):
    (tmp_path / "m.pgm").write_bytes(data)
    with pytest.raises(MapFileError, match=match) as e:
        read_ros_map(put(tmp_path))
    assert e.value.path.endswith("m.pgm")


@pytest.mark.parametrize("yaml, match", [
    (YAML.replace("negate: 0\n", ""), "missing key\\(s\\) negate"),
    ("image: m.pgm\n", "missing key\\(s\\) resolution, origin, negate, occupied_thresh, free_thresh"),
    (YAML.replace("[-1.5, 2.25, 0.0]", "[-1.5, 2.25]"), "origin must be a list \\[x, y, yaw\\]"),
    (YAML.replace("[-1.5, 2.25, 0.0]", "[-1.5, a, 0.0]"), "origin must be a number, got 'a'"),
    (YAML.replace("[-1.5, 2.25, 0.0]", "[-1.5, 2.25, 0.0"), "not closed"),
    (YAML.replace("0.05", "-0.05"), "resolution must be positive"),
    (YAML.replace("0.05", "fast"), "resolution must be a number"),
    (YAML.replace("0.05", "0"), "resolution must be positive, got 0.0"),
    (YAML.replace("0.05", "true"), "resolution must be a number, got True"),
    (YAML.replace("[-1.5, 2.25, 0.0]", "[-1.5, 2.25, 0.0, 1.0]"), "origin must be a list \\[x, y, yaw\\]"),
    (YAML.replace("occupied_thresh: 0.65", "occupied_thresh: 65"), "free_thresh \\(0.196\\) < occupied_thresh \\(65.0\\) <= 1"),
    (YAML.replace("image: m.pgm", "image: 5"), "image must be a file name, got 5"),
    (YAML.replace("negate: 0", "negate: 2"), "negate must be 0 or 1"),
    (YAML.replace("free_thresh: 0.196", "free_thresh: 0.9"), "free_thresh \\(0.9\\) < occupied_thresh"),
    (YAML + "mode: fuzzy\n", "mode 'fuzzy'"),
    (YAML.replace("image: m.pgm", "image: other.pgm"), "image 'other.pgm' not found"),
    (YAML + "resolution: 0.1\n", "line 7: key 'resolution' appears twice"),
    (YAML + "  indented: 1\n", "line 7: unexpected indentation"),
    (YAML + "extra: {a: 1}\n", "line 7: 'extra' is a mapping"),
    (YAML + "just text\n", "line 7: expected 'key: value'"),
])
def test_bad_yaml_names_file_and_fault(tmp_path, yaml, match):
    y = put(tmp_path, yaml, pgm=b"P5\n1 1\n255\n\x00")
    with pytest.raises(MapFileError, match=match) as e:
        read_ros_map(y)
    assert e.value.path == str(y)


def test_missing_yaml_file(tmp_path):
    with pytest.raises(MapFileError, match="cannot read"):
        read_ros_map(tmp_path / "nothing.yaml")


def test_yaml_parser_reads_what_map_server_accepts():
    text = """---
# a map
image: "my map.pgm"   # quoted, with a space
resolution: 5.0e-2
origin:
  - -1
  - 2.5   # block list
  - 0
negate: false
occupied_thresh: 0.65
free_thresh: 0.196
"""
    d = parse_map_yaml(text)
    assert d == {"image": "my map.pgm", "resolution": 0.05, "origin": [-1, 2.5, 0], "negate": False,
                 "occupied_thresh": 0.65, "free_thresh": 0.196}
    # YAML: "#" starts a comment only at the start or after a space
    assert parse_map_yaml("image: map#2.pgm  # the second\n") == {"image": "map#2.pgm"}


def test_absolute_image_path_and_writer_checks(tmp_path):
    (tmp_path / "img").mkdir()
    (tmp_path / "img" / "x.pgm").write_bytes(b"P5\n1 1\n255\n\xfe")
    m = read_ros_map(put(tmp_path, YAML.replace("image: m.pgm", f"image: {tmp_path / 'img' / 'x.pgm'}")))
    assert m.image.tolist() == [[254]] and m.image_path == tmp_path / "img" / "x.pgm"
    img = np.zeros((2, 2), np.uint8)
    with pytest.raises(MapFileError, match="origin"):
        write_ros_map(tmp_path / "w.yaml", img, 0.05, (np.nan, 0.0))
    with pytest.raises(MapFileError, match="resolution"):
        write_ros_map(tmp_path / "w.yaml", img, 0.0, (0.0, 0.0))
    with pytest.raises(MapFileError, match="mode"):
        write_ros_map(tmp_path / "w.yaml", img, 0.05, (0.0, 0.0), mode="fuzzy")
    with pytest.raises(MapFileError, match="uint8"):
        write_ros_map(tmp_path / "w.yaml", img.astype(float), 0.05, (0.0, 0.0))
    for occ, free in [(0.5, 0.6), (1.5, 0.2), (0.65, -0.1)]:
        with pytest.raises(MapFileError, match="need 0 <= free_thresh"):
            write_ros_map(tmp_path / "w.yaml", img, 0.05, (0.0, 0.0), occupied_thresh=occ, free_thresh=free)
    assert not (tmp_path / "w.yaml").exists() and not (tmp_path / "w.pgm").exists()


def test_a_map_whose_yaml_cannot_be_written_leaves_no_pgm(tmp_path):
    # before: NAME.pgm was written, then NAME.yaml failed (a folder of that name): half a map
    (tmp_path / "m.yaml").mkdir()
    with pytest.raises(MapFileError, match="m.yaml: cannot write: it is a folder"):
        write_ros_map(tmp_path / "m.yaml", np.zeros((2, 3), np.uint8), 0.05, (0.0, 0.0, 0.0))
    assert [p.name for p in tmp_path.iterdir()] == ["m.yaml"]
