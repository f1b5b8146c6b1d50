"""The rings a map's pictures and messages draw: the crisp boundary and the α-cuts' polygons, as
closed (k, 2) arrays, shared by the ROS 2 bag and the Foxglove MCAP writers."""

from __future__ import annotations

import numpy as np
import shapely

from ..brep import FRONTIER


def polygon_rings(geom) -> list[np.ndarray]:
    """Every ring (exterior, then its holes) of a (Multi)Polygon, as (k, 2) arrays without the
    closing point repeated."""
    out = []
    for part in shapely.get_parts(geom):
        if part.is_empty or part.geom_type != "Polygon":
            continue
        for ring in (part.exterior, *part.interiors):
            xy = np.asarray(ring.coords)[:-1, :2]
            if len(xy) >= 3:
                out.append(xy)
    return out


def layers(fuzzy, cuts) -> list[dict]:
    """What a viewer draws, one layer a dict: ``name`` (crisp, frontier, alpha-0.5-inner, ...),
    ``rings`` (closed loops, (k, 2) each) or ``segments`` ((m, 2, 2), the frontier edges), the α
    and the role. The crisp boundary is the map's rings as stored; α = 1 cuts are that, and left out."""
    crisp = fuzzy.crisp
    segs = []
    for r in crisp.rings:
        i = np.flatnonzero(r.kinds == FRONTIER)
        if len(i):
            segs.append(np.stack((r.vertices[i], r.vertices[(i + 1) % len(r)]), axis=1))
    out = [{"name": "crisp", "role": "crisp", "alpha": 1.0, "rings": [r.vertices for r in crisp.rings]},
           {"name": "frontier", "role": "frontier", "alpha": 1.0,
            "segments": np.concatenate(segs) if segs else np.zeros((0, 2, 2))}]
    for c in cuts:
        if c.alpha >= 1.0:
            continue
        for role, geom in (("inner", c.inner), ("outer", c.outer)):
            out.append({"name": f"alpha-{c.alpha:g}-{role}", "role": role, "alpha": float(c.alpha),
                        "method": c.method, "rings": polygon_rings(geom)})
    return out


__all__ = ["layers", "polygon_rings"]
