"""argparse types for numbers with a rule, shared by the commands (not a command: cli.COMMANDS does not list it).

argparse prints an ``ArgumentTypeError``'s text after the option's name, so each type says what
was wrong in the user's words; ``{text}`` is what was typed, ``{value}`` the parsed number.
"""

from __future__ import annotations

import argparse
import math
import re
from typing import Callable


def number(ok: Callable[[float], bool], not_a_number: str, breaks_rule: str, cast: type = float):
    """An argparse type: ``cast(text)``, kept when ``ok(value)``; else the message, formatted."""

    def parse(text: str):
        try:
            value = cast(text)
        except ValueError:
            raise argparse.ArgumentTypeError(not_a_number.format(text=text, value=None)) from None
        if not ok(value):
            raise argparse.ArgumentTypeError(breaks_rule.format(text=text, value=value))
        return value

    return parse


positive = number(lambda v: 0 < v < math.inf, "{text!r} is not a number", "{text} must be a positive number")
non_negative = number(lambda v: 0 <= v < math.inf, "{text!r} is not a number", "{text} must be a finite number ≥ 0")
finite = number(math.isfinite, "{text!r} is not a number", "{text} must be a finite number")
seed = number(lambda s: s >= 0, "seed must be a whole number, got {text!r}", "seed must be ≥ 0, got {text}", cast=int)
alpha = number(lambda a: 0.0 <= a <= 1.0, "α must be a number, got {text!r}", "α must lie in [0, 1], got {text}")


def file_name(s: str) -> str:
    """An argparse type: a plain file name, so that an output lands in the folder given for it."""
    if not re.fullmatch(r"[A-Za-z0-9_.-]+", s) or s in (".", ".."):
        raise argparse.ArgumentTypeError(f"name must be a plain file name (letters, digits, _ . -), got {s!r}")
    return s


class _Georef(argparse.Action):
    """--georef LON LAT HEADING: three finite numbers, LON in [−180, 180], LAT in (−90, 90)."""

    def __call__(self, parser, namespace, values, option_string=None):
        from ..formats.georef import check_georef

        try:
            check_georef(*values)
        except ValueError as e:
            parser.error(f"argument --georef: {str(e).removeprefix('--georef: ')}")
        setattr(namespace, self.dest, tuple(values))


def add_georef_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("--georef", nargs=3, type=finite, action=_Georef, metavar=("LON", "LAT", "HEADING"),
                   help="write RFC 7946 WGS 84 lon/lat: the map origin's longitude and latitude (degrees) and the "
                        "bearing of the map's x axis (degrees clockwise from north); without it the file declares "
                        "the map's local frame (JSON-FG coordRefSys)")
