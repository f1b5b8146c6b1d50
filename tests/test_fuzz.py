"""The mutation fuzzer (``tests/fuzz.py``) under hypothesis: 300 cases by default, each a format
and a seed (CI's ``ci`` profile draws the same ones every run); ``FUZZYBREP_FUZZ_CASES=N`` runs N.
A failing case is replayed with ``python tests/fuzz.py --format FMT --first SEED --cases 1``."""

from __future__ import annotations

import os

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fuzz

CASES = int(os.environ.get("FUZZYBREP_FUZZ_CASES", "300"))


@settings(max_examples=CASES, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(fmt=st.sampled_from(fuzz.FORMATS), seed=st.integers(0, 2**31 - 1))
def test_hostile_inputs(fmt, seed):
    res = fuzz.case(fmt, seed)
    assert not res.problems, (f"python tests/fuzz.py --format {fmt} --first {seed} --cases 1: "
                              f"{res.argv[0]}: {res.problems}")


def test_the_fuzzer_finds_a_traceback(tmp_path, monkeypatch):
    """The checks themselves: a command that raises, one that prints two lines, one that leaves a
    temporary file are each reported."""
    from fuzzybrep import cli

    def boom(argv):
        raise ZeroDivisionError("x")

    monkeypatch.setattr(cli, "main", boom)
    assert "traceback: ZeroDivisionError: x" in fuzz.run(["tables", "m.json"], tmp_path).problems[0]

    def two_lines(argv):
        import sys
        print("warning\nfuzzybrep: error: x", file=sys.stderr)
        (tmp_path / ".m.json.1.tmp").write_text("")
        return 2

    monkeypatch.setattr(cli, "main", two_lines)
    problems = fuzz.run(["tables", "m.json"], tmp_path).problems
    assert any("not one line" in p for p in problems) and any("temporary files left" in p for p in problems)
    assert any("failed run left outputs" in p for p in problems)
