"""The compiled step's pieces called from Python the way ``step_kernel.arm_step`` calls them
(test glue, not an oracle): the kinematics tuple, the limitations' rows and distances."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from cobotsafety.arm.limitations import human as human_kind
from cobotsafety.arm.limitations.rows import kind_count, kind_distances, kind_rows
from cobotsafety.arm.robot_model import RobotModel
from cobotsafety.arm.step_kernel import kinematics, unpack_robot


@lru_cache(maxsize=None)
def robot(name: str, capsules: str = "fitted") -> RobotModel:
    """Each robot loaded once per session."""
    return RobotModel.load(name, capsules)


def compiled_kinematics(model: RobotModel, q: np.ndarray, qdot: np.ndarray | None = None):
    """``(kin, p_ee, R_ee, J6, oR, op, p0, p1)``: ``kin`` the tuple the rows read (see
    ``limitations/rows.py``; the arm moving at ``qdot``, at rest by default), and the compiled
    kinematics at ``q``."""
    (nq, nv, ee_joint, jtype, parent, idx_q, idx_v, support, cap_joint, limited, axes, placement_R, placement_t,
     ee_R, ee_t, cap_p0l, cap_p1l, radius, lower, upper, vel, acc, jerk, ee_limits, lever) = unpack_robot(
        model.robot_i, model.robot_f)
    q = np.ascontiguousarray(q, dtype=float)
    oR, op, p_ee, R_ee, J6, p0, p1 = kinematics(q, jtype, axes, parent, idx_q, idx_v, placement_R, placement_t,
                                                support, ee_joint, ee_R, ee_t, cap_joint, cap_p0l, cap_p1l, nv)
    qdot = np.zeros(nv) if qdot is None else np.ascontiguousarray(qdot, dtype=float)
    kin = (q, p_ee, J6, oR, op, p0, p1, radius, cap_joint, axes, idx_v, support, lower, upper, limited, qdot)
    return kin, p_ee, R_ee, J6, oR, op, p0, p1


def human_tuple(p0, p1, radius, v0, v1, ahead_s: float = 0.0):
    """The human as the rows read it (``human.unpack_human`` of the flat buffer)."""
    p0, p1, radius, v0, v1 = (np.asarray(x, dtype=float) for x in (p0, p1, radius, v0, v1))
    return human_kind.unpack_human(human_kind.human_buffer(p0, p1, radius, v0, v1), ahead_s)


def compiled_rows(pack, model: RobotModel, kin, hum, activation_m: float):
    """Every limitation's active rows ``(dist, A, rate, angular, tag)`` and every distance
    measured (``before``), filled as the step fills them (``compiled_pulls``: with their pulls)."""
    *rows, pull, drift, before = compiled_pulls(pack, model, kin, hum, activation_m)
    return *rows, before


def compiled_pulls(pack, model: RobotModel, kin, hum, activation_m: float):
    """``compiled_rows`` with each row's curvature pull and its point's drift [m/s^2] before
    ``before``."""
    n_caps, L, n_human = len(model.capsules), len(model.limited), hum[2].shape[0]
    sizes = [kind_count(int(k), pack.reals[i], int(pack.skips[i]), n_caps, L, n_human) for i, k in enumerate(pack.kinds)]
    assert all(s >= 0 for s in sizes), sizes
    total = int(sum(sizes))
    dist, A, rate = np.empty(total), np.empty((total, model.nv)), np.empty(total)
    angular, tag = np.empty(total, dtype=np.bool_), np.empty((total, 3), dtype=np.int64)
    pull, drift, before = np.zeros(total), np.zeros(total), np.empty(total)
    m, start = 0, 0
    for con, kind in enumerate(pack.kinds):
        activation = pack.reals[con, 1] if kind == human_kind.KIND else activation_m
        m = kind_rows(int(kind), pack.reals[con], int(pack.skips[con]), con, kin, hum, activation,
                      (dist, A, rate, angular, tag, pull, drift), m, before[start:start + sizes[con]])
        start += sizes[con]
    return dist[:m], A[:m], rate[:m], angular[:m], tag[:m], pull[:m], drift[:m], before


def compiled_distances(pack, model: RobotModel, kin, hum) -> list[np.ndarray]:
    """Each limitation's distances as the safety net re-checks them."""
    n_caps, L, n_human = len(model.capsules), len(model.limited), hum[2].shape[0]
    out = []
    for con, kind in enumerate(pack.kinds):
        size = kind_count(int(kind), pack.reals[con], int(pack.skips[con]), n_caps, L, n_human)
        values = np.full(size, np.nan)
        kind_distances(int(kind), pack.reals[con], int(pack.skips[con]), kin, hum, values)
        out.append(values)
    return out
