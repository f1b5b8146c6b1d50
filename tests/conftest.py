"""Shared fixtures: where the real CARMEN logs are, and a skip when they are absent."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def datasets_dir() -> Path | None:
    """The shared datasets: $FUZZYBREP_DATASETS, else ../shared/datasets beside the checkout."""
    candidates = [os.environ.get("FUZZYBREP_DATASETS"), REPO.parent / "shared" / "datasets", "/work/shared/datasets"]
    for c in candidates:
        if c and (Path(c) / "carmen").is_dir():
            return Path(c)
    return None


LOGS = {
    "intel": "carmen/intel-corrected.log.gz",
    "aces": "carmen/aces-corrected.log.gz",
    "freiburg": "carmen/freiburg-079-corrected.log.gz",
}


def log_path(name: str) -> Path:
    d = datasets_dir()
    if d is None or not (d / LOGS[name]).is_file():
        pytest.skip(f"real log {LOGS[name]} not found (set FUZZYBREP_DATASETS or put ../shared/datasets beside the checkout)")
    return d / LOGS[name]
