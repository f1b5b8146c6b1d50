"""The beam filters: beam classes (no return is unknown), the spike filter's rules, on 360° scans too,
and depth jumps judged with the caller's PolygonConfig."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from _synthetic import room, scan_of

import fuzzybrep.use.evaluate as evaluate
from fuzzybrep.mapping.build import BuildConfig, build_map
from fuzzybrep.scans.filters import CLIPPED, NONE, RETURN
from fuzzybrep.mapping.scan_polygon import PolygonConfig
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


def spiked(r: np.ndarray, cfg: filters.BeamConfig = filters.BeamConfig(), max_range: float = 81.83):
    """(free, status) of a 181-beam 180° scan with ranges r, from the origin."""
    return classify(Scan(r, even_bearings(len(r)), np.zeros(3), 0.0, max_range), cfg)


def test_an_opening_pairs_with_a_later_jump_back_when_the_nearest_is_too_wide():
    """Beams 50-52 pass a 0.14 m gap between walls at 2 m; the nearest jump back (7 → 5 m) gives a
    2.9 m 'opening', too wide, so the next one (5 → 2 m) is tried and closes the narrow gap."""
    r = np.full(181, 2.0)
    r[50:52], r[52] = 7.0, 5.0
    free, status = spiked(r)
    assert (status[50:53] == CLIPPED).all() and (free[50:53] < 2.01).all()
    assert (status[:50] == RETURN).all() and (status[53:] == RETURN).all()


def test_a_beam_cut_by_two_openings_stops_at_the_nearer():
    """Beams 51-52 pass both the gap 49-53 (posts at 1 m, 7 cm apart) and the gap 50-53 (1.6 m to
    1 m): their free space ends on the nearer segment, the one joining the posts at 1 m."""
    r = np.full(181, 1.0)
    r[50], r[51:53] = 1.6, 7.0
    free, status = spiked(r)
    b = even_bearings(181)
    # where beams 51 and 52 cross the segment from beam 49's endpoint to beam 53's
    (px, py), (qx, qy) = (np.cos(b[49]), np.sin(b[49])), (np.cos(b[53]), np.sin(b[53]))
    for k in (51, 52):
        dx, dy = np.cos(b[k]), np.sin(b[k])
        t = (px * (qy - py) - py * (qx - px)) / (dx * (qy - py) - dy * (qx - px))
        assert status[k] == CLIPPED and free[k] == pytest.approx(t, abs=1e-9)


@pytest.mark.parametrize("side", ["lo", "hi"])
def test_a_no_return_beam_does_not_bound_an_opening(side):
    """The flanks of an opening are returns: a no-return beam claiming free space (no_return_free)
    beside beams that reach far is not a post of a doorway, so nothing is cut."""
    r = np.full(181, 1.0)
    r[51:53] = 7.0
    r[50 if side == "lo" else 53] = 81.83
    free, status = spiked(r, filters.BeamConfig(no_return_free=0.5))
    assert (status[51:53] == RETURN).all() and (free[51:53] == 7.0).all()


def test_openings_of_spike_width_beams_anywhere_on_a_full_turn_are_cut():
    """spike_width is the widest opening examined, seam or not: on a 360° scan 4 beams through glass
    are cut wherever they lie with spike_width=4, and 5 beams never are."""
    n = 360
    for width, cut in [(4, True), (5, False)]:
        scans = []
        for shift in range(n):
            r = np.full(n, 2.0)
            r[np.arange(shift, shift + width) % n] = 7.0
            scans.append(full_turn_scan(r))
        for shift, (free, status) in enumerate(filters.classify_all(scans, filters.BeamConfig(spike_width=4))):
            beams = np.arange(shift, shift + width) % n
            assert (status[beams] == CLIPPED).all() == cut and (status == CLIPPED).sum() == (width if cut else 0), shift


def test_the_spike_filter_works_on_three_beams():
    free, status = classify(Scan([2.0, 7.0, 2.0], [-0.05, 0.0, 0.05], np.zeros(3), 0.0, 81.83))
    assert status.tolist() == [RETURN, CLIPPED, RETURN] and free[1] < 2.0


def test_zero_and_max_ranges_are_no_return():
    """A range of 0 or at least max_range is no return (Scan.returns): unknown, no free space claimed
    by default, and never more than max_usable when no_return_free asks for some."""
    scan = Scan([0.0, 2.0, 81.83, 2.0, 90.0], even_bearings(5), np.zeros(3), 0.0, 81.83)
    free, status = classify(scan, filters.BeamConfig(no_return_chord=False))
    assert ((status == NONE) == ~scan.returns).all() and scan.returns.tolist() == [False, True, False, True, False]
    assert free.tolist() == [0.0, 2.0, 0.0, 2.0, 0.0]
    # by default the beam between two returns claims up to the segment joining them (2 m at ±45°:
    # 2 cos 45° straight ahead); the two at the fan's edges have a neighbour on one side only
    free, status = classify(scan)
    np.testing.assert_allclose(free, [0.0, 2.0, 2 * np.cos(np.pi / 4), 2.0, 0.0])
    cfg = filters.BeamConfig(no_return_free=20.0)  # more than the 8 m whose free space is trusted
    free, status = classify(scan, cfg)
    assert free[~scan.returns].tolist() == [cfg.max_usable] * 3


def test_scans_filtered_together_are_filtered_each_on_its_own():
    """classify_all groups scans by beam count; a scan's result must not depend on its group:
    each keeps its own max_range, and an opening never pairs a jump in one scan with another's."""
    b = even_bearings(181)
    cfg, polygon = filters.BeamConfig(spike_jump=0.1), PolygonConfig(jump_floor=1.0)
    # a wall at 2 m, then a surface running from 7 m back to 2.2 m in steps the depth test calls
    # continuous: one jump away (49 → 50) and no jump back, so no opening
    ramp = np.full(181, 2.2)
    ramp[:50], ramp[50:57] = 2.0, [7.0, 6.2, 5.4, 4.6, 3.8, 3.0, 2.2]
    spike = np.full(181, 2.0)
    spike[55] = 7.0  # a jump back at beam 55 in the next scan
    scans = [Scan(ramp, b, np.zeros(3), 0.0, 81.83), Scan(spike, b, np.zeros(3), 1.0, 81.83),
             # the same ranges, no return for one scan (max_range 5) and returns for the other
             Scan(np.full(181, 7.0), b, np.zeros(3), 2.0, 5.0), Scan(np.full(181, 7.0), b, np.zeros(3), 3.0, 10.0)]
    for s, (free, status) in zip(scans, filters.classify_all(scans, cfg, polygon)):
        f1, s1 = classify(s, cfg, polygon)
        np.testing.assert_array_equal(free, f1)
        np.testing.assert_array_equal(status, s1)
    assert not (classify(scans[0], cfg, polygon)[1] == CLIPPED).any()
    assert (classify(scans[2])[1] == NONE).all() and (classify(scans[3])[1] != NONE).all()
