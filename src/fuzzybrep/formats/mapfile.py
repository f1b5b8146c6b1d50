"""The map file: versioned JSON that round-trips exactly, written atomically.

Layout (version 1)::

    {"format": "fuzzybrep-map", "version": 1, "unit": "m",
     "regions": [{"shell": RING, "holes": [RING, ...]}, ...],   # regions[0]: principal polygon
     "membership_functions": [{"index": 1, "type": "triangular", ...}, ...],   # Table 4.2
     "scans": {"count": N, "poses": [[x, y, heading, t], ...]},
     "metadata": {...}}
    RING = {"x": [...], "y": [...], "kind": [0|1, ...], "fm": [1, ...]}

Only what cannot be derived is stored: the crisp vertex tables, edge kinds, FM indices and the
membership-function table. Edge tables and the fuzzy tables (normal lines, VIN, VOUT) follow from
these and are rebuilt on load. Floats are written with ``repr`` precision, so a map read back is
bit-for-bit the map written.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..brep import BRepMap, Region, Ring, drop_short_edges, min_edge
from ..errors import GeometryError, MapFileError
from .compact import MAGIC, compact_from_bytes
from .files import check_map, loads_json, read_limited, write_atomic

FORMAT = "fuzzybrep-map"
VERSION = 1


@dataclass
class MapFile:
    """Everything a map file holds."""

    crisp: BRepMap
    membership_functions: list[dict] = field(default_factory=list)
    poses: np.ndarray | None = None  # (S, 4): x, y, heading, timestamp of every scan used
    metadata: dict = field(default_factory=dict)


def _ring_to_json(r: Ring) -> dict:
    return {
        "x": r.vertices[:, 0].tolist(),
        "y": r.vertices[:, 1].tolist(),
        "kind": r.kinds.tolist(),
        "fm": r.fm.tolist(),
    }


def _numbers(values, what: str, where: str = "vertex") -> np.ndarray:
    """A list of JSON numbers as floats: ValueError naming the first that is not one. NumPy takes
    a boolean (JSON's ``true`` is 1 to Python: bool is an int) or a numeric string ("1.5") without
    a word; a map file holds neither."""
    if not isinstance(values, list):
        raise ValueError(f"{what} must be a list of numbers, got {type(values).__name__}")
    if not set(map(type, values)) <= {int, float}:
        i = next(i for i, v in enumerate(values) if type(v) not in (int, float))
        raise ValueError(f"{where} {i + 1}: {what} {values[i]!r} is not a number")
    return np.asarray(values, dtype=np.float64)


def _whole(d: dict, key: str, what: str, ok, rule: str) -> np.ndarray | None:
    """A ring's edge-kind or FM column as read: whole numbers that pass ``ok``, or None if absent.

    Checked here because Ring casts them to small integers, which would turn 1.7 into 1 and 7
    into an edge kind that is neither obstacle nor frontier without a word."""
    if d.get(key) is None:
        return None
    a = _numbers(d[key], what)
    with np.errstate(invalid="ignore"):
        bad = ~((a == np.round(a)) & ok(a))
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"vertex {i + 1}: {what} {d[key][i]!r} {rule}")
    return a


def _ring_from_json(d: dict, where: str) -> Ring:
    try:
        if not isinstance(d, dict):
            raise ValueError(f"expected an object with x, y, kind and fm lists, got {type(d).__name__}")
        x, y = _numbers(d["x"], "x"), _numbers(d["y"], "y")
        if x.shape != y.shape:
            raise ValueError(f"x has {x.size} values, y has {y.size}")
        kinds = _whole(d, "kind", "edge kind", lambda k: (k == 0) | (k == 1), "is neither 0 (obstacle) nor 1 (frontier)")
        fm = _whole(d, "fm", "FM index", lambda f: (f >= 1) & (f < 2**31), "is not a whole number from 1 up")
        return Ring(np.column_stack((x, y)), kinds, fm)
    except KeyError as e:  # str(KeyError) is the bare key: "region 0 shell: 'x'" said nothing
        raise ValueError(f"{where}: missing key {e}") from None
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}{', ' if str(e).startswith('vertex ') else ': '}{e}") from None


def to_json(m: MapFile) -> dict:
    return {
        "format": FORMAT,
        "version": VERSION,
        "unit": m.crisp.unit,
        "regions": [
            {"shell": _ring_to_json(reg.shell), "holes": [_ring_to_json(h) for h in reg.holes]}
            for reg in m.crisp.regions
        ],
        "membership_functions": m.membership_functions,
        "scans": None if m.poses is None else {"count": int(len(m.poses)), "poses": np.asarray(m.poses).tolist()},
        "metadata": m.metadata,
    }


def _typed(d: dict, key: str, kind: type, default):
    """d[key] if it is a ``kind`` (or absent/null: the default), else a ValueError naming the key."""
    v = d.get(key)
    if v is None:
        return default
    if not isinstance(v, kind):
        raise ValueError(f"{key} must be {'a list' if kind is list else 'an object' if kind is dict else 'a string'}, "
                         f"got {type(v).__name__}")
    return v


def from_json(d: dict, path: str | os.PathLike = "<map>") -> MapFile:
    """The map a file's JSON holds; MapFileError naming the file (and the ring and vertex) if it is
    not one: wrong shape, impossible values, or a degenerate or self-intersecting ring."""
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise MapFileError(path, f"not a fuzzybrep map (format field is {d.get('format') if isinstance(d, dict) else None!r})")
    if d.get("version") != VERSION:
        raise MapFileError(path, f"map file version {d.get('version')!r} is not supported (this is version {VERSION})")
    try:
        regions = []
        for k, reg in enumerate(_typed(d, "regions", list, [])):
            if not isinstance(reg, dict):
                raise ValueError(f"region {k} must be an object with a shell and holes, got {type(reg).__name__}")
            shell = _ring_from_json(reg.get("shell"), f"region {k} shell")
            holes = tuple(_ring_from_json(h, f"region {k} hole {j + 1}") for j, h in enumerate(_typed(reg, "holes", list, [])))
            regions.append(Region(shell, holes))
        if not regions:
            raise ValueError("no regions")
        crisp = BRepMap(tuple(regions), _typed(d, "unit", str, "m"))
        scans = _typed(d, "scans", dict, None)
        poses = None if not scans else _json_poses(scans.get("poses"))
        count = None if not scans else scans.get("count")
        if count is not None and (type(count) is not int or poses is None or count != len(poses)):
            # before: read without a word, and the map's scans were whichever the poses said
            raise ValueError(f"scans.count is {count!r}, but scans.poses holds "
                             f"{'no' if poses is None else len(poses)} poses")
        mfs = list(_typed(d, "membership_functions", list, []))
        meta = dict(_typed(d, "metadata", dict, {}))
    except (KeyError, TypeError, ValueError) as e:
        raise MapFileError(path, f"malformed map: {e}") from None
    check_map(crisp, path)
    return MapFile(crisp, mfs, poses, meta)


def _json_poses(rows, name: str = "scans.poses") -> np.ndarray:
    """``_poses`` of a file's JSON: rows of numbers, not booleans or strings (as ``_numbers``)."""
    if isinstance(rows, list):
        for i, r in enumerate(rows):
            if not (isinstance(r, list) and set(map(type, r)) <= {int, float}):
                raise ValueError(f"{name} row {i + 1} is not a list of numbers: {r!r}")
    return _poses(rows, name)


def _poses(rows, name: str = "scans.poses") -> np.ndarray:
    p = np.asarray(rows, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 4:
        raise ValueError(f"{name} must be rows of x, y, heading, time; got shape {p.shape}")
    bad = ~np.isfinite(p).all(axis=1)
    if bad.any():
        raise ValueError(f"{name} row {int(np.argmax(bad)) + 1} is not finite: {p[int(np.argmax(bad))].tolist()}")
    return p


def write_map(path: str | os.PathLike, m: MapFile) -> int:
    """Write atomically (temporary file in the same folder, then rename); returns bytes written.
    ValueError, before anything is written, for poses ``read_map`` would refuse (not rows of x, y,
    heading, time, or not finite): the file must read back."""
    path = Path(path)
    if m.poses is not None:
        m = replace(m, poses=_poses(m.poses, "poses"))
    data = json.dumps(to_json(m), separators=(",", ":")).encode()
    return write_atomic(path, data)


def read_map(path: str | os.PathLike) -> MapFile:
    """A map file, or a compact map (``export --compact``): the same crisp map and Table 4.2,
    without the scan poses."""
    path = Path(path)
    return map_from_bytes(read_limited(path), path)  # bounded: /dev/zero has no size to check


def map_from_bytes(raw: bytes, path: str | os.PathLike = "<map>") -> MapFile:
    """``read_map`` of a file's bytes already read; MapFileError names ``path``."""

    if raw.startswith(MAGIC):  # before: "not valid JSON ('utf-8' codec can't decode byte 0xfc ...)"
        return _merged(MapFile(*compact_from_bytes(raw, path)), path)
    try:
        d = loads_json(raw)
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise MapFileError(path, f"not valid JSON ({e})") from None
    return _merged(from_json(d, path), path)


def _merged(m: MapFile, path) -> MapFile:
    """The map read with its edges shorter than ``min_edge`` merged away (a file written before
    they were, or by hand); MapFileError naming the ring if that leaves it invalid."""
    try:
        crisp = drop_short_edges(m.crisp)
    except GeometryError as e:
        raise MapFileError(path, f"{e} (edges shorter than {min_edge(m.crisp.unit):g} {m.crisp.unit} are merged away "
                                 f"when a map is read)") from None
    return m if crisp is m.crisp else replace(m, crisp=crisp)
