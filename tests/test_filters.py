"""The beam filters: the spike filter on 360° scans, and depth jumps judged with the caller's PolygonConfig."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from _synthetic import room, scan_of

import fuzzybrep.evaluate as evaluate
from fuzzybrep.build import BuildConfig, build_map
from fuzzybrep.polygon import CLIPPED, RETURN, PolygonConfig
from fuzzybrep.scans import filters
from fuzzybrep.scans.filters import classify
from fuzzybrep.scans.scan import Scan, even_bearings

# a depth-jump allowance of 10 m: no range change in these scans counts as a jump
NO_JUMPS = PolygonConfig(jump_floor=10.0)


def spike_scan() -> Scan:
    r = np.full(181, 2.0)
    r[50] = 7.0  # one beam through glass
    return Scan(r, even_bearings(181), np.zeros(3), 0.0, 81.83)


def test_spike_filter_uses_the_given_polygon_config():
    free, status = classify(spike_scan())
    assert status[50] == CLIPPED and free[50] < 2.1
    # where the polygons see one surface, so does the spike filter: nothing to cut back
    free, status = classify(spike_scan(), polygon=NO_JUMPS)
    assert (status == RETURN).all() and free[50] == 7.0


def test_build_map_gives_the_spike_filter_its_polygon_config(monkeypatch):
    seen = []
    despike = filters.despike

    def spy(*args, **kwargs):
        seen.append(kwargs.get("polygon", args[5] if len(args) > 5 else None))
        return despike(*args, **kwargs)

    monkeypatch.setattr(filters, "despike", spy)
    build_map([spike_scan()], BuildConfig(polygon=NO_JUMPS, use_evidence=False))
    assert seen and all(p is NO_JUMPS for p in seen)


def test_small_objects_uses_the_given_polygon_config():
    r = np.full(181, 3.0)
    r[90:93] = 1.0  # a leg in front of the wall
    scan = Scan(r, even_bearings(181), np.zeros(3), 0.0, 81.83)
    small = evaluate.small_objects([scan])
    assert small[90:93].all() and small.sum() == 3
    # with no depth jumps the leg is part of one long surface
    assert not evaluate.small_objects([scan], polygon=NO_JUMPS).any()


def test_evaluate_log_gives_small_objects_its_polygon_config(monkeypatch):
    seen = []
    small_objects = evaluate.small_objects

    def spy(*args, **kwargs):
        seen.append(kwargs.get("polygon"))
        return small_objects(*args, **kwargs)

    monkeypatch.setattr(evaluate, "small_objects", spy)
    scans = [scan_of(room(6, 4), (1.5 + 0.5 * k, 2.0, 0.3 * k), n=181, t=float(k)) for k in range(4)]
    evaluate.evaluate_log(scans, holdout=2, config=BuildConfig(polygon=NO_JUMPS))
    assert seen == [NO_JUMPS]


def full_turn_scan(r: np.ndarray) -> Scan:
    n = len(r)
    return Scan(r, -np.pi + 2 * np.pi * np.arange(n) / n, np.zeros(3), 0.0, 81.83)


def test_spike_filter_sees_across_the_seam_of_a_full_turn():
    """On a 360° scan the last beam neighbours the first: a spike there is cut like any other."""
    r = np.full(360, 2.0)
    r[[358, 359, 0, 1]] = 7.0  # four beams through glass, straddling the seam
    r[100] = 7.0  # and one away from it
    scan = full_turn_scan(r)
    assert scan.full_circle
    free, status = classify(scan)
    spikes = [358, 359, 0, 1, 100]
    assert (status[spikes] == CLIPPED).all() and (free[spikes] < 2.1).all()
    rest = np.setdiff1d(np.arange(360), spikes)
    assert (status[rest] == RETURN).all() and (free[rest] == 2.0).all()


def test_standing_in_a_doorway_keeps_the_free_space():
    """Flanks exactly opposite put the sensor on the segment between them: that is no opening to cut."""
    for lo, hi in [(90, 270), (10, 190), (0, 180), (179, 359)]:
        r = np.full(360, 3.0)
        r[[lo, hi]] = 0.45  # the door posts, 0.9 m apart, either side of the sensor
        free, status = classify(full_turn_scan(r))
        assert (status == RETURN).all() and np.array_equal(free, r), (lo, hi)


@settings(max_examples=150, deadline=None)
@given(n=st.integers(24, 180), runs=st.lists(st.tuples(st.integers(0, 179), st.integers(1, 5)), max_size=4),
       holes=st.lists(st.integers(0, 179), max_size=3), shift=st.integers(1, 179), seed=st.integers(0, 2**16))
def test_a_full_turn_has_no_seam(n, runs, holes, shift, seed):
    """Turning a 360° scan by whole beams turns what the spike filter does with it: beam 0 is not special."""
    r = np.random.default_rng(seed).uniform(1.8, 2.2, n)
    for start, width in runs:
        r[np.arange(start, start + width) % n] = 7.0  # beams through glass
    r[np.asarray(holes, int) % n] = 81.83  # no return
    free, status = classify(full_turn_scan(r))
    free_t, status_t = classify(full_turn_scan(np.roll(r, shift)))
    assert np.array_equal(status_t, np.roll(status, shift))
    assert np.allclose(free_t, np.roll(free, shift), rtol=0, atol=1e-9)


def test_small_objects_on_a_full_turn_have_no_seam():
    """A leg straddling a 360° scan's seam is one small object; a wall across the seam is none."""
    r = np.full(360, 3.0)
    r[[358, 359, 0, 1]] = 1.0  # a leg: 4 beams at 1 m, 5 cm across
    r[180:184] = 1.0  # another, away from the seam
    scan = full_turn_scan(r)
    small = evaluate.small_objects([scan])
    assert small[[358, 359, 0, 1, 180, 181, 182, 183]].all() and small.sum() == 8
    # turned by 2 beams the legs lie clear of the seam: the same beams (turned) are small
    assert np.array_equal(evaluate.small_objects([full_turn_scan(np.roll(r, 2))]), np.roll(small, 2))
    # no object, one surface all round, or one split by the seam's depth jump: nothing small
    assert not evaluate.small_objects([full_turn_scan(np.full(360, 3.0))]).any()
    assert not evaluate.small_objects([full_turn_scan(np.linspace(2.0, 4.0, 360))]).any()


def test_scans_filtered_in_rows_of_a_few_give_what_all_at_once_give(monkeypatch):
    # classify_all filters at most _ROWS scans at a time, to bound its memory; rows are independent
    rng = np.random.default_rng(3)
    b = even_bearings(37)
    scans = [Scan(np.where(rng.random(37) < 0.1, 9.0, rng.uniform(0.2, 9.5, 37)), b,
                  np.array([0.1 * k, 0.0, 0.2 * k]), float(k), 9.0) for k in range(11)]
    scans += [Scan(rng.uniform(0.5, 3.0, 12), even_bearings(12, np.pi / 2), np.zeros(3), 20.0 + k, 9.0) for k in range(4)]
    at_once = filters.classify_all(scans)
    monkeypatch.setattr(filters, "_ROWS", 3)
    for (f0, s0), (f1, s1) in zip(at_once, filters.classify_all(scans)):
        np.testing.assert_array_equal(f0, f1)
        np.testing.assert_array_equal(s0, s1)
    assert sum(int((s == CLIPPED).sum()) for _, s in at_once) > 0  # the spike filter did cut beams
