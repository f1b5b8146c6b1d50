"""One self-contained HTML file to look at a fuzzy B-rep map in a browser (``fuzzybrep view``).

The page carries the map as a JSON payload (``payload``) and draws it on a <canvas> with its own
script (``viewer.js`` beside this file): no library, no network. The payload holds what the
thesis stores, not pictures: per vertex the crisp vertex (X, Y) and the direction (T, V) of its
parametric line (Table 4.1; U = X − T, W = Y − V), per edge its kind, per vertex its FM index, and
per membership function its d_in(α), d_out(α) sampled at ``levels`` + 1 values of α, and the
method it draws (``safe``, the default, or ``thesis``). The script reads an α-cut in O(n), as the
thesis does, and draws it as a region: for the thesis's sweep the region its α-cut's edges sweep,
for the safe sweep its pieces (every edge's rectangle and every corner's fan, or every edge's
stadium: ``safe_pieces``), both painted over the crisp free space (docs/viewer.md); ``swept_cut``
is the same construction in Shapely, the reference the browser tests compare the page with. μ
under the cursor is the method's μ (``FuzzyBRepMap.membership(points, method)``) and the exact μ,
both computed in the page.
"""

from __future__ import annotations

import json
import math
import os
import re
from importlib import resources
from pathlib import Path

import numpy as np
import shapely

from ..errors import FormatLimitError, MapFileError
from ..formats.compact import ring_vertex_namer, to_quanta
from ..formats.escape import html_text, printable, script_json
from ..formats.export import coordinate_quantum
from ..formats.files import loads_json, write_atomic
from ..geometry import polygonal

FORMAT = "fuzzybrep-viewer"
VERSION = 1
#: default slider positions: α = 0, 0.01, ..., 1
DEFAULT_SLIDER_LEVELS = 101
#: the α-cut methods the page draws (the exact one is GEOS's buffers, not read from the map)
PAGE_METHODS = ("safe", "thesis")
#: d(α) is sampled at least this finely, so that μ read back from it is good to ~1e-3
_MIN_TABLE_STEPS = 1000


def read_path(path: str | os.PathLike) -> np.ndarray:
    """(k, 2) planned path from a JSON file ``{"path": [[x, y], ...]}`` (what ``fuzzybrep plan`` writes)."""
    path = Path(path)
    try:
        obj = loads_json(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as e:
        raise MapFileError(path, f"cannot read: {getattr(e, 'strerror', None) or e}") from None
    except json.JSONDecodeError as e:
        raise MapFileError(path, f"not valid JSON ({e})") from None
    pts = obj.get("path") if isinstance(obj, dict) else None
    if not isinstance(pts, list):
        raise MapFileError(path, 'expected an object with a "path" list of [x, y] points')
    out = np.empty((len(pts), 2))
    for k, p in enumerate(pts):
        if not (isinstance(p, (list, tuple)) and len(p) >= 2 and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in p[:2])):
            raise MapFileError(path, f"path point {k + 1} is not [x, y] numbers: {p!r}")
        out[k] = p[0], p[1]
    if not np.isfinite(out).all():
        raise MapFileError(path, f"path point {int(np.argmax(~np.isfinite(out).all(axis=1))) + 1} is not finite")
    return out


def _table_steps(slider_levels: int) -> int:
    """A multiple of the slider's steps of at least 1000: every slider position is a sample."""
    steps = slider_levels - 1
    return steps * math.ceil(_MIN_TABLE_STEPS / steps)


def _deltas(v: np.ndarray, starts: np.ndarray) -> list[int]:
    """Integers delta-coded within runs that begin at ``starts`` (the first of a run absolute)."""
    d = np.diff(v, prepend=0)
    d[starts] = v[starts]
    return d.tolist()


def payload(fuzzy, poses: np.ndarray | None = None, path: np.ndarray | None = None, *, name: str = "map",
            slider_levels: int = DEFAULT_SLIDER_LEVELS, method: str = "safe") -> dict:
    """The JSON the page draws from. Coordinates are integers in units of ``q`` (a millimetre
    for maps in metres), T and V in q/10, headings in milliradians; vertices and poses are
    delta-coded (within each ring, along the trajectory)."""
    if not (isinstance(slider_levels, int) and 2 <= slider_levels <= 1001):
        raise ValueError(f"the α slider needs 2 to 1001 levels, got {slider_levels!r}")
    method = {"sweep": "thesis"}.get(method, method)
    if method not in PAGE_METHODS:
        raise ValueError(f"the page draws the α-cuts of {' or '.join(PAGE_METHODS)}, not {method!r}")
    crisp, table = fuzzy.crisp, fuzzy.table
    x0, y0, x1, y1 = fuzzy.crisp_geometry.bounds
    q = coordinate_quantum(crisp.unit, max(x1 - x0, y1 - y0))
    s = fuzzy.stack  # every ring's columns stacked in crisp.rings order
    sizes, starts, fm = s["sizes"], s["start"], s["fm"]
    vertex = ring_vertex_namer(crisp)  # JavaScript's numbers hold whole quanta exactly up to 2**53, as compact's
    xi = to_quanta(s["V"], q, vertex)
    ti = to_quanta(s["TV"], q / 10, lambda i: f"{vertex(i)}'s normal line")
    steps = _table_steps(slider_levels)
    alphas = np.arange(steps + 1) / steps
    dec = max(0, -math.floor(math.log10(q / 100) + 1e-9))
    functions = []
    for index, f in table:
        functions.append({
            "index": index,
            "label": f.describe() if hasattr(f, "describe") else f.kind,
            "support_in": f.support_in,
            "support_out": f.support_out,
            "d_in": np.round(np.asarray(f.d_in(alphas), float), dec).tolist(),
            "d_out": np.round(np.asarray(f.d_out(alphas), float), dec).tolist(),
        })
    region = np.repeat(np.arange(len(crisp.regions)), [len(r.rings) for r in crisp.regions])
    shell = np.concatenate([[1] + [0] * len(r.holes) for r in crisp.regions])
    out = {
        "format": FORMAT,
        "version": VERSION,
        "name": printable(name),  # a file name's undecodable bytes, shown as escapes
        "unit": crisp.unit,
        "q": q,
        "rings": {"size": sizes.tolist(), "region": region.tolist(), "shell": shell.tolist()},
        "x": _deltas(xi[:, 0], starts),
        "y": _deltas(xi[:, 1], starts),
        "t": ti[:, 0].tolist(),
        "v": ti[:, 1].tolist(),
        "kind": "".join(map(str, np.concatenate([r.kinds for r in crisp.rings]).tolist())),
        "fm": int(fm[0]) if (fm == fm[0]).all() else fm.tolist(),
        "functions": functions,
        "method": method,
        "safe": {"uniform": fuzzy.safe["function"] is not None},
        "levels": steps,
        "slider": slider_levels,
        "poses": None,
        "path": None,
        "stats": {"vertices": crisp.n_vertices, "holes": crisp.n_holes, "regions": len(crisp.regions),
                  "area": round(float(fuzzy.crisp_geometry.area), 6)},
    }
    if poses is not None and len(poses):
        p = np.asarray(poses, dtype=np.float64)
        pi = to_quanta(p[:, :2], q, lambda i: f"pose {i + 1}")
        h = np.rint(np.mod(p[:, 2] + np.pi, 2 * np.pi) * 1000 - np.pi * 1000).astype(np.int64)
        out["poses"] = {"x": _deltas(pi[:, 0], np.array([0])), "y": _deltas(pi[:, 1], np.array([0])),
                        "heading": h.tolist()}
    if path is not None and len(path):
        pp = to_quanta(np.asarray(path, dtype=np.float64)[:, :2], q, lambda i: f"path point {i + 1}")
        out["path"] = {"x": pp[:, 0].tolist(), "y": pp[:, 1].tolist()}
    return out


def _asset(name: str) -> str:
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")


_SLOT = re.compile(r"\{\{(TITLE|CSS|JS|DATA)\}\}")


def html_document(data: dict, title: str | None = None) -> str:
    """The page: template, style, script and payload in one file.

    The template is filled in one pass, each slot escaped for where it stands: the title as HTML
    text, the payload as JSON safe inside <script> (``escape.script_json``). Filled slot after slot,
    a "{{DATA}}" in a map's file name was filled in turn: the map's strings pasted raw into the page."""
    values = {"TITLE": html_text(title or f"fuzzy B-rep map — {data.get('name', 'map')}"),
              "CSS": _asset("viewer.css"), "JS": _asset("viewer.js"), "DATA": script_json(data)}
    return _SLOT.sub(lambda m: values[m.group(1)], _asset("page.html"))


def write_html(out: str | os.PathLike, fuzzy, poses: np.ndarray | None = None, path: np.ndarray | None = None, *,
               name: str = "map", slider_levels: int = DEFAULT_SLIDER_LEVELS, method: str = "safe") -> int:
    """Write the viewer page atomically; returns bytes written. MapFileError naming ``out`` for a
    map whose coordinates the page cannot hold (``compact.to_quanta``)."""
    try:
        data = payload(fuzzy, poses, path, name=name, slider_levels=slider_levels, method=method)
    except FormatLimitError as e:
        raise MapFileError(out, f"cannot write the viewer: {e}") from None
    return write_atomic(out, html_document(data).encode("utf-8"))


def band_quads(fuzzy, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """(free, obstacle): (m, 4, 2) corners of every band at α — crisp edge and its α-cut edge.

    ``free`` are the bands on the free side (the principal polygon's IN bands, the holes' OUT
    bands), ``obstacle`` the others. The page draws the convex hull of each.
    """
    V, nxt = fuzzy.stack["V"], fuzzy.stack["next"]
    # shrink: the principal polygon's IN offset and the holes' OUT ones, i.e. the free side
    shrink, grow = fuzzy.offset_vertices(alpha)
    free = np.stack((V, V[nxt], shrink[nxt], shrink), axis=1)
    obstacle = np.stack((V, V[nxt], grow[nxt], grow), axis=1)
    return free, obstacle


def safe_pieces(fuzzy, alpha: float) -> tuple[list, list]:
    """(free, obstacle): the convex polygons the page paints for the safe sweep's α-cut, as
    (k, 2) arrays: with one symmetric function every edge's rectangle of height d(α) on each side
    and, on the outer side of every corner's turn, the fan of tangent segments (at most 60° each)
    round the arc of radius d(α) (a disc round a spike, on both sides); otherwise every edge's
    circumscribed stadium, on both sides. The inner α-cut is the crisp free space minus the free
    pieces, the outer one plus the others: ``safe_sweep``'s rectangles and fans (Lemma 2), the
    same regions as ``alpha_cut(α)``."""
    from ..fuzzy import safe_sweep as S

    s = fuzzy.stack
    V, nxt = s["V"], s["next"]
    prv = np.empty_like(nxt)
    prv[nxt] = np.arange(len(nxt))
    f = fuzzy.safe["function"]
    free, obstacle = [], []
    if f is None:
        from ..fuzzy.safe_cut import edge_reach

        r = edge_reach(fuzzy, alpha)
        order = fuzzy.safe["V"]  # the stadiums do not depend on the rings' orientation
        pts, st = S.stadiums(order, s["sizes"], r)
        loops = np.split(pts, st[1:]) if len(st) else []
        return loops, list(loops)
    d_in, d_out = float(fuzzy.offset(f.d_in(alpha))), float(fuzzy.offset(f.d_out(alpha)))
    own = s["own"][s["ring_of"]]
    shell = s["shell"]
    t = V[nxt] - V
    t /= np.hypot(t[:, 0], t[:, 1])[:, None]
    left = np.column_stack((-t[:, 1], t[:, 0]))
    te = t[prv]
    cross = te[:, 0] * t[:, 1] - te[:, 1] * t[:, 0]
    dot = np.einsum("ij,ij->i", te, t)
    psi = np.arctan2(cross, dot)
    spike = (np.abs(cross) <= S._SPIKE) & (dot < 0)
    for side in (1, -1):
        d = d_in if side > 0 else d_out
        if d <= 0:
            continue
        m = (side * own)[:, None] * left
        to = (side > 0) == shell  # the free side
        rect = np.stack((V, V[nxt], V[nxt] + d * m, V + d * m), axis=1)
        for k in range(len(V)):
            (free if to[k] else obstacle).append(rect[k])
        me = (side * own)[:, None] * np.column_stack((-te[:, 1], te[:, 0]))
        for k in np.flatnonzero((side * own * psi < 0) & ~spike):
            n = int(S.fan_pieces(psi[k]))
            half = psi[k] / (2 * n)
            ang = (2 * np.arange(n) + 1) * half
            c, sn = np.cos(ang), np.sin(ang)
            chain = np.column_stack((c * me[k, 0] - sn * me[k, 1], sn * me[k, 0] + c * me[k, 1])) / np.cos(half)
            mh = (side * own[k]) * left[k]
            fan = np.vstack((V[k], V[k] + d * me[k], V[k] + d * chain, V[k] + d * mh))
            (free if to[k] else obstacle).append(fan)
    for k in np.flatnonzero(spike):
        ang = (np.arange(2 * S.CAP_PIECES) + 0.5) * (np.pi / S.CAP_PIECES)
        for side, d in ((1, d_in), (-1, d_out)):
            if d > 0:
                disc = V[k] + d * np.column_stack((np.cos(ang), np.sin(ang))) / np.cos(np.pi / (2 * S.CAP_PIECES))
                free.append(disc)
                obstacle.append(disc)
    return free, obstacle


def swept_cut(fuzzy, alpha: float, method: str = "safe") -> tuple[shapely.Geometry, shapely.Geometry]:
    """(inner, outer) of the α-cut as the page draws them: the crisp free space minus the free
    side's hulls (the thesis's band hulls, or the safe sweep's pieces), and plus the other side's
    (docs/viewer.md).

    Equal to ``fuzzy.alpha_cut(alpha, method)`` up to slivers: a proper polygon is its crisp
    polygon minus (IN) or plus (OUT) the region its edges swept (docs/fuzzy.md), and the safe
    cut is the crisp map minus (plus) its rectangles and fans (``safe_sweep``).
    """
    crisp = fuzzy.crisp_geometry
    if {"sweep": "thesis"}.get(method, method) == "safe":
        free, obstacle = safe_pieces(fuzzy, alpha)
        poly = lambda q: shapely.union_all(shapely.make_valid([shapely.Polygon(c) for c in q]))  # noqa: E731
        inner = polygonal(shapely.difference(crisp, poly(free))) if free else crisp
        outer = polygonal(shapely.union(crisp, poly(obstacle))) if obstacle else crisp
        return inner, outer
    free, obstacle = band_quads(fuzzy, alpha)
    hull = lambda q: shapely.union_all(shapely.convex_hull(shapely.multipoints(q)))  # noqa: E731
    inner = polygonal(shapely.difference(crisp, hull(free)))
    outer = polygonal(shapely.union(crisp, hull(obstacle)))
    return inner, outer


__all__ = ["DEFAULT_SLIDER_LEVELS", "PAGE_METHODS", "band_quads", "html_document", "payload", "read_path", "safe_pieces",
           "swept_cut", "write_html"]
