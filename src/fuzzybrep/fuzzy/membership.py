"""Sensor-uncertainty membership functions, their α-cut bounds, and the table that indexes them.

A membership function here is the fuzzy set swept along a crisp boundary: μ(x) of the signed
distance x from the crisp boundary, measured along the boundary's normal, with the crisp
boundary at x = r = 0 (thesis 4.2: "the description is centered along the crisp B-rep map").
x < 0 is IN (into the interior of the boundary's own ring: free space for the principal polygon,
the obstacle for a hole), x > 0 is OUT.

Every function must meet the three criteria of thesis 4.1.1, for its own TME:

1. μ(x) = 0 for x ≥ r + TME,
2. μ(x) = 0 for x ≤ r − TME,
3. μ(r) = 1,

and, so that each α-cut is one interval [r − d_in(α), r + d_out(α)] (thesis 2.1.2), μ may not
increase away from r. A function that fails is refused with MembershipFunctionError.

Families (thesis 2.1.1, 4.1.1):

- ``Triangular(tme)``, or ``Triangular(tme_in=..., tme_out=...)`` for an asymmetric function:
  the thesis's sensor-uncertainty function, support [−TME, +TME].
- ``A1(p)``: p(x − r) + 1 on [r − 1/p, r), p(r − x) + 1 on [r, r + 1/p]; a triangle of
  support ±1/p (the thesis prints the interval as "[(r−1)/p1, r)", a misprint).
- ``A2(p, tme, truncate=True)``: 1/(1 + p(x − r)²) and ``A3(p, tme, truncate=True)``:
  e^(−|p(x − r)|) are positive for every x, so as printed they fail criteria 1 and 2 and are
  refused. With ``truncate=True`` they are cut to 0 outside ±TME (μ jumps from A(±TME) to 0
  there); inside ±TME they keep the thesis's formula.
- ``A4(p)``: (1 + cos(pπ(x − r)))/2 on [r − 1/p, r + 1/p], 0 outside.

TME = |laser error| + |odometry error| (thesis 4.1.1): 15 mm + 184.13 mm = 199.13 mm.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import MembershipFunctionError

#: The thesis's sensor errors (mm): LMS200 systematic error, and the UMBmark odometry error.
THESIS_LASER_ERROR_MM = 15.0
THESIS_ODOMETRY_ERROR_MM = 184.13
#: TME of the thesis, in mm and in metres (the default for metric maps built from real logs).
THESIS_TME_MM = 199.13
DEFAULT_TME_M = 0.19913


def total_maximum_error(laser_error: float, odometry_error: float) -> float:
    """TME = |laser error| + |odometry error|, in the unit of the errors. Thesis 4.1.1."""
    for name, v in (("laser error", laser_error), ("odometry error", odometry_error)):
        if not math.isfinite(v):
            raise MembershipFunctionError(f"{name} must be a finite number, got {v!r}")
    return abs(float(laser_error)) + abs(float(odometry_error))


def _positive(name: str, v, family: str) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise MembershipFunctionError(f"{family}: {name} must be a number, got {v!r}") from None
    if not math.isfinite(f) or f <= 0:
        raise MembershipFunctionError(f"{family}: {name} must be a positive finite number, got {v!r}")
    return f


def _alpha(alpha) -> np.ndarray:
    a = np.asarray(alpha, dtype=np.float64)
    if np.any(~np.isfinite(a)) or np.any(a < 0) or np.any(a > 1):
        raise MembershipFunctionError(f"α must lie in [0, 1], got {alpha!r}")
    return a


class MembershipFunction:
    """Base of the sensor-uncertainty membership functions (thesis 2.1.1, 4.1.1).

    Subclasses define ``kind``, ``support_in`` and ``support_out`` (where μ reaches 0 on each
    side, both > 0), ``tme_in``/``tme_out`` (the TME the criteria are checked against),
    ``mu(x)`` and ``d_in(α)``/``d_out(α)``.
    """

    kind: str = ""
    support_in: float
    support_out: float
    tme_in: float
    tme_out: float

    def mu(self, x) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def d_in(self, alpha) -> np.ndarray:  # pragma: no cover - abstract
        """Distance IN from the crisp boundary to the α-cut's lower bound: r − d_in(α)."""
        raise NotImplementedError

    def d_out(self, alpha) -> np.ndarray:  # pragma: no cover - abstract
        """Distance OUT from the crisp boundary to the α-cut's upper bound: r + d_out(α)."""
        raise NotImplementedError

    def alpha_cut(self, alpha) -> tuple[np.ndarray, np.ndarray]:
        """The α-cut [r − d_in(α), r + d_out(α)] with r = 0, as (lower, upper). Thesis 2.1.2."""
        return -self.d_in(alpha), self.d_out(alpha)

    @property
    def symmetric(self) -> bool:
        return self.support_in == self.support_out and self.tme_in == self.tme_out

    def to_dict(self) -> dict:  # pragma: no cover - abstract
        raise NotImplementedError

    def parameters(self) -> str:
        """Table 4.2's parameter column: a = −TME; b = +TME; TME = ..."""
        return f"a = {-self.tme_in:g}; b = {self.tme_out:g}; TME = {max(self.tme_in, self.tme_out):g}"

    def formula(self) -> str:  # pragma: no cover - abstract
        raise NotImplementedError

    def check(self) -> None:
        """Raise MembershipFunctionError unless the criteria of thesis 4.1.1 hold.

        Checked numerically on the function itself, so that a family added later cannot skip it:
        criterion 3 at x = 0, criteria 1 and 2 at and beyond ±TME, and μ in [0, 1] and not
        increasing away from r on a fine grid (needed for α-cuts to be intervals, thesis 2.1.2).
        """
        name = self.formula()
        mu0 = float(self.mu(np.array([0.0]))[0])
        if not math.isclose(mu0, 1.0, abs_tol=1e-12):
            raise MembershipFunctionError(f"{name}: criterion 3 of thesis 4.1.1 fails: μ(r) = {mu0:g}, must be 1")
        far = np.array([1.0, 1.0 + 1e-9, 1.5, 10.0, 1e6])
        with np.errstate(over="ignore"):  # a TME near the largest float: far points at ±inf, still beyond
            far_out, far_in = far * self.tme_out, -far * self.tme_in
        out = self.mu(far_out)
        if np.any(out != 0):
            raise MembershipFunctionError(
                f"{name}: criterion 1 of thesis 4.1.1 fails: μ(r + TME) = {out[0]:.6g} with TME = {self.tme_out:g}, "
                f"must be 0 for x ≥ r + TME{self._never_zero_hint()}")
        inn = self.mu(far_in)
        if np.any(inn != 0):
            raise MembershipFunctionError(
                f"{name}: criterion 2 of thesis 4.1.1 fails: μ(r − TME) = {inn[0]:.6g} with TME = {self.tme_in:g}, "
                f"must be 0 for x ≤ r − TME{self._never_zero_hint()}")
        for side, tme in ((1.0, self.tme_out), (-1.0, self.tme_in)):
            x = side * np.linspace(0.0, tme, 2001)
            m = self.mu(x)
            if np.any(~np.isfinite(m)) or np.any(m < 0) or np.any(m > 1):
                raise MembershipFunctionError(f"{name}: μ must lie in [0, 1] (thesis 2.1.1)")
            if np.any(np.diff(m) > 1e-12):
                raise MembershipFunctionError(f"{name}: μ increases away from r, so its α-cuts are not intervals")

    def _never_zero_hint(self) -> str:
        return ""


@dataclass(frozen=True)
class Triangular(MembershipFunction):
    """The thesis's triangular sensor-uncertainty function (4.1.1, Table 4.2).

    μ = (x − a)/(r − a) on [a, r), (b − x)/(b − r) on [r, b], with a = r − TME_in, b = r + TME_out.
    Symmetric with ``Triangular(tme)``; asymmetric with ``Triangular(tme_in=..., tme_out=...)``.
    """

    tme_in: float
    tme_out: float | None = None
    kind = "triangular"

    def __init__(self, tme: float | None = None, *, tme_in: float | None = None, tme_out: float | None = None):
        if tme is not None and (tme_in is not None or tme_out is not None):
            raise MembershipFunctionError("triangular: give either tme, or tme_in and tme_out")
        if tme is not None:
            tme_in = tme_out = tme
        if tme_in is None or tme_out is None:
            raise MembershipFunctionError("triangular: needs tme (or both tme_in and tme_out)")
        object.__setattr__(self, "tme_in", _positive("TME (inner support)", tme_in, "triangular"))
        object.__setattr__(self, "tme_out", _positive("TME (outer support)", tme_out, "triangular"))
        self.check()

    @property
    def support_in(self) -> float:
        return self.tme_in

    @property
    def support_out(self) -> float:
        return self.tme_out

    def mu(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        m = np.where(x < 0, 1.0 + x / self.tme_in, 1.0 - x / self.tme_out)
        return np.clip(m, 0.0, 1.0)

    def d_in(self, alpha) -> np.ndarray:
        return (1.0 - _alpha(alpha)) * self.tme_in

    def d_out(self, alpha) -> np.ndarray:
        return (1.0 - _alpha(alpha)) * self.tme_out

    def to_dict(self) -> dict:
        if self.tme_in == self.tme_out:
            return {"type": "triangular", "tme": self.tme_in}
        return {"type": "triangular", "tme_in": self.tme_in, "tme_out": self.tme_out}

    def formula(self) -> str:
        if self.tme_in == self.tme_out:
            return f"triangular(TME={self.tme_in:g})"
        return f"triangular(TME_in={self.tme_in:g}, TME_out={self.tme_out:g})"

    def describe(self) -> str:
        return ("μ = (x − a)/(−a) for x ∈ [a, 0); μ = (b − x)/b for x ∈ [0, b]; 0 otherwise")


@dataclass(frozen=True)
class _Family(MembershipFunction):
    """A one-parameter family of thesis 2.1.1, symmetric about r, checked against its TME."""

    p: float
    tme: float
    truncate: bool = False
    kind = ""

    def __init__(self, p: float, tme: float | None = None, truncate: bool = False):
        object.__setattr__(self, "p", _positive("p", p, self.kind))
        natural = self._natural_support()
        if tme is None:
            if natural is None:
                raise MembershipFunctionError(
                    f"{self.kind}(p={self.p:g}) never reaches 0, so it needs a TME to be checked against "
                    f"(criteria 1 and 2 of thesis 4.1.1) and truncate=True to be cut to 0 beyond it")
            tme = natural
        object.__setattr__(self, "tme", _positive("TME", tme, self.kind))
        object.__setattr__(self, "truncate", bool(truncate))
        if truncate and natural is not None:
            raise MembershipFunctionError(f"{self.kind} reaches 0 at ±1/p by itself: truncate applies only to A2 and A3")
        self.check()

    def _natural_support(self) -> float | None:
        return None

    def _never_zero_hint(self) -> str:
        n = self._natural_support()
        return "" if n is None else f": its support ±1/p = ±{n:g} is wider than ±TME"

    @property
    def tme_in(self) -> float:  # type: ignore[override]
        return self.tme

    @property
    def tme_out(self) -> float:  # type: ignore[override]
        return self.tme

    @property
    def support_in(self) -> float:
        n = self._natural_support()
        return self.tme if n is None else min(n, self.tme)

    @property
    def support_out(self) -> float:
        return self.support_in

    def _shape(self, ax: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _inverse(self, alpha: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def mu(self, x) -> np.ndarray:
        ax = np.abs(np.asarray(x, dtype=np.float64))
        m = self._shape(ax)
        if self.truncate:
            m = np.where(ax >= self.tme, 0.0, m)
        return np.clip(m, 0.0, 1.0)

    def d_in(self, alpha) -> np.ndarray:
        a = _alpha(alpha)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.where(a > 0, self._inverse(np.where(a > 0, a, 1.0)), np.inf)
        return np.minimum(d, self.support_in)

    d_out = d_in

    def to_dict(self) -> dict:
        d = {"type": self.kind, "p": self.p, "tme": self.tme}
        if self.truncate:
            d["truncate"] = True
        return d

    def formula(self) -> str:
        t = ", truncated" if self.truncate else ""
        return f"{self.kind}(p={self.p:g}, TME={self.tme:g}{t})"


class A1(_Family):
    """A1(x) = p(x − r) + 1 on [r − 1/p, r), p(r − x) + 1 on [r, r + 1/p], else 0 (thesis 2.1.1)."""

    kind = "A1"

    def _natural_support(self) -> float:
        return 1.0 / self.p

    def _shape(self, ax):
        # exactly 0 from 1/p on: 1 − p·(1/p) rounds to 1e−16, which criterion 1 would refuse
        return np.where(ax >= 1.0 / self.p, 0.0, np.maximum(0.0, 1.0 - self.p * ax))

    def _inverse(self, a):
        return (1.0 - a) / self.p

    def describe(self) -> str:
        return "μ = 1 − p|x| for |x| ≤ 1/p; 0 otherwise"


class A2(_Family):
    """A2(x) = 1/(1 + p(x − r)²) (thesis 2.1.1); usable only truncated at ±TME."""

    kind = "A2"

    def _shape(self, ax):
        return 1.0 / (1.0 + self.p * ax * ax)

    def _inverse(self, a):
        # α → 0 gives an infinite distance, which the support then cuts to TME
        with np.errstate(divide="ignore", over="ignore"):
            return np.sqrt((1.0 / a - 1.0) / self.p)

    def _never_zero_hint(self) -> str:
        return (": A2 = 1/(1 + p(x − r)²) is positive for every x; pass truncate=True (CLI: ',truncate') "
                "to cut it to 0 outside ±TME")

    def describe(self) -> str:
        return "μ = 1/(1 + p x²) for |x| < TME; 0 otherwise (truncated)"


class A3(_Family):
    """A3(x) = e^(−|p(x − r)|) (thesis 2.1.1); usable only truncated at ±TME."""

    kind = "A3"

    def _shape(self, ax):
        return np.exp(-self.p * ax)

    def _inverse(self, a):
        return -np.log(a) / self.p

    def _never_zero_hint(self) -> str:
        return (": A3 = e^(−|p(x − r)|) is positive for every x; pass truncate=True (CLI: ',truncate') "
                "to cut it to 0 outside ±TME")

    def describe(self) -> str:
        return "μ = exp(−p|x|) for |x| < TME; 0 otherwise (truncated)"


class A4(_Family):
    """A4(x) = (1 + cos(pπ(x − r)))/2 on [r − 1/p, r + 1/p], else 0 (thesis 2.1.1)."""

    kind = "A4"

    def _natural_support(self) -> float:
        return 1.0 / self.p

    def _shape(self, ax):
        return np.where(ax < 1.0 / self.p, 0.5 * (1.0 + np.cos(self.p * np.pi * np.minimum(ax, 1.0 / self.p))), 0.0)

    def _inverse(self, a):
        return np.arccos(2.0 * a - 1.0) / (self.p * np.pi)

    def describe(self) -> str:
        return "μ = (1 + cos(pπx))/2 for |x| ≤ 1/p; 0 otherwise"


FAMILIES: dict[str, type] = {"triangular": Triangular, "A1": A1, "A2": A2, "A3": A3, "A4": A4}
_ALIASES = {"triangular": "triangular", "tri": "triangular", "triangle": "triangular",
            "a1": "A1", "a2": "A2", "a3": "A3", "a4": "A4"}


def from_dict(d: Mapping) -> MembershipFunction:
    """A membership function from its map-file dict (``to_dict``'s output; "index" is ignored)."""
    if not isinstance(d, Mapping):
        raise MembershipFunctionError(f"a membership function must be an object, got {type(d).__name__}")
    kind = _ALIASES.get(str(d.get("type", "")).lower())
    if kind is None:
        raise MembershipFunctionError(f"unknown membership function type {d.get('type')!r} "
                                      f"(known: {', '.join(FAMILIES)})")
    params = {k: v for k, v in d.items() if k not in ("type", "index")}
    for key, v in params.items():  # a map file's true or "0.2" was read as 1 or 0.2 without a word
        if key in ("p", "tme", "tme_in", "tme_out") and v is not None \
                and (isinstance(v, bool) or not isinstance(v, (int, float))):
            raise MembershipFunctionError(f"{kind}: {key} must be a number, got {v!r}")
        if key == "truncate" and not isinstance(v, bool):
            raise MembershipFunctionError(f"{kind}: truncate must be true or false, got {v!r}")
    try:
        if kind == "triangular":
            return Triangular(params.pop("tme", None), tme_in=params.pop("tme_in", None),
                              tme_out=params.pop("tme_out", None), **params)
        return FAMILIES[kind](**params)
    except TypeError as e:
        raise MembershipFunctionError(f"{kind}: bad parameters {sorted(params)}: {e}") from None


def parse_spec(spec: str, tme: float | None = None) -> MembershipFunction:
    """A membership function from a command-line spec: ``TYPE[:key=value,...,flag]``.

    Examples: ``triangular`` (support ±``tme``), ``triangular:tme=0.2``,
    ``triangular:in=0.1,out=0.3``, ``A1:p=6``, ``A4:p=6`` (support ±1/6: within the default TME), ``A2:p=10,truncate``. A missing
    ``tme`` (or ``in``/``out`` for the triangular function) is taken from ``tme``.
    """
    name, _, rest = spec.strip().partition(":")
    d: dict = {"type": name}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, value = item.partition("=")
        key = {"in": "tme_in", "out": "tme_out"}.get(key.strip().lower(), key.strip().lower())
        if not eq:
            if key != "truncate":
                raise MembershipFunctionError(f"membership function spec {spec!r}: {item!r} is not key=value")
            d["truncate"] = True
            continue
        if key == "truncate":
            d[key] = value.strip().lower() in ("1", "true", "yes")
            continue
        if key not in ("p", "tme", "tme_in", "tme_out"):
            raise MembershipFunctionError(f"membership function spec {spec!r}: unknown parameter {key!r}")
        try:
            d[key] = float(value)
        except ValueError:
            raise MembershipFunctionError(f"membership function spec {spec!r}: {key} = {value!r} is not a number") from None
    kind = _ALIASES.get(name.lower())
    if kind == "triangular" and tme is not None and not any(k in d for k in ("tme", "tme_in", "tme_out")):
        d["tme"] = tme
    elif kind == "triangular" and tme is not None and ("tme_in" in d) != ("tme_out" in d):
        d.setdefault("tme_in", tme)
        d.setdefault("tme_out", tme)
    elif kind in ("A2", "A3") and tme is not None:
        d.setdefault("tme", tme)
    elif kind in ("A1", "A4") and tme is not None and "tme" not in d:
        d["tme"] = tme
    return from_dict(d)


class MembershipTable:
    """Table 4.2: the membership functions of a map, indexed from 1 (the FM column of Table 4.1).

    ``d_in(fm, α)`` and ``d_out(fm, α)`` look up every vertex's function at once.
    """

    def __init__(self, functions: Mapping[int, MembershipFunction] | Iterable[MembershipFunction] | MembershipFunction):
        if isinstance(functions, MembershipFunction):
            functions = {1: functions}
        elif not isinstance(functions, Mapping):
            functions = {i + 1: f for i, f in enumerate(functions)}
        table: dict[int, MembershipFunction] = {}
        for k, f in functions.items():
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
                raise MembershipFunctionError(f"membership-function index must be an integer ≥ 1, got {k!r}")
            if not isinstance(f, MembershipFunction):
                raise MembershipFunctionError(f"membership function {k} is a {type(f).__name__}, not a membership function")
            table[int(k)] = f
        if not table:
            raise MembershipFunctionError("the membership-function table is empty")
        self._table = dict(sorted(table.items()))
        self._max = max(self._table)

    def __getitem__(self, index: int) -> MembershipFunction:
        try:
            return self._table[int(index)]
        except KeyError:
            raise MembershipFunctionError(f"no membership function with index {index} "
                                          f"(the table has {', '.join(map(str, self._table))})") from None

    def __contains__(self, index) -> bool:
        return int(index) in self._table

    def __len__(self) -> int:
        return len(self._table)

    def __iter__(self):
        return iter(self._table.items())

    @property
    def indices(self) -> list[int]:
        return list(self._table)

    def _column(self, fm: np.ndarray, values: Mapping[int, float]) -> np.ndarray:
        fm = np.asarray(fm, dtype=np.int64)
        bad = self.check_indices(fm)
        if bad is not None:
            raise MembershipFunctionError(f"FM index {int(fm.reshape(-1)[bad])} has no membership function in the table")
        # looked up by sorted index, not through a table as long as the largest index: a map file
        # whose Table 4.2 numbers a function 10**12 asked for terabytes
        keys = np.fromiter(values, dtype=np.int64, count=len(values))
        order = np.argsort(keys)
        vals = np.fromiter(values.values(), dtype=np.float64, count=len(values))[order]
        return vals[np.searchsorted(keys[order], fm)]

    def d_in(self, fm, alpha: float) -> np.ndarray:
        """Per vertex: its function's d_in(α)."""
        return self._column(fm, {k: float(f.d_in(alpha)) for k, f in self})

    def d_out(self, fm, alpha: float) -> np.ndarray:
        return self._column(fm, {k: float(f.d_out(alpha)) for k, f in self})

    def support_in(self, fm) -> np.ndarray:
        return self._column(fm, {k: f.support_in for k, f in self})

    def support_out(self, fm) -> np.ndarray:
        return self._column(fm, {k: f.support_out for k, f in self})

    def check_indices(self, fm: np.ndarray) -> int | None:
        """0-based position of the first FM index with no function, or None if all are present."""
        fm = np.asarray(fm)
        ok = np.isin(fm, np.fromiter(self._table, dtype=np.int64)).reshape(-1)
        return None if ok.all() else int(np.argmin(ok))

    def to_dicts(self) -> list[dict]:
        """The map-file form: a list of dicts with their "index" (mapfile.MapFile.membership_functions)."""
        return [{"index": k, **f.to_dict()} for k, f in self]

    @classmethod
    def from_dicts(cls, items: Iterable[Mapping]) -> "MembershipTable":
        table = {}
        for pos, d in enumerate(items):
            index = d.get("index", pos + 1) if isinstance(d, Mapping) else pos + 1
            if isinstance(index, bool) or not isinstance(index, int) or not 1 <= index < 2**31:
                # as FM indices are (mapfile._whole): a dict or a list here was a TypeError traceback
                shown = repr(index) if len(repr(index)) <= 40 else f"{repr(index)[:40]}..."
                raise MembershipFunctionError(f"membership function {pos + 1}: index {shown} is not a whole number "
                                              f"from 1 up")
            try:
                f = from_dict(d)
            except MembershipFunctionError as e:
                raise MembershipFunctionError(f"membership function {index}: {e}") from None
            if index in table:
                raise MembershipFunctionError(f"membership function index {index} appears twice")
            table[index] = f
        return cls(table)

    def rows(self) -> list[dict]:
        """Table 4.2 rows: index, type, parameters, supports, formula."""
        return [{"INDEX": k, "TYPE": f.kind, "PARAMETERS": f.parameters() + _extra(f),
                 "SUPPORT_IN": f.support_in, "SUPPORT_OUT": f.support_out, "FORMULA": f.describe()}
                for k, f in self]


def _extra(f: MembershipFunction) -> str:
    if isinstance(f, _Family):
        return f"; p = {f.p:g}" + ("; truncated at ±TME" if f.truncate else "")
    return ""
