"""UMBmark: the bidirectional square-path test that measures a differential drive's systematic
odometry errors, and the Pioneer 3-DX calibration values Appendix I derives from it.

Units are the thesis's: millimetres for positions, the side L and the wheelbase b, degrees for
α and β. The robot starts at (0, 0) and runs an L × L square five times clockwise and five times
counter-clockwise; each stop position is where the robot really stopped, measured in the frame
the run started in, while its odometry believed it was back at (0, 0).

Equations 1-8 of Appendix I (after Borenstein & Feng's UMBmark):

    (1) x_cg = mean(x_i), y_cg = mean(y_i)                         per direction
    (2) r_cg = sqrt(x_cg² + y_cg²)                                  per direction
    (3) E_max,syst = max(r_cg,cw, r_cg,ccw)
    (4) E_d = D_R / D_L = (R + b/2) / (R - b/2)
    (5) E_b = b_actual / b_nominal = 180° / (180° - α)              (Borenstein & Feng: 90°)
    (6) α = (x_cg,cw + x_cg,ccw) / (-4L) · 180°/π
    (7) R = (L/2) / sin(β/2)
    (8) β = (x_cg,cw - x_cg,ccw) / (-4L) · 180°/π

then driftFactor = (wheel · E_d - wheel) · 10 and revCount = revCount_default / E_b (Appendix I,
part IV). Every value here follows the equations exactly, signs kept; docs/umbmark.md lists where
the thesis's printed numbers differ from them.
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..errors import UMBmarkError
from ..formats.files import write_atomic
from ..fuzzy import membership

#: Appendix I's Pioneer 3-DX values: 4 m square, b = 267 mm, 195 mm of travel per wheel
#: revolution, default revCount 16570 ticks per 180° turn.
SIDE_MM = 4000.0
WHEELBASE_MM = 267.0
WHEEL_MM = 195.0
REV_COUNT = 16570.0
#: the turn in Eq. 5's numerator: the thesis writes 180°; Borenstein & Feng's derivation, where α
#: is the error of each 90° turn, gives 90°.
THESIS_EB_TURN = 180.0
BORENSTEIN_EB_TURN = 90.0

#: Appendix I's stop positions (mm), (cw, ccw): Table I.1 before calibration, Table I.2 after
TABLE_I1 = (
    np.array([(1327, 645), (1420, 581), (1318, 594), (1378, 612), (1349, 642)], dtype=np.float64),
    np.array([(-928, 1477), (-893, 1512), (-802, 1225), (-879, 1286), (-713, 1289)], dtype=np.float64),
)
TABLE_I2 = (
    np.array([(-160, -150), (-134, -134), (-144, -140), (-117, -130), (-93, -100)], dtype=np.float64),
    np.array([(73, -75), (102, -94), (132, -114), (136, -118), (127, -87)], dtype=np.float64),
)


@dataclass(frozen=True)
class UMBmarkResult:
    """Everything Appendix I computes from one UMBmark test; lengths in mm, angles in degrees."""

    x_cg_cw: float
    y_cg_cw: float
    x_cg_ccw: float
    y_cg_ccw: float
    r_cw: float
    r_ccw: float
    E_max_syst: float
    alpha_deg: float
    beta_deg: float
    R: float
    E_d: float
    E_b: float
    drift_factor: float
    rev_count: float

    def as_dict(self) -> dict[str, float]:
        """The values under the keys ``fuzzybrep umbmark --json`` prints, in that order."""
        return asdict(self)


def umbmark(
    cw: np.ndarray,
    ccw: np.ndarray,
    side: float = SIDE_MM,
    wheelbase: float = WHEELBASE_MM,
    wheel: float = WHEEL_MM,
    rev_count: float = REV_COUNT,
    eb_turn_deg: float = THESIS_EB_TURN,
) -> UMBmarkResult:
    """UMBmark from the stop positions of the clockwise and counter-clockwise runs.

    cw, ccw      (n, 2) stop positions (x, y) in mm, start at (0, 0); n >= 1 each (UMBmark: 5).
    side         L, the side of the square (mm); wheelbase b (mm); wheel: travel per wheel
                 revolution (mm) for driftFactor; rev_count: the revCount the test ran with.
    eb_turn_deg  the numerator of Eq. 5: 180 as the thesis prints it, 90 as Borenstein & Feng.

    Thesis Appendix I, equations 1-8 and part IV.
    """
    cw = _stops(cw, "cw")
    ccw = _stops(ccw, "ccw")
    for name, v in (("side", side), ("wheelbase", wheelbase), ("wheel", wheel), ("rev_count", rev_count)):
        if not (math.isfinite(v) and v > 0):
            raise UMBmarkError(f"{name} must be a positive number, got {v!r}")
    if not (math.isfinite(eb_turn_deg) and eb_turn_deg > 0):
        raise UMBmarkError(f"eb_turn_deg must be a positive angle, got {eb_turn_deg!r}")

    (x_cw, y_cw), (x_ccw, y_ccw) = cw.mean(axis=0), ccw.mean(axis=0)  # Eq. 1
    r_cw, r_ccw = math.hypot(x_cw, y_cw), math.hypot(x_ccw, y_ccw)  # Eq. 2
    alpha = math.degrees((x_cw + x_ccw) / (-4.0 * side))  # Eq. 6
    beta = math.degrees((x_cw - x_ccw) / (-4.0 * side))  # Eq. 8
    # β = 0 means no curvature: R is infinite and the wheels are equal
    half_sin = math.sin(math.radians(beta) / 2.0)
    R = math.copysign(math.inf, beta) if half_sin == 0.0 else (side / 2.0) / half_sin  # Eq. 7
    E_d = 1.0 if math.isinf(R) else (R + wheelbase / 2.0) / (R - wheelbase / 2.0)  # Eq. 4
    if alpha >= eb_turn_deg:
        raise UMBmarkError(f"α = {alpha:.4g}° is not below {eb_turn_deg:g}°: Eq. 5 has no solution "
                           f"(are the stop positions in mm and the side {side:g} mm?)")
    E_b = eb_turn_deg / (eb_turn_deg - alpha)  # Eq. 5
    return UMBmarkResult(
        x_cg_cw=float(x_cw), y_cg_cw=float(y_cw), x_cg_ccw=float(x_ccw), y_cg_ccw=float(y_ccw),
        r_cw=r_cw, r_ccw=r_ccw, E_max_syst=max(r_cw, r_ccw),  # Eq. 3
        alpha_deg=alpha, beta_deg=beta, R=R, E_d=E_d, E_b=E_b,
        drift_factor=drift_factor(E_d, wheel),
        rev_count=corrected_rev_count(E_b, rev_count),
    )


def drift_factor(E_d: float, wheel: float = WHEEL_MM) -> float:
    """Appendix I part IV: the Pioneer's driftFactor = (wheel · E_d - wheel) · 10."""
    return (wheel * E_d - wheel) * 10.0


def corrected_rev_count(E_b: float, rev_count: float = REV_COUNT) -> float:
    """Appendix I part IV: the calibrated revCount = revCount / E_b."""
    return rev_count / E_b


def total_maximum_error(odometry_error: float, lrf_error: float = 15.0) -> float:
    """TME from UMBmark's odometry error and the LRF's (thesis 4.1.1): 15 mm + 184.13 mm = 199.13 mm.

    membership.total_maximum_error with the odometry error first and the LMS200's 15 mm default.
    """
    return membership.total_maximum_error(lrf_error, odometry_error)


def _stops(a, direction: str) -> np.ndarray:
    try:
        p = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise UMBmarkError(f"{direction} stop positions are not numbers: {e}") from None
    if p.ndim != 2 or p.shape[1] != 2:
        raise UMBmarkError(f"{direction} stop positions must be an (n, 2) array of x, y, got shape {p.shape}")
    if len(p) == 0:
        raise UMBmarkError(f"no {direction} stop positions: UMBmark needs runs in both directions")
    bad = ~np.isfinite(p).all(axis=1)
    if bad.any():
        raise UMBmarkError(f"{direction} stop position {int(np.argmax(bad)) + 1} is not finite: {p[bad][0].tolist()}")
    return p


def read_runs(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """The cw and ccw stop positions from a CSV with header ``direction,x,y`` (x, y in mm).

    ``direction`` is ``cw`` or ``ccw`` (any case); blank lines and lines starting with ``#`` are
    skipped. Raises UMBmarkError naming the file, line and field of the first problem.
    """
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:  # -sig: a spreadsheet's byte-order mark
            lines = f.read().splitlines()
    except (OSError, UnicodeDecodeError) as e:
        raise UMBmarkError(f"cannot read: {getattr(e, 'strerror', None) or e}", path) from None
    rows = [(n, line) for n, line in enumerate(lines, 1) if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise UMBmarkError("empty: expected a header direction,x,y and ten stop positions", path)
    header_line, header = rows[0]
    names = [h.strip().lower() for h in next(csv.reader([header]))]
    if names != ["direction", "x", "y"]:
        raise UMBmarkError(f"header must be direction,x,y, got {header.strip()!r}", path, header_line)
    stops: dict[str, list[tuple[float, float]]] = {"cw": [], "ccw": []}
    for n, line in rows[1:]:
        fields = [c.strip() for c in next(csv.reader([line]))]
        if len(fields) != 3:
            raise UMBmarkError(f"expected 3 fields (direction,x,y), got {len(fields)}", path, n)
        direction = fields[0].lower()
        if direction not in stops:
            raise UMBmarkError(f"direction must be cw or ccw, got {fields[0]!r}", path, n, "direction")
        xy = []
        for name, text in zip(("x", "y"), fields[1:]):
            try:
                v = float(text)
            except ValueError:
                raise UMBmarkError(f"not a number: {text!r}", path, n, name) from None
            if not math.isfinite(v):
                raise UMBmarkError(f"not finite: {text!r}", path, n, name)
            xy.append(v)
        stops[direction].append((xy[0], xy[1]))
    for direction, p in stops.items():
        if not p:
            raise UMBmarkError(f"no {direction} runs: UMBmark needs stop positions in both directions", path)
    return np.array(stops["cw"]), np.array(stops["ccw"])


def write_runs(path: str | os.PathLike, cw: np.ndarray, ccw: np.ndarray) -> int:
    """Write stop positions (mm) as the CSV ``read_runs`` reads; returns bytes written."""
    rows = [("cw", p) for p in _stops(cw, "cw")] + [("ccw", p) for p in _stops(ccw, "ccw")]
    text = "direction,x,y\n" + "".join(f"{d},{x:.1f},{y:.1f}\n" for d, (x, y) in rows)
    return write_atomic(Path(path), text.encode())
