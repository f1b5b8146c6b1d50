"""A reader of map_server maps that follows nav2_map_server's loading rules (map_io.cpp), written
from its documentation and source, apart from fuzzybrep's own reader, for the Nav2 export tests.

Two releases differ, and both are implemented:

- ``humble`` (loadMapFromFile to 2024): per pixel, shade = the mean of R, G, B (and, in trinary
  mode, of the opacity too when the image has alpha) over the maximum; occ = 1 − shade, or shade
  with ``negate``; trinary: occ > occupied_thresh → 100, occ < free_thresh → 0, else −1; scale:
  alpha not opaque → −1, occ > occupied_thresh → 100, occ < free_thresh → 0, else
  rint((occ − free)/(occupied − free)·100); raw: round(shade·255), 0..100 kept, else −1 (negate
  does not apply).
- ``rolling`` (from 2025): the image is converted to 8-bit grey first; occ = 1 − grey/255 (grey/255
  with negate) in float; occ ≥ occupied_thresh → 100, then occ ≤ free_thresh → 0, else −1; scale
  grades the values strictly between as round(...·100); in trinary and scale modes a pixel with
  alpha < 255 is −1; raw: the grey value, outside 0..100 → −1.

Both flip the image so that row 0 of the grid is the bottom of the map. The YAML is read with a
general YAML reader (ruamel), as yaml-cpp reads it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

RELEASES = ("humble", "rolling")


@dataclass
class Grid:
    data: np.ndarray  # (h, w) int8, row 0 the BOTTOM (nav_msgs/OccupancyGrid order)
    resolution: float
    origin: tuple[float, float, float]
    mode: str

    def area(self, value) -> float:
        return float(np.count_nonzero(self.data == value)) * self.resolution ** 2


def load(yaml_path, release: str = "rolling") -> Grid:
    from PIL import Image
    from ruamel.yaml import YAML

    yaml_path = Path(yaml_path)
    doc = YAML(typ="safe").load(yaml_path.read_text())
    image = doc["image"]
    if not str(image).startswith("/"):
        image = yaml_path.parent / image
    res = float(doc["resolution"])
    origin = tuple(float(v) for v in doc["origin"])
    assert len(origin) == 3
    free_t, occ_t = float(doc["free_thresh"]), float(doc["occupied_thresh"])
    mode = doc.get("mode", "trinary")
    assert mode in ("trinary", "scale", "raw"), mode
    negate = bool(int(doc["negate"]))
    with Image.open(image) as im:
        has_alpha = im.mode in ("RGBA", "LA", "PA") or "transparency" in im.info
        rgba = np.asarray(im.convert("RGBA"), dtype=np.float64)
    rgb, alpha = rgba[..., :3], rgba[..., 3]
    if release == "humble":
        channels = [rgb[..., 0], rgb[..., 1], rgb[..., 2]]
        if mode == "trinary" and has_alpha:
            channels.append(alpha)  # MaxRGB - alphaQuantum: the opacity
        shade = sum(channels) / len(channels) / 255.0
        occ = shade if negate else 1.0 - shade
        out = np.full(shade.shape, -1, np.int16)
        if mode == "raw":
            v = np.round(shade * 255)
            out = np.where((v >= 0) & (v <= 100), v, -1).astype(np.int16)
        else:
            if mode == "scale":
                out = np.rint((occ - free_t) / (occ_t - free_t) * 100.0).astype(np.int16)
            out[occ > occ_t] = 100
            out[occ < free_t] = 0
            if mode == "scale" and has_alpha:
                out[alpha != 255] = -1
    elif release == "rolling":
        # ImageMagick's grey of R = G = B is that value; our images are all grey
        grey = np.rint(0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]).astype(np.uint8)
        if mode == "raw":
            v = grey.astype(np.int16)
            out = np.where(v <= 100, v, -1).astype(np.int16)
        else:
            n = grey.astype(np.float32) / np.float32(255.0)
            if not negate:
                n = np.float32(1.0) - n
            out = np.full(n.shape, -1, np.int16)
            out[n >= np.float32(occ_t)] = 100
            out[n <= np.float32(free_t)] = 0
            if mode == "scale":
                between = (n > np.float32(free_t)) & (n < np.float32(occ_t))
                scaled = (n - np.float32(free_t)) / np.float32(occ_t - free_t) * np.float32(100.0)
                # Eigen's round: half away from zero
                out[between] = (np.sign(scaled[between]) * np.floor(np.abs(scaled[between]) + 0.5)).astype(np.int16)
            if has_alpha:
                out[alpha < 255] = -1
    else:
        raise ValueError(release)
    return Grid(out.astype(np.int8)[::-1].copy(), res, origin, mode)
