"""``ConstantVelocityKalman``: a batch of points, each a constant-velocity Kalman filter.

Model per point and per axis (axes are independent and share one 2x2 covariance), with the
state ``x = (p [m], v [m/s])``::

    x_k+1 = F x_k + w,   F = [[1, dt], [0, 1]],
    Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]     (white-noise acceleration, q in m^2/s^3)
    z_k = p_k + n,       R = sigma^2           (a position measurement, sigma in m)

Used for the tracked people (torso position and velocity) and for the human's capsule end
points (the human-velocity estimate of the human-aware filter): the velocity comes from a
model of motion, not from finite differences of noisy positions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class KalmanNoise:
    """Noise settings (units in the names)."""

    accel_density_m2_s3: float = 2.0
    """Spectral density of the white-noise acceleration [m^2/s^3]: a walking person's speed
    changes by ~1 m/s within ~0.5 s."""
    measurement_std_m: float = 0.03
    """Standard deviation of one position measurement [m]."""
    initial_speed_std_m_s: float = 1.0
    """Velocity uncertainty of a new point [m/s] (a person may already be walking)."""

    def __post_init__(self):
        for name in ("accel_density_m2_s3", "measurement_std_m", "initial_speed_std_m_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"KalmanNoise.{name} must be finite and > 0, got {value}")


class ConstantVelocityKalman:
    """``n`` points in ``dim`` dimensions filtered together (same timestamps).

    ``position`` and ``velocity`` are shape (n, dim) [m], [m/s]; ``covariance`` is shape
    (n, 2, 2), the same for every axis of a point.
    """

    def __init__(self, t_s: float, position_m: np.ndarray, noise: KalmanNoise = KalmanNoise()):
        p = np.array(position_m, dtype=float, ndmin=2)
        if not np.all(np.isfinite(p)):
            raise ValueError("position_m must be finite")
        self.noise = noise
        self.t_s = float(t_s)
        self.position = p
        self.velocity = np.zeros_like(p)
        r2 = noise.measurement_std_m ** 2
        self.covariance = np.tile(np.diag([r2, noise.initial_speed_std_m_s ** 2]), (p.shape[0], 1, 1))

    @property
    def n(self) -> int:
        return self.position.shape[0]

    def predicted(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """``(position (n, dim), covariance (n, 2, 2))`` predicted at ``t_s`` without changing state."""
        dt = max(float(t_s) - self.t_s, 0.0)
        F = np.array([[1.0, dt], [0.0, 1.0]])
        q = self.noise.accel_density_m2_s3
        Q = q * np.array([[dt ** 3 / 3.0, dt ** 2 / 2.0], [dt ** 2 / 2.0, dt]])
        return self.position + dt * self.velocity, F @ self.covariance @ F.T + Q

    def predict(self, t_s: float) -> None:
        """Advance the state to ``t_s`` [s] (earlier times are held at the current one)."""
        if float(t_s) <= self.t_s:
            return  # dt = 0: F = I, Q = 0, nothing changes (an update right after a predict)
        self.position, self.covariance = self.predicted(t_s)
        self.t_s = max(float(t_s), self.t_s)

    def mahalanobis2(self, t_s: float, z_m: np.ndarray) -> np.ndarray:
        """Squared Mahalanobis distance of each measurement (m, dim) to each point: (n, m)."""
        p, P = self.predicted(t_s)
        z = np.array(z_m, dtype=float, ndmin=2)
        s = P[:, 0, 0] + self.noise.measurement_std_m ** 2
        return np.sum((p[:, None, :] - z[None, :, :]) ** 2, axis=2) / s[:, None]

    def update(self, t_s: float, z_m: np.ndarray, mask: np.ndarray | None = None) -> None:
        """Predict to ``t_s`` and correct with the measured positions (n, dim) [m].

        ``mask`` (n,) bool: the points measured this time (the others are only predicted).
        Non-finite measurements are ignored point by point.
        """
        self.predict(t_s)
        z = np.array(z_m, dtype=float, ndmin=2)
        if z.shape != self.position.shape:
            raise ValueError(f"z_m must have shape {self.position.shape}, got {z.shape}")
        use = np.all(np.isfinite(z), axis=1)
        if mask is not None:
            use &= np.asarray(mask, dtype=bool)
        if not np.any(use):
            return
        P = self.covariance[use]
        s = P[:, 0, 0] + self.noise.measurement_std_m ** 2
        gain = P[:, :, 0] / s[:, None]  # (m, 2): gains of position and velocity
        innovation = z[use] - self.position[use]
        self.position[use] += gain[:, 0:1] * innovation
        self.velocity[use] += gain[:, 1:2] * innovation
        # Joseph-free form is fine here: K = P H^T / s with H = [1, 0].
        self.covariance[use] = P - gain[:, :, None] * P[:, 0:1, :]
