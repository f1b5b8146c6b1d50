"""Monte Carlo localisation on a fuzzy B-rep map: finding the robot with no start, and a local
search when tracking loses the map.

Particles are sensor poses, weighed by ``SensorModel.log_likelihood``: a subsample of the scan's
endpoints against the map's obstacle edges, endpoints beyond a frontier counting as unknown.
Vectorised over particles and endpoints; the loop is over scans.

Global localisation (``global_localise``) draws particles uniformly over the crisp free space
(``PARTICLES_PER_M2``, within ``MIN_PARTICLES`` .. ``MAX_PARTICLES``; headings uniform), weighs
them by the first scan with a wide σ (``SIGMA0``: a particle a little off the truth still
scores), and keeps the best, apart from each other, as hypotheses (``PROPOSALS``). Each is
aligned to the map (``align``), which moves it onto its local optimum, and then followed scan by
scan like a tracked pose: moved by the odometry, aligned again, scored by the likelihood of the
scan at its pose (σ = TME/2, the endpoints counting as ``INDEPENDENT_BEAMS`` independent ones).
Every update adds the best of a fresh draw (``REFRESH`` particles, or as many as the first draw
when that is fewer; ``NEW_PROPOSALS`` kept), so a pose the first draw missed can still be found.
As AMCL (update_min_d, update_min_a), the filter updates only after the odometry moved
``update_distance`` or turned ``update_turn`` since the last update (a robot standing still
learns nothing new from scan after scan, and the update is the costly part: about a second on
Intel), and the search gives up after ``max_updates`` updates (``LocalisationError``).
Converged: a hypothesis followed for ``PERSIST`` updates whose mean grade is at least
``MIN_GRADE`` leads every other hypothesis more than 1 m or 20° away by ``MARGIN``
(log-likelihood over its last ``PERSIST`` updates); tracking continues from it. Plain particle filtering (the same particles resampled scan by scan) was measured first and
lost the true pose within two scans of 2 m on ACES: docs/localise.md.
"""

from __future__ import annotations

import math

import numpy as np

from ..scans.scan import compose, relative, wrap
from ..errors import LocalisationError
from .sensor_model import SensorModel, sensor_points

PARTICLES_PER_M2 = 200.0
MIN_PARTICLES = 2000
MAX_PARTICLES = 200_000
SIGMA0 = 0.5
PROPOSALS = 200
REFRESH = 20_000
NEW_PROPOSALS = 20
MAX_HYPOTHESES = 300
INDEPENDENT_BEAMS = 10.0
PERSIST = 3
MARGIN = 5.0
MIN_GRADE = 0.5
#: hypotheses closer than this are one (the better kept); a rival is one farther than twice it
SAME_RADIUS = 0.5
SAME_HEADING = math.radians(10.0)


def motion_prior(step: np.ndarray, cfg) -> np.ndarray:
    """(3, 3) covariance of the wheel odometry's error over one relative motion (x, y, heading),
    in the robot's frame."""
    ds = math.hypot(step[0], step[1])
    st = cfg.trans_per_m * ds + cfg.trans_floor
    sh = cfg.heading_per_m * ds + cfg.heading_per_rad * abs(step[2]) + cfg.heading_floor
    return np.diag([st * st, st * st, sh * sh])


def subsample(points: np.ndarray, n: int) -> np.ndarray:
    """At most n of the points, evenly spread over the scan (every k-th)."""
    if len(points) <= n:
        return points
    return points[np.linspace(0, len(points) - 1, n).round().astype(np.int64)]


def local_search(model: SensorModel, pts: np.ndarray, pred: np.ndarray, cov: np.ndarray, rng: np.random.Generator,
                 beams: int = 60, n: int = 300, top: int = 3) -> list[np.ndarray]:
    """The ``top`` best of ``n`` poses drawn from N(pred, cov) (and pred itself), by the
    likelihood of ``beams`` of the scan's endpoints at σ = TME/2."""
    draws = rng.multivariate_normal(pred, cov, n)
    draws = np.vstack((pred, draws))
    ll = model.log_likelihood(draws, subsample(pts, beams), model.tme / 2)
    best = np.argsort(-ll)[:top]
    out = draws[best]
    out[:, 2] = wrap(out[:, 2])
    return list(out)


def _first_draw(model: SensorModel) -> int:
    """The particles of the first draw: ``PARTICLES_PER_M2`` of the free space, within bounds."""
    return int(min(max(PARTICLES_PER_M2 * model.free_space.area, MIN_PARTICLES), MAX_PARTICLES))


def initial_particles(model: SensorModel, rng: np.random.Generator, n: int | None = None) -> np.ndarray:
    """Particles uniform over the map's free space, headings uniform; as many as its area asks
    for (``PARTICLES_PER_M2``) unless ``n`` says."""
    if n is None:
        n = _first_draw(model)
    xy = model.sample_free(n, rng)
    return np.column_stack((xy, rng.uniform(-math.pi, math.pi, len(xy))))


def best_apart(poses: np.ndarray, score: np.ndarray, n: int, avoid: np.ndarray | None = None) -> np.ndarray:
    """Indices of at most n poses, best score first, no two (and none and a pose of ``avoid``)
    within SAME_RADIUS and SAME_HEADING of each other."""
    order = np.argsort(-score)
    kept: list[int] = []
    taken = np.zeros((0, 3)) if avoid is None else np.asarray(avoid).reshape(-1, 3)
    for i in order[: 50 * n]:
        p = poses[i]
        if len(taken) and np.any((np.hypot(taken[:, 0] - p[0], taken[:, 1] - p[1]) < SAME_RADIUS)
                                 & (np.abs(wrap(taken[:, 2] - p[2])) < SAME_HEADING)):
            continue
        kept.append(int(i))
        taken = np.vstack((taken, p))
        if len(kept) == n:
            break
    return np.array(kept, np.int64)


class _Hypothesis:
    __slots__ = ("pose", "scores", "mu", "alignment")

    def __init__(self, alignment, score: float):
        self.alignment = alignment
        self.pose = alignment.pose
        self.mu = alignment.mu
        self.scores = [score]

    def recent(self) -> float:
        return float(sum(self.scores[-PERSIST:]))


def global_localise(model: SensorModel, scans, odo: np.ndarray, cfg, rng: np.random.Generator, tracker, progress=None):
    """Global localisation from no start (module docstring).

    Returns (k, alignment, guesses, updates): the scan k at which it converged and that scan's
    alignment (None, and k = len(scans), when it never did), the best hypothesis's pose (S, 3)
    for every scan before k (for every scan when it did not converge), and the filter updates
    made. A scan whose odometry moved less than ``cfg.update_distance`` and turned less than
    ``cfg.update_turn`` since the last update does not update (its pose is the odometry's
    prediction). Raises ``LocalisationError`` after ``cfg.max_updates`` updates without
    converging.
    """
    S = len(scans)
    guesses = np.zeros((S, 3))
    hyps: list[_Hypothesis] = []
    last = -1  # the scan of the last filter update
    updates = 0
    best = None
    for k in range(S):
        if best is not None:  # AMCL's update_min_d, update_min_a: no update until the robot moved
            step = relative(odo[last], odo[k])
            if math.hypot(step[0], step[1]) < cfg.update_distance and abs(float(wrap(step[2]))) < cfg.update_turn:
                guesses[k] = compose(best.pose, step)  # predicted by the odometry
                if progress is not None:
                    progress(k + 1, S)
                continue
        updates += 1
        pts = sensor_points(scans[k])
        beams = subsample(pts, cfg.beams)
        temper = max(1.0, len(beams) / INDEPENDENT_BEAMS)
        if last >= 0 and hyps:  # follow every hypothesis like a tracked pose
            step = relative(odo[last], odo[k])
            cov = motion_prior(step, cfg)
            info, start = np.linalg.inv(cov), tracker.start_width(cov)
            for h in hyps:
                pred = compose(h.pose, step)
                h.alignment = tracker.align_to_map(pts, pred, info, start)
                h.pose, h.mu = h.alignment.pose, h.alignment.mu
        # new proposals: the best of a uniform draw, weighed with a wide σ, then aligned
        draw = initial_particles(model, rng, None if k == 0 else min(REFRESH, _first_draw(model)))
        ll = model.log_likelihood(draw, beams, max(SIGMA0, model.tme))
        existing = np.array([h.pose for h in hyps]).reshape(-1, 3)
        for i in best_apart(draw, ll, PROPOSALS if k == 0 else NEW_PROPOSALS, existing):
            hyps.append(_Hypothesis(tracker.align_to_map(pts, draw[i], None, cfg.start_kernel), 0.0))
            hyps[-1].scores = []
        poses = np.array([h.pose for h in hyps])
        score = model.log_likelihood(poses, beams, model.tme / 2) / temper
        for h, sc in zip(hyps, score):
            h.scores.append(float(sc))
        hyps = _prune(hyps)
        best = max(hyps, key=lambda h: (len(h.scores) >= PERSIST, h.recent()))
        guesses[k] = best.pose
        last = k
        if _converged(best, hyps):
            tracker.accept(best.alignment)
            if progress is not None:
                progress(k + 1, S)
            return k, best.alignment, guesses[:k], updates
        if updates >= cfg.max_updates:
            travel = float(np.hypot(*np.diff(odo[: k + 1, :2], axis=0).T).sum())
            raise LocalisationError(f"global localisation did not converge in {updates} filter updates (the bound; "
                                    f"{k + 1} scans, {travel:.1f} m of odometry): the scans match no one place "
                                    f"of the map (is the log of this map?)")
        if progress is not None:
            progress(k + 1, S)
    return S, None, guesses, updates


def _prune(hyps: list) -> list:
    """Duplicates merged (the better kept), at most MAX_HYPOTHESES, by their recent score per scan."""
    order = sorted(hyps, key=lambda h: -h.recent() / len(h.scores[-PERSIST:]))
    kept: list = []
    for h in order:
        if any(np.hypot(*(h.pose[:2] - g.pose[:2])) < SAME_RADIUS and abs(wrap(h.pose[2] - g.pose[2])) < SAME_HEADING
               for g in kept):
            continue
        kept.append(h)
        if len(kept) == MAX_HYPOTHESES:
            break
    return kept


def _converged(best, hyps: list) -> bool:
    """``best`` followed for PERSIST scans, agreeing with the map, ahead of every rival by MARGIN."""
    if len(best.scores) < PERSIST or best.mu < MIN_GRADE:
        return False
    top = best.recent()
    for h in hyps:
        if h is best:
            continue
        far = np.hypot(*(h.pose[:2] - best.pose[:2])) > 2 * SAME_RADIUS or \
            abs(wrap(h.pose[2] - best.pose[2])) > 2 * SAME_HEADING
        if not far:
            continue
        # a younger rival is judged by its scans so far, scaled to PERSIST
        theirs = h.recent() * PERSIST / max(len(h.scores[-PERSIST:]), 1)
        if top - theirs < MARGIN:
            return False
    return True


def track_particles(model: SensorModel, scans, odo: np.ndarray, start: np.ndarray, rng: np.random.Generator,
                    particles: int = 500, beams: int = 60, distance_sigma: float = 0.08,
                    heading_sigma: float = math.radians(3.0), floor: float = 0.01) -> np.ndarray:
    """Pose tracking by a plain particle filter on the same sensor model, for comparison with
    ``localise``'s matching (benchmarks/localise.py measures both): ``particles`` poses from
    ``start``, each moved by the odometry's relative motion with Gaussian noise (σ
    ``distance_sigma`` per metre moved plus ``floor`` in position; ``heading_sigma`` per metre and
    per radian plus a tenth of it in heading), weighed by the likelihood of ``beams`` endpoints at
    σ = TME/2 (tempered as the global search's), resampled (systematic) when the effective number
    falls below half. Returns (S, 3): the weighted mean pose of every scan."""
    S = len(scans)
    out = np.zeros((S, 3))
    p = np.tile(np.asarray(start, np.float64), (particles, 1))
    p[:, :2] += rng.normal(0.0, floor, (particles, 2))
    logw = np.zeros(particles)
    for k in range(S):
        if k:
            step = relative(odo[k - 1], odo[k])
            ds, turn = math.hypot(step[0], step[1]), abs(float(step[2]))
            st = distance_sigma * ds + floor
            sh = heading_sigma * (ds + turn) + heading_sigma / 10
            noise = np.column_stack((rng.normal(0, st, particles), rng.normal(0, st, particles),
                                     rng.normal(0, sh, particles)))
            p = compose(p, step + noise)
        pts = subsample(sensor_points(scans[k]), beams)
        temper = max(1.0, len(pts) / INDEPENDENT_BEAMS)
        logw = logw + model.log_likelihood(p, pts, model.tme / 2) / temper
        w = np.exp(logw - logw.max())
        w /= w.sum()
        out[k, :2] = w @ p[:, :2]
        out[k, 2] = math.atan2(float(w @ np.sin(p[:, 2])), float(w @ np.cos(p[:, 2])))
        if 1.0 / float(w @ w) < particles / 2:
            u = (rng.random() + np.arange(particles)) / particles
            p = p[np.minimum(np.searchsorted(np.cumsum(w), u), particles - 1)]
            logw = np.zeros(particles)
    return out
