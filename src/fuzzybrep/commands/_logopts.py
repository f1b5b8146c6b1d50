"""The input options every command that reads a log shares, and reading the log with them.

Not a command itself (cli.COMMANDS does not list it). The bag options only reach the reader when
the input is a bag, so ``read_scans`` keeps one signature per format.
"""

from __future__ import annotations

from ..errors import ScanFormatError, ScanValueError
from ..scans.read import detect_format, read_scans
from ..scans.report import ReadReport
from ._types import positive


def add_log_arguments(p) -> None:
    """LOG, --format, --max-range, --skip-bad and the ROS bag options."""
    p.add_argument("log", help="CARMEN log (.log or .log.gz), CSV scan file (.csv) or ROS bag")
    p.add_argument("--format", choices=["carmen", "csv", "rosbag"], help="input format (default: from the file name)")
    p.add_argument("--max-range", type=positive,
                   help="ranges at or above this mean no return (default: the log's largest range)")
    p.add_argument("--skip-bad", action="store_true",
                   help="skip malformed lines or messages (and say how many) instead of stopping")
    add_bag_arguments(p)


def read_log(args) -> tuple[list, ReadReport]:
    """The scans of ``args.log`` with the options of ``add_log_arguments``, and what was read."""
    report = ReadReport()
    kw = {"skip_bad": args.skip_bad, **bag_kwargs(args, args.log, args.format)}
    if args.max_range is not None:
        kw["max_range"] = args.max_range
    scans = read_scans(args.log, fmt=args.format, report=report, **kw)
    claims_free = getattr(args, "no_return_free", 0.0) > 0
    if not claims_free and not any(s.returns.any() for s in scans):
        # every beam is "no return": nothing marks an obstacle or free space, and the builders
        # would fail deep inside (or map nothing) instead of saying so
        mr = max(s.max_range for s in scans)
        hint = ", or --no-return-free to claim free space along them" if hasattr(args, "no_return_free") else ""
        raise ScanValueError(args.log, None, f"no beam has a return (every range of the {len(scans)} scan(s) is 0 or "
                                             f"at least max_range {mr:g}): nothing to map; give --max-range above "
                                             f"{mr:g} if those ranges are real{hint}")
    return scans, report


def read_notes(report: ReadReport) -> list[str]:
    """What the reader chose for the user (a bag's topics and pose source, a laser frame taken to
    sit on the odometry's frame) and what it skipped, one line each: they change the map, so
    every command that reads a log shows them."""
    lines = [f"note: {note}" for note in report.notes]
    if report.skipped:
        lines.append(f"skipped {report.skipped} bad line(s) or message(s); first: {report.errors[0]}")
    return lines


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
