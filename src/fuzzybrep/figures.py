"""The thesis's figures of a fuzzy B-rep map, redrawn for a demo run (matplotlib, Agg, atomic).

- ``alpha_stack``       Figure 4.2: the α-cuts at 0, 0.2, ..., 1 stacked in 3-D, beside the same
                        cuts as nested outlines, on a window of the map.
- ``support``           Figure 5.10: the support (μ = 0) of the whole map.
- ``membership_surface`` Figure 5.12: μ over a window as a 3-D surface (``FuzzyBRepMap.membership``
                        on a grid, vectorised).
- ``map_vs_floorplan``  Figure 5.13: the support over the true floor plan, the true walls drawn,
                        seen walls the support misses and walls in the safe region marked.

Each takes a ``DemoResult`` (``fuzzybrep.demo``) and a path, and writes a PNG atomically.
"""

from __future__ import annotations

import os

import numpy as np
import shapely

from .plot import FREE, OBSTACLE_EDGE, _agg, _save, draw_edges, fill_geometry

ALPHAS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
BAND = "#f4a261"
TRUE_WALL = "#222222"
GLASS = "#2a9df4"
MISSED = "#d62828"
UNSAFE = "#9b00d9"
ROUTE = "#2a9d8f"
#: windows (x0, y0, x1, y1) on the built-in floor: section B's lift lobby (Figure 4.2), its south
#: corners (Figure 5.12), and the glass half of section C (Figure 5.13 shows "the upper part of
#: section C")
BUILTIN_FEATURE = (6.0, 18.0, 14.0, 28.0)
BUILTIN_CORNER = (7.6, 17.8, 13.0, 22.2)
BUILTIN_SECTION_C = (28.0, 33.0, 44.0, 39.5)
#: section labels, inside the block beside each passage
BUILTIN_SECTIONS = {"A": (27.5, 11.0), "B": (14.5, 22.5), "C": (27.5, 34.0), "D": (43.5, 22.5)}
DPI = 130
#: (elevation, azimuth) of the membership surface: from above the free space
MEMBERSHIP_VIEW = (50, -115)


def windows(result) -> dict[str, tuple[float, float, float, float]]:
    """Windows on the map, (x0, y0, x1, y1): ``feature`` (Figure 4.2), ``corner`` (Figure 5.12) and
    ``zoom`` (Figure 5.13). Fixed on the built-in floor; elsewhere squares of 10 m and 4 m round the
    route's start, kept inside the map."""
    if result.world_source == "built-in":
        return {"feature": BUILTIN_FEATURE, "corner": BUILTIN_CORNER, "zoom": BUILTIN_SECTION_C}
    bounds = result.maps["filtered"].fuzzy.crisp_geometry.bounds
    start = result.route.waypoints[0]
    big = _square(bounds, start, 10.0)
    return {"feature": big, "corner": _square(bounds, start, 4.0), "zoom": big}


def _square(bounds, centre, side: float) -> tuple[float, float, float, float]:
    """A square of ``side`` (at most the map's extent) round ``centre``, shifted to lie inside ``bounds``."""
    x0, y0, x1, y1 = bounds
    side = min(side, max(x1 - x0, y1 - y0))
    c = []
    for v, lo, hi in ((centre[0], x0, x1), (centre[1], y0, y1)):
        c.append(float(np.clip(v, lo + side / 2, hi - side / 2)) if hi - lo > side else (lo + hi) / 2)
    return (c[0] - side / 2, c[1] - side / 2, c[0] + side / 2, c[1] + side / 2)


def _lines_xy(geom):
    """Every boundary ring or line of a geometry as (n, 2) arrays."""
    out = []
    for g in shapely.get_parts(geom):
        if g.is_empty:
            continue
        if g.geom_type == "Polygon":
            out += [np.asarray(g.exterior.coords)] + [np.asarray(r.coords) for r in g.interiors]
        elif g.geom_type in ("LineString", "LinearRing"):
            out.append(np.asarray(g.coords))
        elif g.geom_type in ("MultiPolygon", "MultiLineString", "GeometryCollection"):
            out += _lines_xy(g)
    return out


def _clip(geom, box):
    return shapely.intersection(geom, shapely.box(*box)) if box is not None else geom


def _frame(ax, box, title=None):
    ax.set_xlim(box[0], box[2])
    ax.set_ylim(box[1], box[3])
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if title:
        ax.set_title(title, fontsize=10)


def _legend_place(result) -> str:
    """Inside the central block on the built-in floor; wherever matplotlib finds room elsewhere."""
    return "center" if result.world_source == "built-in" else "best"


def _padded(bounds, pad=1.0):
    x0, y0, x1, y1 = bounds
    return (x0 - pad, y0 - pad, x1 + pad, y1 + pad)


def alpha_stack(result, path: str | os.PathLike, alphas=ALPHAS) -> None:
    """Figure 4.2: every α-cut's inner and outer polygons at height α, and the same from above."""
    plt = _agg()
    from matplotlib import cm
    from matplotlib.lines import Line2D

    fz = result.maps["filtered"].fuzzy
    box = windows(result)["feature"]
    colors = cm.viridis(np.linspace(0.0, 0.9, len(alphas)))
    fig = plt.figure(figsize=(13, 6))
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    ax2 = fig.add_subplot(1, 2, 2)
    fill_geometry(ax2, _clip(fz.crisp_geometry, box), facecolor=FREE, edgecolor="none")
    for a, c in zip(alphas, colors):
        cut = fz.alpha_cut(a)
        for side, ls in ((cut.inner, "-"), (cut.outer, "--")):
            for xy in _lines_xy(_clip(shapely.boundary(side), box)):
                ax3.plot(xy[:, 0], xy[:, 1], np.full(len(xy), a), ls, color=c, lw=0.9)
                ax2.plot(xy[:, 0], xy[:, 1], ls, color=c, lw=0.8)
    ax3.set_xlim(box[0], box[2])
    ax3.set_ylim(box[1], box[3])
    ax3.set_zlim(0, 1)
    ax3.set_box_aspect((box[2] - box[0], box[3] - box[1], 0.6 * max(box[2] - box[0], box[3] - box[1])))
    ax3.set_xlabel("x [m]")
    ax3.set_ylabel("y [m]")
    ax3.set_zlabel("α (μ)")
    ax3.view_init(elev=28, azim=-60)
    ax3.set_title("α-cuts stacked by grade (core μ = 1 on top, support μ = 0 at the bottom)", fontsize=10)
    _frame(ax2, box, "the same α-cuts from above: inner (solid) and outer (dashed) polygons")
    handles = [Line2D([], [], color=c, label=f"α = {a:g}") for a, c in zip(alphas, colors)]
    ax2.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    fig.suptitle(f"Fuzzy B-rep map, α-cuts of the triangular membership function, TME = {result.tme_mm:.1f} mm "
                 "(cf. thesis Figure 4.2)", fontsize=11)
    _save(fig, path, DPI)


def support(result, path: str | os.PathLike) -> None:
    """Figure 5.10: the support band of the whole map, with its crisp boundary and the stops."""
    plt = _agg()
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    m = result.maps["filtered"]
    cut = m.support["safe"]
    box = _padded(cut.outer.bounds)
    fig, ax = plt.subplots(figsize=(12, 12 * (box[3] - box[1]) / (box[2] - box[0]) + 0.8))
    fill_geometry(ax, cut.inner, facecolor=FREE, edgecolor="none")
    fill_geometry(ax, cut.band, facecolor=BAND, edgecolor="none", alpha=0.9)
    draw_edges(ax, m.fuzzy.crisp.rings, lw=0.4)
    stops = result.poses[::2]
    ax.plot(stops[:, 0], stops[:, 1], "o", color=ROUTE, ms=3)
    if result.world_source == "built-in":
        for name, (x, y) in BUILTIN_SECTIONS.items():
            ax.text(x, y, name, fontsize=14, weight="bold", ha="center", va="center", color="#444444")
    _frame(ax, box, f"Support of the fuzzy B-rep map (μ = 0), TME = {result.tme_mm:.1f} mm: {len(result.scans)} "
                    f"scans over {result.route.length:.0f} m, {m.fuzzy.crisp.n_vertices} vertices, "
                    f"{m.fuzzy.crisp.n_holes} holes (cf. thesis Figure 5.10)")
    ax.legend(handles=[Patch(color=BAND, label="support band (0 < μ; the boundary lies here)"),
                       Patch(color=FREE, label="inner region at α = 0 (safe free space)"),
                       Line2D([], [], color=OBSTACLE_EDGE, label="crisp boundary (μ = 1)"),
                       Line2D([], [], color="#e07b39", label="crisp frontier edge"),
                       Line2D([], [], marker="o", ls="", color=ROUTE, label="stops (pose the map used)")],
              loc=_legend_place(result), fontsize=9)
    _save(fig, path, DPI)


def membership_surface(result, path: str | os.PathLike, n: int = 260) -> None:
    """Figure 5.12: μ of the fuzzy boundary over a window, as a 3-D surface (n samples across)."""
    plt = _agg()
    fz = result.maps["filtered"].fuzzy
    box = windows(result)["corner"]
    nx = n
    ny = max(2, int(round(n * (box[3] - box[1]) / (box[2] - box[0]))))
    X, Y = np.meshgrid(np.linspace(box[0], box[2], nx), np.linspace(box[1], box[3], ny))
    mu = fz.membership(np.column_stack((X.ravel(), Y.ravel()))).reshape(X.shape)
    fig = plt.figure(figsize=(11, 8))
    ax = fig.add_subplot(projection="3d")
    ax.plot_surface(X, Y, mu, cmap="viridis", rstride=1, cstride=1, linewidth=0, antialiased=False)
    for xy in _lines_xy(_clip(shapely.boundary(fz.crisp_geometry), box)):
        ax.plot(xy[:, 0], xy[:, 1], np.ones(len(xy)), color="#d62828", lw=1.2, label="crisp boundary (μ = 1)")
    ax.set_box_aspect((box[2] - box[0], box[3] - box[1], 0.5 * max(box[2] - box[0], box[3] - box[1])))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("μ")
    ax.set_zlim(0, 1)
    ax.view_init(*MEMBERSHIP_VIEW)
    ax.set_title(f"Membership of the fuzzy boundary, μ = 1 on the crisp boundary, 0 beyond ±TME = "
                 f"{result.tme_mm:.1f} mm (cf. thesis Figure 5.12)", fontsize=10)
    _save(fig, path, DPI)


def map_vs_floorplan(result, path: str | os.PathLike) -> None:
    """Figure 5.13: the support band over the true floor plan, whole and zoomed."""
    plt = _agg()
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Rectangle

    m = result.maps["filtered"]
    cut = m.support["safe"]
    world = result.world
    missed = shapely.difference(result.seen, cut.band)
    unsafe = shapely.intersection(world.walls, cut.inner)
    whole = _padded(shapely.union(world.free, cut.outer).bounds)
    zoom = windows(result)["zoom"]
    fig, axes = plt.subplots(2, 1, figsize=(12, 15), gridspec_kw={"height_ratios": [1.6, 1]})
    for ax, box, lw in ((axes[0], whole, 0.8), (axes[1], zoom, 1.4)):
        fill_geometry(ax, world.free, facecolor="#eeeeee", edgecolor="none")
        fill_geometry(ax, cut.band, facecolor=BAND, edgecolor="none", alpha=0.75)
        for xy in _lines_xy(world.walls):
            ax.plot(xy[:, 0], xy[:, 1], color=TRUE_WALL, lw=lw)
        for xy in _lines_xy(world.glass_walls):
            ax.plot(xy[:, 0], xy[:, 1], color=GLASS, lw=lw * 2.5)
        for geom, color in ((missed, MISSED), (unsafe, UNSAFE)):
            for xy in _lines_xy(geom):
                ax.plot(xy[:, 0], xy[:, 1], color=color, lw=lw * 3)
        _frame(ax, box)
    axes[0].add_patch(Rectangle(
        (zoom[0], zoom[1]), zoom[2] - zoom[0], zoom[3] - zoom[1], fill=False, ls=":", lw=1.2, color="#555555"))
    t = m.truth["safe"]
    axes[0].set_title(f"Support of the map (α = 0) over the true floor plan: {100 * t.support_coverage:.1f} % of the "
                      f"seen wall inside it, {t.unsafe_wall_length:.2f} m of wall in the safe region "
                      "(cf. thesis Figure 5.13)", fontsize=10)
    axes[1].set_title("zoom (dotted box above)", fontsize=10)
    axes[0].legend(handles=[Patch(color="#eeeeee", label="true free space"),
                            Patch(color=BAND, alpha=0.75, label="support band of the map"),
                            Line2D([], [], color=TRUE_WALL, label="true wall"),
                            Line2D([], [], color=GLASS, lw=3, label="true glass"),
                            Line2D([], [], color=MISSED, lw=3, label="seen wall outside the support"),
                            Line2D([], [], color=UNSAFE, lw=3, label="wall inside the safe region")],
                   loc=_legend_place(result), fontsize=9)
    _save(fig, path, DPI)


FIGURES = {
    "fig_alpha_stack.png": alpha_stack,
    "fig_support.png": support,
    "fig_membership_3d.png": membership_surface,
    "fig_map_vs_floorplan.png": map_vs_floorplan,
}
