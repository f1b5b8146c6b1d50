"""fuzzybrep: fuzzy boundary-representation maps from 2-D laser scans.

Following "Incorporating Sensor Uncertainty in Robot Map Building using Fuzzy Boundary
Representation": scans become scan polygons (chapter 3), their union is the crisp B-rep map, and
a sensor-uncertainty membership function swept along every boundary makes it fuzzy (chapter 4).

The package reads like that pipeline:

    scans/     Scan, the readers (CARMEN, CSV, ROS bags), beam filters, consolidation
    mapping/   evidence, lines, scan polygons, union -> the crisp B-rep map (build_map); grid mapper
    fuzzy/     membership functions, the sweep, the exact cut, the fuzzy map (fuzzify)
    formats/   map file, compact map, GeoJSON, ROS map_server, SVG, exports
    use/       planning, evaluation, localisation (sensor model, alignment, tracking, MCL)
    sim/       worlds, simulator, ground truth, UMBmark, drifting odometry, the demo
    commands/  one module per CLI command;  viewer/  the HTML viewer

The short form of the public API: ``from fuzzybrep import read_scans, build_map, fuzzify,
FuzzyBRepMap``. Names load on first use, so that ``fuzzybrep --help`` starts quickly.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_LAZY = {
    "read_scans": "scans.read", "Scan": "scans.scan",
    "build_map": "mapping.build", "BuildConfig": "mapping.build",
    "fuzzify": "fuzzy.map", "FuzzyBRepMap": "fuzzy.map", "AlphaCut": "fuzzy.map",
    "localise": "use.localise", "Track": "use.localise", "LocaliseConfig": "use.localise",
    "DriftModel": "sim.drift", "drift_scans": "sim.drift",
    "BRepMap": "brep", "Region": "brep", "Ring": "brep", "OBSTACLE": "brep", "FRONTIER": "brep",
    **{e: "errors" for e in ("FuzzyBrepError", "GeometryError", "MapFileError", "MembershipFunctionError",
                             "ScanFormatError", "ScanValueError")},
}
__all__ = list(_LAZY)


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + __all__)
