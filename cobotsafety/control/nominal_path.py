"""The robot program taught off-line (paper 2's nominal path), time-parameterised.

``pick_and_place()``: the panda's two-cycle path in front of the table edge (the ``reach-over``
stress case). ``paper_pick_and_place()``: paper 2's experiment 1 task (sized for the iiwa): wait at home
until the co-worker has put the box at the pick pose and gone, pick it, carry it to the place
pose, return home. ``hold(p)``: experiment 2, the robot keeps its home until ``until_s``.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field

import numpy as np


@dataclass
class NominalPath:
    """A polyline of waypoints [m] followed at ``speed_m_s``. The target waits when the
    end-effector lags more than ``max_lag_m`` behind it (the task is kept, never skipped).

    ``start_after_s``: the target stays at the first waypoint until then [s] (path clock: the
    sum of the ``dt_s`` given to ``advance``). ``dwell_s``: waypoint index -> pause there [s]
    (grasp, release)."""

    waypoints_m: np.ndarray
    speed_m_s: float = 0.15
    max_lag_m: float = 0.05
    s_m: float = 0.0
    start_after_s: float = 0.0
    dwell_s: dict[int, float] = field(default_factory=dict)
    t_s: float = 0.0

    def __post_init__(self):
        self.waypoints_m = np.asarray(self.waypoints_m, dtype=float)
        segments = np.diff(self.waypoints_m, axis=0)
        self._lengths = np.linalg.norm(segments, axis=1)
        self._cumulative = np.concatenate([[0.0], np.cumsum(self._lengths)])
        self._cumulative_list = self._cumulative.tolist()  # searched once per step (bisect: no array call)
        self._segments = segments  # (the differences ``point`` interpolates along)
        self._dwell_left = {i: float(d) for i, d in self.dwell_s.items()}

    @property
    def length_m(self) -> float:
        return float(self._cumulative[-1])

    @property
    def finished(self) -> bool:
        return self.s_m >= self.length_m and self.t_s >= self.start_after_s

    def point(self, s_m: float) -> np.ndarray:
        s_m = min(max(s_m, 0.0), self._cumulative_list[-1])
        i = min(bisect_right(self._cumulative_list, s_m) - 1, len(self._lengths) - 1)
        t = (s_m - self._cumulative_list[i]) / max(float(self._lengths[i]), 1e-12)
        return self.waypoints_m[i] + t * self._segments[i]

    def advance(self, p_ee_m: np.ndarray, dt_s: float) -> np.ndarray:
        """Move the target along the path unless the end-effector lags; return the target."""
        self.t_s += dt_s
        if self.t_s < self.start_after_s:
            return self.point(self.s_m)
        lag = self.point(self.s_m) - p_ee_m
        if math.sqrt(lag.dot(lag)) <= self.max_lag_m:  # (np.linalg.norm's own arithmetic, without its checks)
            for i, left in self._dwell_left.items():
                at = self._cumulative[i]
                if left > 0 and self.s_m >= at - 1e-12:
                    if self.s_m <= at + 1e-12:  # waiting at this waypoint
                        self._dwell_left[i] = left - dt_s
                        return self.point(self.s_m)
            step = self.speed_m_s * dt_s
            ahead = [self._cumulative[i] for i, left in self._dwell_left.items()
                     if left > 0 and self.s_m < self._cumulative[i] <= self.s_m + step]
            self.s_m = min(min(ahead) if ahead else self.s_m + step, self.length_m)
        return self.point(self.s_m)


def pick_and_place(cycles: int = 2) -> NominalPath:
    """Pick at (0.45, -0.30, 0.20) m, place at (0.45, 0.30, 0.20) m, lifting to 0.40 m, and back,
    ``cycles`` times, in front of the table edge the human walks up to."""
    home = [0.45, 0.0, 0.40]
    cycle = [[0.45, -0.30, 0.40], [0.45, -0.30, 0.20], [0.45, -0.30, 0.40],
             [0.45, 0.30, 0.40], [0.45, 0.30, 0.20], [0.45, 0.30, 0.40]]
    return NominalPath(np.array([home] + cycle * cycles + [home]))


#: Paper 2 experiment 1 on the iiwa [m]: the pick pose where the co-worker puts the box (0.63 m
#: from the base) and the place pose (0.57 m), 0.15 m above the table; 0.40 m to carry.
IIWA_PICK_M = (0.55, -0.30, 0.15)
IIWA_PLACE_M = (0.38, 0.42, 0.15)
IIWA_CARRY_HEIGHT_M = 0.40


def paper_pick_and_place(home_m, start_after_s: float = 10.5, speed_m_s: float = 0.12,
                        grasp_s: float = 1.0) -> NominalPath:
    """Home (``home_m``, the end-effector at the home pose) -> above the pick -> pick (grasp
    ``grasp_s``) -> carry above the place -> place (release) -> home; starts at ``start_after_s``."""
    pick, place = np.array(IIWA_PICK_M), np.array(IIWA_PLACE_M)
    lift = np.array([0.0, 0.0, IIWA_CARRY_HEIGHT_M - pick[2]])
    waypoints = [home_m, pick + lift, pick, pick + lift, place + lift, place, place + lift, home_m]
    return NominalPath(np.array(waypoints, dtype=float), speed_m_s=speed_m_s, start_after_s=start_after_s,
                       dwell_s={2: grasp_s, 5: grasp_s})


def hold(home_m, until_s: float) -> NominalPath:
    """Keep ``home_m`` [m] until ``until_s`` [s] (experiment 2: the robot waits at home)."""
    return NominalPath(np.array([home_m, home_m], dtype=float), start_after_s=until_s)
