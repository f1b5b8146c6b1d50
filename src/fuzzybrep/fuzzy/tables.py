"""The fuzzy vertex and edge tables of a ring (thesis Tables 4.1 and 4.3), read from the proper
polygons of its support offsets."""

from __future__ import annotations

import numpy as np

from .sweep import proper_polygon


def support_polygons(fz) -> list[tuple]:
    """Per ring, the proper polygons of its inner and outer support offsets (α = 0)."""
    out = []
    for ln, own in zip(fz.lines, fz.stack["own"]):
        out.append((proper_polygon(ln.vertices, ln.vin, int(own), +1, kept=True),
                    proper_polygon(ln.vertices, ln.vout, int(own), -1, kept=True)))
    return out


def vertex_table(fz, k: int = 0) -> dict[str, np.ndarray]:
    """Table 4.1 of ring k (0: principal polygon; ``ring_names`` order): columns as arrays.

    XOUT/YOUT and XIN/YIN are NaN (NULL) where the vertex does not survive on the proper
    polygon of the support offset; T, U, V, W stay, since the vertex may survive at higher α.
    """
    ln, ring = fz.lines[k], fz.rings[k]
    pin, pout = fz.support_polygons[k]
    vin, vout = ln.vin.copy(), ln.vout.copy()
    vin[~pin.vertex_kept] = np.nan
    vout[~pout.vertex_kept] = np.nan
    return {
        "VERTEX": np.arange(1, len(ring) + 1),
        "X": ln.vertices[:, 0], "Y": ln.vertices[:, 1],
        "XOUT": vout[:, 0], "YOUT": vout[:, 1],
        "XIN": vin[:, 0], "YIN": vin[:, 1],
        "T": ln.T, "U": ln.U, "V": ln.V, "W": ln.W,
        "FM": ring.fm.copy(),
    }


def edge_table(fz, k: int = 0) -> dict[str, np.ndarray]:
    """Table 4.3 of ring k: 1-based vertex indices of each edge and of its outer and inner edges.

    0 stands for NULL (a deleted vertex, or an edge none of which survives on the proper
    polygon); EDGE_OUT/EDGE_IN carry the edge number when some of the edge survives.
    """
    ring = fz.rings[k]
    n = len(ring)
    pin, pout = fz.support_polygons[k]
    e = np.arange(1, n + 1)
    nxt = np.roll(e, -1)
    return {
        "EDGE": e, "VSTART": e, "VEND": nxt,
        "EDGE_OUT": np.where(pout.edge_kept, e, 0),
        "VOUT_START": np.where(pout.vertex_kept, e, 0),
        "VOUT_END": np.where(np.roll(pout.vertex_kept, -1), nxt, 0),
        "EDGE_IN": np.where(pin.edge_kept, e, 0),
        "VIN_START": np.where(pin.vertex_kept, e, 0),
        "VIN_END": np.where(np.roll(pin.vertex_kept, -1), nxt, 0),
        "KIND": ring.kinds.copy(),
    }