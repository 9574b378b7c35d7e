"""The human's own velocity, estimated from successive capsule frames."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class HumanVelocityEstimator:
    """Finite differences of the capsule end points, low-passed with ``time_constant_s``.

    A change of model (5 capsules -> 1, or a person appearing) restarts the estimate; the
    degraded human model is already conservative (its radius grows), so no velocity is invented.
    """

    time_constant_s: float = 0.1
    max_speed_m_s: float = 2.0
    """Estimates are clipped to this [m/s] (ISO 13855's hand speed): a jump of the tracked torso
    (legs swapped, a leg hidden) is not a human moving at 20 m/s."""
    _t: float | None = field(default=None, repr=False)
    _p0: np.ndarray | None = field(default=None, repr=False)
    _p1: np.ndarray | None = field(default=None, repr=False)
    v0: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    v1: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def update(self, t_s: float, p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return the end-point velocities (k, 3) [m/s] after the frame at ``t_s``."""
        p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
        if self._p0 is None or self._p0.shape != p0.shape or self._t is None or t_s <= self._t:
            self.v0, self.v1 = np.zeros_like(p0), np.zeros_like(p1)
        else:
            dt = t_s - self._t
            alpha = dt / (self.time_constant_s + dt)
            self.v0 = (1 - alpha) * self.v0 + alpha * (p0 - self._p0) / dt
            self.v1 = (1 - alpha) * self.v1 + alpha * (p1 - self._p1) / dt
            for v in (self.v0, self.v1):
                speed = np.linalg.norm(v, axis=1, keepdims=True)
                np.multiply(v, np.minimum(1.0, self.max_speed_m_s / np.maximum(speed, 1e-12)), out=v)
        self._t, self._p0, self._p1 = t_s, p0.copy(), p1.copy()
        return self.v0, self.v1
