"""The odometry's systematic error, learnt from the scans as they are aligned (issue 22).

A robot's odometry is wrong in ways that repeat (Appendix I, after Borenstein & Feng's UMBmark):
unequal or worn wheels report more or less distance than was driven and turn a little with every
metre driven straight, a wrong wheelbase scales every turn. ``registration.align_scans`` starts each
scan from the odometry's step and lets the scan correct it; where the scan cannot (along a
featureless corridor, a scan that sees little it has seen before) the step stays as the
odometry says, and its systematic error accumulates (5 % of a 40 m corridor is 2 m). Every scan
the map fixes well measures that error once more; ``OdometryCalibration`` keeps the running
least-squares estimate of the three rates and corrects each new step with it, as a calibration
(UMBmark) would have done beforehand:

    reported distance = (1 + a) × distance driven
    reported turn     = (1 + c) × turn + κ × distance driven

a, c and κ by ridge regression towards 0 (no error) over stretches between two scans the map
fixed well in every direction, a few metres apart: one match is a centimetre or two off, which
over a metre's step would be several per cent of distance, and a corridor's scans (the ones the
odometry matters for) teach nothing. A few stretches, or a robot whose odometry has no systematic
error, leave the odometry as it is.
"""

from __future__ import annotations

import math

import numpy as np


class OdometryCalibration:
    """Running estimate of the odometry's distance factor ``a``, turn factor ``c`` and heading drift
    ``kappa`` (radians per metre), from stretches of (odometry, aligned) motion.

    prior_distance  metres of travel that the prior "no error" weighs as much as: the estimate
                    moves from 0 only once the scans have said so over more than that
    prior_turn      radians of turning, likewise for ``c``
    """

    def __init__(self, prior_distance: float = 10.0, prior_turn: float = math.radians(180.0)):
        self._sdd = prior_distance  # Σ d² (+ the prior's weight), d the aligned distance driven
        self._sdo = prior_distance  # Σ d × reported distance: a = 0 under the prior
        # heading: reported − aligned turn = κ d + c θ, normal equations with a ridge
        self._A = np.diag([prior_distance, prior_turn])
        self._b = np.zeros(2)
        self.steps = 0

    @property
    def a(self) -> float:
        return self._sdo / self._sdd - 1.0

    @property
    def kappa_c(self) -> tuple[float, float]:
        k, c = np.linalg.solve(self._A, self._b)
        return float(k), float(c)

    def learn(self, odometry: np.ndarray, aligned: np.ndarray, distance: float, turn: float) -> None:
        """One stretch between two well-matched scans: where the odometry put the second seen from
        the first, (3,), where the scans put it, (3,), and the distance and the turn the odometry
        reported over the stretch (the sums of its steps' lengths and turns).

        The distance factor compares the two chords (a stretch scaled by 1 + a has its chord
        scaled so), the turn factor and the drift the two net turns: reported − aligned turn
        = κ × distance driven + c × the turn."""
        d_o, d = math.hypot(odometry[0], odometry[1]), math.hypot(aligned[0], aligned[1])
        self._sdd += d * d
        self._sdo += d * d_o
        x = np.array([distance / (1.0 + self.a), turn])
        self._A += np.outer(x, x)
        self._b += x * float(np.angle(np.exp(1j * (odometry[2] - aligned[2]))))
        self.steps += 1

    def correct(self, step: np.ndarray) -> np.ndarray:
        """The odometry's step (3,) with the systematic error estimated so far taken out."""
        if not self.steps:
            return np.asarray(step, np.float64)
        kappa, c = self.kappa_c
        a = self.a
        d_o = math.hypot(step[0], step[1])
        d = d_o / (1.0 + a)
        turn = (step[2] - kappa * d) / (1.0 + c)
        # the chord of an arc points half its turn round: a turn taken out turns the chord by half
        half = -(step[2] - turn) / 2
        ch, sh = math.cos(half), math.sin(half)
        x, y = step[0] / (1.0 + a), step[1] / (1.0 + a)
        return np.array([ch * x - sh * y, sh * x + ch * y, turn])

    def describe(self) -> str:
        kappa, c = self.kappa_c
        return (f"odometry as learnt from {self.steps} stretches: {100 * self.a:+.2f} % of distance, "
                f"{math.degrees(kappa):+.2f}°/m, {100 * c:+.2f} % of every turn")
