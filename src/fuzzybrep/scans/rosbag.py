"""ROS bags: ``sensor_msgs/LaserScan`` with poses from ``nav_msgs/Odometry`` or tf.

Reads ROS 1 bags (``.bag``) and ROS 2 bags (a folder holding ``metadata.yaml`` and ``.db3`` or
``.mcap`` files, or one such file) through the ``rosbags`` library, without a ROS installation.

Each LaserScan becomes one Scan:

* bearings ``angle_min + i * angle_increment`` (a negative increment is turned round so that
  bearings increase; beams beyond a full turn are dropped);
* ranges as recorded, except that a beam with no usable return gets the scan's ``max_range``
  ("no return": unknown, not an obstacle). REP 117: ``+inf`` means nothing within range_max,
  ``-inf`` an object too close to measure, ``NaN`` an invalid measurement; the LaserScan message
  says values outside [range_min, range_max] are to be discarded. None of these places an obstacle,
  so all are no return. A finite negative range is an error (``BagValueError``);
* ``max_range`` is the message's ``range_max`` unless the caller gives one;
* the timestamp is the header stamp (the bag's record time if the stamp is zero);
* the pose is the laser frame's (header.frame_id) pose in the fixed frame at that time.

Poses come from the tf tree (``tf2_msgs/TFMessage`` on /tf and /tf_static), from an odometry
topic, or both: odometry is one more moving transform, odom -> base_link. The laser's pose is the
chain of transforms from its frame up to the root of the tree (map or odom), each moving one
interpolated linearly at the scan's time, static ones as they are. Transforms are projected to
the plane (x, y, yaw); a frame turned upside down (a laser mounted below the robot, roll 180°)
mirrors the scan, which is taken into account. A scan more than ``pose_tolerance`` seconds
outside the span of a moving transform has no pose.

Topics are chosen automatically when there is exactly one candidate; otherwise the caller names
one and the error lists the candidates. Without ``odom_topic``, tf is used when it moves the
laser frame and reaches above the robot (a chain that stops at odometry's child frame only says
where the laser sits on the robot); otherwise the single odometry topic. A laser frame the tf
tree does not know is taken to sit on the odometry's child frame (noted in the report).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import BagMessageError, BagValueError, FuzzyBrepError, ScanFormatError
from .report import ReadReport, first_bytes
from .scan import Scan

LASER_SCAN = "sensor_msgs/msg/LaserScan"
ODOMETRY = "nav_msgs/msg/Odometry"
TF_MESSAGES = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")
TWO_PI = 2 * math.pi


# ---------------------------------------------------------------------------- planar transforms


def wrap(a):
    """Angle(s) into [-π, π]; exactly the input when it is already there."""
    return a - TWO_PI * np.round(np.asarray(a) / TWO_PI)


def planar(qx: float, qy: float, qz: float, qw: float) -> tuple[float, int]:
    """(yaw, mirror) of a quaternion projected to the plane: yaw of the x axis, and -1 when the
    frame's z axis points down (the plane is seen from below), else 1."""
    n2 = qx * qx + qy * qy + qz * qz + qw * qw
    if not (n2 > 1e-12 and math.isfinite(n2)):
        raise ValueError(f"quaternion ({qx}, {qy}, {qz}, {qw}) has no rotation (zero or not finite)")
    if abs(n2 - 1.0) > 1e-9:  # only renormalise when needed, so unit quaternions convert exactly
        s = 1.0 / math.sqrt(n2)
        qx, qy, qz, qw = qx * s, qy * s, qz * s, qw * s
    yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    mirror = -1 if 1.0 - 2.0 * (qx * qx + qy * qy) < 0 else 1
    return yaw, mirror


def _finite(x: float, y: float, what: str) -> None:
    """ValueError naming ``what`` and the values as given when x or y is not finite: refused where
    it is read, since interpolated (inf − inf) it became a NumPy warning and a pose of NaN."""
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"{what} ({x!r}, {y!r}) is not finite")


def compose(a: tuple, b: tuple) -> tuple:
    """a ∘ b of planar transforms (x, y, yaw, mirror), each an array over scans."""
    xa, ya, ta, sa = a
    xb, yb, tb, sb = b
    yb = sa * yb
    c, s = np.cos(ta), np.sin(ta)
    return xa + (c * xb - s * yb), ya + (s * xb + c * yb), ta + sa * tb, sa * sb


@dataclass
class Track:
    """The transform parent -> child over time: a moving tf edge or an odometry stream (static: one sample)."""

    parent: str
    child: str
    source: str  # topic it came from
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    mirror: np.ndarray
    static: bool = False

    @classmethod
    def of(cls, parent, child, source, samples: list[tuple], static: bool = False) -> "Track":
        a = np.array(samples, dtype=np.float64).reshape(-1, 5)
        a = a[np.argsort(a[:, 0], kind="stable")]
        if static:
            a = a[-1:]  # the latest static transform is the one in force
        else:  # of samples with one stamp, the last one received
            a = a[np.r_[a[1:, 0] != a[:-1, 0], True]]
        return cls(parent, child, source, a[:, 0], a[:, 1], a[:, 2], a[:, 3], a[:, 4], static)

    def at(self, ts: np.ndarray, tolerance: float) -> tuple[tuple, np.ndarray]:
        """((x, y, yaw, mirror) at times ts, known) interpolating linearly; ``known`` is False more
        than ``tolerance`` seconds outside the samples' span."""
        n = len(ts)
        if self.static:
            return tuple(np.full(n, v[0]) for v in (self.x, self.y, self.yaw, self.mirror)), np.ones(n, bool)
        j = np.clip(np.searchsorted(self.t, ts, side="right") - 1, 0, len(self.t) - 1)
        k = np.minimum(j + 1, len(self.t) - 1)
        dt = self.t[k] - self.t[j]
        with np.errstate(invalid="ignore", divide="ignore"):
            f = np.clip(np.where(dt > 0, (ts - self.t[j]) / dt, 0.0), 0.0, 1.0)
        # at a sample's own time f = 0 and the sample comes out bit for bit
        x = self.x[j] + f * (self.x[k] - self.x[j])
        y = self.y[j] + f * (self.y[k] - self.y[j])
        yaw = wrap(self.yaw[j] + f * wrap(self.yaw[k] - self.yaw[j]))
        known = (ts >= self.t[0] - tolerance) & (ts <= self.t[-1] + tolerance)
        return (x, y, yaw, self.mirror[j]), known


# ---------------------------------------------------------------------------- reading


@dataclass
class _RawScan:
    index: int  # on its topic, from 0
    stamp: float
    frame: str
    ranges: np.ndarray
    bearings: np.ndarray
    max_range: float


def _frame(name: str) -> str:
    return name.lstrip("/")  # ROS 1 frame ids may carry a leading slash


def _stamp(header, bag_ns: int) -> float:
    s = header.stamp.sec + header.stamp.nanosec * 1e-9
    return s if s != 0 else bag_ns * 1e-9


def _bag_paths(path: Path) -> list[Path]:
    if path.is_dir():
        if not (path / "metadata.yaml").is_file():
            raise ScanFormatError(path, None, "a folder, but not a ROS 2 bag (no metadata.yaml in it)")
        return [path]
    if (path.suffix in (".db3", ".mcap") or path.name == "metadata.yaml") and (path.parent / "metadata.yaml").is_file():
        return [path.parent]  # one file of a ROS 2 bag: read the whole bag, split files included
    return [path]


def _open(path: Path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    paths = _bag_paths(path)
    if paths[0].is_file() and paths[0].suffix != ".bag" and first_bytes(paths[0]).startswith(b"#ROSBAG V"):
        # rosbags tells ROS 1 from ROS 2 by the suffix alone ("Unrecognized storage format '.active'")
        raise ScanFormatError(path, None, "a ROS 1 bag, but one not named .bag, which the bag reader needs: "
                                          f"rename it, or link it as {paths[0].name}.bag")
    # a ROS 2 bag from before Iron stores no message definitions: read it with the standard ones
    store = get_typestore(Stores.ROS1_NOETIC if paths[0].suffix == ".bag" else Stores.ROS2_HUMBLE)
    return AnyReader(paths, default_typestore=store)


def _describe(topics: dict[str, str], kinds=None) -> str:
    items = [f"{t} [{ty}]" for t, ty in sorted(topics.items()) if kinds is None or ty in kinds]
    return ", ".join(items) if items else "none"


def _choose(path, topics: dict[str, str], kind: str, wanted: str | None, option: str) -> str:
    """The one topic of type ``kind``, or the one named; errors list the candidates."""
    cands = sorted(t for t, ty in topics.items() if ty == kind)
    short = kind.replace("/msg/", "/")
    if wanted is not None:
        if wanted not in topics:
            raise ScanFormatError(path, None, f"no topic {wanted!r} in this bag ({short} topics: {', '.join(cands) or 'none'})")
        if topics[wanted] != kind:
            raise ScanFormatError(path, None, f"topic {wanted} is {topics[wanted]}, not {short}")
        return wanted
    if not cands:
        raise ScanFormatError(path, None, f"no {short} topic in this bag (topics: {_describe(topics)})")
    if len(cands) > 1:
        raise ScanFormatError(path, None, f"{len(cands)} {short} topics ({', '.join(cands)}): choose one with {option}")
    return cands[0]


def read_rosbag(
    path: str | os.PathLike,
    scan_topic: str | None = None,
    odom_topic: str | None = None,
    tf: bool = True,
    max_range: float | None = None,
    skip_bad: bool = False,
    report: ReadReport | None = None,
    fixed_frame: str | None = None,
    pose_tolerance: float = 0.1,
) -> list[Scan]:
    """The LaserScans of a ROS 1 or ROS 2 bag as Scans at their laser poses (see module doc).

    scan_topic / odom_topic  needed only when the bag has more than one candidate.
    tf              read /tf and /tf_static (False: odometry only; the laser sits on its child frame).
    max_range       ranges at or above this mean no return (default: each message's range_max).
    skip_bad        skip unusable messages (counted in ``report``) instead of stopping.
    fixed_frame     the frame poses are given in (default: the root of the tf tree, e.g. map or odom).
    pose_tolerance  seconds a scan may lie outside the span of the poses and still get one.
    """
    path = Path(path)
    report = report if report is not None else ReadReport()
    if max_range is not None and not max_range > 0:
        raise ValueError(f"max_range must be positive, got {max_range!r}")
    try:
        reader = _open(path)
    except FuzzyBrepError:
        raise
    except Exception as e:  # rosbags raises many kinds of error on a damaged file
        raise ScanFormatError(path, None, f"cannot read as a ROS bag: {_reason(e)}") from None
    try:
        with reader:
            return _read(path, reader, scan_topic, odom_topic, tf, max_range, skip_bad, report, fixed_frame,
                         pose_tolerance)
    except FuzzyBrepError:
        raise
    except Exception as e:
        raise ScanFormatError(path, None, f"cannot read as a ROS bag: {_reason(e)}") from None


def _reason(e: Exception) -> str:
    # one line: rosbags passes on the YAML parser's message, which draws the spot over several lines
    text = " ".join(str(e).split()) or "no details"
    if "index" in text.lower():  # a ROS 1 bag cut off while recording has no index at its end
        text += " (if the recording was cut off, `rosbag reindex` may repair it)"
    return f"{type(e).__name__}: {text}"


def _read(path, reader, scan_topic, odom_topic, tf, max_range, skip_bad, report, fixed_frame, tolerance):
    topics = {name: info.msgtype or "?" for name, info in reader.topics.items()}
    scan_topic = _choose(path, topics, LASER_SCAN, scan_topic, "scan_topic (--scan-topic)")
    if odom_topic is not None:
        _choose(path, topics, ODOMETRY, odom_topic, "odom_topic (--odom-topic)")
    odom_cands = [odom_topic] if odom_topic else sorted(t for t, ty in topics.items() if ty == ODOMETRY)
    tf_topics = sorted(t for t, ty in topics.items() if ty in TF_MESSAGES) if tf else []
    wanted = {scan_topic, *odom_cands, *tf_topics}

    def bad(err: BagMessageError) -> None:
        if not skip_bad:
            raise err
        report.skip(err)

    raws: list[_RawScan] = []
    odom: dict[str, dict[tuple[str, str], list]] = {t: {} for t in odom_cands}
    moving: dict[tuple[str, str], list] = {}
    static: dict[tuple[str, str], list] = {}
    counts: dict[str, int] = {}
    conns = [c for c in reader.connections if c.topic in wanted]
    messages = reader.messages(connections=conns)
    while True:
        try:
            item = next(messages, None)
        except Exception as e:  # a damaged file: keep what came before only if asked to skip
            bad(BagMessageError(path, None, None, f"bag is truncated or corrupt after {sum(counts.values())} "
                                                  f"messages ({_reason(e)})"))
            break
        if item is None:
            break
        conn, bag_ns, raw = item
        topic = conn.topic
        index = counts.get(topic, 0)
        counts[topic] = index + 1
        try:
            msg = reader.deserialize(raw, conn.msgtype)
        except Exception as e:
            bad(BagMessageError(path, topic, index, f"cannot decode {conn.msgtype}: {_reason(e)}"))
            continue
        try:
            if topic == scan_topic:
                raws.append(_laser_scan(msg, index, bag_ns, max_range))
            elif topic in odom:
                p = msg.pose.pose
                _finite(p.position.x, p.position.y, "position")
                yaw, m = planar(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w)
                key = (_frame(msg.header.frame_id), _frame(msg.child_frame_id))
                odom[topic].setdefault(key, []).append((_stamp(msg.header, bag_ns), p.position.x, p.position.y, yaw, m))
            else:
                into = static if topic.rstrip("/").endswith("tf_static") else moving
                for tr in msg.transforms:
                    q, v = tr.transform.rotation, tr.transform.translation
                    _finite(v.x, v.y, f"transform {_frame(tr.header.frame_id)} -> {_frame(tr.child_frame_id)}: "
                                      f"translation")
                    yaw, m = planar(q.x, q.y, q.z, q.w)
                    key = (_frame(tr.header.frame_id), _frame(tr.child_frame_id))
                    into.setdefault(key, []).append((_stamp(tr.header, bag_ns), v.x, v.y, yaw, m))
        except _Bad as e:
            bad(e.error(path, topic, index))
        except ValueError as e:  # an impossible quaternion, a translation not finite
            bad(BagMessageError(path, topic, index, str(e)))
    if not raws:
        raise ScanFormatError(path, None, f"no usable LaserScan messages on {scan_topic}")

    tracks = _tf_tracks(path, moving, static)
    scans = _place(path, raws, scan_topic, tracks, odom, odom_topic, tolerance, fixed_frame, report, bad)
    if not scans:
        raise ScanFormatError(path, None, f"no LaserScan on {scan_topic} has a pose")
    report.scans = len(scans)
    report.max_range = max(s.max_range for s in scans)
    return scans


class _Bad(Exception):
    def __init__(self, message: str, field: str | None = None, impossible: bool = False):
        super().__init__(message)
        self.message, self.field, self.impossible = message, field, impossible

    def error(self, path, topic, index) -> BagMessageError:
        cls = BagValueError if self.impossible else BagMessageError
        return cls(path, topic, index, self.message, self.field)


def _laser_scan(msg, index: int, bag_ns: int, max_range: float | None) -> _RawScan:
    r = np.array(msg.ranges, dtype=np.float64)
    if r.size == 0:
        raise _Bad("no ranges", "ranges")
    neg = np.isfinite(r) & (r < 0)
    if neg.any():
        i = int(np.argmax(neg))
        raise _Bad(f"range {float(r[i])!r} is negative", f"ranges[{i}]", True)
    amin, inc = float(msg.angle_min), float(msg.angle_increment)
    if not (math.isfinite(amin) and math.isfinite(inc)) or (inc == 0 and r.size > 1):
        raise _Bad(f"angle_min {amin!r}, angle_increment {inc!r} give no bearings", "angle_increment")
    rmin, rmax = float(msg.range_min), float(msg.range_max)
    mr = max_range if max_range is not None else rmax
    if not (math.isfinite(mr) and mr > 0):
        raise _Bad(f"range_max is {rmax!r}: give max_range (--max-range)", "range_max")
    # REP 117 and the LaserScan definition: nothing outside [range_min, range_max] is a return
    none = ~np.isfinite(r) | (r > rmax) | (r < rmin)
    r[none] = mr
    b = amin + np.arange(r.size) * inc
    if inc < 0:  # a clockwise sensor: same beams, listed the other way
        r, b = r[::-1].copy(), b[::-1].copy()
    keep = b - b[0] < TWO_PI  # a full turn with both ends included repeats the first beam
    if not keep.all():
        r, b = r[keep], b[keep]
    return _RawScan(index, _stamp(msg.header, bag_ns), _frame(msg.header.frame_id), r, b, float(mr))


def _tf_tracks(path, moving, static) -> dict[str, Track]:
    """child frame -> the track to its parent; a frame with two parents is an error."""
    tracks: dict[str, Track] = {}
    for (parent, child), samples in list(static.items()) + list(moving.items()):
        is_static = (parent, child) not in moving
        if child in tracks and tracks[child].parent != parent:
            raise ScanFormatError(path, None, f"tf frame {child!r} has two parents: {tracks[child].parent!r} and {parent!r}")
        tracks[child] = Track.of(parent, child, "/tf_static" if is_static else "/tf", samples, is_static)
    return tracks


def _chain(frame: str, tracks: dict[str, Track], fixed_frame: str | None, path=None) -> list[Track]:
    """Tracks from ``frame`` up to the root (or to ``fixed_frame``), lowest first; ScanFormatError
    naming the bag for a loop (it read "cannot read as a ROS bag: ValueError: ...")."""
    out, seen = [], {frame}
    while frame in tracks and frame != fixed_frame:
        tr = tracks[frame]
        out.append(tr)
        frame = tr.parent
        if frame in seen:
            raise ScanFormatError(path, None, f"tf has a loop through frame {frame!r}: a frame is its own "
                                              f"ancestor, so no pose can be found for it")
        seen.add(frame)
    return out


def _place(path, raws, scan_topic, tf_tracks, odom, odom_topic, tolerance, fixed_frame, report, bad) -> list[Scan]:
    """Scans at their laser poses: pick the pose source for each laser frame, then compose."""
    scans: dict[int, Scan] = {}
    for frame in sorted({r.frame for r in raws}):
        group = [r for r in raws if r.frame == frame]
        chain, how = _pose_chain(path, frame, tf_tracks, odom, odom_topic, fixed_frame, report)
        if fixed_frame is not None and (chain[-1].parent if chain else frame) != fixed_frame:
            raise ScanFormatError(path, None, f"laser frame {frame!r} is not connected to fixed frame {fixed_frame!r} ({how})")
        ts = np.array([r.stamp for r in group])
        pose = None
        missing = np.full(len(ts), -1)  # the first transform in the chain that is unknown at each scan's time
        for i, tr in enumerate(reversed(chain)):  # from the root down to the laser
            part, ok = tr.at(ts, tolerance)
            pose = part if pose is None else compose(pose, part)
            missing[~ok & (missing < 0)] = len(chain) - 1 - i
        report.notes.append(f"{frame or 'laser'}: poses from {how}")
        x, y, yaw, m = pose
        yaw = wrap(yaw)
        for k, r in enumerate(group):
            if missing[k] >= 0:
                tr = chain[missing[k]]
                bad(BagMessageError(path, scan_topic, r.index,
                                    f"no pose at t = {r.stamp:.6f} s: {tr.source} {tr.parent} -> {tr.child} spans "
                                    f"{tr.t[0]:.6f} .. {tr.t[-1]:.6f} s"))
                continue
            rr, bb = (r.ranges, r.bearings) if m[k] > 0 else (r.ranges[::-1].copy(), -r.bearings[::-1])
            try:
                scans[r.index] = Scan(rr, bb, np.array([x[k], y[k], yaw[k]]), r.stamp, r.max_range,
                                      f"{path.name}:{scan_topic}#{r.index}")
            except ScanFormatError as e:
                bad(BagMessageError(path, scan_topic, r.index, e.reason))
    return [scans[i] for i in sorted(scans)]


def _pose_chain(path, frame, tf_tracks, odom, odom_topic, fixed_frame, report) -> tuple[list[Track], str]:
    """The transforms that place ``frame``, and a phrase saying where they came from."""
    chain = _chain(frame, tf_tracks, fixed_frame, path)
    # tf places the laser in the world only if its chain climbs above the robot: one that stops at
    # odometry's child frame (a mount republished on /tf, as ROS 1's tf static_transform_publisher
    # does) says where the laser sits on the robot, and odometry where the robot is
    root = chain[-1].parent if chain else frame
    on_robot = any(child == root for streams in odom.values() for (_, child) in streams)
    if odom_topic is None and any(not tr.static for tr in chain) and not on_robot:
        return chain, "tf (" + " <- ".join([chain[-1].parent] + [tr.child for tr in reversed(chain)]) + ")"
    if not odom:
        raise ScanFormatError(path, None, f"no pose for laser frame {frame!r}: no nav_msgs/Odometry topic, and tf "
                                          f"{'does not move that frame' if tf_tracks else 'is absent or not read'}")
    if len(odom) > 1:
        raise ScanFormatError(path, None, f"{len(odom)} nav_msgs/Odometry topics ({', '.join(sorted(odom))}) and tf does "
                                          f"not move laser frame {frame!r}: choose one with odom_topic (--odom-topic)")
    topic, streams = next(iter(odom.items()))
    if not streams:
        raise ScanFormatError(path, None, f"no usable message on odometry topic {topic}")
    if len(streams) > 1:
        raise ScanFormatError(path, None, f"odometry topic {topic} mixes frames {sorted(streams)}")
    (parent, child), samples = next(iter(streams.items()))
    track = Track.of(parent, child, topic, samples)
    tracks = {c: t for c, t in tf_tracks.items() if c != child}  # odometry wins over tf for its own link
    tracks[child] = track
    if frame not in tracks and frame != child:
        report.notes.append(f"laser frame {frame!r} is not in tf: taken to sit on odometry's frame {child!r}")
        frame = child
    chain = _chain(frame, tracks, fixed_frame, path)
    if track not in chain:
        raise ScanFormatError(path, None, f"laser frame {frame!r} is not connected to odometry's frame {child!r} in tf")
    return chain, f"odometry {topic} ({parent} -> {child})" + (f" and tf to {frame}" if chain[0] is not track else "")
