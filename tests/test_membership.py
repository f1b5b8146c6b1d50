"""Membership functions (thesis 2.1.1, 4.1.1), their α-cuts, and Table 4.2."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzybrep.errors import MembershipFunctionError
from fuzzybrep.fuzzy.membership import (A1, A2, A3, A4, DEFAULT_TME_M, THESIS_TME_MM, MembershipTable, Triangular,
                                        from_dict, parse_spec, total_maximum_error)


def test_tme_is_laser_plus_odometry_error():
    assert total_maximum_error(15, 184.13) == pytest.approx(THESIS_TME_MM)
    assert total_maximum_error(-15, 184.13) == pytest.approx(199.13)  # errors are ± values
    assert DEFAULT_TME_M == pytest.approx(THESIS_TME_MM / 1000)
    with pytest.raises(MembershipFunctionError, match="finite"):
        total_maximum_error(float("nan"), 1)


def test_triangular_is_the_thesis_function():
    f = Triangular(200)
    x = np.array([-300, -200, -100, 0, 50, 200, 250])
    assert f.mu(x) == pytest.approx([0, 0, 0.5, 1, 0.75, 0, 0])
    assert f.d_in(0) == 200 and f.d_out(0) == 200
    assert f.d_in(0.75) == pytest.approx(50)
    lo, hi = f.alpha_cut(0.5)
    assert (lo, hi) == (pytest.approx(-100), pytest.approx(100))
    assert f.to_dict() == {"type": "triangular", "tme": 200.0}
    assert "TME = 200" in f.parameters()


def test_asymmetric_triangular_has_its_own_inner_and_outer_support():
    f = Triangular(tme_in=100, tme_out=300)
    assert not f.symmetric
    assert f.mu([-50, 150]) == pytest.approx([0.5, 0.5])
    assert f.d_in(0.5) == pytest.approx(50) and f.d_out(0.5) == pytest.approx(150)
    assert f.support_in == 100 and f.support_out == 300
    assert from_dict(f.to_dict()) == f


def test_a1_is_a_triangle_of_support_one_over_p():
    f = A1(0.01)  # support ±100
    assert f.support_in == pytest.approx(100)
    assert f.mu([-100, -50, 0, 50, 100, 150]) == pytest.approx([0, 0.5, 1, 0.5, 0, 0])
    assert f.d_in(0.25) == pytest.approx(75)
    assert A1(0.01, tme=200).support_in == pytest.approx(100)  # narrower than TME: allowed


def test_a1_wider_than_tme_fails_criterion_1():
    with pytest.raises(MembershipFunctionError, match=r"criterion 1.*support ±1/p = ±1 is wider than ±TME"):
        A1(1.0, tme=0.5)


def test_a4_raised_cosine():
    f = A4(2.0)  # support ±0.5
    assert f.mu([0, 0.25, 0.5, 0.6]) == pytest.approx([1, 0.5, 0, 0])
    assert f.d_in(0.5) == pytest.approx(0.25)
    assert f.d_out(0) == pytest.approx(0.5)


@pytest.mark.parametrize("family, formula", [(A2, r"1/\(1 \+ p\(x − r\)²\)"), (A3, r"e\^\(−\|p\(x − r\)\|\)")])
def test_a2_a3_as_printed_never_reach_zero_and_are_refused(family, formula):
    with pytest.raises(MembershipFunctionError, match=r"criterion 1 of thesis 4.1.1 fails.*" + formula + ".*truncate"):
        family(10.0, tme=0.2)
    with pytest.raises(MembershipFunctionError, match="never reaches 0"):
        family(10.0)


def test_a2_truncated_at_tme_is_accepted_and_documented():
    f = A2(10.0, tme=1.0, truncate=True)
    edge = 1 / 11  # A2(TME): μ jumps from here to 0 at ±TME
    assert f.mu([0, 0.5, 0.999, 1.0, 2.0]) == pytest.approx([1, 1 / 3.5, 1 / (1 + 10 * 0.999 ** 2), 0, 0])
    assert f.d_in(edge / 2) == pytest.approx(1.0)  # below the jump the α-cut is the whole support
    assert f.d_in(0.5) == pytest.approx(math.sqrt(0.1))
    assert f.to_dict() == {"type": "A2", "p": 10.0, "tme": 1.0, "truncate": True}
    g = A3(5.0, tme=0.5, truncate=True)
    assert g.d_in(math.exp(-1)) == pytest.approx(0.2)
    assert g.mu([0.5]) == [0]


def test_truncate_is_only_for_a2_a3():
    with pytest.raises(MembershipFunctionError, match="truncate applies only to A2 and A3"):
        A4(2.0, truncate=True)


@pytest.mark.parametrize("make, match", [
    (lambda: Triangular(0), "positive"),
    (lambda: Triangular(-1), "positive"),
    (lambda: Triangular(float("nan")), "positive"),
    (lambda: Triangular("wide"), "must be a number"),
    (lambda: Triangular(), "needs tme"),
    (lambda: Triangular(1, tme_in=2), "either tme"),
    (lambda: A1(0), "p must be a positive"),
    (lambda: A4(-2), "p must be a positive"),
    (lambda: A2(float("inf"), tme=1, truncate=True), "p must be a positive"),
])
def test_bad_parameters_are_refused(make, match):
    with pytest.raises(MembershipFunctionError, match=match):
        make()


def test_the_criteria_check_runs_on_the_function_itself():
    class Shifted(Triangular):
        def mu(self, x):
            return super().mu(np.asarray(x) - 1)  # core moved off the crisp boundary

    with pytest.raises(MembershipFunctionError, match="criterion 3 of thesis 4.1.1 fails"):
        Shifted(10)

    class Bumpy(Triangular):
        def mu(self, x):
            x = np.asarray(x, float)
            return np.where(np.abs(x - 5) < 1, 0.9, super().mu(x))

    with pytest.raises(MembershipFunctionError, match="increases away from r"):
        Bumpy(10)


def test_the_criteria_hold_at_exactly_tme_and_on_the_inner_side():
    # criterion 1 is μ = 0 for x ≥ r + TME, TME included: an A1 whose support 1/p is a hair
    # (1e-7 relative) wider than its TME is still positive at r + TME and is refused
    with pytest.raises(MembershipFunctionError, match="criterion 1 of thesis 4.1.1 fails"):
        A1(1 / (0.2 * (1 + 1e-7)), tme=0.2)

    class BumpyInside(Triangular):
        def mu(self, x):
            x = np.asarray(x, float)
            return np.where(np.abs(x + 5) < 1, 0.9, super().mu(x))

    with pytest.raises(MembershipFunctionError, match="increases away from r"):
        BumpyInside(10)

    class SlightRise(Triangular):
        def mu(self, x):  # rises by ~3e-4 where it enters [4, 6]: the 0.6-cut is no interval
            x = np.asarray(x, float)
            return super().mu(x) + np.where(np.abs(x - 5) < 1, 8e-4, 0.0)

    with pytest.raises(MembershipFunctionError, match="increases away from r"):
        SlightRise(10)


def test_table_4_2_parameters_of_an_asymmetric_function():
    # a = r − TME_in and b = r + TME_out (Table 4.2's "a = −TME; b = +TME", one TME per side)
    assert Triangular(tme_in=100, tme_out=300).parameters() == "a = -100; b = 300; TME = 300"


def test_alpha_out_of_range():
    with pytest.raises(MembershipFunctionError, match=r"\[0, 1\]"):
        Triangular(1).d_in(1.5)


@pytest.mark.parametrize("spec, expected", [
    ("triangular", Triangular(0.2)),
    ("tri:tme=0.3", Triangular(0.3)),
    ("triangular:in=0.1,out=0.4", Triangular(tme_in=0.1, tme_out=0.4)),
    ("triangular:out=0.4", Triangular(tme_in=0.2, tme_out=0.4)),
    ("A1:p=5", A1(5, tme=0.2)),
    ("a4:p=10", A4(10, tme=0.2)),
    ("A2:p=10,truncate", A2(10, tme=0.2, truncate=True)),
    ("A3:p=5,tme=0.5,truncate=yes", A3(5, tme=0.5, truncate=True)),
])
def test_parse_spec(spec, expected):
    assert parse_spec(spec, tme=0.2) == expected


@pytest.mark.parametrize("spec, match", [
    ("gauss:p=1", "unknown membership function type 'gauss'"),
    ("A1:p=abc", "p = 'abc' is not a number"),
    ("A1:q=1", "unknown parameter 'q'"),
    ("A1:p", "is not key=value"),
    ("A2:p=10", "criterion 1"),
])
def test_parse_spec_errors(spec, match):
    with pytest.raises(MembershipFunctionError, match=match):
        parse_spec(spec, tme=0.2)


def test_table_4_2_indexes_functions_and_round_trips():
    t = MembershipTable({1: Triangular(200), 3: A4(0.01)})
    assert t.indices == [1, 3]
    fm = np.array([1, 3, 3, 1])
    assert t.d_in(fm, 0.5) == pytest.approx([100, 50, 50, 100])
    assert t.support_out(fm) == pytest.approx([200, 100, 100, 200])
    back = MembershipTable.from_dicts(t.to_dicts())
    assert back.to_dicts() == t.to_dicts() == [{"index": 1, "type": "triangular", "tme": 200.0},
                                               {"index": 3, "type": "A4", "p": 0.01, "tme": 100.0}]
    rows = t.rows()
    assert rows[0]["TYPE"] == "triangular" and rows[0]["SUPPORT_IN"] == 200
    with pytest.raises(MembershipFunctionError, match="FM index 2 has no membership function"):
        t.d_in(np.array([1, 2]), 0.5)
    with pytest.raises(MembershipFunctionError, match="no membership function with index 2"):
        t[2]


def test_table_errors():
    with pytest.raises(MembershipFunctionError, match="empty"):
        MembershipTable({})
    with pytest.raises(MembershipFunctionError, match="index must be an integer ≥ 1"):
        MembershipTable({0: Triangular(1)})
    with pytest.raises(MembershipFunctionError, match="appears twice"):
        MembershipTable.from_dicts([{"index": 1, "type": "triangular", "tme": 1}, {"index": 1, "type": "A1", "p": 1}])
    with pytest.raises(MembershipFunctionError, match="membership function 2: A2"):
        MembershipTable.from_dicts([{"type": "triangular", "tme": 1}, {"type": "A2", "p": 1, "tme": 1}])


families = st.one_of(
    st.builds(lambda t: Triangular(t), st.floats(1e-3, 1e3)),
    st.builds(lambda a, b: Triangular(tme_in=a, tme_out=b), st.floats(1e-3, 1e3), st.floats(1e-3, 1e3)),
    st.builds(lambda p: A1(p), st.floats(1e-3, 1e3)),
    st.builds(lambda p: A4(p), st.floats(1e-3, 1e3)),
    st.builds(lambda p, t: A2(p, t, truncate=True), st.floats(1e-3, 1e3), st.floats(1e-3, 1e3)),
    st.builds(lambda p, t: A3(p, t, truncate=True), st.floats(1e-3, 1e3), st.floats(1e-3, 1e3)),
)


@settings(max_examples=150, deadline=None)
@given(f=families, alpha=st.floats(0, 1))
def test_alpha_cut_bounds_are_the_level_set(f, alpha):
    """μ ≥ α inside [−d_in(α), d_out(α)] and μ ≤ α just outside (thesis 2.1.2)."""
    lo, hi = -float(f.d_in(alpha)), float(f.d_out(alpha))
    assert -f.support_in <= lo <= 0 <= hi <= f.support_out
    inside = np.linspace(lo, hi, 33)[1:-1]
    assert np.all(f.mu(inside) >= alpha - 1e-9)
    eps = 1e-6 * max(f.support_in, f.support_out)
    assert np.all(f.mu([lo - eps, hi + eps]) <= alpha + 1e-6)
    x = np.linspace(-2 * f.support_in, 2 * f.support_out, 101)
    assert np.all((f.mu(x) >= 0) & (f.mu(x) <= 1))
    assert f.mu([0.0]) == [1.0]
    assert from_dict(f.to_dict()) == f
