"""The user's task in joint space written with numpy (``arm/task.py``'s docstring)."""

from __future__ import annotations

import numpy as np


def task_mapping(J, J_angular, error_rad, centering, damping_max, w_threshold, orientation_gain_per_s,
                 half_velocity_limit, with_orientation) -> tuple[np.ndarray, np.ndarray]:
    """``(M, c)``: ``M = J^T (J J^T + lambda^2 I)^-1`` with ``lambda`` growing as the
    manipulability ``w = sqrt(det J J^T)`` falls below ``w_threshold``; ``c = N s`` with
    ``N = I - M J`` and ``s`` the centring plus (optionally) the orientation hold through the
    damped (0.01) least squares of ``J_angular N``; ``c`` scaled down to half the speed limits."""
    k, nv = J.shape
    JJt = J @ J.T
    w = np.sqrt(max(np.linalg.det(JJt), 0.0))
    lam2 = damping_max ** 2 * (1.0 - w / w_threshold) ** 2 if w < w_threshold else 0.0
    M = J.T @ np.linalg.inv(JJt + lam2 * np.eye(k))
    N = np.eye(nv) - M @ J
    secondary = np.array(centering, dtype=float)
    if with_orientation:
        JwN = J_angular @ N
        secondary = secondary + JwN.T @ np.linalg.solve(JwN @ JwN.T + 0.01 * np.eye(3), orientation_gain_per_s * error_rad)
    c = N @ secondary
    ratio = np.max(np.abs(c) / half_velocity_limit)
    return M, (c / ratio if ratio > 1.0 else c)


def centering(robot, q: np.ndarray, gain_per_s: float) -> np.ndarray:
    """The joint-centring secondary velocity (nv,): ``-gain (q - middle) / span`` per limited joint."""
    out = np.zeros(robot.nv)
    for iq, iv in robot.limited:
        span = max(robot.upper[iq] - robot.lower[iq], 1e-6)
        out[iv] = -gain_per_s * (q[iq] - 0.5 * (robot.lower[iq] + robot.upper[iq])) / span
    return out
