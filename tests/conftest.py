"""Shared fixtures: where the real CARMEN logs are, a skip when they are absent, and the maps built from
them (a few seconds each), built once per session."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

from fuzzybrep.cli import main
from fuzzybrep.fuzzy.map import FuzzyBRepMap
from fuzzybrep.scans.read import read_scans

REPO = Path(__file__).resolve().parents[1]

# The property tests draw new examples on every run, so that running them keeps looking for
# defects; CI (HYPOTHESIS_PROFILE=ci in .ci/run) draws the same examples every time, so that
# whether main passes does not depend on the luck of the draw. A counterexample found by chance
# is pinned with @example beside its fix.
settings.register_profile("ci", derandomize=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


def datasets_dir() -> Path | None:
    """The shared datasets: $FUZZYBREP_DATASETS, else ../shared/datasets beside the checkout (as the
    README says; before, an absolute /work/shared/datasets was tried last, silently)."""
    candidates = [os.environ.get("FUZZYBREP_DATASETS"), REPO.parent / "shared" / "datasets"]
    for c in candidates:
        if c and (Path(c) / "carmen").is_dir():
            return Path(c)
    return None


LOGS = {
    "intel": "carmen/intel-corrected.log.gz",
    "aces": "carmen/aces-corrected.log.gz",
    "freiburg": "carmen/freiburg-079-corrected.log.gz",
    "orebro": "carmen/orebro-corrected.log.gz",
    "fhw": "carmen/fhw-corrected.log.gz",
    "campus": "carmen/freiburg-campus-corrected.log.gz",  # a minute to build: only with FUZZYBREP_BIG_LOGS=1
}


def log_path(name: str) -> Path:
    d = datasets_dir()
    if d is None or not (d / LOGS[name]).is_file():
        pytest.skip(f"real log {LOGS[name]} not found (set FUZZYBREP_DATASETS or put ../shared/datasets beside the checkout)")
    return d / LOGS[name]


@pytest.fixture(scope="session")
def real_scans():
    """The scans of a real log, read once per session (freiburg takes seconds): ``real_scans(name)``.
    Skips, saying why, when the log is absent. Shared, so read-only: a tuple of scans whose arrays
    refuse writes (a test that changed them would change every later test's input)."""
    read: dict[str, tuple] = {}

    def get(name: str) -> tuple:
        if name not in read:
            scans = tuple(read_scans(log_path(name)))
            for s in scans:
                for a in (s.ranges, s.bearings, s.pose):
                    a.setflags(write=False)
            read[name] = scans
        return read[name]

    return get


@pytest.fixture(scope="session")
def built_map(tmp_path_factory):
    """``fuzzybrep build LOG --out NAME.json --quiet`` of a real log, run once per session and shared by
    every test file that needs it: ``built_map(name)`` is (the map file, the map read back). Skips,
    saying why, when the log is absent."""
    built: dict[str, tuple[Path, FuzzyBRepMap]] = {}

    def get(name: str) -> tuple[Path, FuzzyBRepMap]:
        if name not in built:
            log = log_path(name)
            out = tmp_path_factory.mktemp("built") / f"{name}.json"  # export names its files after the map's
            assert main(["build", str(log), "--out", str(out), "--quiet"]) == 0
            built[name] = out, FuzzyBRepMap.load(out)
        return built[name]

    return get
