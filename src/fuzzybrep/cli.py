"""The ``fuzzybrep`` command line: one sub-command per module in ``fuzzybrep.commands``.

Each command module defines ``NAME``, ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``.
Errors fuzzybrep raises on purpose are printed as one line and exit with status 2.
"""

from __future__ import annotations

import argparse
import importlib
import re
import sys

from .errors import FuzzyBrepError

#: command modules, in the order ``fuzzybrep --help`` lists them
COMMANDS = [
    "demo",
    "build",
    "export",
    "view",
    "fuzzify",
    "tables",
    "alpha_cut",
    "membership",
    "plan",
    "memory",
    "evaluate",
    "grid",
    "simulate",
    "umbmark",
    "drift",
    "localise",
]


#: what argparse takes for a negative number rather than an option: its own pattern misses
#: exponents and infinities (Python < 3.13), so "--goal -1e3 5" was "expected 2 arguments"
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE)


class OneLineParser(argparse.ArgumentParser):
    """argparse with the promise every error of ours keeps: one line, exit status 2. argparse
    printed the whole usage first (4 to 14 lines for ``--alpha 2``); the line says where the
    usage is instead. ``--help`` is unchanged."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} (see {self.prog} --help)\n")


def parser(only: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser: every command's, or only command module ``only``'s (what a run
    of that command needs: importing every command module took longer than some commands run)."""
    p = OneLineParser(prog="fuzzybrep", description="Fuzzy boundary-representation maps from 2-D laser scans.")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=OneLineParser)
    for name in COMMANDS if only is None else [only]:
        mod = importlib.import_module(f".commands.{name}", __package__)
        sp = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP)
        sp._negative_number_matcher = _NEGATIVE_NUMBER  # no option of any command looks like a number
        mod.add_arguments(sp)
        sp.set_defaults(_run=mod.run)
    return p


def _command(argv: list[str]) -> str | None:
    """The command module a command line names (its first word), if any: "alpha-cut" is alpha_cut."""
    first = next((a for a in argv if not a.startswith("-")), "")
    module = first.replace("-", "_")
    return module if module in COMMANDS and module.replace("_", "-") == first else None


def _inputs(args: argparse.Namespace) -> str:
    """"LOG: " (or MAP, CRISP): what an error with no file of its own says it was reading."""
    names = [str(v) for v in (getattr(args, a, None) for a in ("log", "map", "crisp")) if v is not None]
    return f"{', '.join(names)}: " if names else ""


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
    # options before the command (fuzzybrep --help) or no known command: the whole parser says so
    only = _command(argv) if argv and not argv[0].startswith("-") else None
    args = parser(only).parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except FuzzyBrepError as e:
        print(f"fuzzybrep {args.command}: error: {e}", file=sys.stderr)
        return 2
    except MemoryError as e:  # NumPy's _ArrayMemoryError among them: one line, as any error of ours
        print(f"fuzzybrep {args.command}: error: {_inputs(args)}out of memory"
              f"{': ' + ' '.join(str(e).split()) if str(e) else ''} (the input is too large for this "
              f"machine's memory)", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader went away (``fuzzybrep tables MAP | head``): not an error of ours
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
