"""A fuzzy B-rep map as a standalone SVG picture, built as a string (no matplotlib).

The picture is in map units: the viewBox is the map's bounding box (grown by the outer support)
with y flipped, so that north is up, and every coordinate is written as x, −y rounded to the
map's coordinate quantum (``coordinate_quantum``: a millimetre for maps in metres). Layers, from
the bottom: the support band (α = 0: outer polygons shaded, inner polygons over them in the free
colour, so the shade is exactly outer − inner), the inner and outer α-cut outlines of the other
levels, the crisp boundary (obstacle edges dark, frontier edges orange). Strokes keep their
width in screen pixels at any zoom (``vector-effect: non-scaling-stroke``).
"""

from __future__ import annotations

import math
import numpy as np
import shapely

from ..brep import FRONTIER, BRepMap
from .escape import xml_text
from .export import coordinate_quantum

FREE = "#ffffff"
SUPPORT = "#f6d49a"
BACKGROUND = "#e4e4e4"
OBSTACLE_EDGE = "#1f3a5f"
FRONTIER_EDGE = "#e07b39"
INNER = "#2b7bba"
OUTER = "#c0392b"


def _decimals(quantum: float) -> int:
    return max(0, -math.floor(math.log10(quantum) + 1e-9))


def path_data(geom, decimals: int) -> str:
    """SVG path data of a (Multi)Polygon's rings or a (Multi)LineString, y flipped."""
    out = []
    for part in shapely.get_parts(geom):
        if part.is_empty:
            continue
        if part.geom_type == "Polygon":
            rings = [part.exterior, *part.interiors]
            close = True
        else:
            rings = [part]
            close = False
        for ring in rings:
            xy = np.asarray(ring.coords)[:, :2]
            if close and len(xy) > 1 and np.array_equal(xy[0], xy[-1]):
                xy = xy[:-1]
            out.append(_polyline(xy, decimals, close))
    return "".join(out)


def _polyline(xy: np.ndarray, decimals: int, close: bool) -> str:
    # −0 would print as "-0": add 0.0 to make every zero positive
    pts = np.round(np.column_stack((xy[:, 0], -xy[:, 1])), decimals) + 0.0
    fmt = f"{{:.{decimals}f}}"
    body = "L".join(f"{fmt.format(x)} {fmt.format(y)}" for x, y in pts)
    return f"M{body}{'Z' if close else ''}"


def _frontier_paths(crisp: BRepMap, decimals: int) -> str:
    out = []
    for r in crisp.rings:
        for i in np.flatnonzero(r.kinds == FRONTIER):
            out.append(_polyline(r.vertices[[i, (i + 1) % len(r)]], decimals, False))
    return "".join(out)


def svg_document(fuzzy, cuts, support=None, *, title: str | None = None, width_px: int = 1000) -> str:
    """The SVG text of a fuzzy map with its α-cuts.

    cuts     AlphaCuts whose inner and outer polygons are outlined (α = 1 is the crisp
             boundary itself and is not outlined again)
    support  the α = 0 cut for the shaded support band (default: the cut at α = 0 in ``cuts``,
             else computed with the method of the first cut)
    """
    crisp = fuzzy.crisp
    cuts = list(cuts)
    if support is None:
        support = next((c for c in cuts if c.alpha == 0.0), None)
        if support is None:
            support = fuzzy.alpha_cut(0.0, cuts[0].method if cuts else "safe")
    x0, y0, x1, y1 = shapely.bounds(shapely.union(support.outer, fuzzy.crisp_geometry))
    extent = max(x1 - x0, y1 - y0, 1e-300)
    q = coordinate_quantum(crisp.unit, extent)
    dec = _decimals(q)
    pad = 0.02 * extent
    vx, vy, vw, vh = x0 - pad, -(y1 + pad), (x1 - x0) + 2 * pad, (y1 - y0) + 2 * pad
    height_px = max(1, round(width_px * vh / vw))
    f = f"{{:.{dec}f}}"
    name = title or "fuzzy B-rep map"
    levels = ", ".join(f"{c.alpha:g}" for c in cuts)
    desc = (f"fuzzy B-rep map: {crisp.n_vertices} vertices, {crisp.n_holes} holes, unit {crisp.unit}, y up; "
            f"shaded: support band (alpha = 0); outlines: inner (blue) and outer (red) alpha-cuts at alpha = {levels}")
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{width_px}" height="{height_px}" '
        f'viewBox="{f.format(vx)} {f.format(vy)} {f.format(vw)} {f.format(vh)}">',
        f"<title>{xml_text(name)}</title>",  # a map's unit and a file's name are text, whatever they hold
        f"<desc>{xml_text(desc)}</desc>",
        "<style>path{vector-effect:non-scaling-stroke;stroke-linejoin:round}"
        ".cut{fill:none;stroke-width:1}.crisp{fill:none;stroke-width:1.2}</style>",
        f'<rect class="background" x="{f.format(vx)}" y="{f.format(vy)}" width="{f.format(vw)}" '
        f'height="{f.format(vh)}" fill="{BACKGROUND}"/>',
        '<g id="support" fill-rule="evenodd" stroke="none">',
        f'<path class="support" fill="{SUPPORT}" d="{path_data(support.outer, dec)}"/>',
        f'<path class="free" fill="{FREE}" d="{path_data(support.inner, dec)}"/>',
        "</g>",
        '<g id="alpha-cuts">',
    ]
    for c in cuts:
        if c.alpha >= 1.0:
            continue  # the crisp boundary, drawn below
        opacity = f"{0.35 + 0.65 * c.alpha:.2f}"
        for role, geom, colour in (("inner", c.inner, INNER), ("outer", c.outer, OUTER)):
            lines.append(f'<path class="cut {role}" data-alpha="{c.alpha:g}" stroke="{colour}" '
                         f'stroke-opacity="{opacity}" d="{path_data(geom, dec)}"/>')
    lines += [
        "</g>",
        '<g id="crisp">',
        f'<path class="crisp obstacle" stroke="{OBSTACLE_EDGE}" fill-rule="evenodd" '
        f'd="{path_data(fuzzy.crisp_geometry, dec)}"/>',
    ]
    frontier = _frontier_paths(crisp, dec)
    if frontier:
        lines.append(f'<path class="crisp frontier" stroke="{FRONTIER_EDGE}" d="{frontier}"/>')
    lines += ["</g>", "</svg>", ""]
    return "\n".join(lines)


__all__ = ["path_data", "svg_document"]
