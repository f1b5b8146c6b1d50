"""The compact binary encoding of a fuzzy B-rep map: what a small robot stores.

Only what cannot be derived is kept: the crisp vertex tables, the kind of every edge, the FM
index of every vertex (only when it does not simply follow the edge kinds) and the membership
function table (Table 4.2). The fuzzy vertex table (VIN, VOUT, T, U, V, W) and the edge tables
follow from these in O(n) (thesis 4.1.2, 4.2), so storing them would store the same thing twice.

Coordinates are quantised to ``quantum`` (1 mm for maps in metres: 0.5% of the thesis's TME)
and written as zigzag LEB128 varints of the step from the previous vertex, so an edge of a few
centimetres to two metres takes 2 to 4 bytes. Decoding gives every vertex back within
quantum / 2; a map with detail finer than the quantum (which rounding would make cross itself)
is snap-rounded instead, so that it always reads back as a valid map (``snap_rounded``).

Layout (little-endian)::

    b"FBRC" version:u8 unit_len:u8 unit:utf8 quantum:f64 fm_mode:u8
    n_mf:varint { json_len:varint json:utf8 }*          # Table 4.2, each function's to_dict()
    n_regions:varint { n_holes:varint }*
    for every ring, in BRepMap.rings order:
        n_vertices:varint
        2·n zigzag varints: dx, dy in quanta (the first from the previous ring's first vertex)
        ceil(n / 8) bytes: edge kinds, one bit per edge
        fm_mode 1 only: n bytes of FM index
"""

from __future__ import annotations

import json
import os

import numpy as np
import shapely

from ..brep import BRepMap, Region, Ring, frontier_fm, validate_map
from ..errors import FormatLimitError, GeometryError, MapFileError
from .files import check_map, loads_json, write_atomic

MAGIC = b"FBRC"
VERSION = 1
#: default coordinate step per unit
QUANTUM = {"m": 0.001, "cm": 0.1, "mm": 1.0}

FM_FROM_KINDS, FM_EXPLICIT = 0, 1
#: coordinates are held as whole quanta up to ±2**53: exact in a float64 (and in JavaScript, for
#: the viewer); beyond, int64 steps overflowed without a word (a square [0, 1e16]² read back as
#: [-9.22e15, 0]², mirrored)
MAX_QUANTA = 2**53
#: a varint of more than 10 bytes (or of 10 whose last byte is above 1) holds more than 64 bits
MAX_VARINT_BYTES = 10
#: the unit's length in the header (one byte) and an explicit FM index (one byte per vertex)
MAX_UNIT_BYTES = MAX_FM = 255


# -- varints ---------------------------------------------------------------------------------


def encode_varints(values: np.ndarray) -> bytes:
    """Zigzag LEB128 of signed 64-bit integers, vectorised."""
    v = np.asarray(values, dtype=np.int64)
    z = ((v << 1) ^ (v >> 63)).astype(np.uint64)  # zigzag: small magnitudes, small codes
    nbytes = np.ones(len(z), np.int64)
    t = z >> np.uint64(7)
    while t.any():
        nbytes += t > 0
        t >>= np.uint64(7)
    out = np.empty(int(nbytes.sum()), np.uint8)
    pos = np.cumsum(nbytes) - nbytes
    for k in range(int(nbytes.max(initial=0))):
        live = nbytes > k
        chunk = (z[live] >> np.uint64(7 * k)) & np.uint64(0x7F)
        more = (nbytes[live] > k + 1).astype(np.uint64) << np.uint64(7)
        out[pos[live] + k] = (chunk | more).astype(np.uint8)
    return out.tobytes()


def decode_varints(buf: bytes | np.ndarray, count: int, offset: int = 0,
                   ends: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """``count`` zigzag varints starting at ``offset``; returns the values and the next offset.

    ``ends``: the positions of every byte of ``buf`` without the continuation bit, found once for
    the whole buffer (``_Reader``); without it they are found here, which costs the rest of the
    buffer on every call (a file of 300,000 empty rings took 150 s). ValueError for data that
    ends first or a varint longer than ``MAX_VARINT_BYTES``."""
    b = np.frombuffer(buf, np.uint8) if isinstance(buf, (bytes, bytearray, memoryview)) else np.asarray(buf)
    if ends is None:
        ends = offset + np.flatnonzero((b[offset:] & 0x80) == 0)
    first = int(np.searchsorted(ends, offset))
    if len(ends) - first < count:
        raise ValueError("truncated varint data")
    e = ends[first:first + count]
    if not count:
        return np.zeros(0, np.int64), offset
    starts = np.r_[offset, e[:-1] + 1]
    lengths = e - starts + 1
    long = (lengths > MAX_VARINT_BYTES) | ((lengths == MAX_VARINT_BYTES) & (b[e] > 1))
    if long.any():
        raise ValueError(f"the varint at byte {int(starts[np.argmax(long)])} holds more than 64 bits")
    z = np.zeros(count, np.uint64)
    for k in range(int(lengths.max())):
        live = lengths > k
        z[live] |= (b[starts[live] + k].astype(np.uint64) & np.uint64(0x7F)) << np.uint64(7 * k)
    v = (z >> np.uint64(1)).astype(np.int64) ^ -(z & np.uint64(1)).astype(np.int64)
    return v, int(e[-1]) + 1


# -- the map ---------------------------------------------------------------------------------


def fm_from_kinds(kinds: np.ndarray) -> np.ndarray:
    """The FM column ``fuzzify`` gives with one function and a frontier function (``frontier_fm``
    with k = 2): 2 where an edge at the vertex is a frontier, else 1."""
    return frontier_fm(kinds, 1, 2).astype(np.int32)


def encode(crisp: BRepMap, membership_functions: list[dict], quantum: float | None = None) -> bytes:
    """The compact encoding of a map (see the module doc)."""
    q, fm_mode = _quantum(crisp, quantum), _fm_mode(crisp, membership_functions)
    _check_limits(crisp, membership_functions, q, fm_mode)
    return _encode(_stored(crisp, membership_functions, q, fm_mode), membership_functions, q, fm_mode)


def stored_map(crisp: BRepMap, membership_functions: list[dict], quantum: float | None = None) -> BRepMap:
    """The map as the compact encoding stores it, before rounding: ``crisp`` itself, or where
    rounding to the quantum would make it invalid, ``crisp`` snap-rounded (``snap_rounded``)."""
    q, fm_mode = _quantum(crisp, quantum), _fm_mode(crisp, membership_functions)
    _check_limits(crisp, membership_functions, q, fm_mode)
    return _stored(crisp, membership_functions, q, fm_mode)


def to_quanta(values, q: float, what) -> np.ndarray:
    """``rint(values / q)`` as int64, or FormatLimitError when one is beyond ±``MAX_QUANTA``
    (where whole quanta stop being exact, and soon after wrap round int64). ``what(i)``
    names the row i of the first one too far (its ring and vertex)."""
    v = np.asarray(values, dtype=np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        scaled = v / q
    far = ~(np.abs(scaled) <= MAX_QUANTA)
    if far.any():
        i = int(np.argmax(far.reshape(len(v), -1).any(axis=1))) if v.ndim > 1 else int(np.argmax(far))
        raise FormatLimitError(f"{what(i)}: coordinate {np.asarray(v[i]).tolist()} is beyond ±{MAX_QUANTA * q:.6g}, "
                               f"the most this format holds in steps of {q:g}")
    return np.rint(scaled).astype(np.int64)


def ring_vertex_namer(crisp: BRepMap):
    """``what`` for ``to_quanta`` over every vertex of ``crisp`` stacked in ``rings`` order."""
    sizes = np.cumsum([len(r) for r in crisp.rings])
    names = crisp.ring_names()

    def what(i: int) -> str:
        k = int(np.searchsorted(sizes, i, side="right"))
        return f"{names[k]}, vertex {i - (int(sizes[k - 1]) if k else 0) + 1}"

    return what


def _check_limits(crisp: BRepMap, membership_functions: list[dict], q: float, fm_mode: int) -> None:
    """FormatLimitError, before anything is encoded, for what the layout cannot hold: a unit of more
    than 255 bytes, an FM index above 255, a coordinate beyond ±MAX_QUANTA quanta."""
    unit = crisp.unit.encode("utf-8")
    if len(unit) > MAX_UNIT_BYTES:
        raise FormatLimitError(f"the unit is {len(unit)} bytes long; the compact map holds at most {MAX_UNIT_BYTES}")
    if fm_mode == FM_EXPLICIT:
        top = max(int(r.fm.max(initial=1)) for r in crisp.rings)
        if top > MAX_FM:
            raise FormatLimitError(f"FM index {top} does not fit the compact map (at most {MAX_FM})")
    to_quanta(np.vstack([r.vertices for r in crisp.rings]), q, ring_vertex_namer(crisp))


def _stored(crisp: BRepMap, membership_functions: list[dict], q: float, fm_mode: int) -> BRepMap:
    try:
        validate_map(quantised(crisp, q))
    except GeometryError:
        try:
            validate_map(crisp)
        except GeometryError:
            return crisp  # invalid as given: the reader names the ring and vertex
        # Features finer than the quantum (a vertex within q/2 of another edge, a spike back along
        # its own edge 1e-15 away, as GEOS leaves them on real maps) cross or
        # collapse when rounded, and the file could not be read back. Snap rounding keeps the
        # map valid on the grid of the quantum. FM from the kinds with fewer than two functions
        # is FM 1 throughout (``_fm_mode``), as ``decode`` reads it
        return snap_rounded(crisp, q, fm_mode, uniform=len(membership_functions) < 2)
    return crisp


def _quantum(crisp: BRepMap, quantum: float | None) -> float:
    q = quantum if quantum is not None else QUANTUM.get(crisp.unit, 1e-3)
    if not q > 0:
        raise ValueError(f"quantum must be positive, got {q}")
    return q


def _fm_mode(crisp: BRepMap, membership_functions: list[dict]) -> int:
    """FM from the kinds where it follows from them (or is 1 throughout), else explicit."""
    rings = crisp.rings
    derived = all(np.array_equal(r.fm, fm_from_kinds(r.kinds)) for r in rings) and len(membership_functions) == 2
    uniform = all(np.all(r.fm == 1) for r in rings) and len(membership_functions) <= 1
    return FM_FROM_KINDS if derived or uniform else FM_EXPLICIT


def quantised(crisp: BRepMap, q: float) -> BRepMap:
    """The map as ``decode`` gives it back: every vertex rounded to the grid of ``q``, exactly
    (integer steps summed, then times q), without encoding it."""
    return crisp.with_rings([Ring(np.round(r.vertices / q).astype(np.int64) * q, r.kinds, r.fm) for r in crisp.rings])


def snap_rounded(crisp: BRepMap, q: float, fm_mode: int = FM_EXPLICIT, uniform: bool = False) -> BRepMap:
    """``crisp`` snap-rounded by GEOS to the grid of ``q`` (valid, every vertex on the grid, the
    boundary moved by at most about q/2), each edge with the kind of the crisp edge nearest its
    middle and each vertex with the FM of the nearest crisp vertex (or as the kinds give it)."""
    snapped = BRepMap.from_shapely(shapely.set_precision(crisp.to_shapely(), q), crisp.unit)
    a, b = _edges(crisp.rings)
    kinds = np.concatenate([r.kinds for r in crisp.rings])
    fm = np.concatenate([r.fm for r in crisp.rings])
    v, w = _edges(snapped.rings)
    _, e = shapely.STRtree(shapely.linestrings(np.stack((a, b), axis=1))).query_nearest(
        shapely.points((v + w) / 2), all_matches=False)
    if fm_mode == FM_EXPLICIT:
        _, n = shapely.STRtree(shapely.points(a)).query_nearest(shapely.points(v), all_matches=False)
    at = np.cumsum([len(r) for r in snapped.rings])[:-1]
    rings = []
    fms = np.split(fm[n], at) if fm_mode == FM_EXPLICIT else [None] * len(snapped.rings)
    for r, k, f in zip(snapped.rings, np.split(kinds[e], at), fms):
        if f is None:
            f = np.ones(len(r), np.int32) if uniform else fm_from_kinds(k)
        rings.append(Ring(r.vertices, k, f))
    return snapped.with_rings(rings)


def _edges(rings) -> tuple[np.ndarray, np.ndarray]:
    """Every edge of the rings: (its first vertices, its second vertices), ring after ring."""
    v = np.vstack([r.vertices for r in rings])
    end = np.cumsum([len(r) for r in rings])
    after = np.arange(1, len(v) + 1)
    after[end - 1] = end - np.array([len(r) for r in rings])
    return v, v[after]


def _encode(crisp: BRepMap, membership_functions: list[dict], q: float, fm_mode: int) -> bytes:
    rings = crisp.rings
    unit = crisp.unit.encode()
    parts = [MAGIC, bytes([VERSION, len(unit)]), unit, np.float64(q).tobytes(), bytes([fm_mode])]
    parts.append(encode_varints([len(membership_functions)]))
    for mf in membership_functions:
        js = json.dumps(mf, separators=(",", ":")).encode()
        parts += [encode_varints([len(js)]), js]
    parts.append(encode_varints([len(crisp.regions)] + [len(reg.holes) for reg in crisp.regions]))
    prev = np.zeros(2, np.int64)
    for r in rings:
        v = np.round(r.vertices / q).astype(np.int64)
        d = np.diff(np.vstack((prev, v)), axis=0)
        prev = v[0]
        parts += [encode_varints([len(r)]), encode_varints(d.ravel()), np.packbits(r.kinds.astype(bool)).tobytes()]
        if fm_mode == FM_EXPLICIT:
            parts.append(r.fm.astype(np.uint8).tobytes())
    return b"".join(parts)


class _Reader:
    """``data`` read front to back; running short says what was being read and where (a file cut
    short would otherwise fail on a slice that silently comes back shorter, or an odd NumPy error)."""

    def __init__(self, data: bytes):
        self.data, self.o = data, 0
        self.ends = np.flatnonzero((np.frombuffer(data, np.uint8) & 0x80) == 0)  # once: decoding stays linear

    @property
    def left(self) -> int:
        return len(self.data) - self.o

    def short(self, what: str) -> ValueError:
        return ValueError(f"truncated: the data ends at byte {len(self.data)}, in {what}")

    def bytes(self, n: int, what: str) -> bytes:
        if self.o + n > len(self.data):
            raise self.short(what)
        self.o += n
        return self.data[self.o - n : self.o]

    def one(self, what: str) -> int:
        """One varint, in plain Python: NumPy's overhead for a single count was most of the time
        spent on a map of many small rings."""
        data, o, z, shift = self.data, self.o, 0, 0
        while True:
            if o >= len(data):
                raise self.short(what)
            byte = data[o]
            z |= (byte & 0x7F) << shift
            o += 1
            if byte < 0x80:
                break
            shift += 7
            if shift >= 7 * MAX_VARINT_BYTES:
                break
        if byte >= 0x80 or z >= 2**64:
            raise ValueError(f"{what}: the varint at byte {self.o} holds more than 64 bits")
        self.o = o
        return (z >> 1) ^ -(z & 1)

    def varints(self, count: int, what: str) -> np.ndarray:
        if count == 1:
            return np.array([self.one(what)], np.int64)
        try:
            v, self.o = decode_varints(self.data, count, self.o, self.ends)
        except ValueError as e:
            raise (self.short(what) if str(e).startswith("truncated") else ValueError(f"{what}: {e}")) from None
        return v

    def counts(self, count: int, what: str, each: int = 1) -> np.ndarray:
        """``count`` counts of things that take at least ``each`` byte(s) each in what follows: a
        count larger than the bytes left cannot be right (and summed, 2**62 holes wrapped to 0)."""
        v = self.varints(count, what)
        if (v < 0).any():
            raise ValueError(f"{what}: negative count {int(v.min())}")
        if count and int(v.max()) * each > self.left:
            raise self.short(f"{what} (a count of {int(v.max())} needs more bytes than the {self.left} left)")
        return v


def decode(data: bytes) -> tuple[BRepMap, list[dict]]:
    """(crisp map, membership-function dicts) from ``encode``'s bytes."""
    if data[:4] != MAGIC:
        raise ValueError("empty" if not data else "truncated in the magic" if MAGIC.startswith(data)
                         else "not a compact fuzzybrep map (bad magic)")
    f = _Reader(data)
    f.bytes(4, "the magic")
    version, n_unit = f.bytes(2, "the header")
    if version != VERSION:
        raise ValueError(f"compact map version {version} is not supported (this is version {VERSION})")
    unit = f.bytes(n_unit, "the unit").decode()
    q = float(np.frombuffer(f.bytes(8, "the quantum"), np.float64)[0])
    if not (np.isfinite(q) and q > 0):  # a zero, negative or NaN step would collapse or mirror the map
        raise ValueError(f"quantum {q!r} is not a positive number")
    (fm_mode,) = f.bytes(1, "the FM mode")
    if fm_mode not in (FM_FROM_KINDS, FM_EXPLICIT):
        raise ValueError(f"FM mode {fm_mode} is neither {FM_FROM_KINDS} (from the edge kinds) nor {FM_EXPLICIT} (explicit)")
    (n_mf,) = f.counts(1, "the membership-function count")
    mfs = []
    for k in range(int(n_mf)):
        (n,) = f.counts(1, f"membership function {k + 1}")
        mf = loads_json(f.bytes(int(n), f"membership function {k + 1}"))
        if not isinstance(mf, dict):
            raise ValueError(f"membership function {k + 1} is not a JSON object")
        mfs.append(mf)
    (n_regions,) = f.counts(1, "the region count")
    holes = f.counts(int(n_regions), "the hole counts")
    n_rings = int(n_regions) + sum(int(h) for h in holes)  # Python ints: no wrap
    if n_rings > f.left:  # every ring takes a byte at least
        raise f.short(f"the rings ({n_rings} declared, {f.left} bytes left)")
    prev = np.zeros(2, np.int64)
    rings = []
    for k in range(n_rings):
        what = f"ring {k + 1}"
        (n,) = f.counts(1, what, each=2)
        n = int(n)
        d = f.varints(2 * n, what).reshape(n, 2)
        # each step is an int64 (MAX_VARINT_BYTES); their sums must stay within MAX_QUANTA,
        # which a float sum shows without the int64 sum's silent wrap
        far = ~(np.abs(np.cumsum(d, axis=0, dtype=np.float64) + prev) <= MAX_QUANTA).all(axis=1)
        if far.any():
            raise ValueError(f"{what}, vertex {int(np.argmax(far)) + 1}: coordinate beyond ±{MAX_QUANTA} quanta")
        v = np.cumsum(d, axis=0) + prev
        prev = v[0] if n else prev
        kinds = np.unpackbits(np.frombuffer(f.bytes((n + 7) // 8, what), np.uint8))[:n]
        if fm_mode == FM_EXPLICIT:
            fm = np.frombuffer(f.bytes(n, what), np.uint8).astype(np.int32)
        else:
            fm = fm_from_kinds(kinds) if len(mfs) == 2 else np.ones(n, np.int32)
        rings.append(Ring(v * q, kinds, fm))
    if f.o != len(data):
        raise ValueError(f"{len(data) - f.o} unexpected bytes after the last ring")
    it = iter(rings)
    regions = tuple(Region(next(it), tuple(next(it) for _ in range(int(h)))) for h in holes)
    return BRepMap(regions, unit), mfs


def write_compact(path: str | os.PathLike, crisp: BRepMap, membership_functions: list[dict], quantum: float | None = None) -> int:
    """Write the compact map atomically; MapFileError naming the file, before anything is written,
    for a map the layout cannot hold (``_check_limits``)."""
    try:
        data = encode(crisp, membership_functions, quantum)
    except FormatLimitError as e:
        raise MapFileError(path, f"cannot write a compact map: {e}") from None
    return write_atomic(path, data)


def read_compact(path: str | os.PathLike) -> tuple[BRepMap, list[dict]]:
    try:
        data = open(path, "rb").read()
    except OSError as e:
        raise MapFileError(path, f"cannot read: {e.strerror or e}") from None
    return compact_from_bytes(data, path)


def compact_from_bytes(data: bytes, path: str | os.PathLike) -> tuple[BRepMap, list[dict]]:
    """``read_compact`` of a file's bytes already read; MapFileError names ``path``."""
    try:
        crisp, mfs = decode(data)
    except (ValueError, IndexError, json.JSONDecodeError, UnicodeDecodeError) as e:
        raise MapFileError(path, f"not a valid compact map: {e}") from None
    check_map(crisp, path)
    return crisp, mfs
