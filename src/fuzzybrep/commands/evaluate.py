"""fuzzybrep evaluate: how well a map built from some scans predicts the others."""

from __future__ import annotations

import json
import math
import sys

from ..errors import ScanValueError
from ._logopts import add_log_arguments, read_log, read_notes
from ._progress import steps
from ._types import number, positive
from .grid import check_grid_size

_holdout = number(lambda k: k >= 2, "K must be a whole number, got {text!r}",
                  "K must be at least 2 (every K-th scan is held out, the rest build the map), got {text}", cast=int)

NAME = "evaluate"
HELP = "build from all scans but every K-th and score the held-out ones against the map"


def add_arguments(p) -> None:
    add_log_arguments(p)
    p.add_argument("--holdout", type=_holdout, default=2, metavar="K", help="hold out every K-th scan (default 2)")
    # checked here, not by the map's fuzzify once the map is built (11 s into Freiburg 079)
    p.add_argument("--tme", type=positive, default=None, help="TME in the map's unit (default 0.19913)")
    p.add_argument("--resolution", type=positive, default=0.05, help="occupancy-grid cell for the comparison (default 0.05)")
    p.add_argument("--json", action="store_true", help="print the scores as JSON")


def run(args) -> int:
    from dataclasses import replace

    from ..mapping.build import BuildConfig
    from ..use.evaluate import EVALUATION_STEPS, evaluate_log, ordinal
    scans, report = read_log(args)
    for line in read_notes(report):  # on standard error: --json's output stays one JSON document
        print(line, file=sys.stderr)
    cfg = BuildConfig() if args.tme is None else replace(BuildConfig(), tme=args.tme)
    check_grid_size(args.log, scans, args.resolution, cfg.beams.max_usable)
    try:
        with steps(len(EVALUATION_STEPS)) as step:
            e = evaluate_log(scans, args.holdout, cfg, resolution=args.resolution, progress=step)
    except ScanValueError as err:
        if err.path is not None:
            raise
        raise ScanValueError(args.log, None, err.reason) from None  # nothing to score: name the log
    for note in e.notes:  # the scans' order, when their timestamps cannot give it
        print(f"note: {note}", file=sys.stderr)
    if args.json:
        print(json.dumps(e.as_dict(), indent=2))
        return 0
    pct = lambda x: f"{100 * x:.2f} %"  # noqa: E731
    print(f"{args.log}: map from {e.scans_used} scans, {e.scans_held_out} held out (every {ordinal(e.holdout)}), "
          f"{e.exact.endpoints} held-out endpoints under 5 m")
    for name, s in (("exact band", e.exact), ("safe band (the default α-cut)", e.safe), ("thesis's sweep band", e.thesis)):
        print(f"  {name}: explained {pct(s.explained)}, violations {pct(s.violations)}, beyond {pct(s.beyond)}")
    print(f"  of the exact band's violations, {pct(e.violations_on_small_objects)} of all endpoints lie on small "
          f"isolated objects (< 0.5 m across, in front of both neighbours: legs, people, poles)")
    print(f"  {pct(e.violations_unseen)} of all endpoints are violations where no kept scan saw any return "
          f"within TME: no map of the kept scans could know them")
    print(f"    {pct(e.violations_seen_through)} of all endpoints: of those, a kept beam passed more than TME "
          f"beyond them: free in every map true to the kept scans")
    print(f"  {pct(e.violations_came_and_went)} of all endpoints are violations that came and went: beams of kept "
          f"scans passed more than TME beyond them both before and after (people, doors)")
    print(f"  {pct(e.violations_rest)} of all endpoints are violations neither unseen nor come and gone: a kept scan "
          f"saw a return within TME (a better map could have avoided them, unless kept scans saw it go)")
    print(f"  {pct(e.beyond_seen)} of all endpoints lie beyond the exact band although a kept scan saw a return "
          f"within TME of them: what a map of the kept scans could have explained")
    iou = "undefined (no free space in either at the cell centres)" if math.isnan(e.free_iou) else f"{e.free_iou:.3f}"
    print(f"  free-space IoU with the {e.resolution:g} m grid: {iou}")
    print(f"  bytes: fuzzy map {e.map_bytes_compact} compact ({e.map_bytes_thesis} as Table 5.3 counts) vs grid "
          f"{e.grid_bytes} ({e.grid_bytes / e.map_bytes_compact:.1f}x the compact map)")
    return 0

