"""ROS map_server maps: a PGM image and the YAML file that places it in the world.

    image: map.pgm               # relative to the YAML file's folder, or absolute
    resolution: 0.050000         # metres per pixel
    origin: [-12.5, -8.0, 0.0]   # x, y, yaw of the LOWER-LEFT pixel's corner in the world
    negate: 0
    occupied_thresh: 0.65
    free_thresh: 0.196
    mode: trinary                # optional: trinary (default), scale or raw

Row 0 of the image is the TOP of the map (y grows upwards in the world, downwards in the image).
map_server reads a pixel of value v (0..255) as the occupancy probability p = (255 - v) / 255
(p = v / 255 with ``negate: 1``); in trinary mode p > occupied_thresh is occupied, p < free_thresh
free and anything else unknown; in scale mode values in between grade linearly; in raw mode v is
the occupancy itself. So map_saver writes occupied as 0 (black), free as 254 (white) and unknown
as 205 (grey), with the thresholds above. This module follows that specification (ROS wiki
``map_server``, section "YAML format"; nav2_map_server's map_io) without a ROS installation.

The writer takes any 8-bit image (an occupancy grid's trinary picture, or grey levels encoding a
fuzzy membership), so that every map fuzzybrep exports for ROS goes through one place.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MapFileError
from .escape import comment_line, yaml_scalar, yaml_unquote_double
from .files import check_outputs, write_atomic

#: map_saver's thresholds: p > 0.65 is occupied, p < 0.196 is free (the defaults everywhere)
OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.196
#: refuse rasters larger than this many cells (a too fine resolution over a large map): 160 MB of
#: float32, where a mistyped resolution would otherwise end in NumPy failing to allocate petabytes
MAX_CELLS = 40_000_000
#: map_saver's grey levels (trinary mode)
PIXEL_OCCUPIED, PIXEL_FREE, PIXEL_UNKNOWN = 0, 254, 205
MODES = ("trinary", "scale", "raw")
REQUIRED_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")


@dataclass(frozen=True, eq=False)
class RosMap:
    """A map_server map as read: the image exactly as stored (row 0 at the top) and its placement."""

    image: np.ndarray  # (height, width) uint8, or uint16 for a 16-bit PGM
    resolution: float
    origin: tuple[float, float, float]
    negate: bool = False
    occupied_thresh: float = OCCUPIED_THRESH
    free_thresh: float = FREE_THRESH
    mode: str = "trinary"
    maxval: int = 255
    image_path: Path | None = None  # where the image was read from

    @property
    def shape(self) -> tuple[int, int]:
        return self.image.shape  # type: ignore[return-value]

    def probability(self) -> np.ndarray:
        """(height, width) occupancy probability map_server gives each pixel (row 0 at the top)."""
        v = self.image.astype(np.float64) * (255.0 / self.maxval)  # map_server sees 8-bit values
        return v / 255.0 if self.negate else (255.0 - v) / 255.0

    def occupancy(self) -> np.ndarray:
        """(height, width) int8 as map_server publishes it: 100 occupied, 0 free, -1 unknown.

        Row 0 is the BOTTOM of the map here (nav_msgs/OccupancyGrid order), as in OccupancyGrid.
        """
        if self.mode == "raw":  # the pixel value is the occupancy; anything above 100 is unknown
            v = self.image.astype(np.int64)
            return np.where(v > 100, -1, v).astype(np.int8)[::-1]
        p = self.probability()
        out = np.full(p.shape, -1, np.int8)
        if self.mode == "scale":  # ROS 1 map_server: 1 + 98 * ratio, truncated
            ratio = (p - self.free_thresh) / (self.occupied_thresh - self.free_thresh)
            out[:] = (1 + 98 * ratio).clip(1, 99).astype(np.int8)
        out[p > self.occupied_thresh] = 100
        out[p < self.free_thresh] = 0
        return out[::-1]


# ---------------------------------------------------------------------------- writing


def pgm_bytes(image: np.ndarray, comment: str | None = None) -> bytes:
    """A binary (P5) 8-bit PGM of a uint8 image, row 0 first (the top)."""
    img = np.asarray(image)
    if img.ndim != 2 or img.dtype != np.uint8:
        raise ValueError(f"a PGM image must be a 2-D uint8 array, got {img.ndim}-D {img.dtype}")
    h, w = img.shape
    head = "P5\n" + "".join(f"# {comment_line(line)}\n" for line in (comment or "").splitlines()) + f"{w} {h}\n255\n"
    return head.encode("ascii") + np.ascontiguousarray(img).tobytes()


def _num(x: float) -> str:
    """A float as YAML that reads back to the same value: shortest repr, with a point in the
    mantissa so that YAML 1.1 readers (PyYAML) do not take ``1e-05`` for a string."""
    r = repr(float(x))
    mant, e, exp = r.partition("e")
    return f"{mant}.0e{exp}" if e and "." not in mant else r


def map_yaml(image_name: str, resolution: float, origin, negate: bool = False, occupied_thresh: float = OCCUPIED_THRESH,
             free_thresh: float = FREE_THRESH, mode: str | None = "trinary") -> str:
    """The YAML text of a map_server map (flat keys, ``origin`` as a flow list, as map_saver writes)."""
    ox, oy, yaw = (float(v) for v in origin)
    lines = [f"image: {yaml_scalar(image_name)}"]  # a file name may hold anything but / and NUL
    if mode is not None:
        lines.append(f"mode: {mode}")
    lines += [
        f"resolution: {_num(resolution)}",
        f"origin: [{_num(ox)}, {_num(oy)}, {_num(yaw)}]",
        f"negate: {int(bool(negate))}",
        f"occupied_thresh: {_num(occupied_thresh)}",
        f"free_thresh: {_num(free_thresh)}",
    ]
    return "\n".join(lines) + "\n"


def write_ros_map(yaml_path: str | os.PathLike, image: np.ndarray, resolution: float, origin,
                  *, occupied_thresh: float = OCCUPIED_THRESH, free_thresh: float = FREE_THRESH, negate: bool = False,
                  mode: str | None = "trinary", comment: str | None = None) -> tuple[Path, Path]:
    """Write ``image`` (uint8, row 0 = top of the map) as NAME.pgm beside the YAML file NAME.yaml.

    ``origin`` is (x, y) or (x, y, yaw) of the lower-left pixel's corner. Both files are written
    atomically, the image first, so a YAML file never names an image that is not there yet.
    Returns (yaml path, image path).
    """
    yaml_path = Path(yaml_path)
    origin = tuple(float(v) for v in origin)
    if len(origin) == 2:
        origin += (0.0,)
    if len(origin) != 3 or not all(math.isfinite(v) for v in origin):
        raise MapFileError(yaml_path, f"origin must be finite (x, y[, yaw]), got {origin}")
    if not (math.isfinite(resolution) and resolution > 0):
        raise MapFileError(yaml_path, f"resolution must be positive, got {resolution!r}")
    if not 0 <= free_thresh < occupied_thresh <= 1:
        raise MapFileError(yaml_path, f"need 0 <= free_thresh ({free_thresh}) < occupied_thresh ({occupied_thresh}) <= 1")
    if mode is not None and mode not in MODES:
        raise MapFileError(yaml_path, f"mode {mode!r} is not one of {', '.join(MODES)}")
    pgm_path = yaml_path.with_suffix(".pgm")
    try:
        data = pgm_bytes(image, comment)
    except ValueError as e:
        raise MapFileError(pgm_path, str(e)) from None
    check_outputs(pgm_path, yaml_path, inputs=())  # both before either: a YAML that cannot be written leaves no PGM
    write_atomic(pgm_path, data)
    write_atomic(yaml_path, map_yaml(pgm_path.name, resolution, origin, negate, occupied_thresh, free_thresh,
                                     mode).encode())
    return yaml_path, pgm_path


def grid_image(grid) -> np.ndarray:
    """The trinary picture of an OccupancyGrid as map_saver draws it: row 0 at the top."""
    img = np.full(grid.shape, PIXEL_UNKNOWN, np.uint8)
    img[grid.free()] = PIXEL_FREE
    img[grid.occupied()] = PIXEL_OCCUPIED
    return img[::-1]


def write_grid(yaml_path: str | os.PathLike, grid, comment: str | None = None) -> tuple[Path, Path]:
    """Write an OccupancyGrid as a trinary map_server map (NAME.yaml + NAME.pgm)."""
    return write_ros_map(yaml_path, grid_image(grid), grid.resolution, (*grid.origin, 0.0),
                         occupied_thresh=grid.occupied_thresh, free_thresh=grid.free_thresh, mode="trinary",
                         comment=comment or f"fuzzybrep occupancy grid, {grid.resolution:g} m/pix")


# ---------------------------------------------------------------------------- reading

_PGM_TOKEN = re.compile(rb"\s*(?:#[^\n\r]*[\n\r]\s*)*(\S+)")  # whitespace and comments, then a token


def read_pgm(path: str | os.PathLike) -> tuple[np.ndarray, int]:
    """(image, maxval) of a PGM file, binary (P5) or plain (P2), comments allowed in the header.

    The image is uint8 when maxval < 256, else uint16 (big-endian samples in P5, as Netpbm says).
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise MapFileError(path, f"cannot read image: {e.strerror or e}") from None
    if raw[:2] not in (b"P5", b"P2"):
        what = "a PNG" if raw[:4] == b"\x89PNG" else f"magic number {raw[:2]!r}"
        raise MapFileError(path, f"not a PGM image ({what}; only P5 and P2 PGM are read)")
    magic, pos = raw[:2], 2
    fields = []
    for name in ("width", "height", "maxval"):
        m = _PGM_TOKEN.match(raw, pos)
        if not m:
            raise MapFileError(path, f"bad PGM header: no {name}")
        fields.append(m.group(1))
        pos = m.end()
    try:
        w, h, maxval = (int(f) for f in fields)
    except ValueError:
        raise MapFileError(path, f"bad PGM header: width, height and maxval must be integers, got "
                                 f"{b' '.join(fields).decode('ascii', 'replace')!r}") from None
    if w <= 0 or h <= 0:
        raise MapFileError(path, f"bad PGM header: size {w} x {h}")
    if not 0 < maxval < 65536:
        raise MapFileError(path, f"bad PGM header: maxval {maxval} must be 1..65535")
    dtype = np.uint8 if maxval < 256 else np.dtype(">u2")
    if magic == b"P5":
        # exactly one whitespace byte separates maxval from the raster
        start = pos + 1
        need = w * h * np.dtype(dtype).itemsize
        body = raw[start : start + need]
        if len(body) < need:
            raise MapFileError(path, f"truncated PGM: {w} x {h} pixels need {need} bytes, {len(body)} present")
        rest = raw[start + need :]
        if rest.strip() and not rest.lstrip().startswith((b"P5", b"P2")):  # a second image may follow
            raise MapFileError(path, f"PGM raster has {len(rest)} bytes more than {w} x {h} pixels need "
                                     f"(image size mismatch)")
        img = np.frombuffer(body, dtype=dtype).reshape(h, w)
    else:
        toks = raw[pos:].split()
        if len(toks) < w * h:
            raise MapFileError(path, f"truncated PGM: {w} x {h} pixels, {len(toks)} values present")
        if len(toks) > w * h and toks[w * h] not in (b"P5", b"P2"):
            raise MapFileError(path, f"PGM raster has {len(toks)} values, {w} x {h} pixels need {w * h} "
                                     f"(image size mismatch)")
        try:
            img = np.array([int(t) for t in toks[: w * h]], dtype=np.int64).reshape(h, w)
        except ValueError:
            raise MapFileError(path, "plain PGM raster holds a value that is not an integer") from None
    if img.max(initial=0) > maxval:
        raise MapFileError(path, f"PGM pixel value {int(img.max())} exceeds maxval {maxval}")
    return img.astype(np.uint8 if maxval < 256 else np.uint16), maxval


def parse_map_yaml(text: str, path: str | os.PathLike = "<yaml>") -> dict:
    """The flat ``key: value`` YAML map_server uses: numbers, strings, and lists as ``[a, b]`` or
    ``- a`` lines. Not general YAML: nested mappings are refused, with the line."""
    out: dict = {}
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = _strip_comment(lines[i])
        i += 1
        if not line.strip() or line.strip() in ("---", "..."):
            continue
        if line[0].isspace():
            raise MapFileError(path, f"line {i}: unexpected indentation (only flat key: value pairs are read)")
        key, sep, val = line.partition(":")
        key = key.strip().strip("'\"")
        if not sep or not key:
            raise MapFileError(path, f"line {i}: expected 'key: value', got {line.strip()!r}")
        if key in out:
            raise MapFileError(path, f"line {i}: key {key!r} appears twice")
        val = val.strip()
        if not val:  # a block list follows: "- a" lines
            items = []
            while i < len(lines) and _strip_comment(lines[i]).strip().startswith("-"):
                items.append(_scalar(_strip_comment(lines[i]).strip()[1:].strip()))
                i += 1
            out[key] = items if items else None
        elif val.startswith("["):
            if not val.endswith("]"):
                raise MapFileError(path, f"line {i}: list for {key!r} is not closed with ']'")
            body = val[1:-1].strip()
            out[key] = [_scalar(v.strip()) for v in body.split(",")] if body else []
        elif val.startswith("{"):
            raise MapFileError(path, f"line {i}: {key!r} is a mapping; map_server keys are flat")
        else:
            out[key] = _scalar(val)
    return out


def _strip_comment(line: str) -> str:
    # '#' starts a comment at the line start or after whitespace, outside quotes
    quote = None
    for k, ch in enumerate(line):
        if quote:
            if ch == quote and not (quote == '"' and _escaped(line, k)):
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (k == 0 or line[k - 1].isspace()):
            return line[:k].rstrip()
    return line.rstrip()


def _escaped(line: str, k: int) -> bool:
    """Whether line[k] follows an odd number of backslashes (``\\"`` inside double quotes)."""
    n = 0
    while k - n - 1 >= 0 and line[k - n - 1] == "\\":
        n += 1
    return n % 2 == 1


def _scalar(tok: str):
    if len(tok) >= 2 and tok[0] == tok[-1] == "'":
        return tok[1:-1].replace("''", "'")
    if len(tok) >= 2 and tok[0] == tok[-1] == '"':
        return yaml_unquote_double(tok[1:-1])
    low = tok.lower()
    if low in ("true", "yes", "on"):
        return True
    if low in ("false", "no", "off"):
        return False
    if low in ("null", "~", ""):
        return None
    try:
        return int(tok)
    except ValueError:
        pass
    try:
        return float(tok)
    except ValueError:
        return tok


def _number(v, what: str, path) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise MapFileError(path, f"{what} must be a number, got {v!r}")
    return float(v)


def read_ros_map(yaml_path: str | os.PathLike) -> RosMap:
    """Read a map_server map (YAML + PGM) as map_server would, checking every key.

    Errors name the file and what is wrong: a missing key, a bad value, a bad PGM header, an
    image whose size disagrees with its file.
    """
    yaml_path = Path(yaml_path)
    try:
        text = yaml_path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise MapFileError(yaml_path, f"cannot read: {getattr(e, 'strerror', None) or e}") from None
    d = parse_map_yaml(text, yaml_path)
    missing = [k for k in REQUIRED_KEYS if k not in d]
    if missing:
        raise MapFileError(yaml_path, f"missing key(s) {', '.join(missing)} (map_server needs {', '.join(REQUIRED_KEYS)})")
    resolution = _number(d["resolution"], "resolution", yaml_path)
    if resolution <= 0:
        raise MapFileError(yaml_path, f"resolution must be positive, got {resolution!r}")
    origin = d["origin"]
    if not isinstance(origin, list) or len(origin) != 3:
        raise MapFileError(yaml_path, f"origin must be a list [x, y, yaw], got {origin!r}")
    origin = tuple(_number(v, "origin", yaml_path) for v in origin)
    negate = d["negate"]
    if negate not in (0, 1, True, False):
        raise MapFileError(yaml_path, f"negate must be 0 or 1, got {negate!r}")
    occ = _number(d["occupied_thresh"], "occupied_thresh", yaml_path)
    free = _number(d["free_thresh"], "free_thresh", yaml_path)
    if not 0 <= free < occ <= 1:
        raise MapFileError(yaml_path, f"need 0 <= free_thresh ({free}) < occupied_thresh ({occ}) <= 1")
    mode = d.get("mode", "trinary")
    if mode not in MODES:
        raise MapFileError(yaml_path, f"mode {mode!r} is not one of {', '.join(MODES)}")
    if not isinstance(d["image"], str) or not d["image"]:
        raise MapFileError(yaml_path, f"image must be a file name, got {d['image']!r}")
    image_path = Path(d["image"])
    if not image_path.is_absolute():
        image_path = yaml_path.parent / image_path
    if not image_path.exists():
        raise MapFileError(yaml_path, f"image {d['image']!r} not found (looked for {image_path})")
    image, maxval = read_pgm(image_path)
    return RosMap(image, resolution, origin, bool(negate), occ, free, mode, maxval, image_path)
