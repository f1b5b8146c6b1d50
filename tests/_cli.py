"""Running the command line in tests: the one-line error every hostile or bad input must give."""

from __future__ import annotations

from fuzzybrep import cli


def fails(capsys, argv, *words) -> str:
    """Run the CLI, expect exit status 2 and one error line holding every word, nothing before it."""
    assert cli.main([str(a) for a in argv]) == 2
    out = capsys.readouterr()
    assert out.err.count("\n") == 1 and "Traceback" not in out.err, out.err
    for w in words:
        assert w in out.err, out.err
    return out.err
