"""Options and loading shared by the fuzzy B-rep commands (and by ``build``)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..brep import BRepMap, Ring
from ..errors import MapFileError, MembershipFunctionError
from ..formats.compact import MAGIC
from ..formats.files import loads_json, read_limited
from ..formats.geojson import MAX_GEOJSON_BYTES, MAX_GEOJSON_POSITIONS, crisp_from_geojson
from ..formats.mapfile import FORMAT, MapFile, from_json, map_from_bytes, read_map
from ..fuzzy.map import ALIASES, DEFAULT_METHOD, METHODS, FuzzyBRepMap, fuzzify
from ..fuzzy.membership import DEFAULT_TME_M, parse_spec, total_maximum_error


def add_mf_arguments(parser: argparse.ArgumentParser, default_tme: float | None = None, unit: str | None = None) -> None:
    """--tme / --laser-error + --odometry-error, --mf, --frontier-mf (for fuzzify and build).

    ``unit``: the unit of the lengths, when the command has one (build is metric: "metres");
    else they are in the map's unit."""
    g = parser.add_argument_group("sensor uncertainty (thesis 4.1.1)")
    dflt = f" (default {default_tme:g})" if default_tme is not None else ""
    where = f"in {unit}" if unit else "in the map's unit"
    g.add_argument("--tme", type=float, default=None,
                   help=f"total maximum error, {where}{dflt}: the support ±TME of the membership function")
    g.add_argument("--laser-error", type=float, default=None,
                   help=f"laser range error, {where}; TME = |laser| + |odometry|")
    g.add_argument("--odometry-error", type=float, default=None,
                   help=f"odometry error (UMBmark), {where}; TME = |laser| + |odometry|")
    g.add_argument("--mf", default="triangular", metavar="SPEC",
                   help="membership function: triangular (default), triangular:in=A,out=B, A1:p=P, A4:p=P, "
                        "A2:p=P,truncate, A3:p=P,truncate; a missing TME comes from --tme")
    g.add_argument("--frontier-mf", default=None, metavar="SPEC",
                   help="a second membership function for vertices on frontier edges")
    parser.set_defaults(_default_tme=default_tme)


def tme_from_args(args: argparse.Namespace, required: bool = False) -> float | None:
    if args.laser_error is not None or args.odometry_error is not None:
        if args.tme is not None:
            raise MembershipFunctionError("give --tme or --laser-error/--odometry-error, not both")
        return total_maximum_error(args.laser_error or 0.0, args.odometry_error or 0.0)
    if args.tme is not None:
        return args.tme
    if getattr(args, "_default_tme", None) is not None:
        return args._default_tme
    if required:
        raise MembershipFunctionError("the map's unit is unknown: give --tme (or --laser-error and --odometry-error)")
    return None


def mf_from_args(args: argparse.Namespace, tme_required: bool = False):
    """(membership function, frontier function or None) of the options of ``add_mf_arguments``;
    MembershipFunctionError for a bad spec or TME. ``build`` calls it before its work, so that a
    typo is not found only once the map is built."""
    tme = tme_from_args(args, tme_required)
    mf = parse_spec(args.mf, tme)
    return mf, parse_spec(args.frontier_mf, tme) if args.frontier_mf else None


def fuzzify_from_args(crisp: BRepMap, args: argparse.Namespace, tme_required: bool = False) -> FuzzyBRepMap:
    """fuzzify() with the options of ``add_mf_arguments``."""
    mf, frontier = mf_from_args(args, tme_required)
    return fuzzify(crisp, mf, frontier_mf=frontier)


#: what --method means, for every command that takes it
METHOD_HELP = ("safe: the conservative sweep, never closer to a wall than the uncertainty allows (default); "
               "thesis: the thesis's single normal vertex sweep (sweep is its old name); exact: the Extension "
               "principle (the crisp map buffered)")


def add_method_argument(parser: argparse.ArgumentParser, flag: str = "--method", what: str = "α-cuts",
                        extra: tuple[str, ...] = (), default: str = DEFAULT_METHOD) -> None:
    """``--method safe|thesis|exact`` (``sweep`` read as ``thesis``), default safe."""
    parser.add_argument(flag, type=lambda s: ALIASES.get(s, s), choices=METHODS + extra, default=default,
                        help=f"{what} by {METHOD_HELP}")


def add_map_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("map", metavar="MAP.json", help="a fuzzybrep map file")
    parser.add_argument("--tme", type=float, default=None,
                        help="fuzzify a crisp map (one without Table 4.2) with this TME on the fly")


def load_map(args: argparse.Namespace, m: MapFile | None = None) -> FuzzyBRepMap:
    """The fuzzy map of ``args.map`` (``m``: the file, if already read); --tme fuzzifies a crisp one.

    --tme on a map that has its own functions (Table 4.2) is refused rather than ignored: the
    user asked for an uncertainty the map does not carry."""
    m = read_map(args.map) if m is None else m
    if args.tme is not None and m.membership_functions:
        tme = repr(args.tme)  # every digit: the command suggested must fuzzify with the TME given
        raise MapFileError(args.map, f"the map has its own membership functions (Table 4.2), so --tme {tme} "
                                     f"would not be used: leave it out, or fuzzify the map anew with "
                                     f"`fuzzybrep fuzzify {args.map} --tme {tme} --out NEW.json`")
    return FuzzyBRepMap.from_mapfile(m, args.map, args.tme)


def read_crisp(path: str | Path, unit: str | None) -> BRepMap:
    """A crisp map from GeoJSON, or from a fuzzybrep map file or compact map (its crisp part)."""
    path = Path(path)
    # once, and bounded (/dev/zero or a FIFO has no size to check first): a map file or GeoJSON
    # is decoded from these bytes
    raw = read_limited(path, MAX_GEOJSON_BYTES, "a map file or GeoJSON")
    crisp = None
    if raw.startswith(MAGIC):
        crisp = map_from_bytes(raw, path).crisp
    elif path.suffix.lower() == ".json":
        try:
            obj = loads_json(raw)  # as read_map reads it: a byte-order mark is allowed
        except (UnicodeDecodeError, json.JSONDecodeError):
            obj = None
        if isinstance(obj, dict) and obj.get("format") == FORMAT:
            crisp = from_json(obj, path).crisp
    if crisp is None:
        return _geojson_from_bytes(raw, path, unit)
    # the FM column indexes the file's own Table 4.2, which fuzzifying replaces: kept, a
    # frontier index 2 would have no function in a new one-function table
    return crisp.with_rings([Ring(r.vertices, r.kinds) for r in crisp.rings])


def _geojson_from_bytes(raw: bytes, path: Path, unit: str | None) -> BRepMap:
    """``read_geojson`` of a file's bytes already read (a FIFO cannot be read twice), with its limits."""
    brackets = raw.count(b"[")
    if brackets > MAX_GEOJSON_POSITIONS + 1000:  # every position opens one: counted before parsing
        raise MapFileError(path, f"the file holds about {brackets} positions; GeoJSON is read with up to "
                                 f"{MAX_GEOJSON_POSITIONS}")
    try:
        obj = loads_json(raw)
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise MapFileError(path, f"not valid JSON ({e})") from None
    try:
        return crisp_from_geojson(obj, unit)
    except ValueError as e:  # GeometryError among them
        raise MapFileError(path, str(e)) from None


__all__ = ["DEFAULT_TME_M", "add_map_argument", "add_mf_arguments", "fuzzify_from_args", "load_map", "mf_from_args",
           "read_crisp", "tme_from_args"]
