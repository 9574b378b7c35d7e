"""cobotsafety: anticipative sliding and human minimum distance for collaborative robots.

Public names (stable contracts):

* ``slide(v_desired, normals, bounds=None)``: the sliding projection (paper 1).
* ``capsule_distance(a0, a1, ra, b0, b1, rb)``: batched capsule-capsule distance (paper 2).
* ``LaserScan``, ``detect_legs(scan, max_range_m=1.4, background=None)``: the laser pipeline.

Heavy modules load on first use, so ``import cobotsafety`` stays cheap.
"""

from __future__ import annotations

import importlib
from typing import Any

from cobotsafety import compile_cache

compile_cache.configure()  # before any kernel is defined: a cache per version of the source

from cobotsafety.errors import CobotSafetyError, InfeasibleConstraintsError, RecordingError
from cobotsafety.projection import slide

__version__ = "0.1.0"

_LAZY = {
    "capsule_distance": "cobotsafety.geometry.capsule",
    "LaserScan": "cobotsafety.sensors.laser_scan",
    "detect_legs": "cobotsafety.sensors.legs",
}

__all__ = [
    "slide",
    "capsule_distance",
    "LaserScan",
    "detect_legs",
    "CobotSafetyError",
    "InfeasibleConstraintsError",
    "RecordingError",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'cobotsafety' has no attribute {name!r}")
