"""Figures of maps with matplotlib: free space, holes, edge kinds, robot poses, fuzzy bands."""

from __future__ import annotations

import os

import numpy as np
import shapely

from .brep import FRONTIER, BRepMap, Ring

FREE = "#dbe9f6"
OBSTACLE_EDGE = "#1f3a5f"
FRONTIER_EDGE = "#e07b39"
#: the support band (0 < μ): the viewer's and the SVG's amber, not the frontier's orange
BAND = "#f2c46d"
INNER = "#2b7bba"
OUTER = "#c0392b"


def _agg():
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg", "ps", "cairo"):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def fill_geometry(ax, geom, **kw) -> None:
    """Fill a (Multi)Polygon with holes on a matplotlib axis."""
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path

    for g in shapely.get_parts(geom):
        if g.is_empty or g.geom_type != "Polygon":
            continue
        rings = [np.asarray(g.exterior.coords)] + [np.asarray(h.coords) for h in g.interiors]
        verts = np.vstack(rings)
        codes = np.concatenate([[Path.MOVETO] + [Path.LINETO] * (len(r) - 2) + [Path.CLOSEPOLY] for r in rings])
        ax.add_patch(PathPatch(Path(verts, codes), **kw))


def draw_edges(ax, rings: list[Ring], lw: float = 0.8) -> None:
    """Edges coloured by kind: obstacle (dark) or frontier (orange)."""
    from matplotlib.collections import LineCollection

    segs, colors = [], []
    for r in rings:
        v = r.vertices
        segs.append(np.stack((v, np.roll(v, -1, axis=0)), axis=1))
        colors.append(np.where(r.kinds == FRONTIER, 1, 0))
    if not segs:
        return
    segs = np.concatenate(segs)
    c = np.concatenate(colors)
    palette = np.array([OBSTACLE_EDGE, FRONTIER_EDGE])
    ax.add_collection(LineCollection(segs, colors=palette[c], linewidths=lw))


def draw_map(ax, crisp: BRepMap, poses: np.ndarray | None = None, title: str | None = None) -> None:
    fill_geometry(ax, crisp.to_shapely(), facecolor=FREE, edgecolor="none")
    draw_edges(ax, crisp.rings)
    if poses is not None and len(poses):
        ax.plot(poses[:, 0], poses[:, 1], "-", color="#2a9d8f", lw=0.6, alpha=0.8, label="robot path")
    x0, y0, x1, y1 = crisp.to_shapely().bounds
    pad = 0.03 * max(x1 - x0, y1 - y0)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_aspect("equal")
    ax.set_xlabel(f"x [{crisp.unit}]")
    ax.set_ylabel(f"y [{crisp.unit}]")
    if title:
        ax.set_title(title)


def _map_figure(plt, crisp: BRepMap):
    """A figure 10 inches wide, as tall as the map's aspect asks (within reason)."""
    x0, y0, x1, y1 = crisp.to_shapely().bounds
    aspect = (y1 - y0) / max(x1 - x0, 1e-9)
    return plt.subplots(figsize=(10, max(3.5, min(14, 10 * aspect))))


def draw_band(ax, fuzzy, alphas=(0.5,)) -> list:
    """The support band (α = 0: from the inner to the outer polygons) shaded, and the inner and outer
    α-cuts of ``alphas`` outlined; returns legend handles. The α-cuts are ``fuzzy.alpha_cut``'s
    default method, which the legend names."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    support = fuzzy.alpha_cut(0.0)
    fill_geometry(ax, support.band, facecolor=BAND, edgecolor="none", alpha=0.85)
    handles = [Patch(facecolor=BAND, alpha=0.85, label=f"support band, μ > 0 ({support.method} α-cut at 0)")]
    for a in alphas:
        cut = fuzzy.alpha_cut(a)
        for geom, colour, role in ((cut.inner, INNER, "inner"), (cut.outer, OUTER, "outer")):
            for part in shapely.get_parts(geom):
                for ring in (part.exterior, *part.interiors):
                    xy = np.asarray(ring.coords)
                    ax.plot(xy[:, 0], xy[:, 1], color=colour, lw=0.35)
            handles.append(Line2D([], [], color=colour, lw=0.8, label=f"{role} α-cut, α = {a:g}"))
    return handles


def save_map_figure(path: str | os.PathLike, crisp: BRepMap, poses: np.ndarray | None = None, title: str | None = None,
                    dpi: int = 150, fuzzy=None) -> None:
    """A picture of a map: free space filled, obstacle edges dark, frontier edges orange; with
    ``fuzzy``, its support band shaded and the α-cuts at 0.5 outlined under the crisp edges."""
    plt = _agg()
    from matplotlib.lines import Line2D

    fig, ax = _map_figure(plt, crisp)
    draw_map(ax, crisp, poses, title)
    band = draw_band(ax, fuzzy) if fuzzy is not None else []
    if fuzzy is not None:
        draw_edges(ax, crisp.rings)  # the crisp boundary over the band
    handles = band + [Line2D([], [], color=OBSTACLE_EDGE, label="obstacle edge"),
                      Line2D([], [], color=FRONTIER_EDGE, label="frontier edge")]
    if poses is not None and len(poses):
        handles.append(Line2D([], [], color="#2a9d8f", label="robot path"))
    _legend(ax, handles)
    _save(fig, path, dpi)


def _legend(ax, handles) -> None:
    """The legend under the map, outside the axes: a map fills its axes, and inside them the
    legend hid part of it wherever it went (freiburg-079's corridors, an ACES spike)."""
    # below the tick labels and the axis label: some 40 points under the axes, whatever its height
    below = 40 / max(ax.get_position().height * ax.figure.get_figheight() * 72, 1.0)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -below), ncol=min(3, len(handles)),
              fontsize=8, frameon=False)


def _format(path: str | os.PathLike) -> str:
    return os.path.splitext(os.fspath(path))[1].lstrip(".").lower() or "png"


def check_figure_path(path: str | os.PathLike) -> None:
    """MapFileError now if a figure cannot be saved at ``path``: a format matplotlib does not
    write (named by the extension; none means PNG), or a place that cannot be written. Commands
    check before their work, so that it is not lost to a typo in the picture's name."""
    from matplotlib.backend_bases import FigureCanvasBase

    from .errors import MapFileError
    from .formats.files import check_writable

    formats = FigureCanvasBase.get_supported_filetypes()
    if _format(path) not in formats:
        raise MapFileError(path, f"cannot draw a figure as .{_format(path)}: give one of "
                                 f"{', '.join('.' + f for f in sorted(formats))}")
    check_writable(path)


def _save(fig, path, dpi) -> None:
    """Lay the figure out, save it atomically (a half-written picture never replaces a good one)
    and close it (pyplot keeps every open figure alive)."""
    import io

    import matplotlib.pyplot as plt

    from .formats.files import write_atomic

    try:
        fig.tight_layout()
        buf = io.BytesIO()
        fig.savefig(buf, format=_format(path), dpi=dpi, bbox_inches="tight")  # the legend lies below the axes
        write_atomic(path, buf.getvalue())
    finally:
        plt.close(fig)


SAFE = "#b7e4c7"
PATH = "#d62828"


def save_plan_figure(path: str | os.PathLike, crisp: BRepMap, safe, plans, title: str | None = None,
                     dpi: int = 150) -> None:
    """A picture of planned paths: the map, the safe region they keep to, and the paths."""
    plt = _agg()
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    fig, ax = _map_figure(plt, crisp)
    draw_map(ax, crisp, None, title)
    fill_geometry(ax, safe, facecolor=SAFE, edgecolor="#2d6a4f", lw=0.3, alpha=0.9)
    handles = [Patch(facecolor=FREE, label="crisp free space"), Patch(facecolor=SAFE, label="safe region"),
               Line2D([], [], color=OBSTACLE_EDGE, label="obstacle edge"),
               Line2D([], [], color=FRONTIER_EDGE, label="frontier edge")]
    colors = [PATH, "#6a4c93", "#1982c4"]
    for k, p in enumerate(plans):
        c = colors[k % len(colors)]
        ax.plot(p.path[:, 0], p.path[:, 1], "-", color=c, lw=1.6)
        ax.plot(*p.path[0], "o", color=c, ms=5)
        ax.plot(*p.path[-1], "*", color=c, ms=9)
        handles.append(Line2D([], [], color=c, lw=1.6, label=f"{p.mode} path, {p.length:.3g} {p.unit}"))
    _legend(ax, handles)
    _save(fig, path, dpi)


def save_track_figure(path: str | os.PathLike, crisp: BRepMap, poses: np.ndarray, confidence: np.ndarray,
                      usable: np.ndarray, truth: np.ndarray | None = None, title: str | None = None,
                      dpi: int = 150) -> None:
    """A picture of a localised track on its map: the track coloured by confidence (the mean
    membership grade of each scan's endpoints), poses not aligned to the map (``usable`` False:
    lost, or before global localisation converged) in grey, and the true poses if known."""
    plt = _agg()
    from matplotlib.lines import Line2D

    fig, ax = _map_figure(plt, crisp)
    draw_map(ax, crisp, None, title)
    handles = [Line2D([], [], color=OBSTACLE_EDGE, label="obstacle edge"),
               Line2D([], [], color=FRONTIER_EDGE, label="frontier edge")]
    if truth is not None and len(truth):
        ax.plot(truth[:, 0], truth[:, 1], "-", color="#6c757d", lw=0.8, alpha=0.7)
        handles.append(Line2D([], [], color="#6c757d", label="the log's own poses"))
    ax.plot(poses[:, 0], poses[:, 1], "-", color="#2a9d8f", lw=0.5, alpha=0.6)
    ok = np.asarray(usable, bool)
    sc = ax.scatter(poses[ok, 0], poses[ok, 1], c=confidence[ok], cmap="viridis", vmin=0, vmax=1, s=6, zorder=3)
    if (~ok).any():
        ax.scatter(poses[~ok, 0], poses[~ok, 1], c="#adb5bd", s=6, zorder=3)
        handles.append(Line2D([], [], color="#adb5bd", marker="o", ls="", label="not aligned to the map"))
    ax.plot(*poses[0, :2], "o", color="#2a9d8f", ms=6, mfc="none")
    fig.colorbar(sc, ax=ax, shrink=0.6, label="confidence (mean μ of the endpoints)")
    _legend(ax, handles)
    _save(fig, path, dpi)
