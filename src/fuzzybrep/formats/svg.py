"""A fuzzy B-rep map as a standalone SVG picture, built as a string (no matplotlib).

The picture is in map units: the viewBox is the map's bounding box (grown by the outer support)
with y flipped, so that north is up, and every coordinate is written as x, −y rounded to the
map's coordinate quantum (``coordinate_quantum``: a millimetre for maps in metres). Layers, from
the bottom: the support band (α = 0: outer polygons shaded, inner polygons over them in the free
colour, so the shade is exactly outer − inner), the inner and outer α-cut outlines of the other
levels, the crisp boundary (obstacle edges dark, frontier edges orange); below the map a legend
and a scale bar. Stroke widths are real widths in map units, a pixel of the picture's nominal
width each (``width_px``): every renderer draws them alike (librsvg ignores CSS
``vector-effect: non-scaling-stroke``, which drew the lines 1 m wide outside browsers), and they
grow as one zooms in, as a drawing's lines do.
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
TEXT = "#222222"
#: stroke widths and legend sizes in pixels of the picture's nominal width
CRISP_PX, FRONTIER_PX, CUT_PX = 1.2, 2.0, 0.9
LEGEND_PX, FONT_PX = 64, 12


def scale_bar_length(extent: float) -> float:
    """A round length (1, 2 or 5 × 10^k) near a fifth of ``extent``, for the scale bar."""
    target = max(extent, 1e-300) / 5
    k = math.floor(math.log10(target))
    for m in (5, 2, 1):
        if m * 10.0 ** k <= target:
            return m * 10.0 ** k
    return 10.0 ** k


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
    """``M x y l dx dy dx dy …`` (``z`` if closed), y flipped: the first point absolute, the others
    as steps between the rounded points, so that the path is exact on the quantum's grid and a
    third shorter than absolute coordinates (librsvg refuses SVG files over 10 MB)."""
    q = 10.0 ** -decimals
    # integers of the quantum: the steps add up exactly; −0 would print as "-0"
    pts = np.rint(np.column_stack((xy[:, 0], -xy[:, 1])) / q).astype(np.int64)
    steps = np.diff(pts, axis=0)
    fmt = lambda v: _number(v, decimals)  # noqa: E731
    head = f"M{fmt(pts[0, 0])} {fmt(pts[0, 1])}"
    if len(steps):
        head += "l" + " ".join(f"{fmt(dx)} {fmt(dy)}" for dx, dy in steps.tolist())
    return head + ("z" if close else "")


def _number(k: int, decimals: int) -> str:
    """k quanta (10^−decimals) as the shortest decimal text: 1234 at 3 decimals is 1.234, 50 is .05."""
    if decimals == 0:
        return str(k)
    sign = "-" if k < 0 else ""
    whole, frac = divmod(abs(k), 10 ** decimals)
    frac_text = f"{frac:0{decimals}d}".rstrip("0")
    if not frac_text:
        return f"{sign}{whole}"
    return f"{sign}{whole if whole else ''}.{frac_text}"


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
    vx, vy, vw, mh = x0 - pad, -(y1 + pad), (x1 - x0) + 2 * pad, (y1 - y0) + 2 * pad
    u = vw / width_px  # one pixel of the picture, in map units
    vh = mh + LEGEND_PX * u  # the map, then the legend below it
    height_px = max(1, round(width_px * vh / vw))
    f = f"{{:.{dec}f}}"
    g = lambda v: f"{v:.9g}"  # noqa: E731  widths and legend coordinates
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
        f"<style>path{{stroke-linejoin:round;stroke-linecap:round}}.cut{{fill:none;stroke-width:{g(CUT_PX * u)}}}"
        f".crisp{{fill:none;stroke-width:{g(CRISP_PX * u)}}}.crisp.frontier{{stroke-width:{g(FRONTIER_PX * u)}}}"
        f"text{{font-family:'DejaVu Sans',Arial,Helvetica,sans-serif;font-size:{FONT_PX}px;fill:{TEXT}}}</style>",
        f'<rect class="background" x="{f.format(vx)}" y="{f.format(vy)}" width="{f.format(vw)}" '
        f'height="{f.format(mh)}" fill="{BACKGROUND}"/>',
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
    lines.append("</g>")
    lines += _legend(vx, vy + mh, vw, u, g, crisp.unit, levels, cuts[0].method if cuts else support.method)
    lines += ["</svg>", ""]
    return "\n".join(lines)


def _legend(x: float, y: float, width: float, u: float, g, unit: str, levels: str, method: str) -> list[str]:
    """The legend and the scale bar, in the band of LEGEND_PX pixels below the map.

    Drawn in a group scaled to pixels (``transform``), so that the text's font size is 12 there:
    a font size of a hundredth of a user unit, scaled up, comes out garbled in librsvg (hinting)."""
    out = [f'<g id="legend" transform="translate({g(x)} {g(y)}) scale({g(u)})">',
           f'<rect x="0" y="0" width="{g(width / u)}" height="{LEGEND_PX}" fill="#ffffff"/>']
    row1, row2 = 22, 48
    items = [("swatch", SUPPORT, "support band (α = 0)"), ("swatch", BACKGROUND, "outside the map"),
             ("line", OBSTACLE_EDGE, "obstacle edge"), ("line", FRONTIER_EDGE, "frontier edge"),
             ("line", INNER, "inner α-cut"), ("line", OUTER, "outer α-cut")]
    cx = 10.0
    for kind, colour, label in items:
        if kind == "swatch":
            out.append(f'<rect x="{g(cx)}" y="{row1 - 10}" width="18" height="12" fill="{colour}" '
                       f'stroke="#888888" stroke-width="0.6"/>')
        else:
            out.append(f'<path d="M{g(cx)} {row1 - 4}h18" stroke="{colour}" stroke-width="2.2"/>')
        out.append(f'<text x="{g(cx + 23)}" y="{row1}">{xml_text(label)}</text>')
        cx += 30 + 7.0 * len(label)
    out.append(f'<text x="10" y="{row2}">α-cuts at α = {xml_text(levels)} ({xml_text(method)}), outlines more opaque '
               f'as α grows; y up, unit {xml_text(unit)}</text>')
    # the scale bar, at the right of the second row; data-length in map units
    length = scale_bar_length(width)
    x1 = width / u - 14
    x0 = x1 - length / u
    out.append(f'<path class="scale-bar" data-length="{g(length)}" d="M{g(x0)} {row2 - 5}V{row2}H{g(x1)}V{row2 - 5}" '
               f'fill="none" stroke="{TEXT}" stroke-width="1.5"/>')
    out.append(f'<text x="{g((x0 + x1) / 2)}" y="{row2 - 8}" text-anchor="middle">{xml_text(f"{length:g} {unit}")}</text>')
    out.append("</g>")
    return out


__all__ = ["path_data", "scale_bar_length", "svg_document"]
