"""The ground-truth human of a generated recording (``<name>_truth.npz`` beside it).

``TruthHuman.load(path)`` reads ``t_s`` (n,), ``p0_b_m``/``p1_b_m`` (n, k, 3), ``radius_m`` (k,)
(k = 5 per person); ``capsules_at(t_s)`` interpolates the end points linearly between the
samples (clamped at both ends); ``distance_m(robot_p0, robot_p1, robot_radius, t_s)`` is the
minimum distance [m] between the robot's capsules (c, 3), (c, 3), (c,) and the true human.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np

from cobotsafety.geometry.capsule import _capsule_kernel


def truth_path(recording_path: Path) -> Path:
    """The ground truth beside a generated recording: ``<name>_truth.npz``."""
    name = Path(recording_path).name.split(".")[0]
    return Path(recording_path).with_name(f"{name}_truth.npz")


@dataclass(frozen=True)
class TruthHuman:
    t_s: np.ndarray
    p0_b_m: np.ndarray
    p1_b_m: np.ndarray
    radius_m: np.ndarray
    _memo: dict = field(default_factory=dict, compare=False, repr=False)
    """``capsules_at`` by time: every controller run on the same person asks for the same times."""

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
        found = self._memo.get(t_s)
        if found is None:
            found = self._memo[t_s] = self._interpolate(t_s)
        return found

    def _interpolate(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        t = self.t_s
        i = min(max(int(t.searchsorted(t_s)) - 1, 0), len(t) - 2)  # (np.clip on scalars costs microseconds)
        w = min(max(float((t_s - t[i]) / (t[i + 1] - t[i])), 0.0), 1.0)
        return ((1 - w) * self.p0_b_m[i] + w * self.p0_b_m[i + 1], (1 - w) * self.p1_b_m[i] + w * self.p1_b_m[i + 1])

    def distance_m(self, robot_p0, robot_p1, robot_radius, t_s: float) -> float:
        """Minimum distance [m] between the robot's capsules and the true human at ``t_s``."""
        if len(robot_radius) == 0:
            return np.inf
        p0, p1 = self.capsules_at(t_s)
        return min_capsule_distance_m(robot_p0, robot_p1, robot_radius, p0, p1, self.radius_m)


def min_capsule_distance_m(a0, a1, ra, b0, b1, rb) -> float:
    """The smallest distance [m] between any capsule of A ((c, 3), (c, 3), (c,)) and any of B
    ((k, 3), (k, 3), (k,)), ``capsule_distance``'s kernel on the c x k pairs in one compiled
    call (the broadcasting wrapper costs more than the distances at these sizes). inf when
    either is empty."""
    if len(ra) == 0 or len(rb) == 0:
        return np.inf
    f = [np.ascontiguousarray(x, dtype=np.float64) for x in (a0, a1, ra, b0, b1, rb)]
    return float(_min_pairs(*f))


@numba.njit(cache=True)
def _min_pairs(a0, a1, ra, b0, b1, rb):  # pragma: no cover - compiled
    c, k = ra.shape[0], rb.shape[0]
    p0, p1, r0 = np.empty((c * k, 3)), np.empty((c * k, 3)), np.empty(c * k)
    q0, q1, r1 = np.empty((c * k, 3)), np.empty((c * k, 3)), np.empty(c * k)
    for i in range(c):
        for j in range(k):
            row = i * k + j
            p0[row], p1[row], r0[row] = a0[i], a1[i], ra[i]
            q0[row], q1[row], r1[row] = b0[j], b1[j], rb[j]
    d, pa, pb = np.empty(c * k), np.empty((c * k, 3)), np.empty((c * k, 3))
    _capsule_kernel(p0, p1, r0, q0, q1, r1, d, pa, pb)
    return d.min()
