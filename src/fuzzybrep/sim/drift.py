"""Drifting odometry for a log whose poses are true: every corrected log becomes a localisation
benchmark with ground truth.

The relative motion between consecutive true poses is what the robot really did. Each is split
into the three motions a differential drive makes (turn on the spot, drive straight, turn on the
spot: the "rot1, trans, rot2" decomposition; a step backwards drives backwards), and each is
passed through the wheel-encoder model of Appendix I (after Borenstein & Feng's UMBmark, the
``sim.simulate.DiffDrive`` model), which says what the odometry reports for it:

    E_d = D_R / D_L        unequal wheel diameters (their mean the nominal D): driving straight,
                           the odometry turns by (1/E_d − E_d) / (2 b) radians per metre
    E_b = b_act / b_nom    wheelbase error: every turn on the spot is reported × E_b
    E_s = D_mean / D_nom   the mean wheel diameter off the nominal (Appendix I lists it among the
                           systematic errors and neglects it): every reading is divided by E_s

plus random error, Gaussian and independent per motion, growing with the square root of what
was travelled (a random walk): σ_distance m and σ_heading rad per √m driven, σ_turn rad per √rad
turned. The reported motions are chained from the first true pose: the odometry starts where the
robot is and drifts from there, without bound, as dead reckoning does.

The benchmark setting (``DriftModel.benchmark``, ``fuzzybrep drift``'s defaults) is given by
what the odometry does rather than by the wheels: it reports 5 % more distance than was driven,
turns 2° per metre driven straight, and reports every turn 2 % too large; ``from_rates`` solves
for E_d, E_b and E_s (for b = 267 mm: E_d = 0.99116, E_b = 0.97143, E_s = 0.95240; the
uncalibrated Pioneer of Table I.1, E_d = 0.99087 with E_s = 1, drifts 1.97°/m), with σ_distance = 2 cm/√m,
σ_heading = 0.5°/√m and σ_turn = 1°/√rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scans.scan import Scan, decompose, relative, wrap
from .simulate import DiffDrive

#: Appendix I's Pioneer 3-DX wheelbase (m), the simulator's
WHEELBASE_M = DiffDrive.wheelbase
#: the localisation benchmark's odometry (``DriftModel.benchmark``, ``fuzzybrep drift``'s defaults):
#: ``DriftModel.from_rates``'s arguments
BENCHMARK_RATES = {"distance": 0.05, "heading_deg_per_m": 2.0, "turn": 0.02,
                   "sigma_distance": 0.02, "sigma_heading_deg": 0.5, "sigma_turn_deg": 1.0}


@dataclass(frozen=True)
class DriftModel:
    """UMBmark's systematic odometry errors and random error per metre and per radian.

    E_d, E_b, E_s   wheel-diameter ratio D_R/D_L, wheelbase ratio b_actual/b_nominal, mean wheel
                    diameter / nominal (module docstring); 1 each: no systematic error
    wheelbase       nominal b (m): how E_d turns into heading drift
    sigma_distance  m per √m driven; sigma_heading rad per √m driven; sigma_turn rad per √rad turned
    """

    E_d: float = 1.0
    E_b: float = 1.0
    E_s: float = 1.0
    wheelbase: float = WHEELBASE_M
    sigma_distance: float = 0.0
    sigma_heading: float = 0.0
    sigma_turn: float = 0.0

    def __post_init__(self) -> None:
        for name in ("E_d", "E_b", "E_s", "wheelbase"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        for name in ("sigma_distance", "sigma_heading", "sigma_turn"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be a number ≥ 0, got {v!r}")

    @classmethod
    def from_rates(cls, distance: float = 0.05, heading_deg_per_m: float = 2.0, turn: float = 0.02,
                   wheelbase: float = WHEELBASE_M, sigma_distance: float = 0.0, sigma_heading_deg: float = 0.0,
                   sigma_turn_deg: float = 0.0) -> "DriftModel":
        """The model whose odometry reports (1 + distance) × every distance driven straight,
        turns ``heading_deg_per_m`` degrees per metre driven straight (positive: to the left) and
        reports (1 + turn) × every turn on the spot; random errors in degrees per √m and per √rad.

        Solves the equations of the module docstring for E_d, E_b and E_s: with
        u = 1/E_d − E_d and c = (E_d + 1/E_d + 2) / 4 (the mean of the two wheels' reading
        factors), distance: c / E_s = 1 + distance; heading: u / (2 b E_s) = κ; turn:
        E_b c / E_s = 1 + turn.
        """
        for name, v, lo in (("distance", distance, -1.0), ("turn", turn, -1.0)):
            if not (math.isfinite(v) and v > lo):
                raise ValueError(f"{name} error must be a number above {lo:g}, got {v!r}")
        if not math.isfinite(heading_deg_per_m):
            raise ValueError(f"heading drift must be a finite number, got {heading_deg_per_m!r}")
        kappa = math.radians(heading_deg_per_m)
        u = 0.0
        for _ in range(50):  # fixed point: c depends on u only at second order
            c = (math.sqrt(u * u + 4) + 2) / 4
            u = 2 * wheelbase * kappa * c / (1 + distance)
        c = (math.sqrt(u * u + 4) + 2) / 4
        E_d = (-u + math.sqrt(u * u + 4)) / 2
        E_s = c / (1 + distance)
        E_b = (1 + turn) * E_s / c
        return cls(E_d=E_d, E_b=E_b, E_s=E_s, wheelbase=wheelbase, sigma_distance=sigma_distance,
                   sigma_heading=math.radians(sigma_heading_deg), sigma_turn=math.radians(sigma_turn_deg))

    @classmethod
    def benchmark(cls) -> "DriftModel":
        """The localisation benchmark's odometry: 5 % of distance, 2°/m, 2 % of every turn, and
        random error of 2 cm/√m, 0.5°/√m and 1°/√rad."""
        return cls.from_rates(**BENCHMARK_RATES)

    # -- what the odometry does, from the wheels ---------------------------------------------

    @property
    def _c(self) -> float:
        return (self.E_d + 1 / self.E_d + 2) / 4

    @property
    def distance_error(self) -> float:
        """Reported / driven distance − 1, driving straight."""
        return self._c / self.E_s - 1

    @property
    def heading_drift(self) -> float:
        """Radians the odometry turns per metre driven straight."""
        return (1 / self.E_d - self.E_d) / (2 * self.wheelbase * self.E_s)

    @property
    def turn_error(self) -> float:
        """Reported / true turn − 1, turning on the spot."""
        return self.E_b * self._c / self.E_s - 1

    def describe(self) -> str:
        """One line: the rates and the wheel parameters that make them."""
        return (f"odometry drift {100 * self.distance_error:+.2f} % of distance, "
                f"{math.degrees(self.heading_drift):+.3f}°/m, {100 * self.turn_error:+.2f} % of every turn "
                f"(E_d = {self.E_d:.5f}, E_b = {self.E_b:.5f}, E_s = {self.E_s:.5f}, b = {self.wheelbase:g} m); "
                f"random {self.sigma_distance:g} m/√m, {math.degrees(self.sigma_heading):g}°/√m, "
                f"{math.degrees(self.sigma_turn):g}°/√rad")

    def _robot(self) -> DiffDrive:
        return DiffDrive(wheelbase=self.wheelbase, E_d=self.E_d, E_b=self.E_b)

    def reported(self, ds: np.ndarray, dth: np.ndarray, rng: np.random.Generator | None) -> tuple[np.ndarray, np.ndarray]:
        """What the odometry reports, (ds', dθ'), for true arcs (ds, dθ): E_d and E_b through the
        wheel model, E_s on every reading, then the random error."""
        ods, odth = self._robot().odometry_motion(np.asarray(ds, np.float64), np.asarray(dth, np.float64))
        ods, odth = ods / self.E_s, odth / self.E_s
        if self.sigma_distance or self.sigma_heading or self.sigma_turn:
            if rng is None:
                raise ValueError("random odometry error needs a random generator (a seed)")
            a, t = np.sqrt(np.abs(ds)), np.sqrt(np.abs(dth))
            n = rng.standard_normal((3, np.size(ds)))
            ods = ods + self.sigma_distance * a * n[0]
            odth = odth + self.sigma_heading * a * n[1] + self.sigma_turn * t * n[2]
        return ods, odth


def _arc(ds: np.ndarray, dth: np.ndarray) -> np.ndarray:
    """(m, 3) relative poses of arcs of length ds turning by dθ (sim.simulate.integrate's chord)."""
    chord = ds * np.sinc(dth / (2 * np.pi))
    return np.column_stack((chord * np.cos(dth / 2), chord * np.sin(dth / 2), dth))


def _chain(start: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """(m + 1, 3) poses from ``start`` (3,) through relative steps (m, 3), without a Python loop:
    the heading is a cumulative sum, each step is turned by the heading before it."""
    th = start[2] + np.concatenate(([0.0], np.cumsum(steps[:, 2])))
    c, s = np.cos(th[:-1]), np.sin(th[:-1])
    dx = c * steps[:, 0] - s * steps[:, 1]
    dy = s * steps[:, 0] + c * steps[:, 1]
    x = start[0] + np.concatenate(([0.0], np.cumsum(dx)))
    y = start[1] + np.concatenate(([0.0], np.cumsum(dy)))
    return np.column_stack((x, y, wrap(th)))


def _then(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Relative motions a then b, row by row (both (m, 3)): a ⊕ b with a at the origin."""
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack((a[:, 0] + c * b[:, 0] - s * b[:, 1], a[:, 1] + s * b[:, 0] + c * b[:, 1], a[:, 2] + b[:, 2]))


def drift_poses(true_poses: np.ndarray, model: DriftModel, seed: int | None = 0) -> np.ndarray:
    """(S, 3) odometry poses for true poses (S, 3): the first equal, the rest dead-reckoned from
    the motions the odometry reports for each true step (module docstring). Seeded: equal seeds
    give equal odometry."""
    true = np.asarray(true_poses, np.float64).reshape(-1, 3)
    if len(true) == 0:
        return true.copy()
    if not np.isfinite(true).all():
        raise ValueError(f"true pose {int(np.argmax(~np.isfinite(true).all(axis=1))) + 1} is not finite")
    rng = np.random.default_rng(seed)
    rot1, trans, rot2 = decompose(relative(true[:-1], true[1:]))
    m = len(rot1)
    zero = np.zeros(m)
    # one call for the three motions of every step, so that the random draws are in one order
    ds, dth = model.reported(np.concatenate((zero, trans, zero)), np.concatenate((rot1, zero, rot2)), rng)
    r1 = _arc(zero, dth[:m])
    t = _arc(ds[m:2 * m], dth[m:2 * m])
    r2 = _arc(zero, dth[2 * m:])
    return _chain(true[0], _then(_then(r1, t), r2))


def drift_scans(scans: list[Scan], model: DriftModel, seed: int | None = 0) -> list[Scan]:
    """The scans with their poses kept as the truth and ``odometry`` set to drifting odometry
    (``drift_poses`` of the poses)."""
    odo = drift_poses(np.array([s.pose for s in scans]).reshape(-1, 3), model, seed)
    return [Scan(s.ranges, s.bearings, s.pose, s.timestamp, s.max_range, s.source, o) for s, o in zip(scans, odo)]


@dataclass(frozen=True)
class DriftStats:
    """How far odometry poses are from the true ones (metres, degrees).

    travel          metres the true poses moved, step by step
    final_position  distance between the last odometry and the last true pose
    final_heading   heading error at the end, degrees (signed)
    max_position    the largest position error along the way
    distance_ratio  odometry's step lengths summed / the true ones' (1.05 for 5 % more)
    heading_per_m   mean heading error per metre of travel, degrees: the step heading changes'
                    error summed, over the travel
    """

    travel: float
    final_position: float
    final_heading: float
    max_position: float
    distance_ratio: float
    heading_per_m: float

    def summary(self) -> str:
        return (f"{self.travel:.1f} m of travel: odometry {100 * (self.distance_ratio - 1):+.2f} % of distance, "
                f"{self.heading_per_m:+.2f}°/m; at the end {self.final_position:.2f} m and {self.final_heading:+.1f}° "
                f"off (at most {self.max_position:.2f} m)")


def drift_stats(odometry: np.ndarray, true_poses: np.ndarray) -> DriftStats:
    """``DriftStats`` of odometry poses against true poses, both (S, 3)."""
    odo, true = np.asarray(odometry, np.float64), np.asarray(true_poses, np.float64)
    t_steps, o_steps = relative(true[:-1], true[1:]), relative(odo[:-1], odo[1:])
    travel = float(np.hypot(t_steps[:, 0], t_steps[:, 1]).sum())
    odo_travel = float(np.hypot(o_steps[:, 0], o_steps[:, 1]).sum())
    err = np.hypot(*(odo[:, :2] - true[:, :2]).T)
    turn_err = float(np.degrees(np.sum(o_steps[:, 2] - t_steps[:, 2])))
    return DriftStats(travel, float(err[-1]), float(np.degrees(wrap(odo[-1, 2] - true[-1, 2]))), float(err.max()),
                      odo_travel / travel if travel > 0 else 1.0, turn_err / travel if travel > 0 else 0.0)
