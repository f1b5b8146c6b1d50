"""A fuzzy B-rep map as a ROS 2 bag (rosbags): what RViz shows of it, latched.

``write_bag(path, fuzzy, raster, cuts, storage)`` writes a ROS 2 bag folder (MCAP or sqlite3
storage) with, each one message at t = 0 in the frame ``map``, on topics offered with
transient-local durability and keep-last 1 (what map_server's latched /map has), so that a
subscriber joining after the bag started still gets them when the bag is played:

- ``/map``: ``nav_msgs/msg/OccupancyGrid``, the Nav2 map's values (``nav2.map_values``): 100
  occupied, −1 unknown, round(99·μ) in the free space; resolution and origin in metres;
- ``/map_boundary``: ``visualization_msgs/msg/MarkerArray``: namespace ``crisp``, one LINE_STRIP a
  ring (closed: the first point repeated at the end), marker id = the ring's index in the map file;
  namespace ``frontier``, one LINE_LIST of the frontier edges; and per α below 1 namespaces
  ``alpha-A-inner`` and ``alpha-A-outer``, one LINE_STRIP a ring of the α-cut's polygons.

Which ROS 2 reads it (``distro``): rosbag2's ``metadata.yaml`` changed shape between releases.
Jazzy writes version 9, whose topics' ``offered_qos_profiles`` is a YAML list; Humble (the LTS
release most robots run until 2027) writes version 5 and reads ``offered_qos_profiles`` as a
YAML *string* (a serialized list), so it fails on a version 9 file. ``humble`` (the default)
writes version 5 with string QoS profiles and none of the keys later versions added
(``custom_data``, ``ros_distro``, ``type_description_hash``): Jazzy and newer read older
versions too, so this is the bag both read. ``jazzy`` writes version 9. Humble has no MCAP storage
plugin unless ``ros-humble-rosbag2-storage-mcap`` is installed: ``--bag-storage sqlite3`` is its
default storage.

No ``geometry_msgs/msg/PolygonStamped``: it holds one ring, and a latched topic keeps one message,
so a map of many rings would need a topic a ring; the markers carry every ring with its role.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np

from ..errors import MapFileError
from .nav2 import map_values
from .rings import layers

STORAGES = ("mcap", "sqlite3")
#: ROS 2 releases whose rosbag2 the bag is written for, and the metadata version each writes
DISTROS = {"humble": 5, "jazzy": 9}
#: metadata keys added after version 5 (Humble's), left out of a Humble bag
_AFTER_V5 = ("custom_data", "ros_distro")
MAP_TOPIC, BOUNDARY_TOPIC, FRAME = "/map", "/map_boundary", "map"
OCCUPANCY_GRID = "nav_msgs/msg/OccupancyGrid"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
LINE_STRIP, LINE_LIST = 4, 5  # visualization_msgs/Marker types
#: RGBA of each layer's lines (the SVG's colours)
COLOURS = {"crisp": (0.12, 0.23, 0.37, 1.0), "frontier": (0.88, 0.48, 0.22, 1.0),
           "inner": (0.17, 0.48, 0.73, 1.0), "outer": (0.75, 0.22, 0.17, 1.0)}
#: line widths, metres (RViz draws LINE_STRIP widths in the frame's unit)
WIDTHS = {"crisp": 0.03, "frontier": 0.05, "inner": 0.015, "outer": 0.015}


def latched_qos():
    """Transient local, reliable, keep last 1: map_server's QoS for /map."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    zero = QosTime(0, 0)
    return Qos(QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL, zero, zero,
               QosLiveliness.AUTOMATIC, zero, False)


def _typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def _marker(T, **fields):
    """A Marker with the texture and mesh fields Humble added left empty."""
    empty = np.zeros(0, np.uint8)
    return T["visualization_msgs/msg/Marker"](
        **fields, colors=[], texture_resource="", uv_coordinates=[], text="", mesh_resource="",
        texture=T["sensor_msgs/msg/CompressedImage"](header=fields["header"], format="", data=empty),
        mesh_file=T["visualization_msgs/msg/MeshFile"](filename="", data=empty), mesh_use_embedded_materials=False)


def write_bag(path: str | os.PathLike, fuzzy, raster, cuts, storage: str = "mcap", *, scale: float = 1.0,
              distro: str = "humble") -> Path:
    """Write the bag folder ``path`` (module doc). ``scale``: metres per map unit; ``distro``: the
    ROS 2 release whose rosbag2 reads it (``DISTROS``). Written into a temporary folder beside it
    and renamed, so a failure leaves nothing half-written; an existing bag at ``path`` is replaced
    only once the new one is complete."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    if storage not in STORAGES:
        raise ValueError(f"storage must be one of {', '.join(STORAGES)}, got {storage!r}")
    if distro not in DISTROS:
        raise ValueError(f"ROS 2 distribution must be one of {', '.join(DISTROS)}, got {distro!r}")
    path = Path(path)
    ts = _typestore()
    T = ts.types
    stamp = T["builtin_interfaces/msg/Time"](sec=0, nanosec=0)
    header = T["std_msgs/msg/Header"](stamp=stamp, frame_id=FRAME)
    Point, Quat = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    identity = T["geometry_msgs/msg/Pose"](position=Point(x=0.0, y=0.0, z=0.0), orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0))

    h, w = raster.shape
    values = map_values(raster)[::-1]  # OccupancyGrid rows run from the bottom
    origin = T["geometry_msgs/msg/Pose"](position=Point(x=raster.origin[0] * scale, y=raster.origin[1] * scale, z=0.0),
                                         orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0))
    info = T["nav_msgs/msg/MapMetaData"](map_load_time=stamp, resolution=float(raster.resolution * scale),
                                         width=w, height=h, origin=origin)
    grid = T[OCCUPANCY_GRID](header=header, info=info, data=np.ascontiguousarray(values.ravel(), np.int8))

    def points(xy):
        return [Point(x=float(x) * scale, y=float(y) * scale, z=0.0) for x, y in xy]

    markers = []
    for layer in layers(fuzzy, cuts):
        role = layer["role"]
        r, g, b, a = COLOURS[role]
        colour = T["std_msgs/msg/ColorRGBA"](r=r, g=g, b=b, a=a)
        width = T["geometry_msgs/msg/Vector3"](x=WIDTHS[role], y=0.0, z=0.0)
        common = dict(header=header, ns=layer["name"], action=0, pose=identity, scale=width, color=colour,
                      lifetime=T["builtin_interfaces/msg/Duration"](sec=0, nanosec=0), frame_locked=False)
        if "segments" in layer:
            seg = layer["segments"]
            if len(seg):
                markers.append(_marker(T, id=0, type=LINE_LIST,
                                        points=points(seg.reshape(-1, 2)), **common))
            continue
        for k, ring in enumerate(layer["rings"]):
            markers.append(_marker(T, id=k, type=LINE_STRIP,
                                    points=points(np.vstack((ring, ring[:1]))), **common))
    array = T[MARKER_ARRAY](markers=markers)

    # written in a folder of its own beside it, under its own name (rosbags names the storage file
    # after the bag's folder), then moved into place
    work = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=False)
    tmp = work / path.name
    try:
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        # rosbags writes versions 8 and 9; 8 holds the QoS profiles as a string, as Humble's 5 does
        with Writer(tmp, version=9 if distro == "jazzy" else 8, storage_plugin=plugin) as bag:
            qos = [latched_qos()]
            for topic, msgtype, msg in ((MAP_TOPIC, OCCUPANCY_GRID, grid), (BOUNDARY_TOPIC, MARKER_ARRAY, array)):
                conn = bag.add_connection(topic, msgtype, typestore=ts, offered_qos_profiles=qos)
                bag.write(conn, 0, ts.serialize_cdr(msg, msgtype))
        if distro == "humble":
            _as_version_5(tmp / "metadata.yaml")
        if path.is_dir():
            old = path.with_name(f".{path.name}.{os.getpid()}.old")
            path.rename(old)
            tmp.rename(path)
            shutil.rmtree(old)
        elif path.exists():
            raise MapFileError(path, "exists and is not a bag folder: not replaced")
        else:
            tmp.rename(path)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return path


def _as_version_5(meta: Path) -> None:
    """Rewrite a version 8 ``metadata.yaml`` in the shape Humble's rosbag2 writes (version 5):
    the same fields less the ones later versions added; QoS profiles stay YAML strings."""
    from ruamel.yaml import YAML

    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    doc = yaml.load(meta.read_text())
    info = doc["rosbag2_bagfile_information"]
    info["version"] = DISTROS["humble"]
    for key in _AFTER_V5:
        info.pop(key, None)
    for t in info.get("topics_with_message_count", []):
        t["topic_metadata"].pop("type_description_hash", None)
        if not isinstance(t["topic_metadata"].get("offered_qos_profiles"), str):
            raise AssertionError("rosbags wrote the QoS profiles of a version 8 bag as a list")
    with meta.open("w") as fh:
        yaml.dump(doc, fh)


__all__ = ["BOUNDARY_TOPIC", "DISTROS", "FRAME", "MAP_TOPIC", "STORAGES", "latched_qos", "write_bag"]
