"""Clearance mode of the planner: a path along the medial axis of the safe region (the GVD of
thesis 2.2.3), entered from start and goal, with straight steps off the axis priced so that the
path keeps to it.

Functions of a ``plan.Planner`` (``pl``).
"""

from __future__ import annotations

import numpy as np
import shapely

from .visibility import shortest_chain

#: a straight step off the medial axis costs this many times its length
OFF_AXIS_COST = 4.0
#: how many nearest medial-axis nodes to try to step onto from start and goal, and from each corner
ENTRIES = 24
LINKS = 4


def clearance_path(pl, s: np.ndarray, g: np.ndarray, piece: int) -> np.ndarray | None:
    """The cheapest path when moving along the medial axis costs its length and any straight
    step off it (between corners of the visibility graph, from a corner onto the axis, or
    from start to goal) costs ``OFF_AXIS_COST`` times its length; stepping from start and
    goal onto the axis costs its length. So the path keeps to the axis, and leaves it only
    where the axis breaks (a pinch of the safe region narrower than the spacing) or where
    following it would be a long way round."""
    axis, graph = pl.medial, pl.visibility
    if len(axis.nodes) == 0:
        return None
    n, m = len(axis.nodes), len(graph.triangulation.points)
    S, G = n + m, n + m + 1
    es, ds = entries(pl, s)
    eg, dg = entries(pl, g)
    vs, dvs = graph.reach(s, piece)
    vg, dvg = graph.reach(g, piece)
    lv, ln, ld = pl.axis_links
    k = OFF_AXIS_COST
    # nodes: medial axis 0..n-1, triangulation vertices n..n+m-1, start, goal
    rows = np.concatenate((axis.edges[:, 0], n + graph.edges[:, 0], n + lv,
                           np.full(len(es) + len(vs) + 1, S), eg, n + vg))
    cols = np.concatenate((axis.edges[:, 1], n + graph.edges[:, 1], ln,
                           es, n + vs, [G], np.full(len(eg) + len(vg), G)))
    direct = float(np.hypot(*(g - s))) if pl.covers(np.vstack((s, g))) else np.inf
    w = np.concatenate((axis.lengths, k * graph.lengths, k * ld, ds, k * dvs, [k * direct], dg, k * dvg))
    ok = np.isfinite(w)
    chain = shortest_chain(rows[ok], cols[ok], w[ok], n + m + 2, S, G)
    if chain is None:
        return None
    path = np.vstack((s, np.vstack((axis.nodes, graph.triangulation.points))[chain[1:-1]], g))
    # the axis zigzags by about the spacing: straighten within it where that stays inside
    smooth = np.asarray(shapely.simplify(shapely.linestrings(path), pl.spacing).coords)
    for candidate in (smooth, path):
        if pl.covers(candidate):
            if np.isfinite(direct) and not pl.free.is_empty:
                # a short hop across an open hall: stepping onto the axis and off again can pass
                # nearer the walls than the straight line does (ACES: 2 cm nearer); the line is
                # then both shorter and clearer
                line = np.vstack((s, g))
                straight, along = (shapely.distance(shapely.LineString(c), pl.free_boundary) for c in (line, candidate))
                if straight >= along:
                    return line
            return candidate
    return None


def axis_links(pl) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each corner of the visibility graph joined to the nearest medial-axis nodes it sees:
    (corner vertices, axis nodes, lengths)."""
    graph, axis = pl.visibility, pl.medial
    v = np.unique(graph.vertex)
    k = min(LINKS, len(axis.nodes))
    d, i = pl.medial_tree.query(graph.triangulation.points[v], k=k)
    v, d, i = np.repeat(v, k), d.reshape(-1), i.reshape(-1)
    seen = graph.triangulation.visible(v, axis.nodes[i])
    return v[seen], i[seen], d[seen]


def entries(pl, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest medial-axis nodes that ``p`` sees, and their distances."""
    k = min(ENTRIES, len(pl.medial.nodes))
    d, i = pl.medial_tree.query(p, k=k)
    d, i = np.atleast_1d(d), np.atleast_1d(i)
    segs = shapely.linestrings(np.stack((np.broadcast_to(p, (k, 2)), pl.medial.nodes[i]), axis=1))
    ok = shapely.covers(pl.covering, segs)
    return i[ok], d[ok]
