"""UMBmark (thesis Appendix I): every number the thesis prints, checked against its own equations."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fuzzybrep import cli
from fuzzybrep.errors import UMBmarkError
from fuzzybrep.sim.umbmark import (BORENSTEIN_EB_TURN, TABLE_I1, TABLE_I2, corrected_rev_count, drift_factor,
                                   read_runs, total_maximum_error, umbmark, write_runs)

KEYS = ["x_cg_cw", "y_cg_cw", "x_cg_ccw", "y_cg_ccw", "r_cw", "r_ccw", "E_max_syst", "alpha_deg", "beta_deg",
        "R", "E_d", "E_b", "drift_factor", "rev_count"]


@pytest.fixture
def before():
    return umbmark(*TABLE_I1, side=4000, wheelbase=267)


@pytest.fixture
def after():
    return umbmark(*TABLE_I2, side=4000, wheelbase=267)


def test_table_i1_centres_of_gravity_and_offsets_as_printed(before):
    assert (before.x_cg_cw, before.y_cg_cw) == pytest.approx((1358.4, 614.8), abs=1e-9)
    assert (before.x_cg_ccw, before.y_cg_ccw) == pytest.approx((-843.0, 1357.8), abs=1e-9)
    assert round(before.r_cw) == 1491  # printed 1491
    assert round(before.r_ccw, 1) == 1598.2
    assert before.E_max_syst == before.r_ccw
    assert round(before.E_max_syst, 1) == 1598.2


def test_table_i1_alpha_beta_R_as_printed(before):
    assert round(before.alpha_deg, 4) == -1.8456
    # Eq. 8 gives β < 0 for these stops; the thesis prints its magnitude
    assert before.beta_deg < 0
    assert round(abs(before.beta_deg), 4) == 7.8832
    assert abs(before.R) == pytest.approx(29095.35, abs=0.01)  # printed 29095.3 (cut, not rounded)
    assert before.R < 0  # the sign of β


def test_table_i1_E_b_and_rev_count(before):
    assert before.E_b == pytest.approx(180 / (180 + 1.8456403), rel=1e-9)
    assert round(before.E_b, 2) == 0.99  # printed 0.99
    # the thesis divides by the rounded 0.99: 16737.37; the unrounded E_b gives 16739.90
    assert round(corrected_rev_count(round(before.E_b, 2)), 2) == 16737.37
    assert round(before.rev_count, 2) == 16739.90


def test_table_i1_E_d_and_drift_factor_discrepancy(before):
    """The printed E_d = 1.053 does not follow from Eq. 4 with R from Eq. 7: see docs/umbmark.md."""
    assert before.E_d == pytest.approx(0.990865, abs=1e-6)  # signed β, as Eq. 8 gives it
    r = abs(before.R)
    assert (r + 133.5) / (r - 133.5) == pytest.approx(1.009219, abs=1e-6)  # with |β|, as the thesis prints β
    for e_d in (before.E_d, (r + 133.5) / (r - 133.5)):
        assert abs(e_d - 1.053) > 0.04
    # the printed driftFactor 103.35 follows from the printed E_d, not from the equations
    assert drift_factor(1.053) == pytest.approx(103.35)
    assert before.drift_factor == pytest.approx(-17.81, abs=0.01)


def test_table_i2_after_calibration_and_tme(after):
    assert (after.x_cg_cw, after.y_cg_cw, after.x_cg_ccw, after.y_cg_ccw) == pytest.approx((-129.6, -130.8, 114.0, -97.6))
    assert round(after.r_cw, 2) == 184.13
    assert round(after.r_ccw, 2) == 150.07
    assert after.E_max_syst == after.r_cw
    assert round(total_maximum_error(after.E_max_syst, 15.0), 2) == 199.13


def test_borenstein_form_of_E_b(before):
    b = umbmark(*TABLE_I1, eb_turn_deg=BORENSTEIN_EB_TURN)
    assert b.E_b == pytest.approx(90 / (90 + 1.8456403), rel=1e-9)
    assert b.E_b < before.E_b < 1  # the 180° form halves the correction


def test_no_curvature_means_equal_wheels():
    res = umbmark([(10.0, 5.0)], [(10.0, -5.0)])  # x_cw == x_ccw: β = 0
    assert res.beta_deg == 0 and math.isinf(res.R) and res.E_d == 1.0 and res.drift_factor == 0.0


@pytest.mark.parametrize("cw, ccw, match", [
    (np.empty((0, 2)), [(1, 2)], "no cw stop positions"),
    ([(1, 2, 3)], [(1, 2)], r"\(n, 2\)"),
    ([(1, np.nan)], [(1, 2)], "cw stop position 1 is not finite"),
])
def test_bad_stop_positions(cw, ccw, match):
    with pytest.raises(UMBmarkError, match=match):
        umbmark(cw, ccw)


@pytest.mark.parametrize("name", ["side", "wheelbase", "wheel", "rev_count"])
@pytest.mark.parametrize("value", [0.0, -1.0, math.inf])
def test_bad_parameters(name, value):
    with pytest.raises(UMBmarkError, match=f"{name} must be a positive number"):
        umbmark(*TABLE_I2, **{name: value})
    with pytest.raises(UMBmarkError, match="eb_turn_deg must be a positive angle"):
        umbmark(*TABLE_I2, eb_turn_deg=-90.0)


def test_alpha_at_or_beyond_the_turn_has_no_E_b():
    # Eq. 6: x_cw + x_ccw = −4L·α; α = 100° > 90° leaves Eq. 5 (90 / (90 − α)) no positive solution
    x = -4 * 4000 * math.radians(100) / 2
    with pytest.raises(UMBmarkError, match="is not below 90°"):
        umbmark([(x, 0.0)], [(x, 0.0)], eb_turn_deg=BORENSTEIN_EB_TURN)
    # and α just below the turn still gives a finite, large E_b
    x = -4 * 4000 * math.radians(89) / 2
    assert umbmark([(x, 0.0)], [(x, 0.0)], eb_turn_deg=BORENSTEIN_EB_TURN).E_b == pytest.approx(90.0)


def test_runs_csv_round_trip(tmp_path):
    path = tmp_path / "runs.csv"
    write_runs(path, *TABLE_I1)
    cw, ccw = read_runs(path)
    np.testing.assert_array_equal(cw, TABLE_I1[0])
    np.testing.assert_array_equal(ccw, TABLE_I1[1])
    # stop positions measured to a tenth of a millimetre keep it
    write_runs(path, TABLE_I1[0] + 0.3, TABLE_I1[1] - 0.7)
    cw, ccw = read_runs(path)
    np.testing.assert_allclose(cw, TABLE_I1[0] + 0.3, atol=1e-9)
    np.testing.assert_allclose(ccw, TABLE_I1[1] - 0.7, atol=1e-9)


@pytest.mark.parametrize("text, match", [
    ("", "empty"),
    ("dir,x,y\ncw,1,2\n", r"line 1: header must be direction,x,y"),
    ("direction,x,y\ncw,1,2\nsideways,1,2\n", r"line 3, field direction: direction must be cw or ccw"),
    ("direction,x,y\ncw,1,2\nccw,1,two\n", r"line 3, field y: not a number"),
    ("direction,x,y\ncw,1,2\nccw,1\n", r"line 3: expected 3 fields"),
    ("direction,x,y\ncw,1,2\ncw,3,4\n", "no ccw runs"),
])
def test_runs_csv_errors_name_file_line_field(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(UMBmarkError, match=match) as e:
        read_runs(path)
    assert str(path) in str(e.value)


def test_runs_csv_comments_blank_lines_and_case(tmp_path):
    path = tmp_path / "runs.csv"
    path.write_text("# Table I.2\nDirection, X, Y\n\nCW, -160, -150\n ccw ,73,-75\n")
    cw, ccw = read_runs(path)
    assert cw.tolist() == [[-160, -150]] and ccw.tolist() == [[73, -75]]


def _cli(argv, monkeypatch, capsys):
    # only this branch's commands: the registry also names commands other branches provide
    monkeypatch.setattr(cli, "COMMANDS", ["umbmark"])
    code = cli.main(argv)
    return code, capsys.readouterr()


def test_command_json_has_exact_keys_and_thesis_values(tmp_path, monkeypatch, capsys):
    path = tmp_path / "runs.csv"
    write_runs(path, *TABLE_I2)
    code, out = _cli(["umbmark", str(path), "--side", "4000", "--wheelbase", "267", "--json"], monkeypatch, capsys)
    assert code == 0
    d = json.loads(out.out)
    assert list(d) == KEYS
    assert round(d["r_cw"], 2) == 184.13 and round(d["r_ccw"], 2) == 150.07 and d["E_max_syst"] == d["r_cw"]


def test_command_plain_output(tmp_path, monkeypatch, capsys):
    path = tmp_path / "runs.csv"
    write_runs(path, *TABLE_I1)
    code, out = _cli(["umbmark", str(path)], monkeypatch, capsys)
    assert code == 0
    for text in ("5 cw and 5 ccw runs", "r = 1598.21 mm", "-1.8456°", "-7.8832°", "16739.90", "1613.21 mm"):
        assert text in out.out


def test_command_error_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    path = tmp_path / "runs.csv"
    path.write_text("direction,x,y\ncw,1,2\n")
    code, out = _cli(["umbmark", str(path)], monkeypatch, capsys)
    assert code == 2
    assert out.err.startswith("fuzzybrep umbmark: error:") and "no ccw runs" in out.err
