"""The arm's state after its last step: the configuration and its kinematics.

The compiled step computes the kinematics of the configuration it reaches; ``RobotState``
reads them from that step's output (each step writes a new buffer, so arrays handed out
earlier keep their values). pinocchio's ``data`` is computed only when something reads it.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin


class RobotState:
    """``q`` (nq,) and, at ``q``: ``p_world_ee`` (3,) [m], ``R_world_ee`` (3, 3), ``J_ee``
    (3, nv) and ``J_ee_angular`` (3, nv) (LOCAL_WORLD_ALIGNED), ``capsule_p0``/``capsule_p1``
    (c, 3) [m] and ``capsule_radius`` (c,) [m]."""

    def __init__(self, model):
        self.robot = model
        self.model = model.model
        self.name = model.name
        self.spec = model.spec
        self.capsules = model.capsules
        self.capsule_radius = np.array([c.radius_m for c in model.capsules], dtype=float)
        self.capsule_p0_local = np.array([c.p0_joint for c in model.capsules], dtype=float).reshape(-1, 3)
        self.capsule_p1_local = np.array([c.p1_joint for c in model.capsules], dtype=float).reshape(-1, 3)
        """Shape (c, 3): the capsules' end points in their joint's frame [m]."""
        self.capsule_joint_ids = [int(model.model.getJointId(c.joint)) for c in model.capsules]
        self.lower, self.upper = model.lower, model.upper
        self.limited_names = model.limited_names
        self._out: np.ndarray | None = None
        self._offsets: np.ndarray | None = None
        self._data = None
        self._data_q: np.ndarray | None = None

    def refresh(self, out_f: np.ndarray, offsets: np.ndarray) -> None:
        """Read the state from a step's output buffer (``step_kernel.output_layout``)."""
        self._out, self._offsets = out_f, offsets

    @property
    def out_f(self) -> np.ndarray:
        """The output buffer of the step the state was read from (the next step's ``kin_f``)."""
        return self._out

    def _part(self, i: int) -> np.ndarray:
        return self._out[self._offsets[i]:self._offsets[i + 1]]

    @property
    def nv(self) -> int:
        return self.robot.nv

    @property
    def q(self) -> np.ndarray:
        return self._part(0)

    @property
    def p_world_ee(self) -> np.ndarray:
        return self._part(2)

    @property
    def R_world_ee(self) -> np.ndarray:
        return self._part(3).reshape(3, 3)

    @property
    def J_ee(self) -> np.ndarray:
        return self._part(4).reshape(6, -1)[:3]

    @property
    def J_ee_angular(self) -> np.ndarray:
        return self._part(4).reshape(6, -1)[3:]

    @property
    def capsule_p0(self) -> np.ndarray:
        return self._part(5).reshape(-1, 3)

    @property
    def capsule_p1(self) -> np.ndarray:
        return self._part(6).reshape(-1, 3)

    @property
    def data(self) -> pin.Data:
        """pinocchio's data at ``q`` (joint placements, Jacobians, frames), made when read."""
        q = self.q
        if self._data is None or self._data_q is None or not np.array_equal(self._data_q, q):
            self._data = self.model.createData()
            pin.computeJointJacobians(self.model, self._data, q)
            pin.updateFramePlacements(self.model, self._data)
            self._data_q = q.copy()
        return self._data

    def point_jacobian(self, capsule_index: int, p_world: np.ndarray) -> np.ndarray:
        """Translation Jacobian (3, nv) of the point ``p_world`` fixed to a capsule's link
        (pinocchio's, for readers outside the compiled step)."""
        return point_jacobian(self.model, self.data, int(self.capsule_joint_ids[capsule_index]), p_world)


def point_jacobian(model: pin.Model, data: pin.Data, joint: int, p_world: np.ndarray) -> np.ndarray:
    """Translation Jacobian (3, nv) of the point ``p_world`` fixed to ``joint``'s link, from
    ``data`` after ``pin.computeJointJacobians`` at the configuration in question."""
    J = pin.getJointJacobian(model, data, joint, pin.LOCAL_WORLD_ALIGNED)
    r = p_world - data.oMi[joint].translation
    skew = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    return J[:3] - skew @ J[3:]
