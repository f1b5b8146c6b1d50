"""fuzzybrep alpha-cut: the inner and outer polygons of α-cuts, as a GeoJSON FeatureCollection."""

from __future__ import annotations

import argparse
import json
import sys

from ..errors import MapFileError
from ..formats.export import geojson_collection
from ..formats.files import check_outputs, write_atomic
from ..formats.geojson import alpha_cut_collection
from ._maps import add_map_argument, add_method_argument, load_map
from ._progress import steps
from ._types import add_georef_argument, alpha

NAME = "alpha-cut"
HELP = "write α-cuts (inner: free at confidence α; outer) as GeoJSON features with properties role and alpha"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_map_argument(p)
    p.add_argument("--alpha", type=alpha, action="append", required=True, metavar="A",
                   help="membership grade in [0, 1]; repeat for several α-cuts")
    add_method_argument(p)
    p.add_argument("--out", metavar="CUT.geojson", help="file to write (default: standard output)")
    add_georef_argument(p)


def run(args: argparse.Namespace) -> int:
    check_outputs(args.out, inputs=(args.map,))
    with steps(1 + len(args.alpha)) as step:
        step(f"reading {args.map}")
        fuzzy = load_map(args)
        cuts = []
        for a in args.alpha:
            step(f"α-cut at α = {a:g} ({args.method})")
            cuts.append(fuzzy.alpha_cut(a, args.method))
    try:
        fc = geojson_collection(alpha_cut_collection(cuts, fuzzy.crisp), fuzzy.unit, args.georef)
    except ValueError as e:
        raise MapFileError(args.map, str(e)) from None
    data = json.dumps(fc, separators=(",", ":"))
    if args.out:
        write_atomic(args.out, data.encode())
        for c in cuts:
            print(f"α = {c.alpha:g}: inner area {c.inner.area:.6g}, outer area {c.outer.area:.6g} {fuzzy.unit}²")
    else:
        sys.stdout.write(data + "\n")
    return 0
