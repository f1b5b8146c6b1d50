"""The fuzzy B-rep map: a crisp B-rep map, its membership-function table, and the sweep's lines.

``fuzzify(crisp, tme=...)`` turns a crisp map into a fuzzy one (thesis chapter 4): every vertex
gets its normal vertex and parametric line (Table 4.1), every edge its inner and outer edges
(Table 4.3), every function its row in Table 4.2. From these:

- ``alpha_cut(α)``: the inner polygons (free at confidence α: principal polygon shrunk, holes
  grown) and the outer polygons (free at possibility α: principal grown, holes shrunk), read from
  the lines in O(n) and made proper (thesis 4.1.2);
- ``membership(points)``: μ of the fuzzy boundary at each point;

by one of three methods:

- ``"safe"`` (the default): the conservative sweep (``safe_sweep``, ``safe_cut``), read from
  stored per-vertex directions in O(n) and made proper by one winding-number union; its inner
  cut never reaches into the exact band and its outer cut always holds it (mitre and bevel
  vertices instead of the single normal vertex);
- ``"thesis"``: the thesis's single-normal-vertex sweep (4.1.2), as Table 4.1 prints it
  (``"sweep"`` is accepted as its old name);
- ``"exact"``: the exact fuzzification of the Extension principle (thesis 2.1.4: μ = membership
  function of the signed distance to the crisp boundary, whose α-cuts are the map buffered with
  round joins);

and ``approximation_error`` measures how far the thesis's sweep is from the exact method.

Only the crisp map and Table 4.2 are stored (``mapfile``); everything else is rebuilt on load.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely

from ..brep import LARGEST, BRepMap, Ring, drop_short_edges, frontier_fm, validate_map
from ..errors import GeometryError, MapFileError, MembershipFunctionError
from ..formats.mapfile import MapFile, read_map, write_map
from ..geometry import polygonal
from . import exact, safe_cut, sweep_cut, sweep_membership, tables
from .accuracy import ErrorRow, approximation_error
from .exact import EXACT_QUAD_SEGS
from .membership import DEFAULT_TME_M, THESIS_TME_MM, MembershipFunction, MembershipTable, Triangular
from .memory import MemoryRow, map_memory
from .stack import ring_stack
from .sweep import ParametricLines, normal_vertices_stacked

SHELL = "shell"
HOLE = "hole"
#: α-cut and μ methods; the first is the default
METHODS = ("safe", "thesis", "exact")
#: old names still accepted (map files, scripts and CLI options that said ``sweep``)
ALIASES = {"sweep": "thesis"}
DEFAULT_METHOD = METHODS[0]
#: membership functions with a support wider than ± this are refused (by ``fuzzify``): their
#: support polygons and α-cuts square distances, which passes the largest float from about
#: 1.3e154 on (a TME of 1e154 ended in OverflowError, 1e160 in GEOS exceptions); up to 1e150 the
#: tables, α-cuts and plans still work
WIDEST_SUPPORT = 1e150
_DEFAULT_TME = {"m": DEFAULT_TME_M, "mm": THESIS_TME_MM, "cm": DEFAULT_TME_M * 100}


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


@dataclass(frozen=True, eq=False)
class FuzzyBRepMap:
    """A fuzzy B-rep map (thesis 4.2): crisp map + Table 4.2 + one parametric line per vertex.

    ``lines[k]`` belongs to ``crisp.rings[k]``. Build with ``fuzzify``; tables with
    ``vertex_table``/``edge_table``/``membership_table``. The work is done by the modules named
    in each method (``tables``, ``sweep_cut``, ``exact``, ``sweep_membership``, ``memory``,
    ``formats.mapfile``); the map caches what they share.
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
    def rings(self) -> list[Ring]:
        """``crisp.rings``, listed once: the crisp map lists them anew on every access, so a table
        per ring that asked it made ``tables`` quadratic in rings (issue 36 item 8)."""
        return self.crisp.rings

    @cached_property
    def roles(self) -> list[str]:
        return [SHELL if j == 0 else HOLE for region in self.crisp.regions for j in range(1 + len(region.holes))]

    @cached_property
    def stack(self) -> dict:
        """All rings' columns stacked (``stack.ring_stack``)."""
        return ring_stack(self.crisp, self.lines, self.roles)

    @cached_property
    def crisp_geometry(self) -> shapely.Geometry:
        g = self.crisp.to_shapely()
        shapely.prepare(g)
        return g

    @cached_property
    def ring_polygons(self) -> np.ndarray:
        """Every ring's own polygon (``crisp.rings`` order), prepared: what IN means for its edges."""
        polys = self.stack["ring_polys"]
        shapely.prepare(polys)
        return polys

    @cached_property
    def rounding(self) -> float:
        """An α-cut offset up to this, 1e-12 of the map's size (α within rounding of 1), is none."""
        return 1e-12 * float(np.ptp(self.stack["V"], axis=0).max())

    def offset(self, d):
        """Offset distances d (scalar or array) with those within ``rounding`` made none."""
        return np.where(d <= self.rounding, 0.0, d)

    # -- Tables 4.1, 4.2, 4.3 (module ``tables``) ------------------------------------------------

    @cached_property
    def support_polygons(self) -> list[tuple]:
        return tables.support_polygons(self)

    def vertex_table(self, k: int = 0) -> dict[str, np.ndarray]:
        """Table 4.1 of ring k (0: principal polygon; ``ring_names`` order): columns as arrays."""
        return tables.vertex_table(self, k)

    def edge_table(self, k: int = 0) -> dict[str, np.ndarray]:
        """Table 4.3 of ring k: 1-based vertex indices of each edge and of its outer and inner edges."""
        return tables.edge_table(self, k)

    def membership_table(self) -> list[dict]:
        """Table 4.2 rows."""
        return self.table.rows()

    # -- α-cuts --------------------------------------------------------------------------------

    def offset_vertices(self, alpha: float) -> tuple[np.ndarray, np.ndarray]:
        """The sweep's α-cut vertices read from the parametric lines, O(n): (shrink, grow) over all
        rings stacked (``sweep_cut.offset_vertices``)."""
        return sweep_cut.offset_vertices(self, alpha)

    def alpha_cut(self, alpha: float, method: str = DEFAULT_METHOD, *, quad_segs: int = EXACT_QUAD_SEGS) -> AlphaCut:
        """The α-cut: inner and outer polygons, all valid (thesis 2.1.2, 4.1.2).

        ``safe`` (default): the conservative sweep, inner(α) ⊆ crisp ⊖ d_in(α) and outer(α) ⊇
        crisp ⊕ d_out(α) (``safe_cut``, proof in ``safe_sweep``). ``thesis`` (or ``sweep``):
        read from the parametric lines and made proper (single normal vertex method,
        ``sweep_cut``). ``exact``: the Extension principle, i.e. the crisp map buffered by −d and
        +d (round joins, ``quad_segs`` segments per quarter circle); with several distances or an
        asymmetric function, minus and plus the band each edge reaches d_in(α) into its own ring
        and d_out(α) out of it (``exact``).
        α-cuts nest: α1 < α2 gives inner(α1) ⊆ inner(α2) and outer(α2) ⊆ outer(α1).
        """
        alpha = check_alpha(alpha)
        method = check_method(method)
        if method == "exact":
            return AlphaCut(alpha, "exact", *exact.exact_cut(self, alpha, quad_segs), self.unit)
        if method == "safe":
            return AlphaCut(alpha, method, *safe_cut.safe_cut(self, alpha), self.unit)
        return AlphaCut(alpha, method, *sweep_cut.sweep_cut(self, alpha), self.unit)

    @cached_property
    def safe(self) -> dict:
        """The conservative sweep's stored directions and what its cuts share (``safe_cut.prepare``)."""
        return safe_cut.prepare(self)

    @cached_property
    def edge_groups(self) -> list[dict]:
        """Crisp edges grouped by (membership function, ring role), for the exact method."""
        return exact.edge_groups(self)

    # -- membership ----------------------------------------------------------------------------

    def membership(self, points, method: str = DEFAULT_METHOD) -> np.ndarray:
        """μ of the fuzzy boundary at each of an (m, 2) array of points, vectorised.

        ``safe`` (default): μ ≥ α exactly where the safe α-cut's band is (the function of the
        smallest distance at which one of its rectangles, fans or stadiums holds the point;
        ``safe_cut``). ``exact``: the function of the signed distance to the crisp boundary, negative inside
        the boundary's own ring (Extension principle; the nearest edge of each function on each
        side decides). ``thesis`` (or ``sweep``): the fuzzy union (max,
        thesis 2.1.3) over edges of the swept edge: in the band between an edge and its inner
        (or outer) support edge, μ is the α whose α-cut edge passes through the point. 1 on the
        crisp boundary, 0 beyond the support, within [0, 1] everywhere.
        """
        method = check_method(method)
        p = np.asarray(points, dtype=np.float64)
        if p.size == 0:  # no points ([] as well as an empty (0, 2) array): no grades
            return np.zeros(0)
        if p.ndim != 2 or p.shape[1] != 2:
            raise GeometryError(f"points must be an (m, 2) array, got shape {p.shape}")
        if not np.isfinite(p).all():
            raise GeometryError(f"point {int(np.argmax(~np.isfinite(p).all(axis=1))) + 1} is not finite")
        if self.rounding * 1e12 > LARGEST:  # the map's size (an O(1) check: it is cached)
            raise GeometryError(f"the map is {self.rounding * 1e12:.3g} {self.unit} across: μ is computed "
                                f"for maps up to {LARGEST:g} {self.unit} across, beyond which its arithmetic overflows")
        if method == "exact":
            return exact.membership_exact(self, p)
        if method == "safe":
            return safe_cut.membership_safe(self, p)
        return sweep_membership.membership_sweep(self, p)

    @cached_property
    def bands(self) -> dict:
        """Every edge's inner and outer band, with an STRtree of boxes (``sweep_membership.bands``)."""
        return sweep_membership.bands(self)

    # -- approximation error, memory -------------------------------------------------------------

    def approximation_error(self, alphas=None) -> list[ErrorRow]:
        """Sweep vs exact α-cuts: area of the symmetric difference of inner and of outer polygons.

        The thesis calls its single-normal-vertex sweep an approximation of the Extension
        principle (4.2); this says by how much, per α, in the map's unit squared.
        """
        return approximation_error(self, alphas)

    def memory(self, cells=None) -> list[MemoryRow]:
        """Table 5.3 for this map: thesis accounting, compact encoding, occupancy grids per cell size
        (in the map's unit; by default the thesis's 30, 20 and 10 cm)."""
        return map_memory(self, cells)

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


def check_method(method: str) -> str:
    """The method's name (``sweep`` read as ``thesis``); ValueError naming the methods otherwise."""
    m = ALIASES.get(method, method)
    if m not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)} (or sweep, the thesis's old name), got {method!r}")
    return m


def check_alpha(alpha) -> float:
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
    validate     refuse degenerate or self-intersecting rings (GeometryError names the vertex),
                 and merge edges shorter than ``brep.min_edge`` away (``brep.drop_short_edges``).

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
        crisp = drop_short_edges(crisp)  # edges shorter than brep.min_edge: no direction to sweep along
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


# ---------------------------------------------------------------------------------------------
# Approximation error and memory


__all__ = ["AlphaCut", "FuzzyBRepMap", "default_tme", "fuzzify"]
