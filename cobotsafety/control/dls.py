"""Damped least squares (paper 2, eqs. 16 and 20 with erratum 6): ``J^T (J J^T + lambda I)^-1 x``."""

from __future__ import annotations

import numpy as np


def damped_least_squares(J: np.ndarray, x: np.ndarray, damping: float = 1e-3) -> np.ndarray:
    """Joint velocities (nv,) for a task velocity ``x`` (m,) through the Jacobian ``J`` (m, nv)."""
    J = np.asarray(J, dtype=float)
    return J.T @ np.linalg.solve(J @ J.T + damping * np.eye(J.shape[0]), np.asarray(x, dtype=float))
