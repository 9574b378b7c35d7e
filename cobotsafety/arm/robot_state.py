"""One robot-state object: pinocchio model, data and q; kinematics updated once per step."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from cobotsafety.arm.robot_capsules import RobotCapsule, load_capsules
from cobotsafety.arm.robots import DEFAULT_ROBOT, RobotSpec, load_robot


class RobotState:
    """Wraps ``model``, ``data`` and ``q``. Call ``update()`` after changing ``q``.

    After ``update()``: ``p_world_ee`` (3,), ``J_ee`` (3, nv) translation Jacobian
    (LOCAL_WORLD_ALIGNED), ``J_ee_angular`` (3, nv), ``capsules_world`` -> (p0 (c,3), p1 (c,3),
    radius (c,)), and ``point_jacobian(capsule_index, p_world)`` for any point on a capsule.
    """

    def __init__(self, robot: str = DEFAULT_ROBOT, model=None, spec: RobotSpec | None = None,
                 capsules: str = "fitted"):
        if model is None:
            model, self.collision_model, spec = load_robot(robot)
        self.model, self.spec = model, spec
        self.name = spec.name
        self._data = model.createData()
        self._data_q: np.ndarray | None = None
        self.ee_frame_id = model.getFrameId(spec.ee_frame)
        # Joints with finite limits (continuous joints have none).
        self.lower = model.lowerPositionLimit.copy()
        self.upper = model.upperPositionLimit.copy()
        self.limited_v = self._limited_velocity_indices()
        self.q = np.array(spec.home_q, dtype=float)
        self.use_capsules(capsules)

    def use_capsules(self, capsule_model: str) -> None:
        """Cover the links with the ``capsule_model`` table ("fitted" or "paper", see
        ``cobotsafety.arm.robot_capsules``) and update the kinematics."""
        self.capsule_model = capsule_model
        self.capsules: list[RobotCapsule] = load_capsules(self.name, capsule_model)
        self.capsule_joint_ids = [int(self.model.getJointId(c.joint)) for c in self.capsules]
        self.capsule_p0_local = np.array([c.p0_joint for c in self.capsules]).reshape(-1, 3)
        self.capsule_p1_local = np.array([c.p1_joint for c in self.capsules]).reshape(-1, 3)
        self.capsule_radius = np.array([c.radius_m for c in self.capsules])
        self.lever_m = self._lever_bound_m()
        self.update()

    def _lever_bound_m(self) -> float:
        """An upper bound [m] on how far any capsule end point or the end-effector moves per
        radian (or metre) of any joint, in every configuration: the length of the kinematic
        chain (joint offsets, then the farthest attached point), and at least 1 (prismatic)."""
        model = self.model
        chain = sum(float(np.linalg.norm(model.jointPlacements[j].translation)) for j in range(1, model.njoints))
        attached = [float(np.linalg.norm(model.frames[self.ee_frame_id].placement.translation))]
        attached += [float(np.linalg.norm(p)) for p in (*self.capsule_p0_local, *self.capsule_p1_local)]
        return max(1.0, chain + max(attached))

    def _limited_velocity_indices(self) -> np.ndarray:
        """Velocity indices of 1-dof joints with finite position limits (idx_q, idx_v) pairs."""
        pairs = []
        self.limited_names = []
        for j in range(1, self.model.njoints):
            joint = self.model.joints[j]
            if joint.nq == 1 and joint.nv == 1:
                iq = joint.idx_q
                if np.isfinite(self.lower[iq]) and np.isfinite(self.upper[iq]) and self.upper[iq] - self.lower[iq] < 1e9:
                    pairs.append((iq, joint.idx_v))
                    self.limited_names.append(self.model.names[j])
        return np.array(pairs, dtype=int).reshape(-1, 2)

    @property
    def nv(self) -> int:
        return self.model.nv

    @property
    def data(self) -> pin.Data:
        """pinocchio's data at ``q``, refreshed here when a fast-path step left it behind."""
        if self._data_q is not None:
            pin.computeJointJacobians(self.model, self._data, self._data_q)
            pin.updateFramePlacements(self.model, self._data)
            self._data_q = None
        return self._data

    def set_kinematics(self, q: np.ndarray, p_world_ee: np.ndarray, R_world_ee: np.ndarray, J_ee6: np.ndarray,
                       capsule_p0: np.ndarray, capsule_p1: np.ndarray, capsule_origins: np.ndarray) -> None:
        """The state at ``q`` as the packed fast path computed it (``cobotsafety.arm.packed``):
        what ``update()`` sets, without pinocchio; its ``data`` is refreshed when read."""
        self.q = q
        self.p_world_ee, self.R_world_ee = p_world_ee, R_world_ee
        self.J_ee, self.J_ee_angular = J_ee6[:3], J_ee6[3:]
        if len(self.capsules):
            self.capsule_p0, self.capsule_p1, self._capsule_origins = capsule_p0, capsule_p1, capsule_origins
        self._data_q = q

    def update(self) -> None:
        """Forward kinematics, joint Jacobians, frame placements: once per step."""
        model, data = self.model, self._data
        self._data_q = None
        pin.computeJointJacobians(model, data, self.q)
        pin.updateFramePlacements(model, data)
        J = pin.getFrameJacobian(model, data, self.ee_frame_id, pin.LOCAL_WORLD_ALIGNED)
        self.J_ee, self.J_ee_angular = J[:3], J[3:]
        self.p_world_ee = data.oMf[self.ee_frame_id].translation.copy()
        self.R_world_ee = data.oMf[self.ee_frame_id].rotation.copy()
        if len(self.capsules):
            rotations = np.array([data.oMi[j].rotation for j in self.capsule_joint_ids])
            origins = np.array([data.oMi[j].translation for j in self.capsule_joint_ids])
            self.capsule_p0 = origins + np.einsum("cij,cj->ci", rotations, self.capsule_p0_local)
            self.capsule_p1 = origins + np.einsum("cij,cj->ci", rotations, self.capsule_p1_local)
            self._capsule_origins = origins
        else:
            self.capsule_p0 = self.capsule_p1 = np.zeros((0, 3))

    def point_jacobian(self, capsule_index: int, p_world: np.ndarray) -> np.ndarray:
        """Translation Jacobian (3, nv) of the point ``p_world`` rigidly attached to a capsule."""
        joint = int(self.capsule_joint_ids[capsule_index])
        J = pin.getJointJacobian(self.model, self.data, joint, pin.LOCAL_WORLD_ALIGNED)
        r = p_world - self._capsule_origins[capsule_index]
        # v_p = v_o + w x r = Jv qdot - [r]x Jw qdot
        skew = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
        return J[:3] - skew @ J[3:]

    def integrate(self, qdot: np.ndarray, dt_s: float) -> np.ndarray:
        """``pin.integrate`` (never q + v dt: continuous joints store cos/sin)."""
        return pin.integrate(self.model, self.q, qdot * dt_s)
