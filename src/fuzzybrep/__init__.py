"""fuzzybrep: fuzzy boundary-representation maps from 2-D laser scans.

Following "Incorporating Sensor Uncertainty in Robot Map Building using Fuzzy Boundary
Representation": scans become scan polygons (chapter 3), their union is the crisp B-rep map, and
a sensor-uncertainty membership function swept along every boundary makes it fuzzy (chapter 4).
"""

from .brep import FRONTIER, OBSTACLE, BRepMap, Region, Ring
from .errors import FuzzyBrepError, GeometryError, MapFileError, MembershipFunctionError, ScanFormatError, ScanValueError
from .scans.scan import Scan

__version__ = "0.1.0"

__all__ = [
    "BRepMap", "Region", "Ring", "OBSTACLE", "FRONTIER", "Scan",
    "FuzzyBrepError", "GeometryError", "MapFileError", "MembershipFunctionError", "ScanFormatError", "ScanValueError",
]
