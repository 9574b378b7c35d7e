"""``LaserScan``: one 2D laser scan with ROS's field names (sensor_msgs/LaserScan)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LaserScan:
    """One scan. Beam i points at ``angle_min + i * angle_increment`` [rad] in the scanner frame.

    ``ranges`` [m], shape (n,), any beam count and resolution. Readings of 0, inf, NaN, below
    ``range_min`` or beyond ``range_max`` mean "no return" (never an obstacle, never a leg).
    """

    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: np.ndarray
    stamp_s: float = 0.0

    def __post_init__(self):
        ranges = np.asarray(self.ranges, dtype=float)
        if ranges.ndim != 1 or ranges.size < 2:
            raise ValueError(f"ranges must have shape (n,) with n >= 2, got {ranges.shape}")
        for name in ("angle_min", "angle_increment", "range_min", "range_max"):
            if not np.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)}")
        if self.angle_increment == 0.0:
            raise ValueError("angle_increment must not be zero")
        if not 0.0 <= self.range_min < self.range_max:
            raise ValueError(f"need 0 <= range_min < range_max, got {self.range_min}, {self.range_max}")
        if ranges is self.ranges:
            ranges = ranges.copy()  # the scan owns its ranges: read-only, so ``valid`` stays true
        ranges.flags.writeable = False
        object.__setattr__(self, "ranges", ranges)
        with np.errstate(invalid="ignore"):
            valid = np.isfinite(ranges) & (ranges > 0.0) & (ranges >= self.range_min) & (ranges <= self.range_max)
        valid.flags.writeable = False
        object.__setattr__(self, "_valid", valid)

    @property
    def angles(self) -> np.ndarray:
        """Shape (n,), beam angles [rad]."""
        return self.angle_min + self.angle_increment * np.arange(self.ranges.size)

    @property
    def valid(self) -> np.ndarray:
        """Shape (n,), True where the beam returned a usable range (computed once, read-only)."""
        return self._valid

    def points(self) -> np.ndarray:
        """Shape (k, 2), the valid returns in the scanner frame [m]."""
        ok = self.valid
        a, r = self.angles[ok], self.ranges[ok]
        return np.column_stack([r * np.cos(a), r * np.sin(a)])
