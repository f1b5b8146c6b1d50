"""fuzzybrep fuzzify: a crisp map (GeoJSON floor plan or map file) to a fuzzy B-rep map file."""

from __future__ import annotations

import argparse

from ..brep import FRONTIER
from ._maps import add_mf_arguments, fuzzify_from_args, read_crisp

NAME = "fuzzify"
HELP = "fuzzify a crisp map given as GeoJSON (Polygon/MultiPolygon with holes) into a fuzzy B-rep map"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("crisp", metavar="CRISP.geojson", help="crisp map: GeoJSON, or a fuzzybrep map file")
    p.add_argument("--unit", default=None,
                   help="unit of the coordinates and of --tme (default: the file's \"unit\", else m)")
    p.add_argument("--out", required=True, metavar="MAP.json", help="fuzzy B-rep map file to write")
    add_mf_arguments(p)


def run(args: argparse.Namespace) -> int:
    from ..formats.files import check_outputs

    check_outputs(args.out, inputs=(args.crisp,))
    crisp = read_crisp(args.crisp, args.unit)
    if args.frontier_mf is None and any((r.kinds == FRONTIER).any() for r in crisp.rings):
        # as `build` does: a built map's frontier vertices keep their own FM index, with the same
        # function until told otherwise; one index for all would lose what the map knows
        args.frontier_mf = args.mf
    fuzzy = fuzzify_from_args(crisp, args, tme_required=True)
    size = fuzzy.save(args.out, metadata={"source": str(args.crisp)})
    print(f"{args.out}: {len(fuzzy.crisp.rings)} rings ({fuzzy.crisp.n_holes} holes), "
          f"{fuzzy.crisp.n_vertices} vertices, {len(fuzzy.table)} membership function(s), {size} bytes")
    return 0
