"""All rings of a fuzzy B-rep map stacked in flat arrays, so that an α-cut or a membership query is
a handful of array operations over every vertex at once, not a loop over rings."""

from __future__ import annotations

import numpy as np
import shapely

from ..brep import BRepMap


def ring_stack(crisp: BRepMap, lines, roles: list[str]) -> dict:
    """All rings' columns stacked, so that an α-cut is a handful of array operations."""
    rings = crisp.rings
    sizes = np.array([len(r) for r in rings])
    start = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    ring_of = np.repeat(np.arange(len(rings)), sizes)
    is_shell = np.repeat(np.array([r == "shell" for r in roles]), sizes)
    closed = np.concatenate([np.append(np.arange(s, s + n), s) for s, n in zip(start, sizes)])
    nxt = np.arange(len(ring_of)) + 1
    nxt[start + sizes - 1] = start
    V = np.vstack([ln.vertices for ln in lines])
    return {
        "V": V,
        "TV": np.vstack([np.column_stack((ln.T, ln.V)) for ln in lines]),
        "SI": np.concatenate([ln.support_in for ln in lines]),
        "fm": np.concatenate([r.fm for r in rings]),
        "shell": is_shell,
        "ring_of": ring_of,
        "start": start,
        "sizes": sizes,
        "closed": closed,
        "next": nxt,
        "closed_ring": ring_of[closed],
        "own": np.sign(np.add.reduceat(V[:, 0] * V[nxt, 1] - V[nxt, 0] * V[:, 1], start)).astype(np.int64),
        "ring_polys": shapely.polygons(shapely.linearrings(np.vstack([r.vertices for r in rings])[closed],
                                                           indices=ring_of[closed])),
    }
