"""The ground-truth human of a generated recording (``<name>_truth.npz`` beside it).

``TruthHuman.load(path)`` reads ``t_s`` (n,), ``p0_b_m``/``p1_b_m`` (n, k, 3), ``radius_m`` (k,)
(k = 5 per person); ``capsules_at(t_s)`` interpolates the end points linearly between the
samples (clamped at both ends); ``distance_m(robot_p0, robot_p1, robot_radius, t_s)`` is the
minimum distance [m] between the robot's capsules (c, 3), (c, 3), (c,) and the true human.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cobotsafety.geometry.capsule import capsule_distance


@dataclass(frozen=True)
class TruthHuman:
    t_s: np.ndarray
    p0_b_m: np.ndarray
    p1_b_m: np.ndarray
    radius_m: np.ndarray

    @classmethod
    def load(cls, path: str | Path) -> "TruthHuman":
        with np.load(path) as data:
            return cls(data["t_s"], data["p0_b_m"], data["p1_b_m"], data["radius_m"])

    @classmethod
    def from_dict(cls, truth: dict) -> "TruthHuman":
        return cls(np.asarray(truth["t_s"]), np.asarray(truth["p0_b_m"]), np.asarray(truth["p1_b_m"]),
                   np.asarray(truth["radius_m"]))

    def capsules_at(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """End points (k, 3), (k, 3) [m] at ``t_s`` (generator clock) [s]."""
        t = self.t_s
        i = int(np.clip(np.searchsorted(t, t_s) - 1, 0, len(t) - 2))
        w = float(np.clip((t_s - t[i]) / (t[i + 1] - t[i]), 0.0, 1.0))
        return ((1 - w) * self.p0_b_m[i] + w * self.p0_b_m[i + 1], (1 - w) * self.p1_b_m[i] + w * self.p1_b_m[i + 1])

    def distance_m(self, robot_p0, robot_p1, robot_radius, t_s: float) -> float:
        """Minimum distance [m] between the robot's capsules and the true human at ``t_s``."""
        if len(robot_radius) == 0:
            return np.inf
        p0, p1 = self.capsules_at(t_s)
        d, _, _ = capsule_distance(np.asarray(robot_p0)[:, None], np.asarray(robot_p1)[:, None],
                                   np.asarray(robot_radius)[:, None], p0[None], p1[None], self.radius_m[None])
        return float(d.min())
