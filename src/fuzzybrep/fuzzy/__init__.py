"""Chapter 4: the fuzzy B-rep map. Membership functions (``membership``), the thesis's sweep
(``sweep``: normal vertices, parametric lines, proper polygons; ``sweep_cut``, ``sweep_membership``),
the exact fuzzification by the Extension principle (``exact``), the fuzzy tables (``tables``), the
map class and ``fuzzify`` (``map``), Table 5.3 (``memory``) and the sweep's error (``accuracy``).

``from fuzzybrep.fuzzy import fuzzify, FuzzyBRepMap, AlphaCut`` works; the modules load on first use.
"""

from __future__ import annotations

import importlib

_LAZY = {"AlphaCut": "map", "FuzzyBRepMap": "map", "fuzzify": "map", "default_tme": "map"}
__all__ = list(_LAZY)


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
