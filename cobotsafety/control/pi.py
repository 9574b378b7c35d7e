"""A vector PI controller with anti-windup (paper 2, eq. 15; Astrom & Hagglund)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass
class AntiWindupPI:
    """``u = Kp e + Ki integral(e)``, its norm saturated at ``limit``; conditional integration
    stops the integral from growing while the output is saturated (no windup), so it recovers
    at once when the error falls."""

    kp_per_s: float = 2.0
    ki_per_s2: float = 0.5
    limit: float = 0.3
    integral: np.ndarray = field(default_factory=lambda: np.zeros(3))
    saturated: bool = False

    def reset(self) -> None:
        self.integral = np.zeros_like(self.integral)
        self.saturated = False

    def update(self, error: np.ndarray, dt_s: float) -> np.ndarray:
        error = np.asarray(error, dtype=float)
        if self.integral.shape != error.shape:
            self.integral = np.zeros_like(error)
        candidate = self.integral + error * dt_s
        output = self.kp_per_s * error + self.ki_per_s2 * candidate
        norm = math.sqrt(output.dot(output))  # (np.linalg.norm's own arithmetic, without its checks)
        self.saturated = norm > self.limit
        if self.saturated:
            # Conditional integration: keep the integral, saturate the output.
            output = self.kp_per_s * error + self.ki_per_s2 * self.integral
            norm = math.sqrt(output.dot(output))
            if norm > self.limit:
                output = output * self.limit / norm
        else:
            self.integral = candidate
        return output
