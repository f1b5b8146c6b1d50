"""A small synthetic floor for the export and viewer tests.

The floor: two rooms and a corridor (10 × 6 m of free space), three obstacles (a desk, a pillar, a
triangle with a sharp corner whose offsets fold), a doorway whose edge is a frontier, scan poses
along the corridor and a planned path. Every vertex lies on the millimetre grid, so that the
viewer's payload (coordinates in mm) holds it exactly.
"""

from __future__ import annotations

import numpy as np
import shapely

from fuzzybrep.brep import FRONTIER, BRepMap, Region, Ring
from fuzzybrep.fuzzy.map import FuzzyBRepMap, fuzzify
from fuzzybrep.fuzzy.membership import Triangular

TME = 0.2


def floor_crisp() -> BRepMap:
    free = shapely.union_all([shapely.box(0, 0, 4, 4), shapely.box(6, 0, 10, 4), shapely.box(3.9, 1.5, 6.1, 2.5),
                              shapely.box(1, 4, 2, 6)])
    holes = [shapely.box(0.8, 0.8, 2.0, 1.4), shapely.box(7.5, 2.5, 7.9, 2.9),
             shapely.Polygon([(2.6, 2.2), (3.4, 3.4), (2.3, 3.0)])]
    g = shapely.orient_polygons(shapely.Polygon(free.exterior, [h.exterior for h in holes]))
    crisp = BRepMap.from_shapely(g, "m")
    # the top of the dead-end corridor (y = 6) is a frontier: nothing was seen beyond it
    shell = crisp.principal
    v = np.round(shell.vertices, 3)
    kinds = np.zeros(len(v), np.uint8)
    top = (np.abs(v[:, 1] - 6) < 1e-9) & (np.abs(np.roll(v, -1, axis=0)[:, 1] - 6) < 1e-9)
    kinds[top] = FRONTIER
    assert top.sum() == 1
    holes = tuple(Ring(np.round(h.vertices, 3)) for h in crisp.holes)
    return BRepMap((Region(Ring(v, kinds), holes),), "m")


def floor_map() -> FuzzyBRepMap:
    """The floor fuzzified with TME 0.2 m, and a wider function (0.35 m) on the frontier's vertices."""
    return fuzzify(floor_crisp(), tme=TME, frontier_mf=Triangular(0.35))


def floor_poses() -> np.ndarray:
    """(S, 4) x, y, heading, t: along the rooms and the corridor."""
    x = np.linspace(0.6, 9.4, 23)
    y = 2.0 + 0.6 * np.sin(x)
    heading = np.arctan2(np.gradient(y), np.gradient(x))
    return np.column_stack((x, y, heading, np.arange(len(x), dtype=float)))


FLOOR_PATH = [[0.5, 0.5], [3.0, 2.0], [5.0, 2.0], [8.5, 3.5]]
