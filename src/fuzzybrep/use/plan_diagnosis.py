"""Why a point is not free, said to the user: inside an obstacle, in the fuzzy boundary's band at
this α (with μ there), too close to the edge for the robot's radius; the nearest free point,
printed so that it reads back free; and about the α from which the point would be free.

Functions of a ``plan.Planner`` (``pl``).
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from ..errors import FuzzyBrepError, PointNotFreeError
from ..fuzzy import safe_cut
from ..fuzzy.map import DEFAULT_METHOD
from .safe_region import QUAD_SEGS, RADIUS_FACTOR


def where(pl) -> str:
    parts = []
    if pl.alpha is not None:
        parts.append(f"α = {pl.alpha:g}")
    parts.append(f"radius {pl.radius:g}")
    if pl.method is not None:
        parts.append(pl.method)
    return f" ({', '.join(parts)})"


def not_free(pl, which: str, p: np.ndarray) -> PointNotFreeError:
    pt = shapely.Point(p)
    if pl.safe.is_empty:
        return PointNotFreeError(which, p, f"the safe region{where(pl)} is empty")
    nearest = np.asarray(shapely.shortest_line(pt, pl.safe).coords)[1]
    distance = float(shapely.distance(pt, pl.safe))
    why, alpha_needed = why_not_free(pl, p, pt)
    return PointNotFreeError(which, p, f"{why}; the nearest free point is ({shown_free(pl, pt, nearest)}), "
                                       f"{distance:.3g} {pl.unit} away", distance, nearest, alpha_needed)


def shown_free(pl, pt: shapely.Point, nearest: np.ndarray) -> str:
    """A free point next to ``nearest``, as text that is free read back.

    The nearest point lies on the safe region's edge: printed to 4 significant digits it was
    rounded out of the region two times in three, and given back as a start it was refused.
    So: the nearest point of the region shrunk by a ten-thousandth of the map's size (only
    about ``nearest``, cheaply), printed to a tenth of that; by less where the region is
    thinner (the tip of a sliver); the nearest point itself if nothing works."""
    x, y = nearest
    for k in range(4):
        step = pl.extent * 1e-4 / 10**k
        decimals = max(0, math.ceil(-math.log10(step / 10)))
        near = shapely.clip_by_rect(pl.safe, x - 20 * step, y - 20 * step, x + 20 * step, y + 20 * step)
        inner = shapely.buffer(near, -step, quad_segs=2)
        if inner.is_empty:
            continue
        q = np.asarray(shapely.shortest_line(pt, inner).coords)[1]
        text = f"{q[0]:.{decimals}f}, {q[1]:.{decimals}f}"
        if shapely.intersects_xy(pl.safe, *map(float, text.split(", "))):
            return text
    return f"{x:.6g}, {y:.6g}"


def why_not_free(pl, p: np.ndarray, pt: shapely.Point) -> tuple[str, float | None]:
    r = pl.radius
    in_free = bool(shapely.intersects(pl.free, pt))
    fuzzy = pl.fuzzy
    if fuzzy is None:
        if not in_free:
            return "it lies outside the free space", None
        return too_close(pl, pt, pl.free_boundary, "the edge of the free space"), None
    crisp = fuzzy.crisp_geometry
    if not shapely.intersects(crisp, pt):
        shells = [shapely.Polygon(reg.shell.closed_coords()) for reg in fuzzy.crisp.regions]
        if any(s.intersects(pt) for s in shells):
            return "it lies inside an obstacle (a hole of the map)", None
        return "it lies outside the map", None
    edge = shapely.boundary(crisp)
    near = float(shapely.distance(pt, edge))
    if near < r or (near < r * RADIUS_FACTOR and not safe_in(pl, crisp, p)):
        return (f"{too_close(pl, pt, edge, 'the crisp boundary')}, so no α frees it "
                f"(α = 1 is the crisp map)"), None
    need = alpha_needed(pl, fuzzy, p)
    if not in_free:
        mu = float(fuzzy.membership(p[None], pl.method or DEFAULT_METHOD)[0])
        why = (f"it lies in the fuzzy boundary's band at α = {pl.alpha:g} (μ = {mu:.3g} there)")
    else:
        why = too_close(pl, pt, pl.free_boundary, f"the edge of the space free at α = {pl.alpha:g}")
    if need is not None and need > (pl.alpha or 0.0):
        why += f"; it is free from about α = {need:.3g} on" + (f" with radius {r:g}" if r > 0 else "")
    return why, need


def too_close(pl, pt: shapely.Point, edge: shapely.Geometry, name: str) -> str:
    """Why a point of the free space is not safe: it is closer than the radius to ``edge``,
    or, between the radius and radius × ``RADIUS_FACTOR`` from it, within the margin that the
    safe region keeps (``shrink``)."""
    r = pl.radius
    if shapely.distance(pt, edge) < r:
        return f"it is closer than the radius {r:g} to {name}"
    return f"it is within the radius {r:g} plus the planner's 2 % margin ({r * RADIUS_FACTOR:.4g} in all) of {name}"


def safe_in(pl, free: shapely.Geometry, p: np.ndarray) -> bool:
    """Whether ``p`` is in ``free`` shrunk as the safe region is (``shrink``), worked out
    near ``p`` only: the disc the shrink keeps clear about ``p`` is all that decides."""
    d = pl.radius * RADIUS_FACTOR
    near = shapely.clip_by_rect(free, p[0] - 3 * d, p[1] - 3 * d, p[0] + 3 * d, p[1] + 3 * d)
    return bool(shapely.intersects_xy(shapely.buffer(near, -d, quad_segs=QUAD_SEGS), p[0], p[1]))


def alpha_needed(pl, fuzzy, p: np.ndarray) -> float | None:
    """About the smallest α at which ``p`` is safe: the largest μ over the disc that the safe
    region keeps clear around its points, of radius × ``RADIUS_FACTOR`` (``shrink``).

    For a point of the crisp free space, μ is the largest α at which it is still outside the
    inner α-cut, so the disc fits in the inner α-cut from α = max μ over the disc on. μ is
    sampled where its largest values lie: on the disc's edge, densely and then more densely
    about the largest samples, and where the α-cut's corners cross the disc (each
    moves along a line from its crisp vertex, and μ peaks narrowly about that line). With
    48 samples of the edge this missed by up to 0.24 on the real maps, and a disc of the
    radius alone put every answer too low by the 2 %. Exact at radius 0; else an estimate,
    not a bound: on the real maps the planner frees the point from within 0.01 of it, mostly
    a little below (GEOS's chords round corners nearer than radius × ``RADIUS_FACTOR``).
    """
    method = pl.method or DEFAULT_METHOD
    R = pl.radius * RADIUS_FACTOR
    if R == 0:
        # μ = 1 on the crisp boundary, which is free at α = 1 (the crisp map, edge included)
        return float(fuzzy.membership(p[None], method)[0])
    a = np.linspace(0, 2 * np.pi, EDGE_SAMPLES, endpoint=False)
    step = 2 * np.pi / EDGE_SAMPLES
    edge = fuzzy.membership(p + R * np.column_stack((np.cos(a), np.sin(a))), method)
    inner = [p[None], corner_crossings(fuzzy, p, R, method)]
    for frac, n in ((2 / 3, 32), (1 / 3, 16)):
        b = np.linspace(0, 2 * np.pi, n, endpoint=False)
        inner.append(p + frac * R * np.column_stack((np.cos(b), np.sin(b))))
    best = max(edge.max(), fuzzy.membership(np.vstack(inner), method).max())
    for _ in range(2):
        # about the largest samples, 32 steps across the step either side of each
        a = (a[np.argsort(edge)[-16:], None] + np.linspace(-step, step, 33)).ravel()
        step /= 16
        edge = fuzzy.membership(p + R * np.column_stack((np.cos(a), np.sin(a))), method)
        best = max(best, edge.max())
    return float(best) if best < 1 else None


#: ``alpha_needed``: samples of the disc's edge before refining about the largest
EDGE_SAMPLES = 256


def corner_crossings(fuzzy, p: np.ndarray, R: float, method: str = DEFAULT_METHOD) -> np.ndarray:
    """Where the inner α-cut corners of ``method``, moving from α = 0 to α = 1, last lie in the
    disc of radius ``R`` about ``p``: the point of each corner's path (a segment from its place at
    α = 0 to its crisp vertex) nearest the crisp vertex within the disc. (k, 2). The safe cut's
    corners move along its stored directions (``safe_cut.corner_paths``); the exact cut's, and
    the safe cut's with several functions, are taken as the thesis's (μ is sampled there too)."""
    paths = safe_cut.corner_paths(fuzzy) if method == "safe" else None
    if paths is None:
        v, _ = fuzzy.offset_vertices(1.0)  # the crisp vertices
        w, _ = fuzzy.offset_vertices(0.0)
    else:
        v, w = paths
    d, f = w - v, v - p
    a = np.einsum("ij,ij->i", d, d)
    b = 2 * np.einsum("ij,ij->i", f, d)
    c = np.einsum("ij,ij->i", f, f) - R * R
    disc = b * b - 4 * a * c
    ok = (a > 0) & (disc >= 0)
    root = np.sqrt(np.where(ok, disc, 0))
    safe_a = np.where(ok, a, 1)
    t0, t1 = (-b - root) / (2 * safe_a), (-b + root) / (2 * safe_a)
    ok &= (t0 <= 1) & (t1 >= 0)
    t = np.clip(t0, 0, 1)[ok]
    return v[ok] + t[:, None] * d[ok]


#: what ``connecting`` tries when start and goal lie in different pieces: higher α at the same
#: radius, smaller radii at the same α (fractions of the radius asked for)
ALPHA_STEP = 0.25
RADIUS_FRACTIONS = (0.75, 0.5, 0.25, 0.0)


def connecting(pl, s: np.ndarray, g: np.ndarray, planner) -> str:
    """A hint for a NoConnectionError: the nearest settings, trying α in steps of ALPHA_STEP
    above the planner's and then 1 (same radius) and the radius cut to RADIUS_FRACTIONS of its own (same α),
    at which start and goal lie in one piece of the safe region; "" if none does or the planner
    has no fuzzy map. ``planner(fuzzy, α, radius, method)`` makes the planners (``plan.planner``,
    which keeps them with the map: a plan at the hinted setting reuses its α-cut and shrink)."""
    fuzzy = pl.fuzzy
    if fuzzy is None:
        return ""

    def joined(alpha, radius) -> bool:
        try:
            other = planner(fuzzy, alpha, radius, pl.method)
            return other.piece(s, "start") == other.piece(g, "goal")
        except FuzzyBrepError:
            return False

    a0 = pl.alpha or 0.0
    hints = []
    # the steps above α, and α = 1 (the crisp map) last when the steps do not land on it
    steps = [float(round(a, 6)) for a in np.arange(a0 + ALPHA_STEP, 1.0 - 1e-9, ALPHA_STEP)]
    for a in steps + ([1.0] if a0 < 1 else []):
        if joined(a, pl.radius):
            hints.append(f"at α = {a:g} (radius {pl.radius:g}) they are joined")
            break
    if pl.radius > 0:
        for f in RADIUS_FRACTIONS:
            if joined(a0, pl.radius * f):
                hints.append(f"at radius {pl.radius * f:g} (α = {a0:g}) they are joined")
                break
    if not hints:
        return (f"; neither a higher α (in steps of {ALPHA_STEP:g}) nor a smaller radius joins them"
                if pl.radius > 0 or a0 < 1 else "")
    return "; " + " and ".join(hints)
