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
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .brep import BRepMap, Region, Ring
from .errors import MapFileError

FORMAT = "fuzzybrep-map"
VERSION = 1


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: the permissions a plain open(path, "w") would give: temporary files start private (0600)
FILE_MODE = 0o666 & ~_umask()


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


def _ring_from_json(d: dict, where: str) -> Ring:
    try:
        x, y = np.asarray(d["x"], dtype=np.float64), np.asarray(d["y"], dtype=np.float64)
        if x.shape != y.shape or x.ndim != 1:
            raise ValueError(f"x has {x.size} values, y has {y.size}")
        return Ring(np.column_stack((x, y)), d.get("kind"), d.get("fm"))
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"{where}: {e}") from None


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


def from_json(d: dict, path: str | os.PathLike = "<map>") -> MapFile:
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise MapFileError(path, f"not a fuzzybrep map (format field is {d.get('format') if isinstance(d, dict) else None!r})")
    if d.get("version") != VERSION:
        raise MapFileError(path, f"map file version {d.get('version')!r} is not supported (this is version {VERSION})")
    try:
        regions = []
        for k, reg in enumerate(d["regions"]):
            shell = _ring_from_json(reg["shell"], f"region {k} shell")
            holes = tuple(_ring_from_json(h, f"region {k} hole {j + 1}") for j, h in enumerate(reg.get("holes", [])))
            regions.append(Region(shell, holes))
        if not regions:
            raise ValueError("no regions")
        crisp = BRepMap(tuple(regions), d.get("unit", "m"))
        scans = d.get("scans")
        poses = None if not scans else np.asarray(scans["poses"], dtype=np.float64).reshape(-1, 4)
        return MapFile(crisp, list(d.get("membership_functions") or []), poses, dict(d.get("metadata") or {}))
    except (KeyError, TypeError, ValueError) as e:
        raise MapFileError(path, f"malformed map: {e}") from None


def write_map(path: str | os.PathLike, m: MapFile) -> int:
    """Write atomically (temporary file in the same folder, then rename); returns bytes written."""
    path = Path(path)
    data = json.dumps(to_json(m), separators=(",", ":")).encode()
    return write_atomic(path, data)


def write_atomic(path: str | os.PathLike, data: bytes) -> int:
    """Write bytes so that the file is either the old one or the complete new one, never half."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        try:
            os.fchmod(fd, FILE_MODE)
            with os.fdopen(fd, "wb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except OSError as e:
        raise MapFileError(path, f"cannot write: {e.strerror or e}") from None
    return len(data)


def read_map(path: str | os.PathLike) -> MapFile:
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise MapFileError(path, f"cannot read: {e.strerror or e}") from None
    try:
        d = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise MapFileError(path, f"not valid JSON ({e})") from None
    return from_json(d, path)
