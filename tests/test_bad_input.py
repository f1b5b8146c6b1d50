"""Bad input through the command line: one clear line naming the file and what is wrong, exit 2, no traceback."""

from __future__ import annotations

import pytest

from fuzzybrep import cli


def flaser(ranges, pose=(1.0, 2.0, 0.5), t=10.0) -> str:
    r = " ".join(str(x) for x in ranges)
    x, y, th = pose
    return f"FLASER {len(ranges)} {r} {x} {y} {th} {x} {y} {th} {t} host {t}\n"


def fails(capsys, argv, *words) -> str:
    """Run the CLI, expect exit status 2 and one error line holding every word."""
    assert cli.main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for w in words:
        assert w in err, err
    return err


@pytest.mark.parametrize("command, extra", [("build", ["--out", "m.json", "--quiet"]), ("grid", ["--out", "g"]),
                                            ("evaluate", [])])
def test_log_where_no_beam_returns(tmp_path, capsys, command, extra):
    # every beam at the log's largest range: all "no return"; the builders crashed deep inside
    log = tmp_path / "blind.log"
    log.write_text("".join(flaser([5.0] * 9, (0.1 * k, 0.0, 0.0), k) for k in range(4)))
    extra = [str(tmp_path / e) if e in ("m.json", "g") else e for e in extra]
    fails(capsys, [command, log, *extra], "blind.log", "no beam has a return", "max_range 5")
    assert not (tmp_path / "m.json").exists()


def test_log_where_no_beam_returns_maps_free_space_when_asked(tmp_path):
    log = tmp_path / "blind.log"
    log.write_text("".join(flaser([5.0] * 9, (0.1 * k, 0.0, 0.0), k) for k in range(4)))
    assert cli.main(["build", str(log), "--out", str(tmp_path / "m.json"), "--quiet", "--no-return-free", "3"]) == 0
