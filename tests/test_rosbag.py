"""ROS bags in: bags written with rosbags read back as the same scans (and the same map) as CSV."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest
import shapely

from fuzzybrep import cli
from fuzzybrep.mapping.build import build_map
from fuzzybrep.errors import BagMessageError, BagValueError, ScanFormatError
from fuzzybrep.formats.mapfile import read_map
from fuzzybrep.scans.csvscans import read_csv, write_csv
from fuzzybrep.scans.report import ReadReport
from fuzzybrep.scans.read import read_scans
from fuzzybrep.scans.rosbag import read_rosbag
from fuzzybrep.scans.scan import Scan
from fuzzybrep.sim.simulate import World, cast_rays

rosbags = pytest.importorskip("rosbags")
from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: E402

LASER, ODOM, TF, TF_STATIC = "sensor_msgs/msg/LaserScan", "nav_msgs/msg/Odometry", "/tf", "/tf_static"
TFMSG = "tf2_msgs/msg/TFMessage"
# what a LaserScan can carry: float32 angles, so the bearings are these exactly
ANGLE_MIN, ANGLE_INC = float(np.float32(-math.pi / 2)), float(np.float32(math.pi / 180))
BEARINGS = ANGLE_MIN + np.arange(181) * ANGLE_INC


def quat(yaw: float, roll: float = 0.0) -> tuple[float, float, float, float]:
    """(x, y, z, w) of yaw then roll (z-y-x Euler with no pitch)."""
    cy, sy, cr, sr = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(roll / 2), math.sin(roll / 2)
    return (sr * cy, sr * sy, cr * sy, cr * cy)


def yaw_of(q) -> float:
    x, y, z, w = q
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def room_scans(n_scans=8, seed=0) -> list[Scan]:
    """Scans along an L-shaped room 12 m long (so some beams find nothing within 8 m), with ranges a
    float32 can hold and headings a quaternion gives back exactly, as a bag stores them."""
    world = World(shapely.Polygon([(0, 0), (12, 0), (12, 3), (4, 3), (4, 7), (0, 7)]), shapely.MultiLineString())
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n_scans):
        x, y = 1.0 + 1.25 * k, 1.5 + 0.125 * (k % 3)
        if x > 11:
            x, y = 2.0, 1.0 + 0.75 * (k - 7)
        h = yaw_of(quat(rng.uniform(-math.pi, math.pi)))
        r, _ = cast_rays(world, np.tile([x, y], (181, 1)), h + BEARINGS, 8.0)
        r = np.minimum(r + rng.normal(0, 0.01, 181), 8.0).astype(np.float32).astype(np.float64)
        out.append(Scan(r, BEARINGS, (x, y, h), 100.0 + 0.25 * k, 8.0))
    return out


# ------------------------------------------------------------------------- writing bags


def typestore(ros1: bool):
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if ros1:  # Noetic's store lacks tf2_msgs; a real ROS 1 bag carries its definition
        ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", TFMSG))
    return ts


class Bag:
    """A bag being written: ROS 1 (.bag) or ROS 2 (folder; sqlite3 or mcap)."""

    def __init__(self, path, ros1=True, storage="sqlite3"):
        self.ros1, self.ts = ros1, typestore(ros1)
        self.T = self.ts.types
        if ros1:
            from rosbags.rosbag1 import Writer

            self.w = Writer(path)
        else:
            from rosbags.rosbag2 import StoragePlugin, Writer

            self.w = Writer(path, version=9,
                            storage_plugin=StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3)
        self.w.open()
        self.conns = {}

    def header(self, t, frame):
        sec = math.floor(t)
        stamp = self.T["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((t - sec) * 1e9))
        kw = {"seq": 0} if self.ros1 else {}
        return self.T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame, **kw)

    def write(self, topic, msgtype, msg, t):
        data = self.ts.serialize_ros1(msg, msgtype) if self.ros1 else self.ts.serialize_cdr(msg, msgtype)
        self.raw(t, topic, msgtype, data)

    def scan(self, t, ranges, topic="/scan", frame="laser", angle_min=ANGLE_MIN, inc=ANGLE_INC, range_max=8.0,
             range_min=0.0, stamp=None):
        """stamp: the header's, when it differs from the record time t."""
        msg = self.T[LASER](header=self.header(t if stamp is None else stamp, frame), angle_min=angle_min,
                            angle_max=angle_min + (len(ranges) - 1) * inc, angle_increment=inc, time_increment=0.0,
                            scan_time=0.0, range_min=range_min, range_max=range_max,
                            ranges=np.asarray(ranges, np.float32), intensities=np.zeros(0, np.float32))
        self.write(topic, LASER, msg, t)

    def odom(self, t, x, y, yaw, topic="/odom", frame="odom", child="base_link", q=None):
        T = self.T
        q = quat(yaw) if q is None else q
        pose = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                                           orientation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]))
        zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        msg = T[ODOM](header=self.header(t, frame), child_frame_id=child,
                      pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
                      twist=T["geometry_msgs/msg/TwistWithCovariance"](
                          twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=np.zeros(36)))
        self.write(topic, ODOM, msg, t)

    def tf(self, t, parent, child, x, y, yaw, roll=0.0, static=False):
        T = self.T
        q = quat(yaw, roll)
        tr = T["geometry_msgs/msg/TransformStamped"](
            header=self.header(t, parent), child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](translation=T["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.3),
                                                       rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])))
        self.write(TF_STATIC if static else TF, TFMSG, T[TFMSG](transforms=[tr]), t)

    def raw(self, t, topic, msgtype, data: bytes):
        """A message whose serialized bytes are given (damaged ones, say)."""
        if topic not in self.conns:
            self.conns[topic] = self.w.add_connection(topic, msgtype, typestore=self.ts)
        self.w.write(self.conns[topic], round(t * 1e9), data)

    def close(self):
        self.w.close()


def bag_of(path, scans, ros1=True, storage="sqlite3", poses="odom", mount=(0.0, 0.0, 0.0)):
    """A bag of LaserScans at the scans' poses: by odometry (laser on base_link), or by tf
    (odom -> base_link moving, base_link -> laser static at ``mount``)."""
    b = Bag(path, ros1, storage)
    mx, my, myaw = mount
    if poses == "tf":
        b.tf(scans[0].timestamp, "base_link", "laser", mx, my, myaw, static=True)
    for s in scans:
        x, y, h = s.pose
        if poses == "odom":
            b.odom(s.timestamp, x, y, h)
        else:  # the base pose that puts the laser at the scan's pose
            bh = h - myaw
            b.tf(s.timestamp, "odom", "base_link", x - math.cos(bh) * mx + math.sin(bh) * my,
                 y - math.sin(bh) * mx - math.cos(bh) * my, bh)
        b.scan(s.timestamp, s.ranges)
    b.close()
    return path


def same_scans(a: list[Scan], b: list[Scan], pose_atol=0.0):
    assert len(a) == len(b)
    for s, t in zip(a, b):
        np.testing.assert_array_equal(s.ranges, t.ranges)
        np.testing.assert_array_equal(s.bearings, t.bearings)
        np.testing.assert_allclose(s.pose, t.pose, rtol=0, atol=pose_atol)
        assert s.timestamp == t.timestamp and s.max_range == t.max_range


@pytest.fixture(scope="module")
def scans():
    return room_scans()


@pytest.fixture(scope="module")
def csv_scans(scans, tmp_path_factory):
    p = tmp_path_factory.mktemp("csv") / "room.csv"
    write_csv(p, scans)
    return read_csv(p)


# ------------------------------------------------------------------------- same scans, same map


@pytest.mark.parametrize("ros1, storage, name", [(True, None, "room.bag"), (False, "sqlite3", "room2"),
                                                 (False, "mcap", "room2mcap")])
def test_bag_with_odometry_reads_as_the_same_scans_as_csv(tmp_path, scans, csv_scans, ros1, storage, name):
    assert (csv_scans[0].ranges == 8.0).any()  # some beams have no return
    path = bag_of(tmp_path / name, scans, ros1, storage or "sqlite3")
    report = ReadReport()
    got = read_rosbag(path, report=report)
    same_scans(got, csv_scans)  # bit for bit
    assert report.scans == len(scans) and report.max_range == 8.0 and report.skipped == 0
    assert any("odometry /odom" in n for n in report.notes)
    assert any("not in tf" in n for n in report.notes)  # the laser frame was taken to be base_link


def test_bag_gives_the_same_map_as_csv(tmp_path, csv_scans, scans):
    got = read_scans(bag_of(tmp_path / "room.bag", scans))  # through the format dispatch
    a, b = build_map(got), build_map(csv_scans)
    assert a.crisp.equals_exactly(b.crisp)
    assert a.crisp.area > 30


def test_bag_with_tf_and_a_mounted_laser(tmp_path, scans, csv_scans):
    path = bag_of(tmp_path / "tf.bag", scans, poses="tf", mount=(0.25, -0.1, 0.3))
    report = ReadReport()
    got = read_rosbag(path, report=report)
    same_scans(got, csv_scans, pose_atol=1e-12)
    assert any("tf (odom <- base_link <- laser)" in n for n in report.notes)
    a, b = build_map(got), build_map(csv_scans)
    assert len(a.crisp.rings) == len(b.crisp.rings)
    for ra, rb in zip(a.crisp.rings, b.crisp.rings):
        np.testing.assert_allclose(ra.vertices, rb.vertices, atol=1e-9)
    # ROS 2 reads the same
    same_scans(read_rosbag(bag_of(tmp_path / "tf2", scans, ros1=False, poses="tf", mount=(0.25, -0.1, 0.3))),
               csv_scans, pose_atol=1e-12)


def test_odometry_is_interpolated_between_samples(tmp_path):
    b = Bag(tmp_path / "i.bag")
    b.odom(10.0, 0.0, 0.0, 3.0)
    b.odom(11.0, 2.0, 4.0, -3.0)  # through ±π: the short way round
    b.scan(10.25, [1.0, 2.0, 3.0])
    b.close()
    (s,) = read_rosbag(tmp_path / "i.bag")
    np.testing.assert_allclose(s.pose[:2], [0.5, 1.0])
    step = (2 * math.pi - 6.0) / 4
    assert math.isclose(s.pose[2], 3.0 + step, abs_tol=1e-9)


def test_upside_down_laser_is_mirrored(tmp_path, scans):
    # laser mounted under the robot (roll 180°): its beams sweep clockwise in the world
    s0 = scans[0]
    b = Bag(tmp_path / "flip.bag")
    b.tf(s0.timestamp, "base_link", "laser", 0.0, 0.0, 0.0, roll=math.pi, static=True)
    b.tf(s0.timestamp, "odom", "base_link", *s0.pose)
    # in the flipped frame the beam at world bearing +b has angle -b: list them from -b_max up
    b.scan(s0.timestamp, s0.ranges[::-1], angle_min=-float(BEARINGS[-1]))
    b.close()
    (s,) = read_rosbag(tmp_path / "flip.bag")
    np.testing.assert_allclose(s.endpoints(), s0.endpoints(), atol=1e-5)


def test_special_ranges_mean_no_return(tmp_path):
    b = Bag(tmp_path / "r.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.scan(1.0, [1.0, np.inf, -np.inf, np.nan, 9.5, 0.05, 2.0], range_min=0.1, range_max=8.0)
    b.close()
    (s,) = read_rosbag(tmp_path / "r.bag")
    assert s.max_range == 8.0
    np.testing.assert_array_equal(s.ranges, [1.0, 8.0, 8.0, 8.0, 8.0, 8.0, 2.0])
    np.testing.assert_array_equal(s.returns, [True, False, False, False, False, False, True])
    (s,) = read_rosbag(tmp_path / "r.bag", max_range=1.5)  # the caller's maximum wins
    assert s.max_range == 1.5 and s.returns.tolist() == [True] + [False] * 6


def test_clockwise_scan_is_turned_round(tmp_path):
    b = Bag(tmp_path / "cw.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.scan(1.0, [1.0, 2.0, 3.0], angle_min=0.5, inc=-0.25)
    b.close()
    (s,) = read_rosbag(tmp_path / "cw.bag")
    np.testing.assert_allclose(s.bearings, [0.0, 0.25, 0.5])
    np.testing.assert_array_equal(s.ranges, [3.0, 2.0, 1.0])


@pytest.mark.parametrize("storage, ext", [("sqlite3", "db3"), ("mcap", "mcap")])
def test_ros2_storage_file_reads_its_whole_bag(tmp_path, scans, csv_scans, storage, ext):
    path = bag_of(tmp_path / "r2", scans, ros1=False, storage=storage)
    (db,) = path.glob(f"*.{ext}")
    same_scans(read_scans(db), csv_scans)
    # and its metadata.yaml, what `ros2 bag info` shows (before: read as a CARMEN log, "no FLASER scans")
    same_scans(read_scans(path / "metadata.yaml"), csv_scans)


def test_ros1_bag_under_another_name_is_recognised_as_a_bag(tmp_path, scans, capsys):
    # `rosbag record` writes run.bag.active until it stops; before, any name but .bag was read as
    # a CARMEN log ("no FLASER scans in this file"), and with --format rosbag rosbags said
    # "Unrecognized storage format '.active'". It reads ROS 1 bags named .bag only: say so
    path = bag_of(tmp_path / "run.bag", scans)
    active = tmp_path / "run.bag.active"
    shutil.copy(path, active)
    with pytest.raises(ScanFormatError, match=r"run.bag.active: a ROS 1 bag, but one not named \.bag.*link it as "
                                              r"run\.bag\.active\.bag"):
        read_scans(active)
    assert cli.main(["build", str(active), "--out", str(tmp_path / "m.json"), "--format", "rosbag"]) == 2
    assert "a ROS 1 bag, but one not named .bag" in capsys.readouterr().err


def test_build_and_grid_commands_read_bags(tmp_path, scans, capsys):
    path = bag_of(tmp_path / "room.bag", scans)
    assert cli.main(["build", str(path), "--out", str(tmp_path / "m.json"), "--quiet", "--scan-topic", "/scan"]) == 0
    assert read_map(tmp_path / "m.json").crisp.area > 30
    assert cli.main(["grid", str(path), "--out", str(tmp_path / "g"), "--odom-topic", "/odom"]) == 0
    assert "poses from odometry /odom" in capsys.readouterr().out
    assert (tmp_path / "g" / "room.pgm").is_file() and (tmp_path / "g" / "room.yaml").is_file()  # the bag's name


def test_build_and_evaluate_say_where_the_poses_came_from(tmp_path, scans, capsys):
    # before: only grid printed the reader's notes; build and evaluate took the laser to sit on
    # base_link (the bag has no tf) without a word
    path = bag_of(tmp_path / "room.bag", scans)
    assumed = "note: laser frame 'laser' is not in tf: taken to sit on odometry's frame 'base_link'"
    source = "note: laser: poses from odometry /odom (odom -> base_link)"
    assert cli.main(["build", str(path), "--out", str(tmp_path / "m.json")]) == 0
    err = capsys.readouterr().err
    assert assumed in err and source in err
    assert cli.main(["evaluate", str(path), "--json"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["scans_used"] == 4 and assumed in err and source in err
    assert cli.main(["build", str(path), "--out", str(tmp_path / "m.json"), "--quiet"]) == 0
    assert capsys.readouterr().err == ""


# ------------------------------------------------------------------------- bad bags


def test_bag_without_laser_scans(tmp_path):
    b = Bag(tmp_path / "o.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.close()
    with pytest.raises(ScanFormatError, match=r"no sensor_msgs/LaserScan topic in this bag \(topics: /odom \[nav_msgs/msg/Odometry\]\)"):
        read_rosbag(tmp_path / "o.bag")


def test_two_scan_topics_need_a_choice(tmp_path):
    b = Bag(tmp_path / "two.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.scan(1.0, [1.0, 2.0], topic="/front")
    b.scan(1.0, [3.0, 4.0, 5.0], topic="/rear")
    b.close()
    with pytest.raises(ScanFormatError, match=r"2 sensor_msgs/LaserScan topics \(/front, /rear\): choose one with scan_topic \(--scan-topic\)"):
        read_rosbag(tmp_path / "two.bag")
    (s,) = read_rosbag(tmp_path / "two.bag", scan_topic="/rear")
    assert s.ranges.tolist() == [3.0, 4.0, 5.0]
    with pytest.raises(ScanFormatError, match=r"no topic '/side'.*\(sensor_msgs/LaserScan topics: /front, /rear\)"):
        read_rosbag(tmp_path / "two.bag", scan_topic="/side")
    with pytest.raises(ScanFormatError, match="topic /odom is nav_msgs/msg/Odometry, not sensor_msgs/LaserScan"):
        read_rosbag(tmp_path / "two.bag", scan_topic="/odom")
    assert cli.main(["build", str(tmp_path / "two.bag"), "--out", str(tmp_path / "m.json"), "--quiet"]) == 2


def test_negative_range_names_bag_topic_message_and_beam(tmp_path):
    b = Bag(tmp_path / "neg.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.odom(2.0, 1.0, 0.0, 0.0)
    b.scan(1.0, [1.0, 2.0, 3.0])
    b.scan(1.5, [1.0, -0.5, 3.0])
    b.scan(2.0, [1.0, 2.0, 3.0])
    b.close()
    with pytest.raises(BagValueError, match=r"neg.bag, topic /scan, message 1, field ranges\[1\]: range -0.5 is negative") as e:
        read_rosbag(tmp_path / "neg.bag")
    assert (e.value.topic, e.value.index, e.value.field) == ("/scan", 1, "ranges[1]")
    report = ReadReport()
    got = read_rosbag(tmp_path / "neg.bag", skip_bad=True, report=report)
    assert [s.timestamp for s in got] == [1.0, 2.0]
    assert report.skipped == 1 and isinstance(report.errors[0], BagValueError)


def test_scan_outside_the_odometry_is_refused_or_skipped(tmp_path):
    b = Bag(tmp_path / "late.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.odom(2.0, 1.0, 0.0, 0.0)
    b.scan(1.5, [1.0, 2.0])
    b.scan(5.0, [1.0, 2.0])
    b.close()
    with pytest.raises(BagMessageError, match=r"message 1: no pose at t = 5.000000 s: /odom odom -> base_link spans 1.000000 .. 2.000000 s"):
        read_rosbag(tmp_path / "late.bag")
    report = ReadReport()
    assert len(read_rosbag(tmp_path / "late.bag", skip_bad=True, report=report)) == 1 and report.skipped == 1
    assert len(read_rosbag(tmp_path / "late.bag", pose_tolerance=5.0)) == 2


def test_no_pose_source_and_ambiguous_odometry(tmp_path):
    b = Bag(tmp_path / "np.bag")
    b.scan(1.0, [1.0, 2.0])
    b.close()
    with pytest.raises(ScanFormatError, match="no pose for laser frame 'laser': no nav_msgs/Odometry topic"):
        read_rosbag(tmp_path / "np.bag")
    b = Bag(tmp_path / "two_odom.bag")
    b.odom(1.0, 0.0, 0.0, 0.0, topic="/odom")
    b.odom(1.0, 5.0, 0.0, 0.0, topic="/odom_filtered")
    b.scan(1.0, [1.0, 2.0])
    b.close()
    with pytest.raises(ScanFormatError, match=r"2 nav_msgs/Odometry topics \(/odom, /odom_filtered\).*--odom-topic"):
        read_rosbag(tmp_path / "two_odom.bag")
    (s,) = read_rosbag(tmp_path / "two_odom.bag", odom_topic="/odom_filtered")
    assert s.pose[0] == 5.0


def test_tf_is_ignored_when_asked_and_odometry_wins_when_named(tmp_path, scans):
    path = bag_of(tmp_path / "tf.bag", scans[:2], poses="tf", mount=(0.5, 0.0, 0.0))
    with pytest.raises(ScanFormatError, match="no nav_msgs/Odometry topic, and tf is absent or not read"):
        read_rosbag(path, tf=False)
    # tf and odometry disagree about base_link: tf by default, odometry when named (mount kept)
    b = Bag(tmp_path / "both.bag")
    b.tf(1.0, "base_link", "laser", 0.5, 0.0, 0.0, static=True)
    b.tf(1.0, "odom", "base_link", 1.0, 0.0, 0.0)
    b.odom(1.0, 3.0, 0.0, 0.0)
    b.scan(1.0, [1.0, 2.0])
    b.close()
    assert read_rosbag(tmp_path / "both.bag")[0].pose[0] == 1.5
    assert read_rosbag(tmp_path / "both.bag", odom_topic="/odom")[0].pose[0] == 3.5
    assert read_rosbag(tmp_path / "both.bag", tf=False)[0].pose[0] == 3.0
    with pytest.raises(ScanFormatError, match="not connected to fixed frame 'map'"):
        read_rosbag(tmp_path / "both.bag", fixed_frame="map")
    assert read_rosbag(tmp_path / "both.bag", fixed_frame="odom")[0].pose[0] == 1.5


@pytest.mark.parametrize("damage", ["truncate", "garbage", "empty"])
def test_unreadable_bag_files(tmp_path, scans, damage):
    path = bag_of(tmp_path / "room.bag", scans)
    data = path.read_bytes()
    bad = tmp_path / "bad.bag"
    bad.write_bytes({"truncate": data[: len(data) // 2], "garbage": b"not a bag at all\n" * 50, "empty": b""}[damage])
    with pytest.raises(ScanFormatError, match="bad.bag: cannot read as a ROS bag") as e:
        read_rosbag(bad)
    # a bag cut off while recording has no index: say how to repair it
    assert ("`rosbag reindex` may repair it" in str(e.value)) == (damage == "truncate")
    assert cli.main(["build", str(bad), "--out", str(tmp_path / "m.json"), "--quiet"]) == 2


def test_damaged_ros2_bag_and_folder_that_is_not_a_bag(tmp_path, scans):
    (tmp_path / "plain").mkdir()
    with pytest.raises(ScanFormatError, match="not a ROS 2 bag \\(no metadata.yaml"):
        read_scans(tmp_path / "plain")
    path = bag_of(tmp_path / "r2", scans, ros1=False)
    (db,) = path.glob("*.db3")
    db.write_bytes(db.read_bytes()[:3000])
    with pytest.raises(ScanFormatError, match="r2"):
        read_rosbag(path)
    shutil.rmtree(path)


def test_bag_with_broken_metadata_is_one_line(tmp_path, scans, capsys):
    path = bag_of(tmp_path / "r2", scans[:2], ros1=False)
    (path / "metadata.yaml").write_text("rosbag2_bagfile_information: [\n")
    with pytest.raises(ScanFormatError, match="r2: cannot read as a ROS bag: .*metadata.yaml") as e:
        read_rosbag(path)
    assert "\n" not in str(e.value)
    assert cli.main(["build", str(path), "--out", str(tmp_path / "m.json"), "--quiet"]) == 2
    assert capsys.readouterr().err.count("\n") == 1


# ------------------------------------------------------------------------- poses: tf and odometry in detail


def test_quaternions_that_are_not_unit_give_the_same_heading_and_zero_is_refused(tmp_path):
    b = Bag(tmp_path / "q.bag")
    b.odom(1.0, 0.0, 0.0, 0.0, q=tuple(3.0 * c for c in quat(1.0)))  # a rotation, scaled
    b.odom(2.0, 0.0, 0.0, 0.0, q=(0.0, 0.0, 0.0, 0.0))  # no rotation at all
    b.scan(1.0, [1.0, 2.0])
    b.close()
    with pytest.raises(BagMessageError, match=r"q.bag, topic /odom, message 1: quaternion \(0.0, 0.0, 0.0, 0.0\) has no "
                                              r"rotation") as e:
        read_rosbag(tmp_path / "q.bag")
    assert (e.value.topic, e.value.index) == ("/odom", 1)
    report = ReadReport()
    (s,) = read_rosbag(tmp_path / "q.bag", skip_bad=True, report=report)
    assert report.skipped == 1 and math.isclose(s.pose[2], 1.0, abs_tol=1e-12)


def test_frame_turned_upside_down_mirrors_what_hangs_below_it(tmp_path):
    """odom -> base_link (1, 2, 0) -> plate (rolled 180°: its y and z point the other way) -> laser at
    (0, 0.2) in the plate, turned 0.3 rad about the plate's z (down). A beam at angle a reaching r
    ends at plate (r cos(a + 0.3), 0.2 + r sin(a + 0.3)), which is base_link (x, -y)."""
    b = Bag(tmp_path / "m.bag")
    b.tf(1.0, "base_link", "plate", 0.0, 0.0, 0.0, roll=math.pi, static=True)
    b.tf(1.0, "plate", "laser", 0.0, 0.2, 0.3, static=True)
    b.tf(1.0, "odom", "base_link", 1.0, 2.0, 0.0)
    r = np.array([1.0, 2.0, 3.0, 1.5, 2.5])
    b.scan(1.0, r, angle_min=-0.5, inc=0.25)
    b.close()
    (s,) = read_rosbag(tmp_path / "m.bag")
    a = -0.5 + 0.25 * np.arange(5) + 0.3
    want = np.column_stack((1.0 + r * np.cos(a), 2.0 - (0.2 + r * np.sin(a))))
    got = s.endpoints()[np.argsort(-s.bearings)]  # mirrored: the beams come out in the other order
    np.testing.assert_allclose(got, want, atol=1e-6)


def test_latest_static_transform_and_last_sample_of_a_stamp_are_in_force(tmp_path):
    b = Bag(tmp_path / "s.bag")
    b.tf(1.0, "base_link", "laser", 0.5, 0.0, 0.0, static=True)
    b.tf(1.5, "base_link", "laser", 0.25, 0.0, 0.0, static=True)  # the laser was moved: this one holds
    b.odom(2.0, 3.0, 0.0, 0.0)
    b.odom(2.0, 4.0, 0.0, 0.0)  # the same stamp again: a correction, received last
    b.scan(2.0, [1.0, 2.0])
    b.close()
    (s,) = read_rosbag(tmp_path / "s.bag")
    assert s.pose.tolist() == [4.25, 0.0, 0.0]


def test_odometry_and_static_tf_place_the_laser_together(tmp_path):
    # tf knows only where the laser is mounted (static): the motion comes from odometry
    b = Bag(tmp_path / "o.bag")
    b.tf(1.0, "base_link", "laser", 0.5, 0.0, 0.0, static=True)
    b.odom(1.0, 3.0, 1.0, math.pi / 2)
    b.scan(1.0, [1.0, 2.0])
    b.close()
    report = ReadReport()
    (s,) = read_rosbag(tmp_path / "o.bag", report=report)
    np.testing.assert_allclose(s.pose, [3.0, 1.5, math.pi / 2], atol=1e-12)
    assert any("odometry /odom (odom -> base_link) and tf to laser" in n for n in report.notes)


def test_odometry_places_a_laser_whose_mount_is_republished_on_tf(tmp_path):
    # ROS 1's tf static_transform_publisher sends base_link -> laser on /tf every 100 ms: a
    # moving edge of tf that places the laser on the robot, not the robot in the world. Before,
    # "tf moves the laser frame" chose tf alone and every scan sat at the mount, 0.5 m from base_link
    b = Bag(tmp_path / "m.bag")
    for k in range(31):
        b.tf(0.9 + 0.1 * k, "base_link", "laser", 0.5, 0.0, 0.0)
    b.odom(1.0, 3.0, 1.0, math.pi / 2)
    b.odom(3.0, 5.0, 1.0, 0.0)
    b.scan(1.0, [1.0, 2.0])
    b.scan(3.0, [1.0, 2.0])
    b.close()
    report = ReadReport()
    s1, s2 = read_rosbag(tmp_path / "m.bag", report=report)
    np.testing.assert_allclose(s1.pose, [3.0, 1.5, math.pi / 2], atol=1e-12)
    np.testing.assert_allclose(s2.pose, [5.5, 1.0, 0.0], atol=1e-12)
    assert any("odometry /odom (odom -> base_link) and tf to laser" in n for n in report.notes)


def test_frame_ids_with_a_leading_slash_and_a_stamp_of_zero(tmp_path):
    # ROS 1 frame ids may start with "/"; a header stamp of zero means "not stamped": the record time
    b = Bag(tmp_path / "z.bag")
    b.tf(5.0, "/odom", "/base_link", 0.0, 0.0, 0.0)
    b.tf(6.0, "odom", "base_link", 2.0, 0.0, 0.0)
    b.tf(5.0, "base_link", "/laser", 0.0, 1.0, 0.0, static=True)
    b.scan(5.5, [1.0, 2.0], frame="/laser", stamp=0.0)
    b.close()
    (s,) = read_rosbag(tmp_path / "z.bag")
    assert s.timestamp == 5.5 and s.pose.tolist() == [1.0, 1.0, 0.0]


def test_pose_tolerance_applies_before_the_first_pose_too(tmp_path):
    b = Bag(tmp_path / "e.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.odom(2.0, 1.0, 0.0, 0.0)
    b.scan(0.5, [1.0, 2.0])
    b.scan(0.95, [1.0, 2.0])  # 50 ms early: within the 0.1 s tolerance, at the first pose
    b.close()
    with pytest.raises(BagMessageError, match=r"message 0: no pose at t = 0.500000 s"):
        read_rosbag(tmp_path / "e.bag")
    (s,) = read_rosbag(tmp_path / "e.bag", skip_bad=True)
    assert math.isclose(s.timestamp, 0.95) and s.pose.tolist() == [0.0, 0.0, 0.0]


def test_poses_in_a_fixed_frame_below_the_root(tmp_path):
    b = Bag(tmp_path / "f.bag")
    b.tf(1.0, "map", "odom", 10.0, 0.0, 0.0)
    b.tf(1.0, "odom", "base_link", 1.0, 0.0, 0.0)
    b.tf(1.0, "base_link", "laser", 0.0, 0.0, 0.0, static=True)
    b.scan(1.0, [1.0, 2.0])
    b.close()
    assert read_rosbag(tmp_path / "f.bag")[0].pose[0] == 11.0
    assert read_rosbag(tmp_path / "f.bag", fixed_frame="odom")[0].pose[0] == 1.0


def test_the_missing_transform_is_the_one_named(tmp_path):
    # map -> odom is known only until 2 s; odom -> base_link until 10 s: at 5 s the first is missing
    b = Bag(tmp_path / "g.bag")
    b.tf(1.0, "base_link", "laser", 0.0, 0.0, 0.0, static=True)
    for t in (1.0, 2.0):
        b.tf(t, "map", "odom", 0.0, 0.0, 0.0)
    for t in (1.0, 10.0):
        b.tf(t, "odom", "base_link", t, 0.0, 0.0)
    b.scan(5.0, [1.0, 2.0])
    b.close()
    with pytest.raises(BagMessageError, match=r"no pose at t = 5.000000 s: /tf map -> odom spans 1.000000 .. 2.000000 s"):
        read_rosbag(tmp_path / "g.bag")


# ------------------------------------------------------------------------- ranges and bearings


def test_range_limits_are_inclusive_and_no_return_is_the_callers_maximum(tmp_path):
    # LaserScan: values < range_min or > range_max are to be discarded; range_min and range_max
    # themselves are measurements
    b = Bag(tmp_path / "r.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.scan(1.0, [0.1, 8.0, 9.5, np.inf, 0.05, 2.0], range_min=0.1, range_max=8.0)
    b.close()
    (s,) = read_rosbag(tmp_path / "r.bag", max_range=10.0)
    assert s.returns.tolist() == [True, True, False, False, False, True]
    assert s.ranges[~s.returns].tolist() == [10.0] * 3  # no return: at the maximum in force


def test_a_full_turn_with_both_ends_keeps_one_of_them(tmp_path):
    b = Bag(tmp_path / "t.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.scan(1.0, [1.0, 2.0, 3.0, 4.0, 5.0], angle_min=-math.pi, inc=math.pi / 2)  # -180° .. +180°
    b.close()
    (s,) = read_rosbag(tmp_path / "t.bag")
    assert s.ranges.tolist() == [1.0, 2.0, 3.0, 4.0] and s.full_circle


@pytest.mark.parametrize("kw, field, words", [
    (dict(ranges=[]), "ranges", "no ranges"),
    (dict(ranges=[1.0, 2.0, 3.0], inc=0.0), "angle_increment", "angle_min -1.5707963705062866, angle_increment 0.0 give no bearings"),
    (dict(ranges=[1.0, 2.0], range_max=np.inf), "range_max", "range_max is inf: give max_range (--max-range)"),
])
def test_laser_scans_that_cannot_be_read(tmp_path, kw, field, words):
    b = Bag(tmp_path / "l.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.scan(1.0, [1.0, 2.0])
    b.scan(1.0, **kw)
    b.close()
    with pytest.raises(BagMessageError) as e:
        read_rosbag(tmp_path / "l.bag")
    assert str(e.value) == f"{tmp_path / 'l.bag'}, topic /scan, message 1, field {field}: {words}"
    report = ReadReport()
    assert len(read_rosbag(tmp_path / "l.bag", skip_bad=True, report=report)) == 1 and report.skipped == 1


def test_undecodable_message_and_impossible_pose_are_named_or_skipped(tmp_path):
    b = Bag(tmp_path / "d.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.odom(2.0, 1.0, 0.0, 0.0)
    b.odom(3.0, float("nan"), 0.0, 0.0)
    b.scan(1.0, [1.0, 2.0])
    b.raw(1.5, "/scan", LASER, b"\x01\x02\x03")
    b.scan(2.5, [1.0, 2.0])  # between a pose and a NaN one
    b.close()
    with pytest.raises(BagMessageError, match=r"topic /scan, message 1: cannot decode sensor_msgs/msg/LaserScan"):
        read_rosbag(tmp_path / "d.bag")
    report = ReadReport()
    (s,) = read_rosbag(tmp_path / "d.bag", skip_bad=True, report=report)
    # the NaN pose is named where it is (issue 36 item 9; before: on the scan placed with it), and
    # the scan after the last good pose has none
    assert s.timestamp == 1.0 and report.skipped == 3
    assert report.errors[1].topic == "/odom" and report.errors[1].index == 2
    assert str(report.errors[1]).endswith("position (nan, 0.0) is not finite")
    assert report.errors[2].topic == "/scan" and "no pose at t = 2.5" in str(report.errors[2])


# ------------------------------------------------------------------------- bad options and trees


def test_bad_max_range_and_odometry_topic(tmp_path):
    b = Bag(tmp_path / "o.bag")
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.scan(1.0, [1.0, 2.0])
    b.close()
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="max_range must be positive"):
            read_rosbag(tmp_path / "o.bag", max_range=bad)
    with pytest.raises(ScanFormatError, match=r"no topic '/odm' in this bag \(nav_msgs/Odometry topics: /odom\)"):
        read_rosbag(tmp_path / "o.bag", odom_topic="/odm")


def test_odometry_that_cannot_place_the_laser(tmp_path):
    b = Bag(tmp_path / "mix.bag")
    b.odom(1.0, 0.0, 0.0, 0.0, child="base_link")
    b.odom(2.0, 0.0, 0.0, 0.0, child="base_footprint")
    b.scan(1.0, [1.0, 2.0])
    b.close()
    with pytest.raises(ScanFormatError, match=r"odometry topic /odom mixes frames \[\('odom', 'base_footprint'\), "
                                              r"\('odom', 'base_link'\)\]"):
        read_rosbag(tmp_path / "mix.bag")
    b = Bag(tmp_path / "none.bag")
    b.odom(1.0, 0.0, 0.0, 0.0, q=(0.0, 0.0, 0.0, 0.0))
    b.scan(1.0, [1.0, 2.0])
    b.close()
    with pytest.raises(ScanFormatError, match="no usable message on odometry topic /odom"):
        read_rosbag(tmp_path / "none.bag", skip_bad=True)
    b = Bag(tmp_path / "apart.bag")
    b.tf(1.0, "mount", "laser", 0.5, 0.0, 0.0, static=True)  # tf knows the laser, but not on base_link
    b.odom(1.0, 0.0, 0.0, 0.0)
    b.scan(1.0, [1.0, 2.0])
    b.close()
    with pytest.raises(ScanFormatError, match="laser frame 'laser' is not connected to odometry's frame 'base_link' in tf"):
        read_rosbag(tmp_path / "apart.bag")


@pytest.mark.parametrize("edges, words", [
    ([("odom", "base_link"), ("map", "base_link")], "tf frame 'base_link' has two parents: 'odom' and 'map'"),
    ([("a", "b"), ("b", "a"), ("b", "laser")], "tf has a loop through frame 'b'"),
])
def test_tf_trees_that_are_not_trees(tmp_path, edges, words):
    b = Bag(tmp_path / "t.bag")
    for parent, child in edges:
        b.tf(1.0, parent, child, 0.0, 0.0, 0.0)
    b.scan(1.0, [1.0, 2.0])
    b.close()
    with pytest.raises(ScanFormatError, match=words):
        read_rosbag(tmp_path / "t.bag")
