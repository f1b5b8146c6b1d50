"""Issue 33: the correlative search, the SLAM benchmark's metric, the odometry's direction of travel
and the alignment's check against the scans (registration/)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from fuzzybrep import cli
from fuzzybrep.errors import ScanFormatError
from fuzzybrep.registration import align_scans as A
from fuzzybrep.registration.check import check_alignment
from fuzzybrep.registration.config import AlignConfig
from fuzzybrep.registration.correlative import LikelihoodField
from fuzzybrep.registration.relations import Relations, read_relations, score
from fuzzybrep.scans.scan import compose, relative, wrap

from conftest import log_path


# -- the correlative search ----------------------------------------------------------------------

def _room(step: float = 0.02) -> np.ndarray:
    """Points every ``step`` along the walls of an L-shaped room with a pillar: no symmetry."""
    corners = np.array([[0, 0], [8, 0], [8, 3], [4, 3], [4, 6], [0, 6], [0, 0]], float)
    pts = [np.linspace(a, b, int(np.hypot(*(b - a)) / step) + 1) for a, b in zip(corners[:-1], corners[1:])]
    t = np.linspace(0, 2 * math.pi, 60, endpoint=False)
    pts.append(np.column_stack((2 + 0.3 * np.cos(t), 2 + 0.3 * np.sin(t))))
    return np.concatenate(pts)


def _scan_of(world: np.ndarray, pose: np.ndarray, n: int = 90) -> np.ndarray:
    """n of the room's points seen from ``pose``, in the sensor frame (a crude scan)."""
    rel = world - pose[:2]
    c, s = math.cos(pose[2]), math.sin(pose[2])
    local = np.column_stack((c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]))
    return local[np.linspace(0, len(local) - 1, n).astype(int)]


def test_search_finds_the_pose_from_a_start_outside_a_local_match_basin():
    world = _room()
    field = LikelihoodField(world, resolution=0.05, sigma=0.08)
    true = np.array([2.6, 1.2, math.radians(20)])
    pts = _scan_of(world, true)
    guess = true + [0.45, -0.35, math.radians(7)]
    found = field.search(pts, guess, window=0.6, angle_window=math.radians(10))
    assert math.hypot(*(found.pose[:2] - true[:2])) <= 0.05 * math.sqrt(2) + 1e-9
    assert abs(wrap(found.pose[2] - true[2])) <= math.radians(1.0)
    assert found.score > 0.8


def test_branch_and_bound_returns_the_exhaustive_best():
    """The coarse grid bounds every translation of its block: opening blocks in the order of their
    bound finds the same best pose as scoring every pose of the window."""
    rng = np.random.default_rng(4)
    world = _room()
    field = LikelihoodField(world, resolution=0.05, sigma=0.1, block=4)
    for _ in range(3):
        true = np.array([rng.uniform(1, 3), rng.uniform(1, 2), rng.uniform(-1, 1)])
        pts = _scan_of(world, true, 40) + rng.normal(0, 0.02, (40, 2))
        guess = true + np.r_[rng.uniform(-0.2, 0.2, 2), rng.uniform(-0.05, 0.05)]
        step = math.radians(1.0)
        found = field.search(pts, guess, window=0.3, angle_window=math.radians(3), angle_step=step)
        best = -1.0
        for a, i, j in itertools.product(range(-3, 4), range(-6, 7), range(-6, 7)):
            pose = guess + [i * 0.05, j * 0.05, a * step]
            c, s = math.cos(pose[2]), math.sin(pose[2])
            w = np.column_stack((pose[0] + c * pts[:, 0] - s * pts[:, 1], pose[1] + s * pts[:, 0] + c * pts[:, 1]))
            best = max(best, field.score(w))
        assert found.score == pytest.approx(best, abs=1e-6)
        assert found.evaluated < 7 * 13 * 13  # the bound spared most of the window


def test_the_prior_decides_only_where_the_scan_cannot():
    """Along a bare corridor every offset scores alike: the prior keeps the guess; across it the scan wins."""
    x = np.arange(0, 20, 0.02)
    world = np.concatenate([np.column_stack((x, np.zeros_like(x))), np.column_stack((x, np.full_like(x, 2.0)))])
    field = LikelihoodField(world, resolution=0.05, sigma=0.08)
    true = np.array([10.0, 1.0, 0.0])
    pts = _scan_of(world[np.abs(world[:, 0] - 10) < 6], true, 80)
    guess = true + [0.2, 0.25, 0.0]
    info = np.diag([1 / 0.1 ** 2, 1 / 0.1 ** 2, 1 / math.radians(2) ** 2])
    found = field.search(pts, guess, 0.4, math.radians(3), prior_information=info)
    assert abs(found.pose[1] - true[1]) <= 0.05  # across: the walls
    assert abs(found.pose[0] - guess[0]) <= 0.05  # along: the prior


# -- the benchmark's metric ----------------------------------------------------------------------

def test_relations_metric_on_known_errors(tmp_path):
    rng = np.random.default_rng(0)
    poses = np.cumsum(np.c_[rng.uniform(0, 1, (50, 2)), rng.uniform(-0.2, 0.2, 50)], axis=0)
    times = np.arange(50) * 0.5 + 100.0
    i, j = np.arange(0, 45), np.arange(5, 50)
    rel = Relations(times[i], times[j], relative(poses[i], poses[j]))
    exact = score(times, poses, rel)
    assert exact.trans[0] < 1e-12 and exact.rot[0] < 1e-9 and exact.used == 45 and exact.missing == 0
    # every estimated relation 3 cm off sideways and 0.5° turned: the errors are exactly that
    off = Relations(rel.t1, rel.t2, compose(rel.delta, np.array([0.0, 0.03, math.radians(0.5)])))
    s = score(times, poses, off)
    assert s.trans[0] == pytest.approx(0.03, rel=1e-6) and s.trans[1] < 1e-9
    assert s.rot[0] == pytest.approx(0.5, rel=1e-6)
    assert s.trans_sq[0] == pytest.approx(0.0009, rel=1e-6)
    # a relation whose times no scan lies within 0.1 s of is left out, and counted
    far = Relations(np.r_[rel.t1, 1e6], np.r_[rel.t2, 1e6 + 1], np.r_[rel.delta, [[0, 0, 0]]])
    assert score(times, poses, far).missing == 1
    f = tmp_path / "x.relations"
    f.write_text("1.0 2.0 0.5 0.1 0 0 0 0.2\n1.0 2.0 0.5 x 0 0 0 0.2\n")
    with pytest.raises(ScanFormatError, match=r"x\.relations, line 2"):
        read_relations(f)


# -- the odometry's direction of travel ----------------------------------------------------------

def test_direction_needs_agreeing_fixed_steps():
    cfg = AlignConfig()
    back = [(0.1, -0.09, True)] * 3
    assert A._direction(back, cfg) is True
    assert A._direction([(0.1, 0.1, True)] * 3, cfg) is False
    assert A._direction(back[:2], cfg) is None  # too few
    assert A._direction(back[:2] + [(0.1, -0.09, False)], cfg) is None  # one match did not fix the travel
    # intel's repeated timestamps: odometry steps that jump back and forth say nothing
    assert A._direction([(0.047, -0.037, True), (0.172, -0.091, True), (-0.123, 0.106, True)], cfg) is None


# -- the check against the scans -----------------------------------------------------------------

def test_check_passes_the_corrected_poses_and_fails_a_bent_map(real_scans):
    scans = real_scans("intel")
    poses = np.array([s.pose for s in scans])
    good = check_alignment(scans, poses)
    assert good.ok and len(good.checked) > 100
    # a loop closed wrongly at scan 450: every later pose turned 4° about it and moved 0.5 m
    bent = poses.copy()
    pivot = poses[450]
    c, s = math.cos(math.radians(4)), math.sin(math.radians(4))
    d = bent[450:, :2] - pivot[:2]
    bent[450:, :2] = pivot[:2] + np.column_stack((c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1])) + [0.5, 0.0]
    bent[450:, 2] = wrap(bent[450:, 2] + math.radians(4))
    bad = check_alignment(scans, bent)
    assert not bad.ok and bad.bad_share > 2 * good.bad_share
    # the check cannot tell which pass is wrong, only where passes disagree: a span after the bend,
    # and possibly one where the bent passes came back to the first ones
    assert any(a >= 450 for a, b in bad.spans)
    assert "FAILED" in bad.describe(scans) and scans[bad.spans[0][0]].source in bad.describe(scans)


def test_align_reports_odometry_that_stopped_for_thirty_scans(real_scans):
    """The Done-when's failure: odometry cut off (frozen) for 30 scans (about 15 m of intel's corridors):
    the alignment cannot follow, and the result says so, naming where."""
    scans = real_scans("intel")
    true = np.array([s.pose for s in scans])
    steps = relative(true[:-1], true[1:])
    steps[399:429] = 0.0
    odo = [true[0]]
    for st in steps:
        odo.append(compose(odo[-1], st))
    result = A.align_scans(scans, odometry=np.array(odo))
    assert result.check is not None and not result.check.ok
    assert result.metadata()["check"]["ok"] is False
    # the loop edges' disagreement with the solved poses is kept too, in standard deviations
    assert len(result.loop_chi) and np.all(np.isfinite(result.loop_chi)) and np.all(result.loop_chi >= 0)
    assert result.metadata()["loop_residuals"]["edges"] == len(result.loop_chi)
    assert result.check.spans


def test_build_strict_refuses_a_failed_alignment(tmp_path, monkeypatch, capsys):
    """--strict: a failed check is an error naming the spans, exit status 2, no map written; without
    it the map is written with a warning."""
    from fuzzybrep.registration import check as C

    log = log_path("orebro")
    real = C.check_alignment

    def failing(scans, poses, config=C.CheckConfig()):
        got = real(scans, poses, config)
        return C.AlignmentCheck(got.checked, np.ones_like(got.contradicted), [(10, 40)], got.config)

    monkeypatch.setattr(A, "check_alignment", failing)
    out = tmp_path / "m.json"
    assert cli.main(["build", str(log), "--align", "--strict", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "alignment check FAILED" in err and "orebro-corrected.log.gz" in err and not out.exists()
    assert cli.main(["build", str(log), "--align", "--out", str(out)]) == 0
    assert "WARNING: --align: alignment check FAILED" in capsys.readouterr().err and out.exists()
    assert cli.main(["build", str(log), "--strict", "--out", str(out)]) == 2  # --strict needs --align
