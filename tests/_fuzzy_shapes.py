"""Polygons for the fuzzy B-rep tests: the thesis's Table 4.1 example, and hypothesis strategies
for random maps with holes, sharp and reflex corners and narrow corridors."""

from __future__ import annotations

import numpy as np
import shapely
from hypothesis import strategies as st

from fuzzybrep.brep import BRepMap, Region, Ring

#: Table 4.1: the eight crisp vertices (mm), listed clockwise, and the printed fuzzy columns
TABLE_4_1_VERTICES = np.array([(300, 300), (300, 2700), (2400, 2400), (2100, 1800), (1200, 1800), (1200, 1200),
                               (2400, 1200), (2400, 300)], float)
#: V: XOUT, YOUT, XIN, YIN, T, U, V, W as printed
TABLE_4_1 = np.array([
    (158.58, 158.58, 441.42, 441.42, -141.4, 441.42, -141.42, 441.42),
    (168.96, 2851.1, 431.04, 2548.9, -131.0, 431.04, 151.09, 2548.9),
    (2577.2, 2492.8, 2222.8, 2307.2, 177.16, 2222.8, 92.82, 2307.2),
    (2205.1, 1629.9, 1994.9, 1970.1, 105.15, 1994.9, -170.1, 1970.1),
    (1341.4, 1658.6, 1058.6, 1941.4, 141.42, 1058.6, -141.42, 1941.4),
    (1341.4, 1341.4, 1058.6, 1058.6, 141.42, 1058.6, 141.42, 1058.6),
    (2541.4, 1341.4, 2258.6, 1058.6, 141.42, 2258.6, 141.42, 1058.6),
    (2541.4, 158.58, 2258.6, 441.4, 141.42, 2258.6, -141.42, 441.42),
])


def thesis_map() -> BRepMap:
    """The Figure 4.10 polygon with its vertices in the thesis's (clockwise) order, in mm."""
    return BRepMap((Region(Ring(TABLE_4_1_VERTICES)),), unit="mm")


def dumbbell(corridor: float = 0.5) -> shapely.Polygon:
    """Two 4×4 rooms joined by a 2-long corridor: its inner offset splits in two (Figure 4.9)."""
    rooms = shapely.union_all([shapely.box(0, 0, 4, 4), shapely.box(6, 0, 10, 4),
                               shapely.box(3.9, 2 - corridor / 2, 6.1, 2 + corridor / 2)])
    return shapely.orient_polygons(rooms)


@st.composite
def star(draw, cx: float = 0.0, cy: float = 0.0, rmin: float = 0.5, rmax: float = 10.0, nmax: int = 16):
    """A star-shaped ring: random radii at increasing angles make sharp and reflex corners."""
    n = draw(st.integers(3, nmax))
    gaps = np.array(draw(st.lists(st.floats(0.05, 1.0), min_size=n, max_size=n)))
    ang = np.cumsum(gaps) / gaps.sum() * 2 * np.pi
    r = np.array(draw(st.lists(st.floats(rmin, rmax), min_size=n, max_size=n)))
    return np.column_stack((cx + r * np.cos(ang), cy + r * np.sin(ang)))


@st.composite
def star_map(draw):
    shell = shapely.Polygon(draw(star()))
    holes: list[shapely.Polygon] = []
    for _ in range(draw(st.integers(0, 3))):
        cx, cy = draw(st.floats(-5, 5)), draw(st.floats(-5, 5))
        h = shapely.Polygon(draw(star(cx, cy, 0.2, 2.5, 10)))
        if (h.is_valid and h.within(shell) and shell.exterior.distance(h) > 1e-2
                and all(h.distance(o) > 1e-2 for o in holes)):
            holes.append(h)
    return shapely.Polygon(shell.exterior, [h.exterior for h in holes])


@st.composite
def corridor_map(draw):
    """Rooms joined by narrow corridors, with obstacles close to the walls."""
    w = draw(st.floats(0.05, 1.5))
    length = draw(st.floats(0.2, 4.0))
    parts = [shapely.box(0, 0, 4, 4), shapely.box(4 + length, 0, 8 + length, 4),
             shapely.box(3.5, 2 - w / 2, 4.5 + length, 2 + w / 2)]
    if draw(st.booleans()):
        parts.append(shapely.box(1, 4 - 0.1, 1 + w, 7))  # a dead-end corridor
    free = shapely.union_all(parts)
    holes = []
    for _ in range(draw(st.integers(0, 3))):
        x, y = draw(st.floats(0.05, 3.5)), draw(st.floats(0.05, 3.5))
        s = draw(st.floats(0.05, 1.0))
        h = shapely.box(x, y, x + s, y + s * draw(st.floats(0.2, 1.0)))
        if h.within(free) and free.exterior.distance(h) > 1e-2 and all(h.distance(o) > 1e-2 for o in holes):
            holes.append(h)
    return shapely.Polygon(free.exterior, [h.exterior for h in holes])


def crisp_maps():
    """Valid crisp maps of every kind, as BRepMaps (unit m)."""
    return st.one_of(star_map(), corridor_map()).filter(lambda g: g.is_valid and g.area > 0).map(BRepMap.from_shapely)
