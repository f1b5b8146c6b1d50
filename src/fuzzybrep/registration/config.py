"""The alignment's settings: the odometry's noise model and every knob of ``registration.align_scans``
(metres and radians). One place, as KISS-ICP keeps its defaults in one config object."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


#: the floor under a match's standard deviation (``_edge_information``): metres, radians
POSE_FLOOR = 0.02
HEADING_FLOOR = math.radians(0.5)


@dataclass(frozen=True)
class OdometryNoise:
    """How far the odometry's step between two scans may be off, one standard deviation:
    ``distance`` × the distance driven + ``floor`` in position, ``turn`` × the turn +
    ``heading_per_m`` × the distance + ``heading_floor`` in heading (radians). The defaults are
    twice the benchmark's systematic drift (5 % and 2°/m), so that a badly calibrated robot is
    still inside the prior."""

    distance: float = 0.10
    floor: float = 0.02
    turn: float = 0.05
    heading_per_m: float = math.radians(4.0)
    heading_floor: float = math.radians(1.0)

    def information(self, step: np.ndarray, heading: float) -> np.ndarray:
        """(3, 3) information of an odometry step (3,) in the world frame at ``heading``
        (isotropic in position, so the frame does not matter)."""
        d = math.hypot(step[0], step[1])
        sp = self.distance * d + self.floor
        st = self.turn * abs(step[2]) + self.heading_per_m * d + self.heading_floor
        return np.diag([1 / sp ** 2, 1 / sp ** 2, 1 / st ** 2])


@dataclass(frozen=True)
class AlignConfig:
    """Knobs of ``align_scans`` (metres and radians; module docstring)."""

    window: int = 16  #: key scans in the local map
    key_distance: float = 0.5
    key_turn: float = math.radians(10.0)
    max_range: float = 15.0  #: returns farther than this are not aligned nor mapped (too sparse)
    #: ... unless fewer than sparse_share of a scan's beams return within it: then far_range
    sparse_share: float = 0.5
    far_range: float = 30.0
    max_points: int = 100  #: returns aligned per scan, evenly subsampled
    join: float = 0.05  #: consecutive returns closer than join + 3 × beam spacing × range are one surface
    width: float = 0.10  #: final kernel width of the match
    start_width: float = 0.3
    spacing: float = 0.05  #: SegmentIndex sample spacing
    iterations: int = 20  #: Gauss-Newton iterations of a scan's match at most
    loop_iterations: int = 30  #: ... of a loop match
    odometry: OdometryNoise = field(default_factory=OdometryNoise)
    #: learn the odometry's systematic error from the well-matched steps and take it out of the
    #: next steps (``registration.calibrate_odometry``)
    calibrate: bool = True
    calibrate_sigma: float = 0.02  #: a stretch teaches it between scans whose match alone fixes them this well (m), every way
    calibrate_stretch: float = 3.0  #: ... at least this far apart (m of odometry travel)
    loop_closure: bool = True
    #: try a loop closure every this many metres of travel. 1 m, not 2: a try is one candidate
    #: place, and one that misses (the drifted estimate nearest the wrong key scans) waited 2 m for
    #: the next; fhw with the benchmark's drift went 9.5 -> 0.48 m RMSE, the raw logs as good or
    #: better (docs/slam.md), at some 5 % more time
    loop_every: float = 1.0
    loop_travel: float = 8.0  #: a place passed at least this much travel ago is a loop candidate
    loop_radius: float = 0.5  #: ... when within this distance of the scan's estimate (and more: ``_try_loop``)
    loop_window: int = 4  #: key scans either side of the candidate in the loop's local map
    loop_growth: float = 0.08  #: ... plus this share of the travel since (``_try_loop``)
    loop_max_radius: float = 10.0
    #: the match may move the scan at most loop_radius + this share of the travel since: a front
    #: end that drifts more than this loses that loop, one that slides along a corridor whose
    #: doors repeat is not believed
    loop_slide: float = 0.06
    #: an old place is a candidate this much farther than the drift reaches: the other side of a
    #: corridor, or a room seen from its door, is the same place (the match's own correction
    #: must still lie within the drift's reach)
    loop_view: float = 2.0
    loop_start_width: float = 1.6
    loop_inliers: float = 0.75  #: share of the scan the old place must explain
    loop_sigma: float = 0.05  #: and its position known this well across the corridor at least (m)
    loop_heading_sigma: float = math.radians(1.0)  #: and its heading this well
    loop_reoptimise: float = 0.20
    #: Gauss-Newton iterations of that solve at most: it moves the local map near the loop's
    #: correction, the solves at the end converge (most of the pose graph's cost on intel)
    loop_solve_iterations: int = 5
    #: a loop match must be unique (``_rival``): along the direction it constrains least, profiled
    #: every loop_probe metres, no other pose farther than loop_unique may explain nearly as
    #: much of the scan (loop_rival of its mean membership): a corridor whose doors repeat has one
    loop_probe: float = 0.1
    loop_unique: float = 0.25
    loop_rival: float = 0.95
    probe_iterations: int = 12  #: Gauss-Newton iterations of a probe at most (it need only show where it goes)
    refine: int = 1  #: passes of ``_refine`` after the online pass (0: none)
    refine_radius: float = 3.0  #: a key scan this near, passed at least loop_travel ago (or later), is matched
    refine_move: float = 0.3  #: a refinement match moving a scan farther than this is not believed
    refine_every: float = 1.0  #: a key scan is matched again once per this much travel
    #: ... and to the key scans around it in time, at least this many key scans either side (0:
    #: not): the front end matched it to the scans before it only (``_refine_local``)
    refine_local: int = 4
    refine_local_every: float = 1.0  #: ... once per this much travel
    check: bool = True  #: check the aligned poses against the scans at the end (``registration.check``)
    strict: bool = False  #: ... and raise AlignmentError when they fail it (``build --align --strict``)
    poor_inliers: float = 0.5
    poor_sigma: float = 0.10
    #: correlative search before each scan's match (``registration.correlative``): the window is
    #: ±(search_sigmas × the odometry step's σ), at least search_window and search_angle, at most
    #: search_max and search_max_angle; 0 search_sigmas: no search (the odometry's guess is the start)
    search_sigmas: float = 3.0
    search_below: float = 0.85  #: ... when the match from the odometry's guess explains less of the scan than this
    search_gain: float = 0.0  #: ... and the search's match is kept when it explains this much more of the scan
    search_window: float = 0.3
    search_angle: float = math.radians(6.0)
    search_max: float = 1.0
    search_max_angle: float = math.radians(20.0)
    search_resolution: float = 0.05
    search_sigma: float = 0.08  #: the likelihood field's σ (m)
    search_points: int = 60  #: returns scored per pose
    search_prior: float = 0.02  #: weight of the odometry prior in the search's score (a tie-breaker)
    #: a loop's match starts from the best pose of a correlative search over the window the drift
    #: allows (its radius; ± search_angle + loop_search_turn per metre of travel since in heading)
    loop_search: bool = True
    loop_search_resolution: float = 0.1
    loop_search_turn: float = math.radians(0.5)
    #: follow the sign of the odometry's travel from the last direction_steps steps, when each
    #: match fixes the travel to direction_sigma and each went one way by direction_min
    #: (``_direction``); a stop ends a reversal
    direction_check: bool = True
    direction_steps: int = 3
    direction_min: float = 0.02
    direction_sigma: float = 0.02
    direction_stop: float = 0.005  #: an odometry step shorter than this (m) and ...
    direction_stop_turn: float = math.radians(0.2)  #: ... turning less than this is a stop
