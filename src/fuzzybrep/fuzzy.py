"""The fuzzy B-rep map: a crisp B-rep map, its membership-function table, and the sweep's lines.

``fuzzify(crisp, tme=...)`` turns a crisp map into a fuzzy one (thesis chapter 4): every vertex
gets its normal vertex and parametric line (Table 4.1), every edge its inner and outer edges
(Table 4.3), every function its row in Table 4.2. From these:

- ``alpha_cut(α)``: the inner polygons (free at confidence α: principal polygon shrunk, holes
  grown) and the outer polygons (free at possibility α: principal grown, holes shrunk), read from
  the lines in O(n) and made proper (thesis 4.1.2);
- ``membership(points)``: μ of the fuzzy boundary at each point;

both by the thesis's sweep (``method="sweep"``) or by the exact fuzzification of the Extension
principle (``method="exact"``, thesis 2.1.4: μ = membership function of the signed distance to
the crisp boundary, whose α-cuts are the map buffered with round joins), and
``approximation_error`` measures how far the first is from the second.

Only the crisp map and Table 4.2 are stored (``mapfile``); everything else is rebuilt on load.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely

from .brep import LARGEST, BRepMap, Ring, check_region, frontier_fm, validate_ring
from .errors import GeometryError, MapFileError, MembershipFunctionError
from .mapfile import MapFile, read_map, write_map
from .membership import DEFAULT_TME_M, THESIS_TME_MM, MembershipFunction, MembershipTable, Triangular
from .sweep import (ParametricLines, band_parameter, clean, folded_bands, free_space, in_hull,
                    normal_vertices_stacked, polygonal, proper_polygon)

SHELL = "shell"
HOLE = "hole"
METHODS = ("sweep", "exact")
#: rings of at most this many vertices are made proper in one vectorised GEOS pass
_SMALL_RING = 64
#: arcs of the exact α-cuts: segments per quarter circle (GEOS buffer's quad_segs)
EXACT_QUAD_SEGS = 32
#: membership functions with a support wider than ± this are refused (by ``fuzzify``): their
#: support polygons and α-cuts square distances, which passes the largest float from about
#: 1.3e154 on (a TME of 1e154 ended in OverflowError, 1e160 in GEOS exceptions); up to 1e150 the
#: tables, α-cuts and plans still work
WIDEST_SUPPORT = 1e150
_DEFAULT_TME = {"m": DEFAULT_TME_M, "mm": THESIS_TME_MM, "cm": DEFAULT_TME_M * 100}
#: the grids Table 5.3 compares with, 30, 20 and 10 cm, in each unit a map can be in
THESIS_GRID_CELLS = {"m": (0.3, 0.2, 0.1), "cm": (30.0, 20.0, 10.0), "mm": (300.0, 200.0, 100.0)}
#: union of many polygons: GEOS's disjoint-subset union (3.12 on) first splits them into groups
#: apart from each other, as the buffered holes of a map mostly are (20× faster than the cascaded
#: union on the jagged benchmark floor, 1.3-2× on Freiburg 079); the same result
_union_all = shapely.disjoint_subset_union_all if shapely.geos_version >= (3, 12, 0) else shapely.union_all


@dataclass(frozen=True, eq=False)
class AlphaCut:
    """One α-cut of a fuzzy B-rep map.

    inner  free space at confidence α: the principal polygon's IN offset minus the holes' OUT
           offsets (Polygon or MultiPolygon; pieces beyond the first when the offset splits)
    outer  the principal polygon's OUT offset minus the holes' IN offsets
    At α = 1 both are the crisp map; ``band`` (outer minus inner) is where a boundary may lie.
    """

    alpha: float
    method: str
    inner: shapely.Geometry
    outer: shapely.Geometry
    unit: str = "m"

    @property
    def band(self) -> shapely.Geometry:
        return polygonal(shapely.difference(self.outer, self.inner))

    def inner_map(self) -> BRepMap:
        """The inner polygons as a crisp map: largest piece principal, the others further regions."""
        return BRepMap.from_shapely(self.inner, self.unit)

    def outer_map(self) -> BRepMap:
        return BRepMap.from_shapely(self.outer, self.unit)


@dataclass(frozen=True)
class ErrorRow:
    """Sweep vs exact at one α: areas of the symmetric differences of inner and outer polygons."""

    alpha: float
    inner_error: float
    outer_error: float
    band_area: float  # exact band (outer − inner) area

    @property
    def relative(self) -> float:
        """(inner + outer symmetric-difference area) / exact band area; NaN when the band is empty."""
        return (self.inner_error + self.outer_error) / self.band_area if self.band_area > 0 else math.nan


@dataclass(frozen=True)
class MemoryRow:
    """One column of Table 5.3."""

    representation: str
    numbers: int | None
    bytes: int


@dataclass(frozen=True, eq=False)
class FuzzyBRepMap:
    """A fuzzy B-rep map (thesis 4.2): crisp map + Table 4.2 + one parametric line per vertex.

    ``lines[k]`` belongs to ``crisp.rings[k]``. Build with ``fuzzify``; tables with
    ``vertex_table``/``edge_table``/``membership_table``.
    """

    crisp: BRepMap
    table: MembershipTable
    lines: tuple[ParametricLines, ...]

    # -- structure ---------------------------------------------------------------------------

    @property
    def unit(self) -> str:
        return self.crisp.unit

    @cached_property
    def ring_names(self) -> list[str]:
        return self.crisp.ring_names()

    @cached_property
    def roles(self) -> list[str]:
        return [SHELL if j == 0 else HOLE for region in self.crisp.regions for j in range(1 + len(region.holes))]

    @cached_property
    def _stack(self) -> dict:
        """All rings' columns stacked, so that an α-cut is a handful of array operations."""
        rings = self.crisp.rings
        sizes = np.array([len(r) for r in rings])
        start = np.concatenate(([0], np.cumsum(sizes)[:-1]))
        ring_of = np.repeat(np.arange(len(rings)), sizes)
        is_shell = np.repeat(np.array([r == SHELL for r in self.roles]), sizes)
        closed = np.concatenate([np.append(np.arange(s, s + n), s) for s, n in zip(start, sizes)])
        nxt = np.arange(len(ring_of)) + 1
        nxt[start + sizes - 1] = start
        V = np.vstack([ln.vertices for ln in self.lines])
        return {
            "V": V,
            "TV": np.vstack([np.column_stack((ln.T, ln.V)) for ln in self.lines]),
            "SI": np.concatenate([ln.support_in for ln in self.lines]),
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

    @cached_property
    def crisp_geometry(self) -> shapely.Geometry:
        g = self.crisp.to_shapely()
        shapely.prepare(g)
        return g

    # -- Tables 4.1, 4.2, 4.3 -----------------------------------------------------------------

    @cached_property
    def _support_polygons(self) -> list[tuple]:
        """Per ring, the proper polygons of its inner and outer support offsets (α = 0)."""
        out = []
        for ln, own in zip(self.lines, self._stack["own"]):
            out.append((proper_polygon(ln.vertices, ln.vin, int(own), +1, kept=True),
                        proper_polygon(ln.vertices, ln.vout, int(own), -1, kept=True)))
        return out

    def vertex_table(self, k: int = 0) -> dict[str, np.ndarray]:
        """Table 4.1 of ring k (0: principal polygon; ``ring_names`` order): columns as arrays.

        XOUT/YOUT and XIN/YIN are NaN (NULL) where the vertex does not survive on the proper
        polygon of the support offset; T, U, V, W stay, since the vertex may survive at higher α.
        """
        ln, ring = self.lines[k], self.crisp.rings[k]
        pin, pout = self._support_polygons[k]
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

    def edge_table(self, k: int = 0) -> dict[str, np.ndarray]:
        """Table 4.3 of ring k: 1-based vertex indices of each edge and of its outer and inner edges.

        0 stands for NULL (a deleted vertex, or an edge none of which survives on the proper
        polygon); EDGE_OUT/EDGE_IN carry the edge number when some of the edge survives.
        """
        ring = self.crisp.rings[k]
        n = len(ring)
        pin, pout = self._support_polygons[k]
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

    def membership_table(self) -> list[dict]:
        """Table 4.2 rows."""
        return self.table.rows()

    # -- α-cuts --------------------------------------------------------------------------------

    def offset_vertices(self, alpha: float) -> tuple[np.ndarray, np.ndarray]:
        """Read the α-cut's vertices from the parametric lines: O(n) array operations, no GEOS.

        Returns (shrink, grow), both (N, 2) over all rings stacked in ``crisp.rings`` order:
        ``shrink`` bounds the inner polygons (principal IN, holes OUT), ``grow`` the outer ones
        (principal OUT, holes IN). The point at inward distance d is at t = 1 − d/support_in,
        at outward distance d at t = 1 + d/support_in (module ``sweep``).
        """
        s = self._stack
        d_in = self.table.d_in(s["fm"], alpha)
        d_out = self.table.d_out(s["fm"], alpha)
        # no offset within rounding: a ring moved by an ulp or two made GEOS take outer − inner
        # for the whole map
        d_in, d_out = self._offset(d_in), self._offset(d_out)
        t_shrink = np.where(s["shell"], 1.0 - d_in / s["SI"], 1.0 + d_out / s["SI"])
        t_grow = np.where(s["shell"], 1.0 + d_out / s["SI"], 1.0 - d_in / s["SI"])
        # x = U + T·t, y = W + V·t, evaluated as X + T·(t − 1) so that t = 1 is the crisp vertex
        return s["V"] + s["TV"] * (t_shrink - 1.0)[:, None], s["V"] + s["TV"] * (t_grow - 1.0)[:, None]

    def _proper_all(self, pts: np.ndarray, grow: bool) -> list:
        """Proper polygon of every ring's offset, vectorised over rings.

        ``grow`` False: principal polygons IN, holes OUT; True: principal OUT, holes IN. Rings
        whose offset is simple, wound like the crisp ring and unfolded (the usual case) are
        their offset polygons; the others are their crisp polygon minus (IN) or plus (OUT) the
        swept hulls of their bands: small rings all in one GEOS pass, long ones strip by strip
        (``sweep.proper_polygon``).
        """
        s = self._stack
        side = np.where(s["shell"] != grow, 1, -1)  # per vertex: +1 IN, −1 OUT
        rings = shapely.linearrings(pts[s["closed"]], indices=s["closed_ring"])
        simple = shapely.is_simple(rings)
        x, y = pts[:, 0], pts[:, 1]
        nxt = s["next"]
        area = 0.5 * np.add.reduceat(x * y[nxt] - x[nxt] * y, s["start"])
        own = s["own"]
        V = s["V"]
        folds = folded_bands(V, V[nxt], pts - V, pts[nxt] - V[nxt], own[s["ring_of"]] * side)
        folded = np.bincount(s["ring_of"], weights=folds, minlength=len(rings)) > 0
        # a ring collapsed to (almost) nothing is not a polygon: it goes the slow way and vanishes
        extent = np.maximum(np.maximum.reduceat(x, s["start"]) - np.minimum.reduceat(x, s["start"]),
                            np.maximum.reduceat(y, s["start"]) - np.minimum.reduceat(y, s["start"]))
        ok = simple & (area * own > 1e-12 * extent * extent) & ~folded
        polys = np.empty(len(rings), dtype=object)
        polys[ok] = shapely.polygons(rings[ok])
        slow = np.flatnonzero(~ok)
        small = slow[s["sizes"][slow] <= _SMALL_RING]
        if len(small):
            polys[small] = self._swept_small(pts, small, side[s["start"][small]])
        for k in slow[s["sizes"][slow] > _SMALL_RING]:
            a, n = s["start"][k], s["sizes"][k]
            polys[k] = proper_polygon(V[a:a + n], pts[a:a + n], int(own[k]), int(side[a])).geometry
        return list(polys)

    def _swept_small(self, pts: np.ndarray, rings: np.ndarray, side: np.ndarray) -> np.ndarray:
        """Proper polygons of short rings: crisp polygon ∓ the union of their bands' swept regions.

        As in ``sweep.proper_polygon``: each run of unfolded bands is one strip polygon when
        valid (else its bands' hulls), each folded band its convex hull; one row of an array per
        ring, reduced by GEOS without a Python loop over rings.
        """
        s = self._stack
        V, nxt = s["V"], s["next"]
        own = s["own"][rings]
        sizes = s["sizes"][rings]
        starts = s["start"][rings]
        ring_row = np.repeat(np.arange(len(rings)), sizes)
        local = np.arange(sizes.sum()) - np.repeat(np.cumsum(sizes) - sizes, sizes)
        band = np.repeat(starts, sizes) + local
        folds = folded_bands(V[band], V[nxt[band]], pts[band] - V[band], pts[nxt[band]] - V[nxt[band]],
                             np.repeat(own * side, sizes))
        # rotate every ring to start just after its first folded band, so no run wraps around
        first = np.full(len(rings), 0)
        has = np.bincount(ring_row, weights=folds, minlength=len(rings)) > 0
        idx_first = np.flatnonzero(folds)
        first_of = np.full(len(rings), np.iinfo(np.int64).max)
        np.minimum.at(first_of, ring_row[idx_first], local[idx_first])
        first[has] = first_of[has] + 1
        rot = np.repeat(starts, sizes) + (local + np.repeat(first, sizes)) % np.repeat(sizes, sizes)
        good = ~folds[np.searchsorted(band, rot)]  # band is increasing: position of each rotated band
        # rings without any fold (self-intersecting or inverted offsets): bands one by one
        good &= np.repeat(has, sizes)
        prev_good = np.r_[False, good[:-1]] & (np.r_[-1, ring_row[:-1]] == ring_row)
        run = np.cumsum(good & ~prev_good) - 1
        run = np.where(good, run, -1)
        parts_row, parts = [], []
        if (run >= 0).any():
            g = np.flatnonzero(run >= 0)
            rid = run[g]
            nrun = rid.max() + 1
            length = np.bincount(rid, minlength=nrun)
            b0 = rot[g]  # bands of every run, in order
            last = np.cumsum(length) - 1
            end_vertex = nxt[b0[last]]
            # strip: crisp starts of its bands, the end vertex, offsets back, closing vertex
            crisp_idx = np.insert(b0, last + 1, end_vertex)
            crisp_run = np.insert(rid, last + 1, np.arange(nrun))
            offs_idx, offs_run = crisp_idx[::-1], crisp_run[::-1]
            order = np.argsort(np.concatenate((crisp_run, offs_run)), kind="stable")
            vidx = np.concatenate((crisp_idx, offs_idx))[order]
            from_off = np.concatenate((np.zeros(len(crisp_idx), bool), np.ones(len(offs_idx), bool)))[order]
            vrun = np.concatenate((crisp_run, offs_run))[order]
            coords = np.where(from_off[:, None], pts[vidx], V[vidx])
            heads = np.searchsorted(vrun, np.arange(nrun))
            coords = np.insert(coords, np.r_[heads[1:], len(coords)], coords[heads], axis=0)
            vrun = np.insert(vrun, np.r_[heads[1:], len(vrun)], np.arange(nrun))
            strips = shapely.polygons(shapely.linearrings(coords, indices=vrun))
            run_ring = ring_row[g][np.searchsorted(rid, np.arange(nrun))]
            x, y = coords[:, 0], coords[:, 1]
            cross = np.append(x[:-1] * y[1:] - x[1:] * y[:-1], 0.0)
            cstart = np.searchsorted(vrun, np.arange(nrun))
            cend = np.r_[cstart[1:], len(coords)] - 1
            area = 0.5 * (np.add.reduceat(cross, cstart) - cross[cend])
            fine = shapely.is_valid(strips) & (area * (own * side)[run_ring] > 0)
            parts_row.append(run_ring[fine])
            parts.append(strips[fine])
            good &= ~np.isin(run, np.flatnonzero(~fine))
        h = ~good
        hb = rot[h]
        hulls = shapely.convex_hull(shapely.multipoints(np.stack((V[hb], V[nxt[hb]], pts[nxt[hb]], pts[hb]), axis=1)))
        parts_row.append(ring_row[h])
        parts.append(hulls)
        prow = np.concatenate(parts_row)
        pgeo = np.concatenate(parts)
        order = np.argsort(prow, kind="stable")
        prow, pgeo = prow[order], pgeo[order]
        col = np.arange(len(prow)) - np.searchsorted(prow, prow)
        table = np.full((len(rings), (col.max() + 2) if len(col) else 1), None, dtype=object)
        table[prow, col + 1] = pgeo
        base = s["ring_polys"][rings]
        grow = side < 0
        table[grow, 0] = base[grow]  # one n-ary union with the crisp polygon (see proper_polygon)
        swept = shapely.union_all(table, axis=1)
        out = np.where(grow, swept, None)
        out[~grow] = shapely.difference(base[~grow], swept[~grow])
        # slivers and collapsed pieces of the overlays would confuse the ones that follow
        x0, y0 = pts.min(axis=0)
        x1, y1 = pts.max(axis=0)
        tiny = 1e-12 * max(x1 - x0, y1 - y0) ** 2
        bad = (shapely.get_num_geometries(out) > 1) | (shapely.get_num_interior_rings(shapely.get_geometry(out, 0)) > 0)
        bad |= ~shapely.is_valid(out) | (shapely.area(out) <= tiny)
        for r in np.flatnonzero(bad):
            out[r] = clean(out[r], tiny)
        return out

    def _combine(self, polys: list, disjoint_holes: bool = False) -> shapely.Geometry:
        shells, holes, k = [], [], 0
        for region in self.crisp.regions:
            shells.append(polys[k])
            holes.append(polys[k + 1:k + 1 + len(region.holes)])
            k += 1 + len(region.holes)
        return free_space(shells, holes, disjoint_holes)

    def alpha_cut(self, alpha: float, method: str = "sweep", *, quad_segs: int = EXACT_QUAD_SEGS) -> AlphaCut:
        """The α-cut: inner and outer polygons, all valid (thesis 2.1.2, 4.1.2).

        ``sweep``: read from the parametric lines and made proper (single normal vertex method).
        ``exact``: the Extension principle, i.e. the crisp map buffered by −d and +d (round joins,
        ``quad_segs`` segments per quarter circle); with several distances or an asymmetric
        function, minus and plus the band each edge reaches d_in(α) into its own ring and d_out(α)
        out of it.
        α-cuts nest: α1 < α2 gives inner(α1) ⊆ inner(α2) and outer(α2) ⊆ outer(α1).
        """
        alpha = _check_alpha(alpha)
        if method == "exact":
            return self._exact_cut(alpha, quad_segs)
        if method != "sweep":
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        shrink, grow = self.offset_vertices(alpha)
        inner = self._combine(self._proper_all(shrink, grow=False))
        # shrunk holes stay inside their crisp holes, which do not overlap: no union needed
        outer = self._combine(self._proper_all(grow, grow=True), disjoint_holes=True)
        return AlphaCut(alpha, method, inner, outer, self.unit)

    @cached_property
    def _edge_groups(self) -> list[dict]:
        """Crisp edges grouped by (membership function, ring role), for the exact method.

        An edge whose two vertices carry different functions is split at its middle, each half
        taking its vertex's function.
        """
        s = self._stack
        V, fm, nxt = s["V"], s["fm"], s["next"]
        a, b, mid = V, V[nxt], 0.5 * (V + V[nxt])
        same = fm == fm[nxt]
        segs = np.concatenate((np.stack((a, b), 1)[same], np.stack((a, mid), 1)[~same], np.stack((mid, b), 1)[~same]))
        seg_fm = np.concatenate((fm[same], fm[~same], fm[nxt][~same]))
        seg_shell = np.concatenate((s["shell"][same], s["shell"][~same], s["shell"][~same]))
        seg_ring = np.concatenate((s["ring_of"][same], s["ring_of"][~same], s["ring_of"][~same]))
        groups = []
        for k in np.unique(seg_fm):
            for shell in (True, False):
                sel = (seg_fm == k) & (seg_shell == shell)
                if sel.any():
                    lines = shapely.linestrings(segs[sel])
                    groups.append({"fm": int(k), "shell": shell, "a": segs[sel][:, 0], "b": segs[sel][:, 1],
                                   "ring": seg_ring[sel], "lines": lines, "tree": shapely.STRtree(lines)})
        return groups

    def _cut_distances(self, alpha: float) -> tuple[list, list]:
        """(symmetric, sided): the α-cut's distances per edge group, (group, d) for a symmetric
        function, (group, d_in, d_out) for an asymmetric one."""
        symmetric, sided = [], []
        for g in self._edge_groups:
            f = self.table[g["fm"]]
            # GEOS buffers at a distance near rounding (α → 1) can come back perturbed by more
            # than the distance (precision-reduction fallback)
            d_in, d_out = float(self._offset(f.d_in(alpha))), float(self._offset(f.d_out(alpha)))
            if f.symmetric:  # d_in = d_out
                symmetric.append((g, d_in))
            else:
                sided.append((g, d_in, d_out))
        return symmetric, sided

    def _exact_cut(self, alpha: float, quad_segs: int = EXACT_QUAD_SEGS) -> AlphaCut:
        crisp = self.crisp_geometry
        symmetric, sided = self._cut_distances(alpha)
        ds = {d for _, d in symmetric}
        if sided or len(ds) > 1:
            return AlphaCut(alpha, "exact", *self._exact_band(crisp, symmetric, sided, quad_segs), self.unit)
        d = ds.pop()
        if d == 0.0:
            return AlphaCut(alpha, "exact", crisp, crisp, self.unit)
        return AlphaCut(alpha, "exact", self._buffered(-d, quad_segs), self._buffered(d, quad_segs), self.unit)

    def _exact_band(self, crisp, symmetric: list, sided: list, quad_segs: int) -> tuple:
        """Inner and outer exact cuts when the distances differ (several functions, or an
        asymmetric one): crisp map minus and plus the band {p : μ(p) ≥ α}, built edge by edge.

        An edge's band reaches d_in(α) into the inside of its own ring and d_out(α) out of it.
        That is not the free space's side everywhere: a point in a hole near the principal
        polygon's wall is inside the principal ring (IN for that wall), a point of another piece
        of explored space lying in a hole is inside that hole's ring. Buffering the crisp map by
        −d and +d sides every boundary by the free space, so it is used only when one symmetric
        distance applies (``_buffered``).

        Every edge is buffered alone (one vectorised call) and the buffers are united once:
        GEOS buffering a MultiLineString of a map's edges nodes all their curves together, which
        took 40-170 s on Freiburg 079 (the union: 3-5 s). Their union is the MultiLineString's
        buffer, round caps at every vertex; rings buffered whole would have joins there instead,
        whose arcs differ (by 5e-6 of the map's area on Intel).
        """
        parts = [shapely.buffer(g["lines"], d, quad_segs=quad_segs) for g, d in symmetric if d > 0]
        polys = self._ring_polygons
        for g, d_in, d_out in sided:
            if d_in == d_out == 0.0:
                continue
            # both sides to the smaller distance, then the wider side on its own: cut by the ring,
            # so that the crisp edges (where the cut runs) lie inside the band, never on its
            # boundary (GEOS overlays of polygons sharing edges were seen to go wrong)
            if min(d_in, d_out) > 0:
                parts.append(shapely.buffer(g["lines"], min(d_in, d_out), quad_segs=quad_segs))
            wide = shapely.buffer(g["lines"], max(d_in, d_out), quad_segs=quad_segs)
            cut = shapely.intersection if d_in > d_out else shapely.difference
            # short rings: each edge's buffer cut by its ring's polygon, all in one call; long
            # ones united first and cut once (edge by edge, a ring of n edges cost n overlays
            # with its whole polygon: 24 s at 20 000 vertices)
            ring = g["ring"]
            long = np.bincount(ring)[ring] > _SMALL_RING
            parts.append(cut(wide[~long], polys[ring[~long]]))
            for k in np.unique(ring[long]):
                parts.append(np.array([cut(_union_all(wide[ring == k]), polys[k])], dtype=object))
        if not parts:
            return crisp, crisp
        band = _union_all(np.concatenate(parts))
        return clean(shapely.difference(crisp, band)), clean(shapely.union(crisp, band))

    def _buffered(self, d: float, quad_segs: int) -> shapely.Geometry:
        """The crisp map buffered by d with round joins (d < 0 erodes it, d > 0 dilates it), ring
        by ring: the geometry of ``shapely.buffer(crisp_geometry, d)``, 6-12× faster on the real
        maps (thousands of holes).

        GEOS nodes the offset curves of all a polygon's rings together, which grows faster than
        linearly with the number of holes (3.5 s on Freiburg 079's 2977). A disc distributes over
        the rings instead. For a region F = P − ∪H_i (principal polygon P, holes H_i inside it
        that meet each other or P's ring at points at most)

            erosion(F, d)  = erosion(P, d) − ∪ dilation(H_i, d)    a disc in F misses every hole
            dilation(F, d) = dilation(P, d) − ∪ erosion(H_i, d)    a disc in ∪H_i lies in one H_i

        and the regions, apart but for points, erode and dilate one by one: the map's erosion and
        dilation are the unions of theirs. So every ring's polygon is buffered alone, all in one
        vectorised call (most small holes vanish when eroded), and each region takes one union
        of its holes and one difference.
        """
        s = self._stack
        shell = s["shell"][s["start"]]
        rings = shapely.buffer(s["ring_polys"], np.where(shell, d, -d), quad_segs=quad_segs)
        pieces, k = [], 0
        for region in self.crisp.regions:
            principal, holes = rings[k], rings[k + 1:k + len(region.rings)]
            k += len(region.rings)
            holes = holes[~shapely.is_empty(holes)]
            if len(holes) and not principal.is_empty:
                principal = shapely.difference(principal, _union_all(holes))
            pieces.append(principal)
        # the dilations of regions can overlap (a piece of explored space inside a hole)
        return clean(pieces[0] if len(pieces) == 1 else _union_all(pieces))

    # -- membership ----------------------------------------------------------------------------

    def membership(self, points, method: str = "sweep") -> np.ndarray:
        """μ of the fuzzy boundary at each of an (m, 2) array of points, vectorised.

        ``exact``: the function of the signed distance to the crisp boundary, negative inside
        the boundary's own ring (Extension principle; the nearest edge of each function on each
        side decides). ``sweep``: the fuzzy union (max,
        thesis 2.1.3) over edges of the swept edge: in the band between an edge and its inner
        (or outer) support edge, μ is the α whose α-cut edge passes through the point. 1 on the
        crisp boundary, 0 beyond the support, within [0, 1] everywhere.
        """
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        p = np.asarray(points, dtype=np.float64)
        if p.size == 0:  # no points ([] as well as an empty (0, 2) array): no grades
            return np.zeros(0)
        if p.ndim != 2 or p.shape[1] != 2:
            raise GeometryError(f"points must be an (m, 2) array, got shape {p.shape}")
        if not np.isfinite(p).all():
            raise GeometryError(f"point {int(np.argmax(~np.isfinite(p).all(axis=1))) + 1} is not finite")
        if self._rounding * 1e12 > LARGEST:  # the map's size (an O(1) check: it is cached)
            raise GeometryError(f"the map is {self._rounding * 1e12:.3g} {self.unit} across: μ is computed "
                                f"for maps up to {LARGEST:g} {self.unit} across, beyond which its arithmetic overflows")
        if method == "exact":
            return self._membership_exact(p)
        return self._membership_sweep(p)

    def _membership_exact(self, p: np.ndarray) -> np.ndarray:
        x, y = p[:, 0], p[:, 1]
        inside = shapely.contains_xy(self.crisp_geometry, x, y)
        mu = np.zeros(len(p))
        for g in self._edge_groups:
            f = self.table[g["fm"]]
            reach = max(f.support_in, f.support_out)  # beyond it μ = 0: look no further
            pi, si = g["tree"].query(shapely.box(x - reach, y - reach, x + reach, y + reach))
            dist = np.full(len(p), np.inf)
            pair = segment_distance(p[pi], g["a"][si], g["b"][si])
            if not f.symmetric:
                # x < 0 inside the edge's own ring, which is not always the free space's side of
                # it (a point in a hole near the principal polygon's wall is inside the principal
                # ring): nearest edge on each side, each through its own half of the function
                own = shapely.intersects_xy(self._ring_polygons[g["ring"][si]], p[pi, 0], p[pi, 1])
                d_in = np.full(len(p), np.inf)
                np.minimum.at(d_in, pi[own], pair[own])
                np.minimum.at(dist, pi[~own], pair[~own])
                mu = np.maximum(mu, np.maximum(f.mu(-d_in), f.mu(dist)))
                continue
            np.minimum.at(dist, pi, pair)
            # IN of a principal polygon is the free space; IN of a hole is the obstacle (for a
            # symmetric function the side does not change μ)
            mu = np.maximum(mu, f.mu(np.where(inside == g["shell"], -dist, dist)))
        return mu

    def _offset(self, d):
        """Offset distances d (scalar or array) with those within ``_rounding`` made none."""
        return np.where(d <= self._rounding, 0.0, d)

    @cached_property
    def _rounding(self) -> float:
        """An α-cut offset up to this, 1e-12 of the map's size (α within rounding of 1), is none."""
        return 1e-12 * float(np.ptp(self._stack["V"], axis=0).max())

    @cached_property
    def _ring_polygons(self) -> np.ndarray:
        """Every ring's own polygon (``crisp.rings`` order), prepared: what IN means for its edges."""
        polys = self._stack["ring_polys"]
        shapely.prepare(polys)
        return polys

    @cached_property
    def _bands(self) -> dict:
        """Every edge's inner and outer band (crisp edge to support edge), with an STRtree of boxes."""
        s = self._stack
        V, nxt = s["V"], s["next"]
        vin = np.vstack([ln.vin for ln in self.lines])
        vout = np.vstack([ln.vout for ln in self.lines])
        si = s["SI"]
        so = np.concatenate([ln.support_out for ln in self.lines])
        c0 = np.concatenate((V, V))
        c1 = np.concatenate((V[nxt], V[nxt]))
        a0 = np.concatenate((vin - V, vout - V))
        a1 = np.concatenate((vin[nxt] - V[nxt], vout[nxt] - V[nxt]))
        n = len(V)
        side = np.repeat([1, -1], n)  # +1: IN band, −1: OUT band
        ring = np.concatenate((s["ring_of"], s["ring_of"]))
        fm0 = np.concatenate((s["fm"], s["fm"]))
        fm1 = np.concatenate((s["fm"][nxt], s["fm"][nxt]))
        folded = folded_bands(c0, c1, a0, a1, s["own"][ring] * side)
        corners = np.stack((c0, c1, c0 + a0, c1 + a1), axis=1)
        lo, hi = corners.min(axis=1), corners.max(axis=1)
        tree = shapely.STRtree(shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1]))
        shell = np.concatenate((s["shell"], s["shell"]))
        region_of_ring = np.repeat(np.arange(len(self.crisp.regions)), [len(r.rings) for r in self.crisp.regions])
        ring_polys = self._ring_polygons
        region_polys = np.array([r.to_shapely() for r in self.crisp.regions], dtype=object)
        shapely.prepare(region_polys)
        return {"c0": c0, "c1": c1, "a0": a0, "a1": a1, "tree": tree, "side": side, "ring": ring,
                "region": region_of_ring[ring], "shell": shell, "fm0": fm0, "fm1": fm1,
                "D0": np.concatenate((si, so)), "D1": np.concatenate((si[nxt], so[nxt])),
                "closed_form": (fm0 == fm1) & ~folded, "ring_polys": ring_polys, "region_polys": region_polys}

    def _membership_sweep(self, p: np.ndarray) -> np.ndarray:
        """μ(p) = sup{α : p in the band outer(α) − inner(α)} of the sweep's α-cuts.

        A point in the crisp free space (closed) is in the band at α iff some IN band of its
        region's principal polygon, or OUT band of one of its holes, covers it at α; a point
        outside, iff some OUT band of a principal polygon it is outside of, or IN band of the
        hole it is in, does. Each band covers at α the hull of its crisp edge and its α-cut
        edge (``sweep.swept_hulls``), so μ is the largest α at which a band still covers p.
        """
        B = self._bands
        x, y = p[:, 0], p[:, 1]
        pi, bi = B["tree"].query(shapely.points(p))
        mu = np.zeros(len(p))
        if len(pi) == 0:
            return mu
        in_crisp = shapely.intersects_xy(self.crisp_geometry, x, y)[pi]
        free_side = (B["side"][bi] > 0) == B["shell"][bi]  # principal IN or hole OUT
        ok = np.zeros(len(pi), bool)
        a = in_crisp & free_side
        ok[a] = shapely.intersects_xy(B["region_polys"][B["region"][bi[a]]], x[pi[a]], y[pi[a]])
        b = ~in_crisp & ~free_side
        inside_ring = shapely.intersects_xy(B["ring_polys"][B["ring"][bi[b]]], x[pi[b]], y[pi[b]])
        ok[b] = np.where(B["shell"][bi[b]], ~inside_ring, inside_ring)
        pi, bi = pi[ok], bi[ok]
        val = np.full(len(pi), np.nan)
        cf = B["closed_form"][bi]
        if cf.any():
            i, b = pi[cf], bi[cf]
            u = band_parameter(p[i], B["c0"][b], B["c1"][b], B["a0"][b], B["a1"][b])
            xs = -B["side"][b] * u * B["D0"][b]  # signed distance: negative IN
            m = np.full(len(b), np.nan)
            fm = B["fm0"][b]
            for k in np.unique(fm):
                sel = (fm == k) & np.isfinite(xs)
                m[sel] = self.table[int(k)].mu(xs[sel])
            val[cf] = m
        if (~cf).any():
            val[~cf] = self._hull_levels(p[pi[~cf]], bi[~cf])
        good = np.isfinite(val)
        np.maximum.at(mu, pi[good], val[good])
        return np.clip(mu, 0.0, 1.0)

    def _d_at(self, fm: np.ndarray, side: np.ndarray):
        """d(α) per pair: d_in on IN bands, d_out on OUT ones, each pair's function from ``fm``.

        Groups by function once; the returned function of α (one per pair) is what bisection calls.
        """
        groups = []
        for k in np.unique(fm):
            sel = fm == k
            groups.append((sel, side[sel] > 0, self.table[int(k)]))

        def d(alpha: np.ndarray) -> np.ndarray:
            out = np.empty(len(fm))
            for sel, inward, f in groups:
                out[sel] = np.where(inward, f.d_in(alpha[sel]), f.d_out(alpha[sel]))
            return out

        return d

    def _hull_levels(self, p: np.ndarray, b: np.ndarray, iterations: int = 45) -> np.ndarray:
        """Largest α at which band b's swept hull still holds p, by bisection (NaN if not at α = 0).

        For bands that fold over, or whose ends carry different functions: no closed form, but
        the hull shrinks as α grows, so bisection on α is exact to 2^−45. Vectorised over pairs.
        """
        B = self._bands
        c0, c1, a0, a1, side = B["c0"][b], B["c1"][b], B["a0"][b], B["a1"][b], B["side"][b]
        D0, D1 = B["D0"][b], B["D1"][b]
        d0, d1 = self._d_at(B["fm0"][b], side), self._d_at(B["fm1"][b], side)

        def holds(alpha):
            p0 = c0 + a0 * (d0(alpha) / D0)[:, None]
            p1 = c1 + a1 * (d1(alpha) / D1)[:, None]
            return in_hull(p, np.stack((c0, c1, p1, p0), axis=1))

        lo, hi = np.zeros(len(p)), np.ones(len(p))
        start = holds(lo)
        for _ in range(iterations):
            mid = 0.5 * (lo + hi)
            h = holds(mid)
            lo = np.where(h, mid, lo)
            hi = np.where(h, hi, mid)
        return np.where(start, lo, np.nan)

    # -- approximation error ---------------------------------------------------------------------

    def approximation_error(self, alphas=None) -> list[ErrorRow]:
        """Sweep vs exact α-cuts: area of the symmetric difference of inner and of outer polygons.

        The thesis calls its single-normal-vertex sweep an approximation of the Extension
        principle (4.2); this says by how much, per α, in the map's unit squared.
        """
        return approximation_error(self, alphas)

    # -- memory (Table 5.3) --------------------------------------------------------------------

    def memory(self, cells=None) -> list[MemoryRow]:
        """Table 5.3 for this map: thesis accounting, compact encoding, occupancy grids per cell size
        (in the map's unit; by default the thesis's 30, 20 and 10 cm)."""
        if cells is None:
            # cells of 0.3 taken in the map's own unit were 0.3 mm on a map in millimetres, the
            # thesis's unit: grids of gigabytes, compared with nothing the thesis compares
            try:
                cells = THESIS_GRID_CELLS[self.unit]
            except KeyError:
                raise GeometryError(f"no default grid cells for unit {self.unit!r}: give the cell sizes") from None
        n = self.crisp.n_vertices
        rows = memory_table(n, n, float(self.crisp_geometry.area), cells, unit=self.unit)
        rows.insert(1, MemoryRow("fuzzy B-rep, compact (vertices to 1 mm as varint steps, edge kinds, Table 4.2)", None,
                                 compact_bytes(self)))
        x0, y0, x1, y1 = self.crisp_geometry.bounds
        for c in cells:
            nc = _cell_count(x1 - x0, c, self.unit) * _cell_count(y1 - y0, c, self.unit)
            rows.append(MemoryRow(f"occupancy grid {c:g}×{c:g} {self.unit} over the bounding box "
                                  f"({x1 - x0:.6g}×{y1 - y0:.6g} {self.unit})", nc, 4 * nc))
        return rows

    # -- files ---------------------------------------------------------------------------------

    def to_mapfile(self, poses: np.ndarray | None = None, metadata: dict | None = None) -> MapFile:
        """The map file: crisp map + Table 4.2 (everything else is derived on load)."""
        return MapFile(self.crisp, self.table.to_dicts(), poses, dict(metadata or {}))

    def save(self, path: str | os.PathLike, poses: np.ndarray | None = None, metadata: dict | None = None) -> int:
        """Write atomically; returns bytes written. ``poses``: rows of x, y, heading, time, one per
        scan (the viewer draws them); ValueError for others, before anything is written."""
        return write_map(path, self.to_mapfile(poses, metadata))

    @classmethod
    def from_mapfile(cls, m: MapFile, path: str | os.PathLike = "<map>", tme: float | None = None) -> "FuzzyBRepMap":
        """Rebuild from a map file as ``read_map`` returns it (its rings already checked there). A
        crisp map (no Table 4.2) is fuzzified with ``tme`` if given. MapFileError names ``path``."""
        if not m.membership_functions:
            if tme is None:
                raise MapFileError(path, "the map has no membership-function table (it is crisp): "
                                         "fuzzify it first (fuzzybrep fuzzify), or give its TME (--tme)")
            table = None
        else:
            try:
                table = MembershipTable.from_dicts(m.membership_functions)
            except MembershipFunctionError as e:
                raise MapFileError(path, str(e)) from None
        try:
            # read_map validated the rings: checking them again would double the cost of a load
            return fuzzify(m.crisp, table, tme=tme if table is None else None, validate=False)
        except (GeometryError, MembershipFunctionError) as e:  # an FM index with no function, a support too wide
            raise MapFileError(path, str(e)) from None

    @classmethod
    def load(cls, path: str | os.PathLike, tme: float | None = None) -> "FuzzyBRepMap":
        return cls.from_mapfile(read_map(path), path, tme)


def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(m,) Euclidean distance from each point p to its segment a–b, all (m, 2)."""
    ab, ap = b - a, p - a
    den = np.einsum("ij,ij->i", ab, ab)
    t = np.clip(np.einsum("ij,ij->i", ap, ab) / np.where(den > 0, den, 1.0), 0.0, 1.0)
    d = ap - t[:, None] * ab
    return np.hypot(d[:, 0], d[:, 1])


def _check_alpha(alpha) -> float:
    try:
        a = float(alpha)
    except (TypeError, ValueError):
        raise MembershipFunctionError(f"α must be a number in [0, 1], got {alpha!r}") from None
    if not 0.0 <= a <= 1.0:  # a membership grade, as membership._alpha says for offset_vertices
        raise MembershipFunctionError(f"α must lie in [0, 1], got {alpha!r}")
    return a


# ---------------------------------------------------------------------------------------------
# fuzzify


def default_tme(unit: str) -> float:
    """The thesis's TME (199.13 mm) in a map unit: 0.19913 for metres, 199.13 for millimetres."""
    try:
        return _DEFAULT_TME[unit]
    except KeyError:
        raise MembershipFunctionError(f"no default TME for unit {unit!r}: give tme explicitly") from None


def _as_table(mf, tme: float | None, unit: str) -> MembershipTable:
    if mf is None:
        return MembershipTable(Triangular(default_tme(unit) if tme is None else tme))
    if tme is not None:
        raise MembershipFunctionError("give either a membership function (mf) or a TME for the triangular one, not both")
    if isinstance(mf, MembershipTable):
        return mf
    return MembershipTable(mf)


def fuzzify(crisp: BRepMap, mf: MembershipFunction | MembershipTable | dict | list | None = None,
            tme: float | None = None, *, frontier_mf: MembershipFunction | None = None,
            validate: bool = True) -> FuzzyBRepMap:
    """Turn a crisp B-rep map into a fuzzy one (thesis chapter 4). The entry point of ``build``.

    mf           one membership function for every vertex, or a Table 4.2 (MembershipTable, or
                 a dict index → function) indexed by the rings' FM columns. Default: the
                 triangular function with support ±``tme``.
    tme          TME of the default triangular function, in the map's unit. Default: the thesis's
                 199.13 mm, i.e. 0.19913 for a map in metres (``default_tme``).
    frontier_mf  optional function for frontier edges: added to the table, and given to every
                 vertex that touches a frontier edge (a frontier's position is less certain).
    validate     refuse degenerate or self-intersecting rings (GeometryError names the vertex).

    Either order of ring vertices works: IN is the inside of each ring, whatever its orientation.
    """
    table = _as_table(mf, tme, crisp.unit)
    if frontier_mf is not None:
        k = max(table.indices) + 1
        table = MembershipTable({**dict(table), k: frontier_mf})
        crisp = crisp.with_rings([Ring(r.vertices, r.kinds, frontier_fm(r.kinds, r.fm, k)) for r in crisp.rings])
    _check_reach(table, crisp.unit)
    names = crisp.ring_names()
    if validate:
        validate_map(crisp)
    rings = crisp.rings
    sizes = np.array([len(r) for r in rings])
    fm = np.concatenate([r.fm for r in rings])
    bad = table.check_indices(fm)
    if bad is not None:
        k = int(np.searchsorted(np.cumsum(sizes), bad, side="right"))
        local = bad - int(np.sum(sizes[:k]))
        raise GeometryError(f"FM index {int(fm[bad])} has no membership function in the table "
                            f"(indices: {', '.join(map(str, table.indices))})", ring=names[k], vertex=local + 1)
    V = np.vstack([r.vertices for r in rings])
    try:
        bisector, _ = normal_vertices_stacked(V, sizes)
    except GeometryError as e:
        raise GeometryError(e.reason, ring=names[int(e.ring)], vertex=e.vertex) from None
    si, so = table.support_in(fm), table.support_out(fm)
    lines = []
    for a, n in zip(np.concatenate(([0], np.cumsum(sizes)[:-1])), sizes):
        parts = [V[a:a + n], bisector[a:a + n], si[a:a + n], so[a:a + n]]
        for arr in parts:
            arr.setflags(write=False)
        lines.append(ParametricLines(*parts))
    return FuzzyBRepMap(crisp, table, tuple(lines))


def _check_reach(table: MembershipTable, unit: str) -> None:
    """MembershipFunctionError if a function's support reaches beyond ±WIDEST_SUPPORT (a TME of
    1e300 was fuzzified and written, and every command reading the map then crashed)."""
    for k, f in table:
        reach = max(f.support_in, f.support_out)
        if reach > WIDEST_SUPPORT:
            raise MembershipFunctionError(f"membership function {k} ({f.formula()}): its support ±{reach:g} {unit} "
                                          f"reaches beyond ±{WIDEST_SUPPORT:g} {unit}, farther than fuzzybrep's "
                                          f"arithmetic holds")


def validate_map(crisp: BRepMap) -> None:
    """Raise GeometryError naming ring and vertex if a ring is degenerate or a region invalid.

    Unlike ``BRepMap.validate`` the ring order is not checked: the sweep works with either.
    """
    if not crisp.regions:
        raise GeometryError("the map has no regions")
    names = crisp.ring_names()
    rings = crisp.rings
    sizes = np.array([len(r) for r in rings])
    suspect = sizes < 3
    if not suspect.any():
        V = np.vstack([r.vertices for r in rings])
        start = np.concatenate(([0], np.cumsum(sizes)[:-1]))
        ring_of = np.repeat(np.arange(len(rings)), sizes)
        nxt = np.arange(len(V)) + 1
        nxt[start + sizes - 1] = start
        finite = np.isfinite(V).all(axis=1)
        dup = np.all(V == V[nxt], axis=1)
        # a ring with a non-finite vertex is suspect already: 0 in its place keeps NumPy from
        # warning (a second line before the error), and an area that overflows is not 0
        Vf = np.where(finite[:, None], V, 0.0)
        x, y = Vf[:, 0], Vf[:, 1]
        with np.errstate(over="ignore", invalid="ignore"):
            area = 0.5 * np.add.reduceat(x * y[nxt] - x[nxt] * y, start)
        closed = np.concatenate([np.append(np.arange(a, a + n), a) for a, n in zip(start, sizes)])
        simple = shapely.is_simple(shapely.linearrings(Vf[closed], indices=ring_of[closed]))
        suspect = (np.bincount(ring_of, weights=~finite | dup, minlength=len(rings)) > 0) | (area == 0) | ~simple
    for k in np.flatnonzero(suspect):  # the detailed message comes from validate_ring
        validate_ring(rings[k].vertices, names[k])
    k = 0
    for region in crisp.regions:
        region_names, k = names[k:k + len(region.rings)], k + len(region.rings)
        check_region(region, region_names)  # the rings are simple now
    _check_disjoint(crisp)


def _check_disjoint(crisp: BRepMap) -> None:
    """GeometryError if two regions overlap. Each region is a piece of free space apart from the
    others (meeting at points at most); overlapping ones were taken as they were, their common
    area counted twice and the α-cuts and rasters of each drawn over the other's."""
    if len(crisp.regions) < 2:
        return
    polys = np.array([region.to_shapely() for region in crisp.regions], dtype=object)
    a, b = shapely.STRtree(polys).query(polys, predicate="intersects")
    a, b = a[a < b], b[a < b]
    inside = shapely.relate_pattern(polys[a], polys[b], "T********")  # interiors meet
    if not inside.any():
        return
    i, j = int(a[inside][0]), int(b[inside][0])
    names = ["principal" if k == 0 else f"piece {k + 1}" for k in range(len(polys))]
    shell = crisp.regions[j].shell.vertices
    within = np.flatnonzero(shapely.contains_xy(polys[i], shell[:, 0], shell[:, 1]))
    x, y = (shell[within[0]] if within.size else
            np.asarray(shapely.intersection(polys[i], polys[j]).representative_point().coords[0]))
    raise GeometryError(f"overlaps {names[i]} near ({x:.6g}, {y:.6g}): regions are separate pieces of free space",
                        ring=names[j], vertex=int(within[0]) + 1 if within.size else None)


# ---------------------------------------------------------------------------------------------
# Approximation error and memory


def approximation_error(fuzzy: FuzzyBRepMap, alphas=None) -> list[ErrorRow]:
    """Per α: symmetric-difference areas between sweep and exact inner polygons, and outer ones."""
    alphas = np.linspace(0.0, 1.0, 5) if alphas is None else np.asarray(alphas, dtype=float).reshape(-1)
    rows = []
    for a in alphas:
        s, e = fuzzy.alpha_cut(float(a), "sweep"), fuzzy.alpha_cut(float(a), "exact")
        rows.append(ErrorRow(float(a),
                             float(shapely.area(shapely.symmetric_difference(s.inner, e.inner))),
                             float(shapely.area(shapely.symmetric_difference(s.outer, e.outer))),
                             float(shapely.area(e.outer) - shapely.area(e.inner))))
    return rows


def error_table_markdown(rows: list[ErrorRow], unit: str = "m") -> str:
    lines = [f"| α | inner Δ area ({unit}²) | outer Δ area ({unit}²) | exact band area ({unit}²) | (inner Δ + outer Δ) / band |",
             "|---:|---:|---:|---:|---:|"]
    for r in rows:
        rel = "—" if math.isnan(r.relative) else f"{100 * r.relative:.2f} %"
        lines.append(f"| {r.alpha:g} | {r.inner_error:.6g} | {r.outer_error:.6g} | {r.band_area:.6g} | {rel} |")
    return "\n".join(lines)


#: Table 5.3's accounting: numbers per vertex in the fuzzy vertex table (X, Y, XOUT, YOUT, XIN,
#: YIN, T, U, V, W) and per edge in the fuzzy edge table (Vstart, Vend for the edge, its outer and
#: its inner edge), 4 bytes each (single-precision floats)
THESIS_NUMBERS_PER_VERTEX = 10
THESIS_NUMBERS_PER_EDGE = 6
BYTES_PER_NUMBER = 4


def memory_table(n_vertices: int, n_edges: int, area: float, cells=(0.3, 0.2, 0.1), unit: str = "m") -> list[MemoryRow]:
    """Table 5.3 from a map's counts: thesis accounting of the fuzzy B-rep, and occupancy grids
    of ``ceil(area / cell²)`` cells of 4 bytes over the map's area (the thesis's E1 map: 77
    vertices, 77 edges, 1050 m² → 1232 numbers, 4928 bytes; 46668, 105000, 420000 bytes)."""
    numbers = THESIS_NUMBERS_PER_VERTEX * n_vertices + THESIS_NUMBERS_PER_EDGE * n_edges
    rows = [MemoryRow("fuzzy B-rep, thesis accounting (10 per vertex + 6 per edge)", numbers, BYTES_PER_NUMBER * numbers)]
    for c in cells:
        nc = _cell_count(area, c, unit, dims=2)
        rows.append(MemoryRow(f"occupancy grid {c:g}×{c:g} {unit} over the map's area ({area:.6g} {unit}²)", nc,
                              BYTES_PER_NUMBER * nc))
    return rows


def _cell_count(size: float, c: float, unit: str, dims: int = 1) -> int:
    """⌈size / c^dims⌉: the cells of ``c``-sized cells along a side (dims 1) or over an area (2);
    GeometryError for a cell size with no such grid: not positive or infinite (0 cells), or so
    small that the count is no finite float (before: ZeroDivisionError, or OverflowError from ceil)."""
    if not 0 < c < math.inf:
        raise GeometryError(f"occupancy grid of {c:g} {unit} cells: the cell size must be a positive finite number")
    n = size
    for _ in range(dims):  # divided once per side: c * c underflows to 0 below 1e-162
        n /= c
    if not math.isfinite(n):
        raise GeometryError(f"occupancy grid of {c:g} {unit} cells: too many cells to count (more than "
                            f"a float holds); the cell size is too small")
    return math.ceil(n - 1e-9)


def compact_bytes(fuzzy: FuzzyBRepMap) -> int:
    """Bytes of the compact encoding (``fuzzybrep.compact``): crisp vertices quantised to 1 mm
    (for metres) as varint steps, edge kinds as bits, FM only where it does not follow the kinds,
    and Table 4.2. VIN, VOUT, T, U, V, W and the edge tables follow from these in O(n)."""
    from .compact import encode

    return len(encode(fuzzy.crisp, fuzzy.table.to_dicts()))


def memory_markdown(rows: list[MemoryRow], reference: int | None = None) -> str:
    ref = reference if reference is not None else rows[0].bytes
    lines = ["| representation | numbers | bytes | × fuzzy B-rep (thesis) |", "|---|---:|---:|---:|"]
    for r in rows:
        num = "—" if r.numbers is None else str(r.numbers)
        lines.append(f"| {r.representation} | {num} | {r.bytes} | {r.bytes / ref:.2f} |")
    return "\n".join(lines)


__all__ = [
    "AlphaCut", "ErrorRow", "FuzzyBRepMap", "MemoryRow", "approximation_error", "compact_bytes", "default_tme",
    "error_table_markdown", "fuzzify", "memory_markdown", "memory_table", "validate_map",
]
