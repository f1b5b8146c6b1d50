"""Polygon helpers shared by every stage: ring areas and orientation, the polygonal parts of an
overlay, clean-up of slivers, and assembling free space from shells and holes (Shapely 2)."""

from __future__ import annotations

import numpy as np
import shapely

from .errors import GeometryError


def signed_area(vertices: np.ndarray) -> float:
    """Shoelace area of a ring: positive when counter-clockwise."""
    x, y = vertices[:, 0], vertices[:, 1]
    # np.roll(a, -1) written out: the same array, without roll's overhead (some 7 µs a call, and
    # a map's every ring is checked when it is made: 2373 rings on Intel)
    return 0.5 * float(np.dot(x, np.concatenate((y[1:], y[:1]))) - np.dot(np.concatenate((x[1:], x[:1])), y))


def orientation(vertices: np.ndarray) -> int:
    """+1 for a counter-clockwise ring, −1 for a clockwise one; GeometryError if it has no area."""
    a = signed_area(vertices)
    if not np.isfinite(a) or a == 0:
        raise GeometryError("ring has no area, so it has no inside to offset into")
    return 1 if a > 0 else -1


def polygonal(geom) -> shapely.Geometry:
    """Only the polygonal parts of an overlay result, as a Polygon or MultiPolygon."""
    if geom is None or geom.is_empty:
        return shapely.MultiPolygon()
    if geom.geom_type in ("Polygon", "MultiPolygon"):
        return geom
    parts = [g for g in shapely.get_parts(geom) if g.geom_type in ("Polygon", "MultiPolygon") and not g.is_empty]
    if not parts:
        return shapely.MultiPolygon()
    return parts[0] if len(parts) == 1 else shapely.union_all(parts)


#: holes × shell vertices from which ``nests`` is asked before GEOS's is_valid: about 0.2 s of
#: is_valid. Below it is_valid alone is cheaper (Freiburg 079's principal polygon, 1669 vertices
#: and 2977 holes, takes 50 ms), and nests can fail on valid regions (a hole touching the shell
#: at a point), which then pay for both
NESTS_FROM = 20_000_000


def nests(shell: shapely.Geometry, holes) -> bool:
    """True if the holes (valid polygons) lie strictly inside the shell (a valid polygon without
    holes) and apart from each other, so that shell and holes make a valid polygon.

    A sufficient test, through the prepared shell's index and an STRtree of the holes: O(n log n).
    GEOS's is_valid tests every hole against the whole shell ring, O(holes × shell vertices),
    which is seconds for a 100000-vertex wall with 10000 obstacles. When this says False, ask
    is_valid (holes may still touch at points).
    """
    holes = np.asarray(holes, dtype=object)
    if not len(holes):
        return True
    shapely.prepare(shell)
    if not shapely.contains_properly(shell, holes).all():
        return False
    i, j = shapely.STRtree(holes).query(holes, predicate="intersects")
    return bool(np.all(i == j))


def clean(geom, min_area: float | None = None, *, valid: bool = False) -> shapely.Geometry:
    """The polygonal parts of an overlay result without zero-area pieces or holes (slits).

    GEOS overlays of polygons sharing edges can leave a hole of zero area along a shared edge, or
    a collapsed piece; such slivers are reported valid yet confuse later overlays, so they are
    dropped here. A result GEOS itself finds invalid (seen, rarely, as nested shells) is rebuilt
    by the area-preserving "structure" rule of make_valid. ``min_area`` defaults to 1e-12 of the
    square of the geometry's size. ``valid``: the caller knows the geometry is valid (the check
    costs O(holes × shell vertices) in GEOS).
    """
    g = polygonal(geom)
    if g.is_empty:
        return g
    if min_area is None:
        x0, y0, x1, y1 = g.bounds
        min_area = 1e-12 * max(x1 - x0, y1 - y0) ** 2
    if not valid and not g.is_valid:
        g = polygonal(shapely.make_valid(g, method="structure", keep_collapsed=False))
        if g.is_empty:
            return g
    parts = shapely.get_parts(g)
    area = shapely.area(parts)
    keep = parts[area > min_area]
    out = []
    for part in keep:
        holes = part.interiors
        if len(holes):
            ha = shapely.area(shapely.polygons(list(holes)))
            if np.any(ha <= min_area):
                part = shapely.Polygon(part.exterior, [h for h, a in zip(holes, ha) if a > min_area])
        out.append(part)
    if not out:
        return shapely.MultiPolygon()
    return out[0] if len(out) == 1 else shapely.MultiPolygon(out)


def free_space(shells: list, holes: list[list], disjoint_holes: bool = False) -> shapely.Geometry:
    """Union over regions of (shell polygon minus its hole polygons): the free space of an α-cut.

    When every part is a plain polygon and they nest properly (the usual case), the result is
    assembled directly without an overlay, which also keeps the crisp map bit-for-bit at α = 1.
    ``disjoint_holes``: the caller knows the holes do not overlap, so they need no union.
    """
    pieces = []
    for shell, hs in zip(shells, holes):
        hs = [h for h in hs if not h.is_empty]
        if shell.is_empty:
            continue
        if not hs:
            pieces.append(shell)
            continue
        if shell.geom_type == "Polygon" and not shell.interiors and all(
                h.geom_type == "Polygon" and not h.interiors for h in hs):
            g = shapely.Polygon(shell.exterior, [h.exterior for h in hs])
            if (len(hs) * shapely.get_num_coordinates(shell) > NESTS_FROM and nests(shell, hs)) or g.is_valid:
                pieces.append(g)
                continue
        obstacles = None
        if disjoint_holes:
            obstacles = shapely.multipolygons(np.concatenate([shapely.get_parts(h) for h in hs]))
            if not obstacles.is_valid:
                obstacles = None
        if obstacles is None:
            obstacles = shapely.union_all(hs)
        pieces.append(clean(shapely.difference(shell, obstacles)))
    pieces = [g for g in pieces if not g.is_empty]
    if not pieces:
        return shapely.MultiPolygon()
    if len(pieces) == 1:  # valid: a ring's proper polygon, checked above, or cleaned
        return clean(pieces[0], valid=True) if pieces[0].geom_type == "MultiPolygon" or pieces[0].interiors \
            else pieces[0]
    return clean(shapely.union_all(pieces))


def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(m,) Euclidean distance from each point p to its segment a–b, all (m, 2)."""
    ab, ap = b - a, p - a
    den = np.einsum("ij,ij->i", ab, ab)
    t = np.clip(np.einsum("ij,ij->i", ap, ab) / np.where(den > 0, den, 1.0), 0.0, 1.0)
    d = ap - t[:, None] * ab
    return np.hypot(d[:, 0], d[:, 1])
