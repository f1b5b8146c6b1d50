"""The real CARMEN logs, mapped truthfully (skipped with a reason when the logs are absent)."""

from __future__ import annotations

import os
from dataclasses import replace

import numpy as np
import pytest

from fuzzybrep.use import evaluate as E
from fuzzybrep.brep import FRONTIER, OBSTACLE
from fuzzybrep.mapping.build import BuildConfig, build_map
from fuzzybrep.fuzzy.memory import compact_bytes
from fuzzybrep.fuzzy.map import fuzzify
from fuzzybrep.mapping.grid import occupancy_grid

NAMES = ["intel", "aces", "freiburg"]


@pytest.fixture(scope="module", params=NAMES)
def built(request, real_scans):
    scans = real_scans(request.param)
    return request.param, scans, build_map(scans)


def test_map_is_valid_with_both_edge_kinds(built):
    _, _, r = built
    crisp = r.crisp
    crisp.validate()
    kinds = np.concatenate([ring.kinds for ring in crisp.rings])
    assert (kinds == OBSTACLE).mean() > 0.5 and (kinds == FRONTIER).any()
    assert crisp.n_holes > 0 and crisp.area > 100


def test_no_free_space_where_the_laser_saw_an_obstacle(built):
    # issue done-when: at most 5 % of endpoints (range under 5 m) inside the crisp free space
    # shrunk by 0.2 m, at most 2 % outside it grown by 0.2 m
    name, scans, r = built
    s = E.score(E.endpoints(scans), *E.band_by_buffer(r.crisp.to_shapely(), 0.2))
    assert s.violations <= 0.05
    assert s.beyond <= 0.02
    # and in fact far fewer violations than a plain union has (about 30 % on intel)
    assert s.violations <= 0.01
    # those left are nearly all things other scans saw through before and after (people walking
    # by), which the map drops, as it should; on ACES they alone exceed the held-out target of
    # 0.5 %: the floor the README gives for any map that drops them
    pts = E.endpoints(scans)
    went = E.came_and_went(pts[s.violated], E.endpoint_times(scans)[s.violated], scans, BuildConfig(), 0.2)
    assert s.violations - went.sum() / len(pts) <= 0.002
    if name == "aces":
        assert went.sum() / len(pts) > 0.005


def test_fuzzy_map_is_at_least_20_times_smaller_than_the_5cm_grid(built):
    _, scans, r = built
    fz = fuzzify(r.crisp)
    grid = occupancy_grid(scans, 0.05)
    assert grid.nbytes(4) >= 20 * compact_bytes(fz)


@pytest.mark.parametrize("name", NAMES)
def test_held_out_scans_are_predicted(name, real_scans):
    scans = real_scans(name)
    e = E.evaluate_log(scans, 2, BuildConfig())
    assert e.exact.explained >= 0.95
    # an obstacle where the map promises free space: rare. On ACES most of the held-out
    # violations are people walking the corridors, seen by that scan alone (scans are about 2 s
    # apart): no kept scan saw any return near them, so no map of the kept scans can know them.
    # What a map could know, and what lies on extended surfaces, is within the target everywhere,
    # and so is what did not come and go (kept scans saw through the spot before and after).
    assert 0 <= e.violations_unseen <= e.exact.violations
    assert 0 <= e.violations_came_and_went <= e.exact.violations
    assert e.exact.violations - e.violations_came_and_went <= 0.005
    assert e.exact.violations - e.violations_unseen <= 0.005
    assert e.exact.violations - e.violations_on_small_objects <= 0.005
    # neither unseen nor come and gone: what a better map could have avoided (at most)
    assert 0 <= e.violations_rest <= e.exact.violations - max(e.violations_unseen, e.violations_came_and_went)
    assert e.violations_rest <= 0.005
    if name != "aces":
        assert e.exact.violations <= 0.005
    else:
        # the other answer to people walking by, keeping every obstacle a kept scan saw, does not
        # meet the target either: the people held-out scans see were mostly seen by no kept scan
        keep = BuildConfig()
        keep = replace(keep, evidence=replace(keep.evidence, clear=False))
        assert E.evaluate_log(scans, 2, keep).exact.violations > 0.005


@pytest.mark.reallog
@pytest.mark.parametrize("name", ["orebro", "fhw", "intel", "campus"])
def test_where_the_robot_stood_is_free(name, real_scans):
    # issue 17: every scan pose in the crisp free space, and in the space free at α = 0 with full
    # confidence (its safe region). Before the footprint and the no-return claims, 151 of
    # Freiburg campus's 2008 poses lay outside the free space and a quarter outside the safe region.
    if name == "campus" and not os.environ.get("FUZZYBREP_BIG_LOGS"):
        pytest.skip("Freiburg campus takes a minute to build: set FUZZYBREP_BIG_LOGS=1 (make bench measures it)")
    import shapely

    scans = real_scans(name)
    crisp = build_map(scans).crisp
    p = np.array([s.pose[:2] for s in scans])
    assert shapely.contains_xy(crisp.to_shapely(), p[:, 0], p[:, 1]).mean() >= 0.995
    safe = fuzzify(crisp).alpha_cut(0.0, "exact").inner
    assert shapely.contains_xy(safe, p[:, 0], p[:, 1]).mean() >= 0.98
    # and without the footprint a 180° scan's own pose lies on its polygon's edge: the track is
    # free only where other scans covered it
    bare = build_map(scans, replace(BuildConfig(), polygon=replace(BuildConfig().polygon, footprint=0.0))).crisp
    safe0 = fuzzify(bare).alpha_cut(0.0, "exact").inner
    assert shapely.contains_xy(safe0, p[:, 0], p[:, 1]).mean() < shapely.contains_xy(safe, p[:, 0], p[:, 1]).mean()
