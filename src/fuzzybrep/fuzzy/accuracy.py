"""How far the thesis's sweep is from the exact fuzzification (thesis 4.2 calls the sweep an
approximation of the Extension principle): areas of the symmetric differences per α."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely


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


def approximation_error(fuzzy, alphas=None) -> list[ErrorRow]:
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
