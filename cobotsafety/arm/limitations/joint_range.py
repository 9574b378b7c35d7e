"""Joint position limits: every joint with finite limits stays within them.

Rows: ``q - lower`` (gradient ``+e_i``) and ``upper - q`` (``-e_i``) of every limited joint, in
radians; lower rows first, then upper rows, in the model's joint order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

KIND = 0
ANGULAR = True


@dataclass(frozen=True)
class JointPositionLimits:
    """The robot's own joint ranges (from its model, with per-robot overrides)."""

    name: str = "joint"


def pack(limitation: JointPositionLimits, robot) -> tuple[np.ndarray, int]:
    """``(reals (12,), skip_capsules)`` for the compiled step."""
    return np.zeros(12), 0


def row_name(limitation: JointPositionLimits, robot, a: int, b: int) -> str:
    """Row ``a`` (0 lower, 1 upper) of limited joint ``b``."""
    return f"{robot.limited_names[b]} {('lower', 'upper')[a]}"


@numba.njit(cache=True)
def count(real, skip, n_caps, n_limited, n_human):  # pragma: no cover - compiled
    return 2 * n_limited


@numba.njit(cache=True, inline="always")
def distances(real, skip, kin, human, out):  # pragma: no cover - compiled
    """Distances [rad] into ``out`` (2L,)."""
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    L = limited.shape[0]
    for i in range(L):
        iq = limited[i, 0]
        out[i] = q[iq] - lower[iq]
        out[L + i] = upper[iq] - q[iq]


@numba.njit(cache=True, inline="always")
def rows(real, skip, con, kin, human, activation_m, out, m, before):  # pragma: no cover - compiled
    """Both rows of every limited joint (always active: the filter's braking bound decides)."""
    q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot = kin
    dist, A, rate, angular, tag, pull, drift = out
    L = limited.shape[0]
    for side in range(2):
        for i in range(L):
            iq, iv = limited[i, 0], limited[i, 1]
            value = q[iq] - lower[iq] if side == 0 else upper[iq] - q[iq]
            before[side * L + i] = value
            dist[m] = value
            A[m, :] = 0.0
            A[m, iv] = 1.0 if side == 0 else -1.0
            rate[m], angular[m] = 0.0, True
            tag[m, 0], tag[m, 1], tag[m, 2] = con, side, i
            m += 1
    return m
