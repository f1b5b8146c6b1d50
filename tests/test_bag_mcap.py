"""export --bag (ROS 2 bag through rosbags) and --mcap (Foxglove schemas through mcap), read back
with the same libraries: the grid is the Nav2 map's, the polygons are the map's."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from _floor import floor_map
from fuzzybrep.cli import main
from fuzzybrep.formats.export import DEFAULT_ALPHAS
from fuzzybrep.formats.nav2 import map_values
from fuzzybrep.formats.raster import membership_raster
from fuzzybrep.formats.rings import polygon_rings


def run(*argv) -> int:
    return main([str(a) for a in argv])


@pytest.fixture(scope="module")
def floor():
    return floor_map()


def read_bag(path):
    """{topic: (connection, message)} of a ROS 2 bag, deserialised by rosbags."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    out = {}
    with Reader(path) as r:
        for conn, t, raw in r.messages():
            assert conn.topic not in out, "one message per topic"
            out[conn.topic] = (conn, t, ts.deserialize_cdr(raw, conn.msgtype))
    return out


def same_rings(got: list[np.ndarray], want: list[np.ndarray], atol: float):
    assert len(got) == len(want)
    for g, w in zip(got, want):
        np.testing.assert_allclose(g, w, atol=atol, rtol=0)


def expected(fz, method="safe"):  # the CLI's default
    cuts = [fz.alpha_cut(a, method) for a in DEFAULT_ALPHAS]
    return {f"alpha-{c.alpha:g}-{role}": polygon_rings(getattr(c, role))
            for c in cuts if c.alpha < 1 for role in ("inner", "outer")}


def check_bag(path, fz, raster):
    from rosbags.interfaces import QosDurability, QosHistory

    msgs = read_bag(path)
    assert set(msgs) == {"/map", "/map_boundary"}
    conn, t, grid = msgs["/map"]
    assert t == 0 and conn.msgtype == "nav_msgs/msg/OccupancyGrid"
    for c in (conn, msgs["/map_boundary"][0]):  # latched: transient local, keep last 1
        (qos,) = c.ext.offered_qos_profiles
        assert qos.durability == QosDurability.TRANSIENT_LOCAL and qos.history == QosHistory.KEEP_LAST and qos.depth == 1
    assert grid.header.frame_id == "map" and grid.info.resolution == np.float32(raster.resolution)  # float32 in ROS
    assert (grid.info.width, grid.info.height) == (raster.shape[1], raster.shape[0])
    assert (grid.info.origin.position.x, grid.info.origin.position.y) == raster.origin
    np.testing.assert_array_equal(grid.data.reshape(grid.info.height, grid.info.width), map_values(raster)[::-1])
    markers = msgs["/map_boundary"][2].markers
    by_ns: dict[str, list] = {}
    for m in markers:
        assert m.header.frame_id == "map"
        by_ns.setdefault(m.ns, []).append(m)
    crisp = sorted(by_ns["crisp"], key=lambda m: m.id)
    assert all(m.type == 4 for m in crisp)  # LINE_STRIP, closed
    pts = [np.array([(p.x, p.y) for p in m.points]) for m in crisp]
    assert all(np.array_equal(p[0], p[-1]) for p in pts)
    same_rings([p[:-1] for p in pts], [r.vertices for r in fz.crisp.rings], atol=0)  # the map's rings, exactly
    for ns, want in expected(fz).items():
        got = [np.array([(p.x, p.y) for p in m.points])[:-1] for m in sorted(by_ns[ns], key=lambda m: m.id)]
        same_rings(got, want, atol=0)
    (frontier,) = by_ns["frontier"]
    n_frontier = sum(int((r.kinds == 1).sum()) for r in fz.crisp.rings)
    assert frontier.type == 5 and len(frontier.points) == 2 * n_frontier


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_bag_reads_back_with_rosbags(floor, tmp_path, storage, capsys):
    path = tmp_path / "floor.json"
    floor.save(path)
    assert run("export", path, "--bag", tmp_path / "floor.bag", "--bag-storage", storage) == 0
    assert "latched" in capsys.readouterr().out
    check_bag(tmp_path / "floor.bag", floor, membership_raster(floor, 0.05, "safe"))
    # written again over itself: replaced whole; a folder that is not a bag is refused
    assert run("export", path, "--bag", tmp_path / "floor.bag", "--bag-storage", storage) == 0
    check_bag(tmp_path / "floor.bag", floor, membership_raster(floor, 0.05, "safe"))
    (tmp_path / "photos").mkdir()
    assert run("export", path, "--bag", tmp_path / "photos") == 2
    assert "not a ROS 2 bag" in capsys.readouterr().err
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())  # no temporary folder left


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_bag_metadata_for_humble_and_jazzy(floor, tmp_path, storage):
    """Humble's rosbag2 reads metadata version 5 with offered_qos_profiles a YAML string (a
    serialized list), and failed on the version 9 file we wrote, whose QoS is a list (issue 36)."""
    from ruamel.yaml import YAML  # what rosbags reads YAML with

    pyyaml = YAML(typ="safe")
    pyyaml.safe_load = pyyaml.load
    path = tmp_path / "floor.json"
    floor.save(path)
    for distro, version in (("humble", 5), ("jazzy", 9), (None, 5)):
        bag = tmp_path / f"{distro}.bag"
        assert run("export", path, "--bag", bag, "--bag-storage", storage,
                   *(["--ros-distro", distro] if distro else [])) == 0
        info = pyyaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        assert info["version"] == version
        topics = {t["topic_metadata"]["name"]: t["topic_metadata"] for t in info["topics_with_message_count"]}
        assert set(topics) == {"/map", "/map_boundary"}
        for t in topics.values():
            qos = t["offered_qos_profiles"]
            if version == 5:
                assert isinstance(qos, str)  # Humble: a YAML document inside a string
                assert "type_description_hash" not in t
                assert not {"custom_data", "ros_distro"} & set(info)
                qos = pyyaml.safe_load(qos)
            assert isinstance(qos, list) and len(qos) == 1
            # transient local, keep last 1: rmw's enum values in Humble's shape, names in Jazzy's
            assert qos[0]["durability"] == (1 if version == 5 else "transient_local") and qos[0]["depth"] == 1
        assert info["message_count"] == 2 and info["relative_file_paths"]
        check_bag(bag, floor, membership_raster(floor, 0.05, "safe"))  # rosbags reads both


def read_mcap(path):
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    out = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            out[channel.topic] = (schema.name, message.log_time, decoded)
    return out


def check_mcap(path, fz, raster):
    msgs = read_mcap(path)
    name, t, grid = msgs["/map"]
    # logged at the time of writing (before: 0, "unset"), the message's own timestamp the same
    assert name == "foxglove.Grid" and abs(t - time.time_ns()) < 600e9 and grid.frame_id == "map"
    assert grid.timestamp.ToNanoseconds() == t
    assert grid.column_count == raster.shape[1] and grid.cell_size.x == raster.resolution
    assert (grid.pose.position.x, grid.pose.position.y) == raster.origin
    fields = {f.name: f.offset for f in grid.fields}
    assert {"red", "green", "blue", "alpha", "occupancy", "mu"} <= set(fields)
    cells = np.frombuffer(grid.data, np.uint8).reshape(-1, grid.cell_stride)
    occupancy = cells[:, fields["occupancy"]].view(np.int8).reshape(raster.shape)
    np.testing.assert_array_equal(occupancy, map_values(raster)[::-1])
    mu = np.ascontiguousarray(cells[:, fields["mu"]:fields["mu"] + 4]).view("<f4").reshape(raster.shape)
    np.testing.assert_allclose(mu, raster.mu[::-1], atol=1e-6)
    alpha = cells[:, fields["alpha"]].reshape(raster.shape)
    np.testing.assert_array_equal(alpha == 0, raster.unknown[::-1])
    name, _, update = msgs["/map_boundary"]
    assert name == "foxglove.SceneUpdate"
    entities = {e.id: e for e in update.entities}
    assert all(e.frame_id == "map" for e in entities.values())
    rings = [np.array([(p.x, p.y) for p in line.points]) for line in entities["crisp"].lines]
    same_rings(rings, [r.vertices for r in fz.crisp.rings], atol=0)
    for ns, want in expected(fz).items():
        e = entities[ns]
        assert {m.key: m.value for m in e.metadata}["role"] in ("inner", "outer")
        same_rings([np.array([(p.x, p.y) for p in line.points]) for line in e.lines], want, atol=0)


def test_mcap_reads_back_with_the_mcap_reader(floor, tmp_path, capsys):
    path = tmp_path / "floor.json"
    floor.save(path)
    assert run("export", path, "--mcap", tmp_path / "floor.mcap") == 0
    assert "foxglove.Grid" in capsys.readouterr().out
    check_mcap(tmp_path / "floor.mcap", floor, membership_raster(floor, 0.05, "safe"))


def test_mcap_passes_strict_readers(floor, tmp_path):
    """Every reader accepts it: the mcap library's seeking and streaming readers with CRCs checked
    and the summary read, and pymcap-cli's doctor (if installed), which found two structural
    errors before: summary offsets pointing at empty MetadataIndex and AttachmentIndex groups."""
    from mcap.reader import SeekingReader, StreamReader
    from mcap.records import MetadataIndex, SummaryOffset

    from fuzzybrep.formats.foxglove_mcap import write_mcap

    out = tmp_path / "floor.mcap"
    stamp = 1_700_000_000_123_456_789
    write_mcap(out, floor, membership_raster(floor, 0.05, "safe"), [floor.alpha_cut(0.5)], stamp_ns=stamp)
    with open(out, "rb") as f:
        reader = SeekingReader(f, validate_crcs=True)
        summary = reader.get_summary()
        assert summary.statistics.message_count == 2
        assert summary.statistics.message_start_time == summary.statistics.message_end_time == stamp
        assert not summary.metadata_indexes and not summary.attachment_indexes
        msgs = list(reader.iter_messages())
        assert [m.log_time for _, _, m in msgs] == [stamp, stamp]
        assert [m.publish_time for _, _, m in msgs] == [stamp, stamp]
    with open(out, "rb") as f:
        records = list(StreamReader(f, validate_crcs=True, skip_magic=False).records)
    offsets = [r for r in records if isinstance(r, SummaryOffset)]
    groups = {type(r).__name__ for r in records}
    assert offsets and all(o.group_length > 0 for o in offsets)  # no offset to an empty group
    assert not any(isinstance(r, MetadataIndex) for r in records) and "ChunkIndex" in groups
    doctor = shutil.which("pymcap-cli", path=os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")]))
    if doctor:
        res = subprocess.run([doctor, "doctor", "--format", "jsonl", str(out)], capture_output=True, text=True, timeout=60)
        lines = [json.loads(x) for x in res.stdout.splitlines() if x.startswith("{")]
        summary = [x for x in lines if x.get("type") == "summary"]
        assert summary and summary[0]["errors"] == 0 and summary[0]["warnings"] == 0, res.stdout


@pytest.mark.reallog
def test_intel_bag_and_mcap_hold_the_map(built_map, tmp_path):
    path, fz = built_map("intel")
    assert run("export", path, "--bag", tmp_path / "intel.bag", "--mcap", tmp_path / "intel.mcap") == 0
    raster = membership_raster(fz, 0.05, "safe")
    check_bag(tmp_path / "intel.bag", fz, raster)
    check_mcap(tmp_path / "intel.mcap", fz, raster)
