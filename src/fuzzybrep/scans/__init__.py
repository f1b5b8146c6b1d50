"""Scans in: the Scan type, readers (CARMEN, CSV, ROS bags) and per-scan filters."""

from .scan import Scan, even_bearings

__all__ = ["Scan", "even_bearings"]
