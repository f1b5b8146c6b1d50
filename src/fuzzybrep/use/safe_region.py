"""The safe region: where the centre of a round robot of some radius may go, at confidence α.

    free  = the inner α-cut: free at confidence α (principal polygon shrunk, holes grown)
    safe  = free shrunk by the robot's radius                 (thesis 4.2: a safety margin)

snapped to a grid of about 1e-10 of the map's size, so that GEOS's later overlays (the planner's
visibility graph, its checks) see no vertices that rounding left 1e-15 apart.
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from ..brep import LARGEST, BRepMap
from ..errors import PlanError
from ..fuzzy.map import DEFAULT_METHOD, FuzzyBRepMap, check_alpha, check_method
from ..geometry import polygonal

#: segments per quarter circle where the radius shrink rounds an obstacle's corner
QUAD_SEGS = 6


#: the free space is buffered by radius × this, so that no point of the safe region comes
#: nearer than the radius to its edge (``shrink``): 2 % more margin along straight walls
RADIUS_FACTOR = 1 / (math.cos(3 * math.pi / (8 * QUAD_SEGS)) - 1e-3)


#: chords per quarter circle of the exact α-cut planned in (``free_space``)
EXACT_CUT_QUAD_SEGS = 8


#: GEOS needs a little slack: coordinates are snapped to a grid of about 1e-10 of the map's size
#: (merging vertices that rounding left 1e-15 apart), and paths are checked against the safe
#: region grown by ``RELATIVE_TOLERANCE`` times the map's size
RELATIVE_TOLERANCE = 1e-9


def free_space(source, alpha: float = 0.0, method: str = DEFAULT_METHOD) -> shapely.Geometry:
    """The space free at confidence α: a fuzzy map's inner α-cut; a crisp map or a Shapely
    (Multi)Polygon as it is (α and method do not apply to them, but a bad one is refused).

    The exact α-cut is drawn with ``EXACT_CUT_QUAD_SEGS`` chords per quarter circle, not the 32 of
    ``FuzzyBRepMap.alpha_cut``: every chord's end is a reflex corner of the free space, and the
    visibility graph's cost grows with their square (Intel, α = 0.3: 47 000 corners and 44 s
    with 32, 14 000 and 4 s with 8). Its rounded corners are then up to 1.1 % of the α-cut's
    distance more generous than circles (2 mm for a TME of 0.2 m).
    """
    applies(source, alpha, method)
    method = check_method(method)
    if isinstance(source, FuzzyBRepMap):
        check_size(source.crisp_geometry, source.unit)
        if method == "exact":
            return source.alpha_cut(alpha, method, quad_segs=EXACT_CUT_QUAD_SEGS).inner
        return source.alpha_cut(alpha, method).inner
    if isinstance(source, BRepMap):
        return check_size(source.to_shapely(), source.unit)
    if isinstance(source, shapely.Geometry):
        check_size(source)
        return polygonal(shapely.make_valid(source) if not source.is_valid else source)
    raise TypeError(f"cannot plan in a {type(source).__name__}: give a FuzzyBRepMap, a BRepMap or a Shapely polygon")


def safe_region(source, alpha: float = 0.0, radius: float = 0.0, method: str = DEFAULT_METHOD) -> shapely.Geometry:
    """Where the centre of a round robot of ``radius`` may go: the free space at confidence α
    (``free_space``) shrunk by the radius. Thesis 4.2: at α = 0 this is the inner bound of the
    support, "the space that the robot can navigate freely" at the highest confidence.

    ``method``: ``safe`` (default) the conservative sweep, which never reaches into the exact
    band; ``thesis`` (or ``sweep``) the thesis's single normal vertex method, whose cut does at
    sharp corners; ``exact`` the Extension principle's (the crisp map buffered).
    """
    return shrink(free_space(source, alpha, method), check_radius(radius))


def applies(source, alpha, method: str) -> float | None:
    """α checked, for a fuzzy map; None for a crisp map or a polygon, where α does not apply (nor
    the method), though a bad α or method given for one is refused all the same."""
    check_method(method)
    if isinstance(source, FuzzyBRepMap):
        return check_alpha(alpha)
    if alpha is not None:
        check_alpha(alpha)
    return None


def check_size(geom: shapely.Geometry, unit: str = "m") -> shapely.Geometry:
    """``geom``, if its coordinates lie within ±``LARGEST``; else PlanError."""
    if not geom.is_empty:
        reach = float(np.abs(geom.bounds).max())
        if reach > LARGEST:
            raise PlanError(f"the map's coordinates reach {reach:.3g} {unit}: the planner works within "
                            f"±{LARGEST:g} {unit}, beyond which its arithmetic overflows")
    return geom


def check_radius(radius) -> float:
    try:
        r = float(radius)
    except (TypeError, ValueError):
        raise PlanError(f"radius must be a number ≥ 0, got {radius!r}") from None
    if not (math.isfinite(r) and r >= 0):
        raise PlanError(f"radius must be a finite number ≥ 0, got {radius!r}")
    return r


def extent_of(geom: shapely.Geometry) -> float:
    if geom.is_empty:
        return 1.0
    x0, y0, x1, y1 = geom.bounds
    return max(x1 - x0, y1 - y0, 1e-300)


def snap_grid(extent: float) -> float:
    # a power of two: coordinates already on it (integers, halves, ...) stay bit for bit
    return 2.0 ** math.floor(math.log2(extent * RELATIVE_TOLERANCE / 8))


def floating(geom: shapely.Geometry) -> shapely.Geometry:
    """``geom`` without a fixed precision model (``shapely.set_precision`` leaves one on its result),
    coordinates unchanged: GEOS computes a buffer of such a geometry on its grid, so a shrink by
    0.3 on a 0.1 grid came out empty, and on a 0.5 grid larger than the region itself."""
    return shapely.set_precision(geom, 0) if shapely.get_precision(geom) > 0 else geom


def shrink(free: shapely.Geometry, radius: float) -> shapely.Geometry:
    """free ⊖ disc(radius), never larger than the exact erosion, snapped and oriented.

    GEOS's buffer rounds an obstacle's corner with chords whose ends lie on the circle, so a
    chord's middle is only d·cos(θ/2) from the corner; θ is the corner's angle over the number
    of chords, which GEOS rounds to the nearest integer, so θ can reach 1.5 × 90°/q (measured
    on the Intel map: 0.957·d for q = 4, 0.989·d for q = 8). Buffering by
    d = radius / (cos(3π/8q) − 10⁻³) keeps every point at least ``radius`` from the edge of the
    free space. (GEOS also simplifies its input first, but only where that moves the curve away.)
    """
    free = floating(free)
    extent = extent_of(free)
    if radius > 0:
        if radius * RADIUS_FACTOR >= extent:
            # nothing lies that far inside; and GEOS overflows on a radius near the largest float
            return shapely.MultiPolygon()
        free = shapely.buffer(free, -radius * RADIUS_FACTOR, quad_segs=QUAD_SEGS)
    safe = polygonal(shapely.set_precision(polygonal(free), snap_grid(extent)))
    # keep the snapped coordinates but not GEOS's fixed precision model: with it, a later
    # buffer by the tolerance can drop a hole (GEOS 3.14)
    safe = shapely.set_precision(safe, 0)
    return shapely.orient_polygons(safe, exterior_cw=False) if not safe.is_empty else safe
