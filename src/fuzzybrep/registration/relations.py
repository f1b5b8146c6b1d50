"""The SLAM benchmark's metric: estimated poses scored on hand-checked relative poses.

Kümmerle, Steder, Dornhege, Ruhnke, Grisetti, Stachniss and Kleiner, "On measuring the accuracy
of SLAM algorithms" (Autonomous Robots 27(4), 2009). A relations file holds one relation a line,
``t1 t2 x y z roll pitch yaw``: where the robot was at t2 seen from where it was at t1 (metres,
radians; z, roll and pitch are 0 in 2-D). For each relation the poses of the scans nearest in
time to t1 and t2 (within ``max_dt``) give the estimated relative pose δ = p1⁻¹ ∘ p2; the
translational error is |δ_xy − δ*_xy|, the rotational error |wrap(δ_θ − δ*_θ)|. The benchmark
reports the mean and standard deviation (N − 1) of the errors and of their squares.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..errors import ScanFormatError
from ..scans.scan import relative, wrap


@dataclass(frozen=True)
class Relations:
    t1: np.ndarray  #: (R,) seconds
    t2: np.ndarray
    delta: np.ndarray  #: (R, 3) x, y, yaw of t2 seen from t1

    def __len__(self) -> int:
        return len(self.t1)


@dataclass(frozen=True)
class RelationScore:
    """Mean and standard deviation (N − 1) of the absolute and squared errors: metres and degrees
    (squared: m² and deg²), over ``used`` relations (``missing`` had no scan within max_dt)."""

    trans: tuple[float, float]
    trans_sq: tuple[float, float]
    rot: tuple[float, float]
    rot_sq: tuple[float, float]
    used: int
    missing: int
    trans_errors: np.ndarray
    rot_errors: np.ndarray  #: degrees

    def summary(self) -> str:
        return (f"{self.trans[0]:.4f} ± {self.trans[1]:.4f} m, {self.rot[0]:.3f} ± {self.rot[1]:.3f}° "
                f"({self.used} relations)")


def read_relations(path: str | os.PathLike) -> Relations:
    """A benchmark relations file (module docstring); ScanFormatError naming the line when a line is not
    eight numbers."""
    rows = []
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            if len(fields) != 8:
                raise ScanFormatError(path, n, f"a relation is 8 numbers (t1 t2 x y z roll pitch yaw), got {len(fields)} fields")
            try:
                v = [float(x) for x in fields]
            except ValueError as e:
                raise ScanFormatError(path, n, str(e)) from None
            if not all(math.isfinite(x) for x in v):
                raise ScanFormatError(path, n, "a relation must be finite")
            rows.append(v)
    a = np.array(rows, np.float64).reshape(-1, 8)
    return Relations(a[:, 0], a[:, 1], a[:, [2, 3, 7]])


def nearest_scan(times: np.ndarray, t: np.ndarray, max_dt: float) -> np.ndarray:
    """(R,) index of the scan nearest in time to each t, −1 where none lies within max_dt."""
    times = np.asarray(times, np.float64)
    order = np.argsort(times, kind="stable")
    ts = times[order]
    i = np.clip(np.searchsorted(ts, t), 1, max(len(ts) - 1, 1))
    lo, hi = ts[i - 1], ts[np.minimum(i, len(ts) - 1)]
    pick = np.where(np.abs(t - lo) <= np.abs(hi - t), i - 1, np.minimum(i, len(ts) - 1))
    out = order[pick]
    return np.where(np.abs(times[out] - t) <= max_dt, out, -1)


def score(times: np.ndarray, poses: np.ndarray, relations: Relations, max_dt: float = 0.1) -> RelationScore:
    """The benchmark's errors of ``poses`` (S, 3) at scan ``times`` (S,) on ``relations``."""
    poses = np.asarray(poses, np.float64).reshape(-1, 3)
    a = nearest_scan(times, relations.t1, max_dt)
    b = nearest_scan(times, relations.t2, max_dt)
    ok = (a >= 0) & (b >= 0)
    d = relative(poses[a[ok]], poses[b[ok]])
    ref = relations.delta[ok]
    et = np.hypot(d[:, 0] - ref[:, 0], d[:, 1] - ref[:, 1])
    er = np.degrees(np.abs(wrap(d[:, 2] - ref[:, 2])))

    def ms(x):
        return (float(x.mean()), float(x.std(ddof=1))) if len(x) > 1 else (float(x.mean()) if len(x) else math.nan, math.nan)

    return RelationScore(ms(et), ms(et ** 2), ms(er), ms(er ** 2), int(ok.sum()), int((~ok).sum()), et, er)
