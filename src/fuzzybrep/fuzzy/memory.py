"""Memory of a fuzzy B-rep map against occupancy grids (thesis Table 5.3): the thesis's accounting,
the compact encoding's actual bytes, and grids over the map's area and its bounding box."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import GeometryError

#: the grids Table 5.3 compares with, 30, 20 and 10 cm, in each unit a map can be in
THESIS_GRID_CELLS = {"m": (0.3, 0.2, 0.1), "cm": (30.0, 20.0, 10.0), "mm": (300.0, 200.0, 100.0)}


@dataclass(frozen=True)
class MemoryRow:
    """One column of Table 5.3."""

    representation: str
    numbers: int | None
    bytes: int


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


def compact_bytes(fuzzy) -> int:
    """Bytes of the compact encoding (``fuzzybrep.formats.compact``): crisp vertices quantised to 1 mm
    (for metres) as varint steps, edge kinds as bits, FM only where it does not follow the kinds,
    and Table 4.2. VIN, VOUT, T, U, V, W and the edge tables follow from these in O(n)."""
    from ..formats.compact import encode

    return len(encode(fuzzy.crisp, fuzzy.table.to_dicts()))


def memory_markdown(rows: list[MemoryRow], reference: int | None = None) -> str:
    ref = reference if reference is not None else rows[0].bytes
    lines = ["| representation | numbers | bytes | × fuzzy B-rep (thesis) |", "|---|---:|---:|---:|"]
    for r in rows:
        num = "—" if r.numbers is None else str(r.numbers)
        lines.append(f"| {r.representation} | {num} | {r.bytes} | {r.bytes / ref:.2f} |")
    return "\n".join(lines)
def map_memory(fz, cells=None) -> list[MemoryRow]:
    """Table 5.3 for this map: thesis accounting, compact encoding, occupancy grids per cell size
    (in the map's unit; by default the thesis's 30, 20 and 10 cm)."""
    if cells is None:
        # cells of 0.3 taken in the map's own unit were 0.3 mm on a map in millimetres, the
        # thesis's unit: grids of gigabytes, compared with nothing the thesis compares
        try:
            cells = THESIS_GRID_CELLS[fz.unit]
        except KeyError:
            raise GeometryError(f"no default grid cells for unit {fz.unit!r}: give the cell sizes") from None
    n = fz.crisp.n_vertices
    rows = memory_table(n, n, float(fz.crisp_geometry.area), cells, unit=fz.unit)
    rows.insert(1, MemoryRow("fuzzy B-rep, compact (vertices to 1 mm as varint steps, edge kinds, Table 4.2)", None,
                             compact_bytes(fz)))
    x0, y0, x1, y1 = fz.crisp_geometry.bounds
    for c in cells:
        nc = _cell_count(x1 - x0, c, fz.unit) * _cell_count(y1 - y0, c, fz.unit)
        rows.append(MemoryRow(f"occupancy grid {c:g}×{c:g} {fz.unit} over the bounding box "
                              f"({x1 - x0:.6g}×{y1 - y0:.6g} {fz.unit})", nc, 4 * nc))
    return rows