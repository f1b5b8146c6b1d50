"""A simulated robot for the thesis's experiment (chapter 5): worlds, an LMS200 laser, a Pioneer 3-DX.

- ``World``, ``Route`` (from ``fuzzybrep.world``): free space as one shapely Polygon with holes,
  some walls glass, read from GeoJSON or ``builtin_floor()`` (the E1 fifth floor); waypoints with
  a stop every ``spacing`` metres (``builtin_route()``: the thesis's clockwise route, 27 stops).
- ``Laser``: SICK LMS200 in mm-mode (Table 5.1): 181 beams over 180°, 8 m usable range, a fixed
  per-run bias in [-15, 15] mm, 5 mm Gaussian noise, and configurable glass.
- ``DiffDrive``: a differential drive with Appendix I's systematic errors E_d and E_b.
- ``simulate_run``: drive the route and take two 180° scans (headings 0° and 180°) at every stop.
  Ranges come from the true pose; each scan carries the pose the odometry believes in.
- ``umbmark_runs``: the 5 + 5 square runs of Appendix I with the same odometry model.

Units: metres and radians throughout, except ``umbmark_runs``, which speaks UMBmark's millimetres.
"""

from __future__ import annotations

import io
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ScanFormatError
from ..formats.files import write_atomic
from ..scans.scan import Scan, even_bearings, wrap
from .world import FOOTPRINT, HOME, Route, World, builtin_floor, builtin_route, check_route

__all__ = [
    "World", "Route", "builtin_floor", "builtin_route", "check_route", "FOOTPRINT", "HOME",
    "Laser", "cast_rays", "DiffDrive", "integrate", "wrap", "SimRun", "simulate_run", "consolidate",
    "umbmark_runs", "save_run", "load_scans",
]

# ----------------------------------------------------------------------------------- laser


@dataclass(frozen=True)
class Laser:
    """SICK LMS200 in mm-mode (Table 5.1), with configurable glass.

    n_beams, fov   181 beams over 180° (1° resolution), bearings -90°..+90° both included.
    max_range      8 m usable range; beams returning nothing within it read max_range (no return).
    systematic     ±15 mm systematic error, modelled as one range offset per run drawn uniformly
                   in [-systematic, +systematic] (a calibration offset, the same for every beam);
                   ``bias`` fixes it instead.
    sigma          5 mm statistical error: Gaussian, independent per beam.
    glass_pass     probability that a beam passes through glass as if it were not there.
    glass_reflect  probability that it reflects specularly off the first glass it meets (the
                   range is then the whole path, a phantom point beyond the glass); otherwise
                   (1 - pass - reflect) glass returns the beam like any wall.
    """

    n_beams: int = 181
    fov: float = math.pi
    max_range: float = 8.0
    systematic: float = 0.015
    sigma: float = 0.005
    glass_pass: float = 0.5
    glass_reflect: float = 0.2
    bias: float | None = None

    def __post_init__(self) -> None:
        if self.n_beams < 2:
            raise ValueError(f"n_beams must be at least 2, got {self.n_beams}")
        if not 0 < self.fov < 2 * math.pi:
            raise ValueError(f"fov must be in (0, 2π), got {self.fov}")
        if not self.max_range > 0:
            raise ValueError(f"max_range must be positive, got {self.max_range}")
        if self.systematic < 0 or self.sigma < 0:
            raise ValueError("systematic and sigma must not be negative")
        p, q = self.glass_pass, self.glass_reflect
        if not (0 <= p <= 1 and 0 <= q <= 1 and p + q <= 1):
            raise ValueError(f"glass_pass and glass_reflect must be probabilities summing to at most 1, got {p}, {q}")

    @property
    def bearings(self) -> np.ndarray:
        return even_bearings(self.n_beams, self.fov)

    def draw_bias(self, rng: np.random.Generator) -> float:
        return float(self.bias) if self.bias is not None else float(rng.uniform(-self.systematic, self.systematic))

    def measure(self, world: World, poses: np.ndarray, rng: np.random.Generator,
                bias: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Measured ranges (S, n) from sensor poses (S, 3), and the wall segment that returned each
        beam (-1: none, the range is max_range). ``bias``: the run's offset (drawn if not given)."""
        if bias is None:
            bias = self.draw_bias(rng)
        poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        angles = (poses[:, 2:3] + self.bearings).ravel()
        origins = np.repeat(poses[:, :2], self.n_beams, axis=0)
        t, seg = cast_rays(world, origins, angles, self.max_range, glass_pass=self.glass_pass,
                           glass_reflect=self.glass_reflect, rng=rng)
        hit = seg >= 0
        r = np.full(t.shape, self.max_range)
        r[hit] = np.maximum(t[hit] + bias + self.sigma * rng.standard_normal(int(hit.sum())), 0.0)
        # a noisy reading at or past the usable range is indistinguishable from no return
        seg = np.where(r >= self.max_range, -1, seg)
        r = np.minimum(r, self.max_range)
        shape = (len(poses), self.n_beams)
        return r.reshape(shape), seg.reshape(shape)


def cast_rays(world: World, origins: np.ndarray, angles: np.ndarray, max_range: float, *,
              glass_pass: float = 0.0, glass_reflect: float = 0.0,
              rng: np.random.Generator | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free range along every ray and the wall segment that returned it.

    origins (N, 2), angles (N,) world frame. Returns (N,) ranges (inf: nothing within max_range)
    and (N,) segment indices into ``world.segments`` (-1: nothing). Glass: each ray draws once
    whether it passes through all glass (glass_pass), reflects off the first glass it meets
    (glass_reflect; the reflected leg treats glass as a wall) or is returned by it.
    """
    o = np.asarray(origins, dtype=np.float64).reshape(-1, 2)
    a = np.asarray(angles, dtype=np.float64).reshape(-1)
    d = np.column_stack((np.cos(a), np.sin(a)))
    n = len(o)
    seg, glass = world.segments, world.is_glass
    t, idx = _first_hits(seg, o, d, np.full(n, max_range))
    if (glass_pass > 0 or glass_reflect > 0) and glass.any():
        if rng is None:
            raise ValueError("glass that passes or reflects beams needs a random generator")
        u = rng.random(n)
        on_glass = idx >= 0
        on_glass[on_glass] = glass[idx[on_glass]]
        through = on_glass & (u < glass_pass)
        if through.any():
            opaque = np.flatnonzero(~glass)
            t2, i2 = _first_hits(seg[opaque], o[through], d[through], np.full(int(through.sum()), max_range))
            behind = np.full_like(i2, -1)  # all glass (no opaque wall): nothing behind the pane
            behind[i2 >= 0] = opaque[i2[i2 >= 0]]
            t[through], idx[through] = t2, behind
        mirror = on_glass & ~through & (u < glass_pass + glass_reflect)
        if mirror.any():
            t1, g = t[mirror], idx[mirror]
            hit = o[mirror] + t1[:, None] * d[mirror]
            e = seg[g, 2:] - seg[g, :2]
            e /= np.hypot(e[:, 0], e[:, 1])[:, None]
            dm = d[mirror]
            dr = 2 * np.sum(dm * e, axis=1)[:, None] * e - dm  # specular: mirror about the wall
            t2, i2 = _first_hits(seg, hit, dr, max_range - t1, exclude=g)
            t[mirror], idx[mirror] = t1 + t2, i2
    return t, idx


def _first_hits(seg: np.ndarray, o: np.ndarray, d: np.ndarray, limit: np.ndarray,
                exclude: np.ndarray | None = None, chunk: int = 1 << 21) -> tuple[np.ndarray, np.ndarray]:
    """Nearest segment hit along each ray o + t·d, 0 < t <= limit: (t, index), (inf, -1) if none.

    All rays against all segments at once, in row blocks of at most ``chunk`` ray-segment pairs.
    """
    n, w = len(o), len(seg)
    t_out, i_out = np.full(n, np.inf), np.full(n, -1)
    if n == 0 or w == 0:
        return t_out, i_out
    p, e = seg[:, :2], seg[:, 2:] - seg[:, :2]
    rows = max(1, chunk // w)
    for lo in range(0, n, rows):
        sl = slice(lo, lo + rows)
        dx, dy = d[sl, 0:1], d[sl, 1:2]
        wx, wy = p[:, 0] - o[sl, 0:1], p[:, 1] - o[sl, 1:2]
        den = dx * e[:, 1] - dy * e[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (wx * e[:, 1] - wy * e[:, 0]) / den
            u = (wx * dy - wy * dx) / den
        ok = (den != 0) & (t > 1e-9) & (u >= 0) & (u <= 1) & (t <= limit[sl, None])
        if exclude is not None:
            ok &= np.arange(w) != exclude[sl, None]
        t = np.where(ok, t, np.inf)
        i = np.argmin(t, axis=1)
        tm = t[np.arange(len(i)), i]
        t_out[sl], i_out[sl] = tm, np.where(np.isfinite(tm), i, -1)
    return t_out, i_out


# ------------------------------------------------------------------------------ the robot


@dataclass(frozen=True)
class DiffDrive:
    """A differential drive with Appendix I's systematic odometry errors (after Borenstein & Feng).

    wheelbase       nominal b (m); 267 mm for the Pioneer 3-DX as the thesis gives it.
    wheel_diameter  nominal D (m); 195 mm (Appendix I, part IV).
    E_d             D_R / D_L, unequal wheel diameters; their mean is the nominal D.
    E_b             b_actual / b_nominal, wheelbase error.
    slip            non-systematic error: each wheel's travel is off by a Gaussian with standard
                    deviation slip·sqrt(travel) (m per √m); 0 for a purely systematic robot.
    speed, turn_rate  for the scans' timestamps only (m/s, rad/s).

    The odometry integrates encoder ticks with the nominal D and b; the wheels roll with the
    actual ones. With E_d = E_b = 1 and slip = 0 the odometry is exact.
    """

    wheelbase: float = 0.267
    wheel_diameter: float = 0.195
    E_d: float = 1.0
    E_b: float = 1.0
    slip: float = 0.0
    speed: float = 0.4
    turn_rate: float = math.radians(60)

    def __post_init__(self) -> None:
        for name in ("wheelbase", "wheel_diameter", "E_d", "E_b", "speed", "turn_rate"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if not (math.isfinite(self.slip) and self.slip >= 0):
            raise ValueError(f"slip must not be negative, got {self.slip!r}")

    @classmethod
    def pioneer_3dx(cls, calibrated: bool = True, slip: float = 0.0005) -> "DiffDrive":
        """The thesis's Pioneer 3-DX: E_d and E_b that UMBmark finds from Table I.2 (calibrated)
        or Table I.1 (before calibration), with Borenstein & Feng's E_b = 90°/(90° - α) and the
        signs Eq. 8 gives. Calibrated: E_d = 1.00102, E_b = 1.00062; before: 0.99087, 0.97990."""
        from .umbmark import BORENSTEIN_EB_TURN, TABLE_I1, TABLE_I2, umbmark

        cw, ccw = TABLE_I2 if calibrated else TABLE_I1
        res = umbmark(cw, ccw, eb_turn_deg=BORENSTEIN_EB_TURN)
        return cls(E_d=res.E_d, E_b=res.E_b, slip=slip)

    @property
    def wheel_diameters(self) -> tuple[float, float]:
        """Actual (D_L, D_R): D_R / D_L = E_d, mean D (Borenstein & Feng)."""
        return 2 * self.wheel_diameter / (self.E_d + 1), 2 * self.wheel_diameter / (1 / self.E_d + 1)

    def odometry_motion(self, ds: np.ndarray, dth: np.ndarray, rng: np.random.Generator | None = None):
        """What the odometry reports (ds', dθ') for true motions (ds, dθ) (arrays)."""
        d_l, d_r = self.wheel_diameters
        b = self.wheelbase * self.E_b
        s_l, s_r = ds - dth * b / 2, ds + dth * b / 2  # true wheel travel
        # encoders count wheel turns; the odometry multiplies them by the nominal diameter
        e_l, e_r = s_l * self.wheel_diameter / d_l, s_r * self.wheel_diameter / d_r
        e_l, e_r = self._slip(e_l, e_r, rng)
        return (e_l + e_r) / 2, (e_r - e_l) / self.wheelbase

    def true_motion(self, ds: np.ndarray, dth: np.ndarray, rng: np.random.Generator | None = None):
        """The true motions (ds, dθ) when the robot drives until its odometry reports (ds', dθ')."""
        d_l, d_r = self.wheel_diameters
        e_l, e_r = ds - dth * self.wheelbase / 2, ds + dth * self.wheelbase / 2
        s_l, s_r = self._slip(e_l * d_l / self.wheel_diameter, e_r * d_r / self.wheel_diameter, rng)
        return (s_l + s_r) / 2, (s_r - s_l) / (self.wheelbase * self.E_b)

    def _slip(self, a: np.ndarray, b: np.ndarray, rng: np.random.Generator | None):
        if self.slip == 0:
            return a, b
        if rng is None:
            raise ValueError("a robot with slip needs a random generator")
        a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
        return (a + self.slip * np.sqrt(np.abs(a)) * rng.standard_normal(a.shape),
                b + self.slip * np.sqrt(np.abs(b)) * rng.standard_normal(b.shape))


def integrate(pose: np.ndarray, ds: np.ndarray, dth: np.ndarray) -> np.ndarray:
    """(m+1, 3) poses after each of m motions, each an arc of length ds turning by dθ (exact)."""
    ds, dth = np.asarray(ds, dtype=np.float64), np.asarray(dth, dtype=np.float64)
    th = pose[2] + np.concatenate(([0.0], np.cumsum(dth)))
    mid = th[:-1] + dth / 2
    chord = ds * np.sinc(dth / (2 * np.pi))  # sin(dθ/2) / (dθ/2)
    x = pose[0] + np.concatenate(([0.0], np.cumsum(chord * np.cos(mid))))
    y = pose[1] + np.concatenate(([0.0], np.cumsum(chord * np.sin(mid))))
    return np.column_stack((x, y, th))


# ------------------------------------------------------------------------------ simulation


@dataclass(frozen=True, eq=False)
class SimRun:
    """The result of ``simulate_run``.

    scans        2 per stop: heading 0° then 180° relative to the robot; poses from odometry.
    true_poses   (2k, 3) the true sensor pose of every scan.
    stops        (k, 3) the planned stop poses on the route.
    true_path, odometry_path  (m, 3) true and dead-reckoned pose after every motion.
    laser_bias   the run's systematic range offset (m).
    """

    scans: list[Scan]
    true_poses: np.ndarray
    stops: np.ndarray
    true_path: np.ndarray
    odometry_path: np.ndarray
    laser_bias: float
    seed: int | None

    @property
    def odometry_poses(self) -> np.ndarray:
        return np.array([s.pose for s in self.scans])

    @property
    def drift(self) -> np.ndarray:
        """(2k,) distance between odometry and true position at every scan."""
        return np.hypot(*(self.odometry_poses[:, :2] - self.true_poses[:, :2]).T)

    @property
    def final_drift(self) -> tuple[float, float]:
        """Position (m) and heading (rad) error of the odometry at the end of the route."""
        e = self.odometry_path[-1] - self.true_path[-1]
        return float(math.hypot(e[0], e[1])), float(wrap(e[2]))

    def consolidated(self) -> list[Scan]:
        """One 360° scan per stop, the two 180° scans merged as in thesis 5.2."""
        return [consolidate(a, b) for a, b in zip(self.scans[::2], self.scans[1::2])]


def simulate_run(world: World, route: Route, laser: Laser | None = None, robot: DiffDrive | None = None,
                 seed: int | None = 0) -> SimRun:
    """Drive ``route`` in ``world`` and scan at every stop.

    The robot follows the route truly (it turns on the spot at waypoints) while its odometry
    integrates what its wheels report through E_d and E_b; the odometry starts at the true start
    pose. At each stop it scans at heading 0°, turns 180° left, scans, turns back: two 180° scans
    (thesis 5.2). Ranges come from the true pose; each Scan carries the odometry pose, which is
    all a real robot would know. Seeded: equal seeds give identical runs.
    """
    laser = laser or Laser()
    robot = robot or DiffDrive.pioneer_3dx()
    check_route(world, route)
    rng = np.random.default_rng(seed)
    bias = laser.draw_bias(rng)
    ds, dth, scan_at = _plan(route)
    true_path = integrate(np.array([*route.waypoints[0], route.headings[0]]), ds, dth)
    ods, odth = robot.odometry_motion(ds, dth, rng)
    odo_path = integrate(true_path[0], ods, odth)
    times = np.concatenate(([0.0], np.cumsum(np.abs(ds) / robot.speed + np.abs(dth) / robot.turn_rate)))
    true_poses, odo_poses = true_path[scan_at], odo_path[scan_at]  # copies: fancy indexing
    ranges, _ = laser.measure(world, true_poses, rng, bias)
    true_poses[:, 2], odo_poses[:, 2] = wrap(true_poses[:, 2]), wrap(odo_poses[:, 2])
    bearings = laser.bearings
    scans = [
        Scan(ranges[j], bearings, odo_poses[j], float(times[i]), laser.max_range,
             f"sim:stop {j // 2 + 1}:{'0' if j % 2 == 0 else '180'}°")
        for j, i in enumerate(scan_at)
    ]
    return SimRun(scans, true_poses, route.poses_at(route.stop_distances()), true_path, odo_path, bias, seed)


def _plan(route: Route) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The route as motions (ds, dθ) and the indices (into the integrated poses) of the scans."""
    cum, heads = route.cumulative, route.headings
    stops = route.stop_distances()
    events = np.union1d(cum, stops)
    motions: list[tuple[float, float]] = []  # (ds, dθ)
    scan_at: list[int] = []
    heading, s_prev = heads[0], 0.0
    for s in events:
        if s > s_prev:
            motions.append((s - s_prev, 0.0))
            s_prev = s
        leg = np.searchsorted(cum, s, side="right") - 1
        if 0 < leg < len(heads) and np.isclose(cum[leg], s, atol=1e-9):  # a waypoint: turn to the next leg
            turn = float(wrap(heads[leg] - heading))
            if turn != 0.0:
                motions.append((0.0, turn))
            heading = heads[leg]
        if np.any(np.isclose(stops, s, atol=1e-9)):
            # pose index k is the pose after k motions: scan, turn 180° left, scan, turn back
            scan_at += [len(motions), len(motions) + 1]
            motions += [(0.0, math.pi), (0.0, -math.pi)]
    ds, dth = np.array(motions).T
    return ds, dth, np.array(scan_at)


def consolidate(front: Scan, back: Scan) -> Scan:
    """Two 180° scans taken at one stop (headings 0° and 180°) as one 360° scan at the front pose.

    The back scan's beams are re-expressed from the front pose (its odometry pose may differ by
    the turn's error); beams whose direction the front scan already covers are dropped, so the
    bearings stay strictly increasing. No-return beams stay no-return.
    """
    end = back.endpoints()
    rel = end - front.pose[:2]
    bearing = np.arctan2(rel[:, 1], rel[:, 0]) - front.pose[2]
    lo, hi = front.bearings[0], front.bearings[-1]
    # express each back bearing in (hi, lo + 2π), the part of the turn the front scan misses
    bearing = lo + (bearing - lo) % (2 * np.pi)
    keep = (bearing > hi + 1e-9) & (bearing < lo + 2 * np.pi - 1e-9)
    r = np.where(back.returns, np.hypot(rel[:, 0], rel[:, 1]), back.max_range)
    order = np.argsort(bearing[keep])
    return Scan(
        np.concatenate((front.ranges, np.minimum(r[keep][order], back.max_range))),
        np.concatenate((front.bearings, bearing[keep][order])),
        front.pose, front.timestamp, min(front.max_range, back.max_range),
        front.source.rsplit(":", 1)[0] + ":360°" if front.source else "",
    )


def umbmark_runs(robot: DiffDrive, side: float = 4000.0, seed: int | None = 0, runs: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """Stop positions (mm) of ``runs`` clockwise and ``runs`` counter-clockwise square runs.

    The robot starts at (0, 0) heading along +x (y to its left) and drives the square of side
    ``side`` mm by its odometry: four legs, each followed by a 90° turn on the spot. The stop
    position is where it truly ends, in the start frame: the UMBmark input of Appendix I.
    """
    if not (math.isfinite(side) and side > 0):
        raise ValueError(f"side must be positive (mm), got {side!r}")
    rng = np.random.default_rng(seed)
    L = side / 1000.0
    out = []
    for turn in (-math.pi / 2, math.pi / 2):  # cw turns right
        ds = np.tile([L, 0.0], 4)
        dth = np.tile([0.0, turn], 4)
        stops = [integrate(np.zeros(3), *robot.true_motion(ds, dth, rng))[-1, :2] for _ in range(runs)]
        out.append(np.array(stops) * 1000.0)
    return out[0], out[1]


def save_run(path: str | os.PathLike, run: SimRun) -> int:
    """Write a run's scans as .npz (until the CSV scan format exists); returns bytes written.

    Arrays: ranges (S, n), bearings (n,), poses (S, 3) odometry, true_poses (S, 3), timestamps
    (S,), max_range (), sources (S,), stops (k, 3), laser_bias (), seed () (-1: none).
    """
    if not run.scans:
        raise ValueError("the run has no scans")
    buf = io.BytesIO()
    np.savez_compressed(
        buf, ranges=np.array([s.ranges for s in run.scans]), bearings=run.scans[0].bearings,
        poses=run.odometry_poses, true_poses=run.true_poses,
        timestamps=np.array([s.timestamp for s in run.scans]), max_range=run.scans[0].max_range,
        sources=np.array([s.source for s in run.scans]), stops=run.stops, laser_bias=run.laser_bias,
        seed=-1 if run.seed is None else run.seed,
    )
    return write_atomic(Path(path), buf.getvalue())


def load_scans(path: str | os.PathLike) -> tuple[list[Scan], np.ndarray]:
    """The scans (odometry poses) and their true poses (S, 3) from a ``save_run`` file."""
    try:
        with np.load(path, allow_pickle=False) as z:
            d = {k: z[k] for k in ("ranges", "bearings", "poses", "true_poses", "timestamps", "max_range", "sources")}
    except (OSError, ValueError, EOFError) as e:
        raise ScanFormatError(path, None, f"not a simulated-run .npz: {e}") from None
    except KeyError as e:
        raise ScanFormatError(path, None, f"not a simulated-run .npz: no array {e}") from None
    scans = [Scan(r, d["bearings"], p, float(t), float(d["max_range"]), str(src))
             for r, p, t, src in zip(d["ranges"], d["poses"], d["timestamps"], d["sources"])]
    return scans, d["true_poses"]
