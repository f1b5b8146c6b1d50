"""Nav2: a map map_server loads with μ kept, and costmap filter masks from the fuzzy boundary.

``write_nav2(directory, name, raster, ...)`` writes, on the raster's grid (``formats.raster``):

- ``NAME.yaml`` + ``NAME.png`` (``mode: scale``) or ``NAME.pgm`` (``mode: raw``): the map. The
  OccupancyGrid map_server publishes from it holds 100 where the raster is occupied, −1 where it is
  unknown and, in the free space, ``round(99·μ)``: 0 beyond the support, up to 99 at the crisp
  boundary. Nav2's static layer with its defaults (``trinary_costmap: true``, lethal threshold
  100) reads that as free / lethal / unknown; with ``trinary_costmap: false`` it reads μ as cost
  (value/100 · 254: 251 at the crisp boundary, still passable). AMCL treats only 0 as free and
  100 as occupied, so it draws no particles within the support of a wall.
- ``NAME_keepout.yaml`` + ``.pgm`` (trinary): a keepout mask, 100 in the crisp free space outside
  the inner α-cut (μ ≥ α, or μ > 0 at α = 0), −1 elsewhere. The keepout filter writes a mask
  cell's cost over the costmap's where it is higher, and over unknown ones, but skips mask cells
  that are unknown: a 0 (free) in the mask would clear the map's unknown space, so the mask holds
  only 100 and −1.
- ``NAME_speed.yaml`` + image (the map's mode): a speed mask from μ, 0 (no limit) beyond the
  support, ``max(1, round(100·μ))`` in the free side of the band, 100 outside the free space
  (where the robot should not be: the slowest). With the filter info's ``type: 1`` (percent),
  ``base: 100`` and ``multiplier: −(100 − S)/100`` the limit is 100 − (100 − S)·μ percent of
  the maximum speed: S at the crisp boundary.
- ``NAME_nav2_params.yaml``: the map server, the two mask servers and the two
  ``costmap_filter_info_server`` blocks (type, base, multiplier, mask topic) and the costmap
  filters to paste into a Nav2 params file.

Why ``scale`` by default: map_server keeps a value between its thresholds as a grade only in scale
mode (trinary thresholds it away), and scale mode takes unknown from the alpha channel, which a
PGM has not: hence a PNG, grey R = G = B = 255·(1 − value/100), alpha 0 where unknown, with
``free_thresh: 0`` and ``occupied_thresh: 1`` so that every value 0..100 comes back exactly. It is
also what Nav2's map_saver writes in scale mode, and the picture reads as a map (white free space,
black walls, grey near them, transparent unknown). ``raw`` stores the values themselves (0..100, 255
unknown) in a PGM: the same OccupancyGrid, for tools without PNG alpha, but a nearly black picture.

The loading rules (nav2_map_server ``map_io.cpp``): occupancy p = 1 − shade (``negate: 0``); in
trinary and scale modes p ≥ occupied_thresh is 100, p ≤ free_thresh is 0 (Humble-era releases: >
and <), scale grades in between as round((p − free)/(occupied − free)·100); a pixel whose alpha is
not opaque is −1 in scale mode (and, from 2025, in trinary mode too); raw mode takes the grey
value, above 100 is −1. Row 0 of the image is the top of the map. Every level written here is at
least 0.2 of a step away from where these variants round or threshold differently, and the
trinary masks are PGMs without alpha, so every released map_server reads the same grid.
"""

from __future__ import annotations

import io
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MapFileError
from .files import check_outputs, write_atomic
from .raster import MembershipRaster
from .escape import comment_line, yaml_scalar
from .rosmap import FREE_THRESH, OCCUPIED_THRESH, map_yaml, pgm_bytes

MODES = ("scale", "raw")
#: value of a free cell at the crisp boundary (μ = 1): below Nav2's lethal threshold (100)
FREE_MAX = 99
#: OccupancyGrid values
OCCUPIED, UNKNOWN = 100, -1
#: the slowest speed of the speed mask, percent of the maximum (at the crisp boundary)
DEFAULT_MIN_SPEED = 30.0
#: raw mode's unknown pixel (any value above 100 reads as unknown)
RAW_UNKNOWN = 255
KEEPOUT_TYPE, SPEED_PERCENT_TYPE = 0, 1


def map_values(raster: MembershipRaster) -> np.ndarray:
    """(h, w) int8, row 0 at the top: the OccupancyGrid values of the map (module doc)."""
    v = np.full(raster.shape, UNKNOWN, np.int8)
    v[raster.free] = np.rint(FREE_MAX * np.clip(raster.mu[raster.free], 0.0, 1.0)).astype(np.int8)
    v[raster.occupied] = OCCUPIED
    return v


def keepout_values(raster: MembershipRaster, alpha: float) -> np.ndarray:
    """(h, w) int8, row 0 at the top: 100 in the crisp free space outside the inner α-cut, −1 elsewhere."""
    mu = raster.mu
    keep = raster.free & (mu > 0) & (mu >= alpha)
    return np.where(keep, OCCUPIED, UNKNOWN).astype(np.int8)


def speed_values(raster: MembershipRaster) -> np.ndarray:
    """(h, w) int8, row 0 at the top: 0 where μ = 0 in the free space (no limit), 1..100 by μ in the
    band, 100 outside the free space."""
    v = np.full(raster.shape, OCCUPIED, np.int8)
    mu = np.clip(raster.mu[raster.free], 0.0, 1.0)
    v[raster.free] = np.where(mu > 0, np.maximum(1, np.rint(100 * mu)), 0).astype(np.int8)
    return v


def speed_filter_coefficients(min_speed: float) -> tuple[float, float]:
    """(base, multiplier) of the speed filter in percent: 100 + multiplier · mask = the limit."""
    return 100.0, -(100.0 - min_speed) / 100.0


def scale_png(values: np.ndarray) -> bytes:
    """An RGBA PNG that map_server in scale mode (thresholds 0 and 1) reads back as ``values``:
    grey 255·(1 − v/100), alpha 0 where v is −1 (map_saver writes scale maps so, TrueColorMatte)."""
    from PIL import Image

    v = np.asarray(values, np.int16)
    grey = np.rint(255.0 * (1.0 - np.clip(v, 0, 100) / 100.0)).astype(np.uint8)
    grey[v < 0] = 128  # map_saver's grey under a transparent pixel; never read
    alpha = np.where(v < 0, 0, 255).astype(np.uint8)
    rgba = np.dstack((grey, grey, grey, alpha))
    buf = io.BytesIO()
    Image.fromarray(rgba, "RGBA").save(buf, format="PNG", optimize=False, compress_level=6)
    return buf.getvalue()


def raw_pgm(values: np.ndarray, comment: str | None = None) -> bytes:
    """A PGM whose grey levels are the values (0..100), 255 where unknown (raw mode)."""
    v = np.asarray(values, np.int16)
    return pgm_bytes(np.where(v < 0, RAW_UNKNOWN, v).astype(np.uint8), comment)


def trinary_pgm(values: np.ndarray, comment: str | None = None) -> bytes:
    """A PGM of map_saver's three levels: 0 occupied, 254 free, 205 unknown."""
    v = np.asarray(values)
    img = np.full(v.shape, 205, np.uint8)
    img[v == 0] = 254
    img[v == OCCUPIED] = 0
    return pgm_bytes(img, comment)


@dataclass(frozen=True)
class Nav2Files:
    """What ``write_nav2`` wrote, and the filter parameters it wrote them with."""

    map_yaml: Path
    map_image: Path
    keepout_yaml: Path
    keepout_image: Path
    speed_yaml: Path
    speed_image: Path
    params: Path
    mode: str
    alpha: float
    speed_base: float
    speed_multiplier: float

    @property
    def paths(self) -> list[Path]:
        return [self.map_yaml, self.map_image, self.keepout_yaml, self.keepout_image, self.speed_yaml,
                self.speed_image, self.params]


def nav2_paths(directory: str | os.PathLike, name: str, mode: str = "scale") -> list[Path]:
    """Every file ``write_nav2`` writes, for ``check_outputs`` before any work."""
    d = Path(directory)
    ext = "png" if mode == "scale" else "pgm"
    return [d / f"{name}.yaml", d / f"{name}.{ext}", d / f"{name}_keepout.yaml", d / f"{name}_keepout.pgm",
            d / f"{name}_speed.yaml", d / f"{name}_speed.{ext}", d / f"{name}_nav2_params.yaml"]


def _q(s: str) -> str:
    return yaml_scalar(s)


def params_yaml(files: list[Path], name: str, alpha: float, base: float, multiplier: float, method: str) -> str:
    """The Nav2 parameters for the map, the masks and the filters, as YAML to paste."""
    map_yaml_path, _, keepout_yaml, _, speed_yaml, _, _ = (p.resolve() for p in files)
    keep_info, keep_mask = "/keepout_filter_info", "/keepout_filter_mask"
    speed_info, speed_mask = "/speed_filter_info", "/speed_filter_mask"
    return f"""\
# Nav2 parameters for the fuzzy B-rep map {comment_line(name)}, written by `fuzzybrep export --nav2`.
# Paste the blocks into your Nav2 params file (merge the costmap ones with yours) and run the two
# mask servers and the two filter info servers (nav2_map_server: map_server and
# costmap_filter_info_server), as Nav2's keepout and speed-filter tutorials do. Paths are where
# the files were written; change them if you move the files.
map_server:
  ros__parameters:
    yaml_filename: {_q(str(map_yaml_path))}

# keepout: the crisp free space outside the inner alpha-cut at alpha = {alpha:g} ({method} mu)
keepout_filter_mask_server:
  ros__parameters:
    topic_name: {_q(keep_mask)}
    frame_id: map
    yaml_filename: {_q(str(keepout_yaml))}
keepout_costmap_filter_info_server:
  ros__parameters:
    type: {KEEPOUT_TYPE}
    filter_info_topic: {_q(keep_info)}
    mask_topic: {_q(keep_mask)}
    base: 0.0
    multiplier: 1.0

# speed limit, percent of the maximum: base + multiplier * mask = 100 - {-100 * multiplier:g} * mu
speed_filter_mask_server:
  ros__parameters:
    topic_name: {_q(speed_mask)}
    frame_id: map
    yaml_filename: {_q(str(speed_yaml))}
speed_costmap_filter_info_server:
  ros__parameters:
    type: {SPEED_PERCENT_TYPE}
    filter_info_topic: {_q(speed_info)}
    mask_topic: {_q(speed_mask)}
    base: {base!r}
    multiplier: {multiplier!r}

global_costmap:
  global_costmap:
    ros__parameters:
      filters: ["keepout_filter", "speed_filter"]
      keepout_filter:
        plugin: "nav2_costmap_2d::KeepoutFilter"
        enabled: true
        filter_info_topic: {_q(keep_info)}
      speed_filter:
        plugin: "nav2_costmap_2d::SpeedFilter"
        enabled: true
        filter_info_topic: {_q(speed_info)}
        speed_limit_topic: /speed_limit
      # static_layer: trinary_costmap: false reads the map's mu as cost near walls

controller_server:
  ros__parameters:
    speed_limit_topic: /speed_limit
"""


def write_nav2(directory: str | os.PathLike, name: str, raster: MembershipRaster, *, mode: str = "scale",
               alpha: float = 0.0, min_speed: float = DEFAULT_MIN_SPEED, resolution_m: float | None = None,
               origin_m: tuple[float, float] | None = None) -> Nav2Files:
    """Write the Nav2 map, the keepout and speed masks and the params snippet (module doc).

    ``resolution_m`` and ``origin_m``: the raster's in metres (Nav2 works in metres), when its unit
    is not. Every file is checked before any is written, images before the YAML that names them.
    """
    if mode not in MODES:
        raise ValueError(f"Nav2 mode must be one of {', '.join(MODES)}, got {mode!r}")
    if not 0.0 <= alpha <= 1.0:
        raise ValueError(f"alpha must be in [0, 1], got {alpha!r}")
    if not (math.isfinite(min_speed) and 0.0 <= min_speed < 100.0):
        raise ValueError(f"the minimum speed must be a percentage in [0, 100), got {min_speed!r}")
    paths = nav2_paths(directory, name, mode)
    check_outputs(*paths, inputs=())
    res = float(resolution_m if resolution_m is not None else raster.resolution)
    origin = (*(origin_m if origin_m is not None else raster.origin), 0.0)
    if not (math.isfinite(res) and res > 0):
        raise MapFileError(paths[0], f"resolution must be positive, got {res!r}")
    comment = f"fuzzybrep fuzzy B-rep map, {raster.resolution:g} {raster.unit}/pixel, mu by {raster.method}"
    base, multiplier = speed_filter_coefficients(min_speed)
    values = map_values(raster)
    speed = speed_values(raster)
    if mode == "scale":
        images = [scale_png(values), trinary_pgm(keepout_values(raster, alpha), comment), scale_png(speed)]
        modes, thresholds = ["scale", "trinary", "scale"], [(1.0, 0.0), (OCCUPIED_THRESH, FREE_THRESH), (1.0, 0.0)]
    else:
        images = [raw_pgm(values, comment), trinary_pgm(keepout_values(raster, alpha), comment), raw_pgm(speed, comment)]
        modes, thresholds = ["raw", "trinary", "raw"], [(OCCUPIED_THRESH, FREE_THRESH)] * 3
    for k in range(3):
        yaml_path, image_path = paths[2 * k], paths[2 * k + 1]
        write_atomic(image_path, images[k])
        occ, free = thresholds[k]
        write_atomic(yaml_path, map_yaml(image_path.name, res, origin, False, occ, free, modes[k]).encode())
    write_atomic(paths[6], params_yaml(paths, name, alpha, base, multiplier, raster.method).encode("utf-8"))
    return Nav2Files(*paths, mode=mode, alpha=alpha, speed_base=base, speed_multiplier=multiplier)


__all__ = ["DEFAULT_MIN_SPEED", "FREE_MAX", "MODES", "Nav2Files", "keepout_values", "map_values", "nav2_paths",
           "params_yaml", "raw_pgm", "scale_png", "speed_filter_coefficients", "speed_values", "trinary_pgm",
           "write_nav2"]
