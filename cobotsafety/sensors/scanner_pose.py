"""The laser scanner's pose in the robot base frame (paper 2, eq. 10, as a full 2D pose)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ScannerPose:
    """Scanner frame origin ``(x_m, y_m)`` and heading ``yaw_rad`` in the robot base frame.

    The paper's scanner is parallel to the base (yaw = 0), so eq. 10 is a translation
    ``x_t^b = x_t + [c1, c2]``; any mounting yaw is handled here as well.
    """

    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0

    def to_base(self, p_scanner_m: np.ndarray) -> np.ndarray:
        """Points (..., 2) in the scanner frame -> the robot base frame [m]."""
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        p = np.asarray(p_scanner_m, dtype=float)
        x, y = p[..., 0], p[..., 1]
        return np.stack([c * x - s * y + self.x_m, s * x + c * y + self.y_m], axis=-1)
