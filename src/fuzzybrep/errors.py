"""Error classes: every error says where (file and line, or ring and vertex) and what is wrong.

A caller can catch everything fuzzybrep raises with ``FuzzyBrepError``, or one kind by its class.
"""

from __future__ import annotations

import os


class FuzzyBrepError(Exception):
    """Base class of every error fuzzybrep raises on purpose."""


class ScanFormatError(FuzzyBrepError, ValueError):
    """A scan file is malformed or truncated: names the file, the line and the field."""

    def __init__(self, path: str | os.PathLike | None, line: int | None, message: str, field: str | None = None):
        self.path = None if path is None else os.fspath(path)
        self.line = line
        self.field = field
        self.reason = message
        where = self.path or "<scans>"
        if line is not None:
            where += f", line {line}"
        if field is not None:
            where += f", field {field}"
        super().__init__(f"{where}: {message}")


class ScanValueError(ScanFormatError):
    """A scan holds an impossible value (NaN or negative range, NaN pose)."""


class AlignmentError(FuzzyBrepError):
    """``build --align --strict``: the aligned poses failed their check against the scans; names the
    log and the spans of it that failed."""


class LocalisationError(FuzzyBrepError):
    """``localise --global`` gave up: its search reached its bound without converging."""


class GeometryError(FuzzyBrepError, ValueError):
    """A polygon is degenerate or self-intersecting: names the ring and the vertex."""

    def __init__(self, message: str, ring: str | None = None, vertex: int | None = None):
        self.ring = ring
        self.vertex = vertex
        self.reason = message
        where = []
        if ring is not None:
            where.append(ring)
        if vertex is not None:
            where.append(f"vertex {vertex}")
        super().__init__(f"{', '.join(where)}: {message}" if where else message)


class MembershipFunctionError(FuzzyBrepError, ValueError):
    """A membership function fails the criteria of thesis section 4.1.1."""


class MapFileError(FuzzyBrepError):
    """A map file cannot be read or written: names the file."""

    def __init__(self, path: str | os.PathLike, message: str):
        self.path = os.fspath(path)
        self.reason = message
        super().__init__(f"{self.path}: {message}")


class FormatLimitError(FuzzyBrepError, ValueError):
    """A map holds something a file format cannot hold exactly (a coordinate beyond its integer
    range, a unit too long for its header, an FM index too large for its byte): says which and the limit."""


class UMBmarkError(FuzzyBrepError, ValueError):
    """UMBmark stop positions are malformed or incomplete: names the file, line and field when read from one."""

    def __init__(self, message: str, path: str | os.PathLike | None = None, line: int | None = None,
                 field: str | None = None):
        self.path = None if path is None else os.fspath(path)
        self.line = line
        self.field = field
        self.reason = message
        where = [w for w in (self.path, None if line is None else f"line {line}",
                             None if field is None else f"field {field}") if w]
        super().__init__(f"{', '.join(where)}: {message}" if where else message)


class WorldError(FuzzyBrepError, ValueError):
    """A simulated world (floor plan) or route is malformed: names the file and the feature."""

    def __init__(self, message: str, path: str | os.PathLike | None = None, feature: int | None = None):
        self.path = None if path is None else os.fspath(path)
        self.feature = feature
        self.reason = message
        where = [w for w in (self.path, None if feature is None else f"feature {feature}") if w]
        super().__init__(f"{', '.join(where)}: {message}" if where else message)


class BagMessageError(ScanFormatError):
    """A message in a ROS bag is unusable: names the bag, the topic, the message's index on that
    topic (from 0) and the field."""

    def __init__(self, path: str | os.PathLike | None, topic: str | None, index: int | None, message: str,
                 field: str | None = None):
        super().__init__(path, None, message, field)
        self.topic = topic
        self.index = index
        where = [w for w in (self.path or "<bag>", None if topic is None else f"topic {topic}",
                             None if index is None else f"message {index}",
                             None if field is None else f"field {field}") if w]
        self.args = (f"{', '.join(where)}: {message}",)


class BagValueError(BagMessageError, ScanValueError):
    """A message in a ROS bag holds an impossible value (a negative range)."""


class PlanError(FuzzyBrepError, ValueError):
    """No path can be planned: says which point or which part of the request is at fault."""


class PointNotFreeError(PlanError):
    """The start or the goal lies outside the safe region.

    which         "start" or "goal"
    point         (x, y) as given
    distance      how far it is from the safe region (None when the region is empty, or the
                  point is beyond ±brep.LARGEST: far outside the map)
    nearest       the nearest point of the safe region (None in the same cases)
    alpha_needed  the smallest α at which it would be free with the same radius, when one
                  exists and is known (None otherwise)
    """

    def __init__(self, which: str, point, message: str, distance: float | None = None, nearest=None,
                 alpha_needed: float | None = None):
        self.which = which
        self.point = tuple(float(c) for c in point)
        self.distance = distance
        self.nearest = None if nearest is None else tuple(float(c) for c in nearest)
        self.alpha_needed = alpha_needed
        self.reason = message
        super().__init__(f"{which} ({self.point[0]:g}, {self.point[1]:g}) is not free: {message}")


class NoConnectionError(PlanError):
    """Start and goal are both free but lie in different pieces of the safe region."""

    def __init__(self, message: str, start_piece: int | None = None, goal_piece: int | None = None):
        self.start_piece = start_piece
        self.goal_piece = goal_piece
        self.reason = message
        super().__init__(message)
