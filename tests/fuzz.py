"""A bounded mutation fuzzer over every format fuzzybrep reads (issue 19).

Each case is a format and a seed: a valid input of that format (``seed_files``) is damaged by one
to three mutations drawn from the seed (bits flipped, bytes cut, copied or inserted, the file cut
short, a number or a JSON value replaced by a hostile one: NaN, 1e400, -1e308, a 400-digit
integer, a lone surrogate, markup, a control character, deep nesting; a bag's messages made
wrong in kind or content), and a command is run on it in this process. A case fails on:

- a traceback: any exception but the CLI's own exit (``SystemExit`` from argparse is a usage error);
- an error that is not one line, or a warning printed before it;
- a run past ``TIME_LIMIT`` seconds;
- an output that does not read back (map files, compact maps, GeoJSON, SVG as XML, the viewer's
  page and its payload, ROS YAML + PGM, CSV tables);
- a partial file: a temporary file left beside an output, or an output written by a run that failed.

``tests/test_fuzz.py`` runs a few hundred cases (``FUZZYBREP_FUZZ_CASES``) under hypothesis; this
file run as a script runs many and goes on past failures, printing each as one JSON line:

    python tests/fuzz.py --cases 20000 [--first 0] [--format carmen] > findings.jsonl

A case is replayed with ``--first SEED --cases 1 --format FMT`` (``case(fmt, seed)`` in Python).
"""

from __future__ import annotations

import contextlib
import csv
import gzip
import io
import json
import math
import os
import random
import re
import signal
import sys
import tempfile
import time
import traceback
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

from fuzzybrep import cli  # noqa: E402

FORMATS = ("carmen", "carmen-gz", "csv", "csv-gz", "ros1", "ros2-sqlite3", "ros2-mcap", "bag-messages",
           "map-json", "compact", "geojson")
TIME_LIMIT = 30.0  # seconds per command: the seeds take well under one

HOSTILE_TOKENS = ["nan", "NaN", "inf", "-inf", "-1e308", "1e308", "1e400", "-0", "0", "1e-320", "9" * 400, "",
                  " ", "\x00", "-1", "2147483648", "18446744073709551616", "1e16", "0x10", "1,5", "\u00e9",
                  "<script>alert(1)</script>", "{{DATA}}", "'\n", "\x01", "\u2028", "]]>", "\\ud800"]
HOSTILE_JSON = [float("nan"), float("inf"), -1e308, 1e308, 1e16, -1, 0, 256, 2**62, 10**400, True, None, "", "\ud800",
                "<!--<script>", "x</script><img src=x onerror=alert(1)>", "a\x01b", "a\nb", "{{DATA}}", [], {}, [[]],
                [[[0, 0]]], "m" * 300, 1e-320]


# ---------------------------------------------------------------------------- seeds


@dataclass
class Seeds:
    """Valid inputs of every format, made once per process in ``root``."""

    root: Path
    files: dict = field(default_factory=dict)  # format -> (bytes or folder path, file name)


def _scans():
    from test_rosbag import room_scans

    return room_scans(6)


def seed_files(root: Path) -> Seeds:
    from test_rosbag import bag_of

    from fuzzybrep.scans.csvscans import write_csv

    s = Seeds(root)
    scans = _scans()
    lines = []
    for k, sc in enumerate(scans):
        x, y, h = sc.pose
        r = " ".join(f"{v:.3f}" for v in sc.ranges)
        lines.append(f"ODOM {x} {y} {h} 0 0 0 {sc.timestamp} host {sc.timestamp}\n")
        lines.append(f"FLASER {len(sc.ranges)} {r} {x} {y} {h} {x} {y} {h} {sc.timestamp} host {sc.timestamp}\n")
    carmen = ("# CARMEN log\n" + "".join(lines)).encode()
    s.files["carmen"] = (carmen, "run.log")
    s.files["carmen-gz"] = (gzip.compress(carmen, mtime=0), "run.log.gz")
    write_csv(root / "scans.csv", scans)
    text = (root / "scans.csv").read_bytes()
    s.files["csv"] = (text, "scans.csv")
    s.files["csv-gz"] = (gzip.compress(text, mtime=0), "scans.csv.gz")
    bag_of(root / "run.bag", scans, ros1=True)
    s.files["ros1"] = ((root / "run.bag").read_bytes(), "run.bag")
    for storage, ext in (("sqlite3", "db3"), ("mcap", "mcap")):
        folder = root / f"bag-{storage}"
        bag_of(folder, scans, ros1=False, storage=storage)
        f = next(folder.glob(f"*.{ext}"))
        s.files[f"ros2-{storage}"] = (f.read_bytes(), f"run.{ext}")
    (root / "run.log").write_bytes(carmen)
    with _quiet():
        assert cli.main(["build", str(root / "run.log"), "--out", str(root / "map.json"), "--quiet"]) == 0
        assert cli.main(["export", str(root / "map.json"), "--compact", str(root / "map.fbrc"),
                         "--geojson", str(root / "map.geojson")]) == 0
    s.files["map-json"] = ((root / "map.json").read_bytes(), "map.json")
    s.files["compact"] = ((root / "map.fbrc").read_bytes(), "map.fbrc")
    plan = {"type": "FeatureCollection", "unit": "m", "features": [
        {"type": "Feature", "properties": {"role": "free"},
         "geometry": {"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 6], [0, 6], [0, 0]],
                                                         [[2, 2], [2, 3], [3, 3], [3, 2], [2, 2]]]}},
        {"type": "Feature", "properties": {"role": "obstacle"},
         "geometry": {"type": "Polygon", "coordinates": [[[6, 2], [7, 2], [7, 3], [6, 2]]]}},
        {"type": "Feature", "properties": {"role": "route"},
         "geometry": {"type": "LineString", "coordinates": [[1, 1], [9, 5]]}}]}
    s.files["geojson"] = [(json.dumps(plan).encode(), "plan.geojson"),
                          ((root / "map.geojson").read_bytes(), "cuts.geojson")]
    return s


# ---------------------------------------------------------------------------- mutations


_NUMBER = re.compile(rb"-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?")


def mutate_bytes(rng: random.Random, data: bytes) -> bytes:
    """One byte-level or token-level mutation."""
    n = len(data)
    op = rng.randrange(9)
    if n == 0:
        return rng.choice(HOSTILE_TOKENS).encode("utf-8", "surrogatepass")
    if op == 0:  # flip a few bits
        b = bytearray(data)
        for _ in range(rng.randint(1, 8)):
            b[rng.randrange(n)] ^= 1 << rng.randrange(8)
        return bytes(b)
    if op == 1:  # cut a slice out
        i = rng.randrange(n)
        return data[:i] + data[i + rng.randint(1, max(1, n // rng.choice((2, 10, 100, 1000)))):]
    if op == 2:  # copy a slice elsewhere (duplicated lines, messages, records)
        i, j = sorted(rng.randrange(n) for _ in range(2))
        k = rng.randrange(n)
        return data[:k] + data[i:j + 1] * rng.choice((1, 1, 2, 50)) + data[k:]
    if op == 3:  # cut short
        return data[:rng.randrange(n)]
    if op == 4:  # insert a hostile token
        k = rng.randrange(n + 1)
        return data[:k] + rng.choice(HOSTILE_TOKENS).encode("utf-8", "surrogatepass") + data[k:]
    if op in (5, 6):  # replace numbers by hostile ones
        nums = list(_NUMBER.finditer(data))
        if not nums:
            return data[: n // 2]
        out, last = [], 0
        for m in sorted(rng.sample(nums, min(len(nums), rng.choice((1, 1, 3, 20)))), key=lambda m: m.start()):
            out += [data[last:m.start()], rng.choice(HOSTILE_TOKENS).encode("utf-8", "surrogatepass")]
            last = m.end()
        return b"".join(out) + data[last:]
    if op == 7:  # a line swapped, dropped or repeated
        lines = data.split(b"\n")
        i = rng.randrange(len(lines))
        choice = rng.randrange(3)
        if choice == 0:
            j = rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
        elif choice == 1:
            del lines[i]
        else:
            lines[i:i] = [lines[i]] * rng.choice((1, 2, 100))
        return b"\n".join(lines)
    k = rng.randrange(n + 1)  # random bytes
    return data[:k] + bytes(rng.randrange(256) for _ in range(rng.randint(1, 16))) + data[k:]


def mutate_json(rng: random.Random, data: bytes) -> bytes:
    """A value somewhere in a JSON document replaced by a hostile one (or deep nesting)."""
    try:
        doc = json.loads(data)
    except (ValueError, RecursionError):  # damaged or nested deep by an earlier mutation
        return mutate_bytes(rng, data)
    nodes = []  # (container, key)
    stack = [doc]
    while stack:
        o = stack.pop()
        items = o.items() if isinstance(o, dict) else enumerate(o) if isinstance(o, list) else ()
        for k, v in items:
            nodes.append((o, k))
            if isinstance(v, (dict, list)) and len(nodes) < 20000:
                stack.append(v)
    if not nodes:
        return mutate_bytes(rng, data)
    for _ in range(rng.choice((1, 1, 2, 5))):
        o, k = rng.choice(nodes)
        if isinstance(o, list) and k >= len(o):  # an earlier mutation shortened the list
            continue
        r = rng.random()
        if r < 0.1:
            o[k] = "__DEEP__" if rng.random() < 0.5 else [o[k]] * 3
        elif r < 0.2 and isinstance(o[k], list) and o[k]:
            o[k] = o[k] + o[k][: rng.randint(1, len(o[k]))]  # lengths that disagree
        elif r < 0.3 and isinstance(o[k], list) and o[k]:
            del o[k][rng.randrange(len(o[k]))]
        else:
            o[k] = rng.choice(HOSTILE_JSON)
    try:
        text = json.dumps(doc).replace('"__DEEP__"', "[" * 5000 + "]" * 5000, 1)
        return text.encode("utf-8", "surrogatepass")
    except (ValueError, RecursionError):
        return data


def bag_messages(rng: random.Random, root: Path) -> Path:
    """A bag whose messages are wrong in content or kind: NaN, ±inf and negative ranges, empty
    scans, zero or NaN angle increments, tf loops, a scan topic of odometry messages, a zero
    quaternion, scans before any pose, many tiny messages."""
    from test_rosbag import ANGLE_INC, ANGLE_MIN, LASER, ODOM, Bag

    ros1 = rng.random() < 0.5
    path = root / ("hostile.bag" if ros1 else "hostile")
    b = Bag(path, ros1=ros1, storage=rng.choice(("sqlite3", "mcap")))
    n = rng.choice((1, 3, 8, 2000))
    kinds = rng.sample(["nan", "inf", "negative", "empty", "increment", "loop", "wrongtype", "quaternion", "late",
                        "huge", "frames", "stamp"], rng.randint(1, 3))
    base = np.full(181, 3.0)
    if "loop" in kinds:
        b.tf(0.0, "odom", "base_link", 0, 0, 0)
        b.tf(0.0, "base_link", "odom", 0, 0, 0)
    for k in range(n):
        t = 1.0 + 0.1 * k
        if "late" not in kinds or k > n // 2:
            if "quaternion" in kinds and k == 0:
                b.odom(t, 0.0, 0.0, 0.0, q=(0.0, 0.0, 0.0, 0.0))
            else:
                b.odom(t, 0.01 * k if "huge" not in kinds else 1e300 * k, 0.0, 0.0)
        if "loop" in kinds:
            b.tf(t, "base_link", "laser", 0.1, 0, 0)
            b.tf(t, "laser", "base_link", -0.1, 0, 0)
        r = base.copy()
        if not len(r):
            b.scan(t, r)
            continue
        if "nan" in kinds:
            r[rng.randrange(181)] = math.nan
        if "inf" in kinds:
            r[rng.randrange(181)] = rng.choice((math.inf, -math.inf))
        if "negative" in kinds and k == n - 1:
            r[rng.randrange(181)] = -1.0
        if "empty" in kinds and k % 2 == 0:
            r = r[:0]
        inc = ANGLE_INC
        if "increment" in kinds:
            inc = rng.choice((0.0, math.nan, -ANGLE_INC, 1e-30, 10.0))
        frame = "laser" if "frames" not in kinds else rng.choice(("", "laser", "/laser", "x" * 300))
        stamp = None if "stamp" not in kinds else rng.choice((0.0, -1.0, 1e9, t))
        if "wrongtype" in kinds and k == 0:
            b.odom(t, 0, 0, 0, topic="/scan2")
            b.raw(t, "/scan3", LASER, b"\x00\x01")  # a LaserScan cut short
        b.scan(t, r, angle_min=ANGLE_MIN, inc=inc, stamp=stamp)
        if n > 100 and k > 3:  # many tiny messages: the rest are empty scans
            base = base[:0]
    b.close()
    _ = ODOM
    return path


# ---------------------------------------------------------------------------- commands and checks


@dataclass
class Outcome:
    fmt: str
    seed: int
    argv: list
    status: int | None = None
    seconds: float = 0.0
    problems: list = field(default_factory=list)
    stderr: str = ""


class _Timeout(BaseException):
    """Raised in the command by the timer: BaseException, so no except of ours catches it."""


@contextlib.contextmanager
def _quiet():
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        yield


def _command(rng: random.Random, fmt: str, inp: Path, out: Path) -> list[str]:
    i, o = str(inp), str(out)
    if fmt in ("carmen", "carmen-gz", "csv", "csv-gz", "ros1", "ros2-sqlite3", "ros2-mcap", "bag-messages"):
        argv = rng.choice([["build", i, "--out", f"{o}/m.json", "--quiet"],
                           ["build", i, "--out", f"{o}/m.json", "--quiet", "--skip-bad"],
                           ["grid", i, "--out", f"{o}/g", "--quiet", "--resolution", "0.1"]])
        return argv
    if fmt == "geojson":
        return rng.choice([["fuzzify", i, "--tme", "0.1", "--out", f"{o}/f.json"],
                           ["fuzzify", i, "--tme", "0.1", "--out", f"{o}/f.json", "--frontier-mf", "triangular"],
                           ["plan", i, "--tme", "0.1", "--start", "1", "1", "--goal", "8", "5"]])
    exports = [a for a in (["--compact", f"{o}/c.fbrc"], ["--svg", f"{o}/s.svg"], ["--geojson", f"{o}/g.geojson"],
                           ["--ros", f"{o}/r"]) if rng.random() < 0.5] or [["--svg", f"{o}/s.svg"]]
    return rng.choice([
        ["tables", i], ["tables", i, "--csv", f"{o}/t"],
        ["export", i, *[x for a in exports for x in a], "--resolution", "0.25"],
        ["view", i, "--html", f"{o}/v.html"],
        ["alpha-cut", i, "--alpha", rng.choice(("0", "0.5", "1")), "--out", f"{o}/a.geojson"],
        ["fuzzify", i, "--tme", "0.1", "--out", f"{o}/f.json"],
        ["membership", i, "--points", str(out.parent / "points.csv")],
        ["memory", i, "--cell", "0.5"],
    ])


def _read_back(path: Path) -> None:
    """Raise if an output does not read back as what it claims to be."""
    from fuzzybrep.formats.compact import read_compact
    from fuzzybrep.formats.geojson import read_geojson
    from fuzzybrep.formats.mapfile import read_map
    from fuzzybrep.formats.rosmap import read_ros_map

    name = path.name
    if name.endswith(".json"):
        read_map(path)
    elif name.endswith(".fbrc"):
        read_compact(path)
    elif name.endswith(".geojson"):
        doc = json.loads(path.read_text(encoding="utf-8"))
        if any(f.get("properties", {}).get("role") == "crisp" for f in doc.get("features", [])):
            read_geojson(path)
    elif name.endswith(".svg"):
        ET.parse(path)
    elif name.endswith(".yaml"):
        read_ros_map(path)
    elif name.endswith(".html"):
        page = path.read_text(encoding="utf-8")
        if page.count("<script") != 2 or page.count("</script>") != 2:
            raise AssertionError(f"{name}: {page.count('<script')} script elements (the viewer has 2)")
        m = re.search(r'<script type="application/json" id="fuzzybrep-data">(.*?)</script>', page, re.S)
        if not m:
            raise AssertionError(f"{name}: no payload")
        json.loads(m.group(1))
    elif name.endswith(".csv"):
        list(csv.reader(io.StringIO(path.read_text(encoding="utf-8"))))


def run(argv: list[str], out: Path, fmt: str = "", seed: int = -1, time_limit: float = TIME_LIMIT) -> Outcome:
    """Run one command in this process and check what it did."""
    res = Outcome(fmt, seed, argv)
    before = set(out.rglob("*")) if out.exists() else set()
    err, std = io.StringIO(), io.StringIO()

    def alarm(signum, frame):
        raise _Timeout()

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, time_limit)
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings(record=True) as caught, contextlib.redirect_stdout(std), \
                contextlib.redirect_stderr(err):
            warnings.simplefilter("always")
            try:
                res.status = cli.main(argv)
            except SystemExit as e:  # argparse: a usage error
                res.status = e.code if isinstance(e.code, int) else 2
    except _Timeout:
        res.problems.append(f"still running after {time_limit:g} s")
        caught = []
    except BaseException as e:  # noqa: BLE001 - any traceback is what the fuzzer is for
        res.problems.append("traceback: " + "".join(traceback.format_exception_only(type(e), e)).strip()[:500]
                            + " at " + _where(e))
        caught = []
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
        res.seconds = time.perf_counter() - t0
    res.stderr = err.getvalue()
    if res.seconds > time_limit and not res.problems:
        res.problems.append(f"took {res.seconds:.1f} s (limit {time_limit:g} s)")
    for w in caught:
        res.problems.append(f"warning: {w.category.__name__}: {str(w.message)[:200]} ({Path(w.filename).name}:{w.lineno})")
    if res.status not in (0, 2, None):
        res.problems.append(f"exit status {res.status}")
    if res.status == 2 and res.stderr.count("\n") != 1:
        res.problems.append(f"error is not one line: {res.stderr[:300]!r}")
    after = set(out.rglob("*")) if out.exists() else set()
    new = sorted(after - before)
    temps = [p for p in after if p.name.endswith(".tmp")]
    if temps:
        res.problems.append(f"temporary files left: {[p.name for p in temps]}")
    if res.status == 2 and [p for p in new if p.is_file()]:
        res.problems.append(f"a failed run left outputs: {[p.name for p in new if p.is_file()]}")
    if res.status == 0:
        for p in new:
            if p.is_file():
                try:
                    _read_back(p)
                except Exception as e:  # noqa: BLE001
                    res.problems.append(f"output {p.name} does not read back: {type(e).__name__}: {str(e)[:200]}")
    return res


def _where(e: BaseException) -> str:
    tb = traceback.extract_tb(e.__traceback__)
    ours = [f for f in tb if "fuzzybrep" in f.filename] or tb
    f = ours[-1] if ours else None
    return f"{Path(f.filename).name}:{f.lineno} ({f.name})" if f else "?"


_SEEDS: dict = {}


def seeds() -> Seeds:
    if "s" not in _SEEDS:
        root = Path(tempfile.mkdtemp(prefix="fuzzybrep-fuzz-seeds-"))
        _SEEDS["s"] = seed_files(root)
    return _SEEDS["s"]


def case(fmt: str, seed: int, time_limit: float = TIME_LIMIT) -> Outcome:
    """Make the damaged input of (format, seed), run its command, check it."""
    rng = random.Random(f"{fmt}:{seed}")
    s = seeds()
    with tempfile.TemporaryDirectory(prefix="fuzzybrep-fuzz-") as tmp:
        tmp = Path(tmp)
        out = tmp / "out"
        out.mkdir()
        (tmp / "points.csv").write_text("x,y\n1,1\n2,2\n")
        if fmt == "bag-messages":
            inp = bag_messages(rng, tmp)
        else:
            choices = s.files[fmt]
            data, name = rng.choice(choices) if isinstance(choices, list) else choices
            json_like = name.endswith((".json", ".geojson"))
            for _ in range(rng.choice((1, 1, 1, 2, 3))):
                data = mutate_json(rng, data) if json_like and rng.random() < 0.6 else mutate_bytes(rng, data)
            if fmt in ("carmen-gz", "csv-gz") and rng.random() < 0.5:  # damage the text, not the stream
                data = gzip.compress(mutate_bytes(rng, gzip.decompress(s.files[fmt][0])), mtime=0)
            if fmt.startswith("ros2"):
                folder = tmp / "bag"
                src = s.root / f"bag-{fmt[5:]}"
                folder.mkdir()
                (folder / "metadata.yaml").write_bytes((src / "metadata.yaml").read_bytes())
                stored = next(p for p in src.iterdir() if p.suffix in (".db3", ".mcap"))
                (folder / stored.name).write_bytes(data)
                inp = folder if rng.random() < 0.5 else folder / stored.name
            else:
                inp = tmp / name
                inp.write_bytes(data)
        argv = _command(rng, fmt, inp, out)
        return run(argv, out, fmt, seed, time_limit)


def main(argv: list[str] | None = None) -> int:
    import argparse

    p = argparse.ArgumentParser(description="run the fuzzer; findings as JSON lines on stdout")
    p.add_argument("--cases", type=int, default=1000)
    p.add_argument("--first", type=int, default=0, help="first seed")
    p.add_argument("--format", choices=FORMATS, action="append", help="only these formats (repeat)")
    p.add_argument("--time-limit", type=float, default=TIME_LIMIT)
    a = p.parse_args(argv)
    fmts = a.format or list(FORMATS)
    failed, t0 = 0, time.time()
    for k in range(a.cases):
        seed = a.first + k
        fmt = fmts[seed % len(fmts)]
        try:
            res = case(fmt, seed, a.time_limit)
        except Exception as e:  # noqa: BLE001 - the fuzzer's own fault in making an input: say so, go on
            res = Outcome(fmt, seed, [], problems=[f"fuzzer error making the input: {type(e).__name__}: {e}"])
        if res.problems:
            failed += 1
            print(json.dumps({"format": fmt, "seed": seed, "argv": [Path(x).name if "/" in x else x for x in res.argv],
                              "status": res.status, "seconds": round(res.seconds, 2), "problems": res.problems,
                              "stderr": res.stderr[-300:]}), flush=True)
        if (k + 1) % 500 == 0:
            print(f"# {k + 1} cases, {failed} failed, {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    print(f"# done: {a.cases} cases, {failed} failed, {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
