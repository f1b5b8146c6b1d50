"""fuzzybrep tables: the fuzzy vertex, edge and membership-function tables (Tables 4.1-4.3)."""

from __future__ import annotations

import argparse
import csv
import io
import sys
from pathlib import Path

import numpy as np

from ..brep import KIND_NAMES
from ..formats.files import check_outputs, write_atomic
from ._maps import add_map_argument, load_map

NAME = "tables"
HELP = "print or write as CSV the fuzzy vertex (4.1), membership-function (4.2) and fuzzy edge (4.3) tables"

VERTEX_HEADER = ["VERTEX", "X", "Y", "XOUT", "YOUT", "XIN", "YIN", "T", "U", "V", "W", "FM"]
EDGE_HEADER = ["EDGE", "VSTART", "VEND", "EDGE_OUT", "VOUT_START", "VOUT_END", "EDGE_IN", "VIN_START", "VIN_END", "KIND"]
MF_HEADER = ["INDEX", "TYPE", "PARAMETERS", "SUPPORT_IN", "SUPPORT_OUT", "FORMULA"]


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_map_argument(p)
    p.add_argument("--csv", metavar="DIR", help="write vertices.csv and edges.csv (every ring, its name in the first "
                                                "column RING) and membership_functions.csv into DIR instead of printing")
    p.add_argument("--per-ring", action="store_true",
                   help="--csv: one vertices_<ring>.csv and edges_<ring>.csv per ring instead (thousands of files "
                        "for a real map)")


def slug(name: str) -> str:
    """File-name part of a ring name: principal, hole_1, piece_2, piece_2_hole_1."""
    return name.replace(" ", "_")


def vertex_rows(fuzzy, k: int, fmt) -> list[list[str]]:
    t = fuzzy.vertex_table(k)
    rows = []
    for i in range(len(t["X"])):
        row = [f"V{i + 1}"]
        for col in VERTEX_HEADER[1:-1]:
            row.append(fmt(t[col][i]))
        row.append(str(int(t["FM"][i])))
        rows.append(row)
    return rows


def edge_rows(fuzzy, k: int, null: str) -> list[list[str]]:
    t = fuzzy.edge_table(k)

    def name(prefix, v):
        return f"{prefix}{int(v)}" if v else null

    rows = []
    for i in range(len(t["EDGE"])):
        rows.append([name("E", t["EDGE"][i]), name("V", t["VSTART"][i]), name("V", t["VEND"][i]),
                     name("EO", t["EDGE_OUT"][i]), name("VO", t["VOUT_START"][i]), name("VO", t["VOUT_END"][i]),
                     name("EI", t["EDGE_IN"][i]), name("VI", t["VIN_START"][i]), name("VI", t["VIN_END"][i]),
                     KIND_NAMES.get(int(t["KIND"][i]), str(int(t["KIND"][i])))])
    return rows


def mf_rows(fuzzy, fmt) -> list[list[str]]:
    return [[str(r["INDEX"]), r["TYPE"], r["PARAMETERS"], fmt(r["SUPPORT_IN"]), fmt(r["SUPPORT_OUT"]), r["FORMULA"]]
            for r in fuzzy.membership_table()]


def _csv(header, rows) -> bytes:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    return buf.getvalue().encode()


def _print(title: str, header: list[str], rows: list[list[str]]) -> None:
    widths = [max(len(h), *(len(r[j]) for r in rows)) if rows else len(h) for j, h in enumerate(header)]
    lines = [title, "  ".join(h.rjust(w) for h, w in zip(header, widths))]
    lines += ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in rows]
    sys.stdout.write("\n".join(lines) + "\n\n")  # one write a table: a print a row took a fifth of the time


def run(args: argparse.Namespace) -> int:
    fuzzy = load_map(args)
    names = fuzzy.ring_names
    if args.csv:
        out = Path(args.csv)

        def num(x):
            return "" if not np.isfinite(x) else repr(float(x))

        files = {}
        if args.per_ring:
            for k, name in enumerate(names):
                files[out / f"vertices_{slug(name)}.csv"] = _csv(VERTEX_HEADER, vertex_rows(fuzzy, k, num))
                files[out / f"edges_{slug(name)}.csv"] = _csv(EDGE_HEADER, edge_rows(fuzzy, k, ""))
        else:
            # one file per table, the ring in the first column (issue 20: 1,629 files for belgioioso)
            vertices, edges = [], []
            for k, name in enumerate(names):
                vertices += [[slug(name), *row] for row in vertex_rows(fuzzy, k, num)]
                edges += [[slug(name), *row] for row in edge_rows(fuzzy, k, "")]
            files[out / "vertices.csv"] = _csv(["RING", *VERTEX_HEADER], vertices)
            files[out / "edges.csv"] = _csv(["RING", *EDGE_HEADER], edges)
        files[out / "membership_functions.csv"] = _csv(MF_HEADER, mf_rows(fuzzy, num))
        check_outputs(*files, inputs=(args.map,))  # all before any: a failure leaves no partial set of tables
        for path, data in files.items():
            write_atomic(path, data)
        print(f"{out}: {len(files)} tables ({len(names)} rings)")
        return 0

    def num(x):
        return "NULL" if not np.isfinite(x) else f"{x:.6g}"

    for k, name in enumerate(names):
        _print(f"Fuzzy vertex table (Table 4.1): {name}", VERTEX_HEADER, vertex_rows(fuzzy, k, num))
        _print(f"Fuzzy edge table (Table 4.3): {name}", EDGE_HEADER, edge_rows(fuzzy, k, "NULL"))
    _print(f"Membership functions (Table 4.2), unit {fuzzy.unit}", MF_HEADER, mf_rows(fuzzy, num))
    return 0
