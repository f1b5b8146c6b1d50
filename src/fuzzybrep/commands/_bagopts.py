"""Command-line options for reading ROS bags, shared by every command that reads scans.

Not a command itself (cli.COMMANDS does not list it). The options only reach the reader when the
input is a bag, so ``read_scans`` keeps one signature per format.
"""

from __future__ import annotations

from ..errors import ScanFormatError
from ..scans.read import detect_format

_DESTS = ("scan_topic", "odom_topic", "fixed_frame")


def add_bag_arguments(p) -> None:
    g = p.add_argument_group("ROS bags")
    g.add_argument("--scan-topic", help="sensor_msgs/LaserScan topic (needed when the bag has more than one)")
    g.add_argument("--odom-topic", help="nav_msgs/Odometry topic for poses (default: tf when it moves the laser, "
                                        "else the bag's only odometry topic)")
    g.add_argument("--no-tf", action="store_true", help="ignore /tf and /tf_static (odometry only)")
    g.add_argument("--fixed-frame", help="frame to give poses in (default: the root of the tf tree)")


def bag_kwargs(args, log, fmt: str | None) -> dict:
    """read_scans keyword arguments for the bag options given; an error if given for another format."""
    given = {k: getattr(args, k) for k in _DESTS if getattr(args, k, None) is not None}
    if getattr(args, "no_tf", False):
        given["tf"] = False
    if (fmt or detect_format(log)) == "rosbag":
        return given
    if given:
        opts = ", ".join("--" + k.replace("_", "-") if k != "tf" else "--no-tf" for k in given)
        raise ScanFormatError(log, None, f"{opts}: {'this option applies' if len(given) == 1 else 'these options apply'} to ROS bags only")
    return {}
