"""A pick-and-place nominal path (the robot program taught off-line), time-parameterised."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class NominalPath:
    """A polyline of waypoints [m] followed at ``speed_m_s``. The target waits when the
    end-effector lags more than ``max_lag_m`` behind it (the task is kept, never skipped)."""

    waypoints_m: np.ndarray
    speed_m_s: float = 0.15
    max_lag_m: float = 0.05
    s_m: float = 0.0

    def __post_init__(self):
        self.waypoints_m = np.asarray(self.waypoints_m, dtype=float)
        segments = np.diff(self.waypoints_m, axis=0)
        self._lengths = np.linalg.norm(segments, axis=1)
        self._cumulative = np.concatenate([[0.0], np.cumsum(self._lengths)])

    @property
    def length_m(self) -> float:
        return float(self._cumulative[-1])

    @property
    def finished(self) -> bool:
        return self.s_m >= self.length_m

    def point(self, s_m: float) -> np.ndarray:
        s_m = min(max(s_m, 0.0), self.length_m)
        i = min(int(np.searchsorted(self._cumulative, s_m, side="right")) - 1, len(self._lengths) - 1)
        t = (s_m - self._cumulative[i]) / max(self._lengths[i], 1e-12)
        return self.waypoints_m[i] + t * (self.waypoints_m[i + 1] - self.waypoints_m[i])

    def advance(self, p_ee_m: np.ndarray, dt_s: float) -> np.ndarray:
        """Move the target along the path unless the end-effector lags; return the target."""
        if np.linalg.norm(self.point(self.s_m) - p_ee_m) <= self.max_lag_m:
            self.s_m = min(self.s_m + self.speed_m_s * dt_s, self.length_m)
        return self.point(self.s_m)


def pick_and_place(cycles: int = 2) -> NominalPath:
    """Pick at (0.45, -0.30, 0.20) m, place at (0.45, 0.30, 0.20) m, lifting to 0.40 m, and back,
    ``cycles`` times, in front of the table edge the human walks up to."""
    home = [0.45, 0.0, 0.40]
    cycle = [[0.45, -0.30, 0.40], [0.45, -0.30, 0.20], [0.45, -0.30, 0.40],
             [0.45, 0.30, 0.40], [0.45, 0.30, 0.20], [0.45, 0.30, 0.40]]
    return NominalPath(np.array([home] + cycle * cycles + [home]))
