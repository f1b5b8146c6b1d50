"""formats.files: outputs checked before a command writes any of them."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from fuzzybrep.errors import MapFileError
from fuzzybrep.formats import files


def test_an_output_that_is_an_input_or_given_twice_is_refused(tmp_path, monkeypatch):
    log = tmp_path / "run.log"
    log.write_text("x")
    (tmp_path / "link.log").symlink_to(log)
    os.link(log, tmp_path / "hard.log")
    monkeypatch.chdir(tmp_path)
    for same in ("run.log", "./run.log", tmp_path / "link.log", tmp_path / "hard.log"):
        with pytest.raises(MapFileError, match="it is the input"):
            files.check_outputs(same, inputs=(log,))
    with pytest.raises(MapFileError, match="given for two outputs"):
        files.check_outputs(tmp_path / "a.json", "a.json", inputs=())
    with pytest.raises(MapFileError, match="given for two outputs"):
        files.check_outputs(tmp_path / "hard.log", tmp_path / "run.log", inputs=())
    files.check_outputs(tmp_path / "a.json", tmp_path / "b.json", None, inputs=(log, None))


def test_checking_many_outputs_is_linear(tmp_path, monkeypatch):
    # tables --csv gives one output per ring and table: compared pairwise, Freiburg's 5958 took
    # ten minutes; each path is now resolved once
    calls = []
    resolve = Path.resolve
    monkeypatch.setattr(Path, "resolve", lambda self, *a, **k: calls.append(1) or resolve(self, *a, **k))
    for n in (100, 1000):
        calls.clear()
        files.check_outputs(*(tmp_path / f"t{k}.csv" for k in range(n)), inputs=(tmp_path / "map.json",))
        assert len(calls) <= n + 1
