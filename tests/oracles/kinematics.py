"""The arm's kinematics from pinocchio: joint placements, capsule end points, the end-effector's
pose and Jacobian, and the Jacobian of any point fixed to a joint."""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def random_configuration(model, rng: np.random.Generator) -> np.ndarray:
    """A configuration (nq,) drawn from ``rng`` (never pinocchio's shared generator): each
    limited joint uniform in its range, an unlimited one in [-pi, pi], a continuous joint
    (nq = 2) as (cos, sin) of a uniform angle."""
    q = pin.neutral(model)
    for j in range(1, model.njoints):
        joint = model.joints[j]
        iq = joint.idx_q
        if joint.nq == 2:
            angle = rng.uniform(-np.pi, np.pi)
            q[iq:iq + 2] = (np.cos(angle), np.sin(angle))
        else:
            lower, upper = model.lowerPositionLimit[iq], model.upperPositionLimit[iq]
            lower = lower if np.isfinite(lower) and lower > -10 else -np.pi
            upper = upper if np.isfinite(upper) and upper < 10 else np.pi
            q[iq] = rng.uniform(lower, upper)
    return q


def skew(r: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


class Kinematics:
    """pinocchio's kinematics of ``robot`` (a ``RobotModel``) at ``q``."""

    def __init__(self, robot, q: np.ndarray):
        self.robot = robot
        self.model = robot.model
        self.q = np.array(q, dtype=float)
        self.data = self.model.createData()
        pin.computeJointJacobians(self.model, self.data, self.q)  # also the forward kinematics
        pin.updateFramePlacements(self.model, self.data)
        self.capsule_joint = [int(self.model.getJointId(c.joint)) for c in robot.capsules]
        self.radius = np.array([c.radius_m for c in robot.capsules], dtype=float)
        self.p0 = np.array([self.data.oMi[j].act(np.array(c.p0_joint, dtype=float))
                            for j, c in zip(self.capsule_joint, robot.capsules)]).reshape(-1, 3)
        self.p1 = np.array([self.data.oMi[j].act(np.array(c.p1_joint, dtype=float))
                            for j, c in zip(self.capsule_joint, robot.capsules)]).reshape(-1, 3)
        frame = self.data.oMf[robot.ee_frame_id]
        self.p_ee = frame.translation.copy()
        self.R_ee = frame.rotation.copy()
        self.J6_ee = pin.getFrameJacobian(self.model, self.data, robot.ee_frame_id, pin.LOCAL_WORLD_ALIGNED).copy()

    @property
    def J_ee(self) -> np.ndarray:
        """(3, nv): the end-effector's translation Jacobian."""
        return self.J6_ee[:3]

    def point_jacobian(self, joint: int, p_world: np.ndarray) -> np.ndarray:
        """(3, nv): the Jacobian of the point ``p_world`` fixed to ``joint``: the joint origin's
        velocity plus ``omega x (p - origin)``."""
        J = pin.getJointJacobian(self.model, self.data, joint, pin.LOCAL_WORLD_ALIGNED)
        r = np.asarray(p_world, dtype=float) - self.data.oMi[joint].translation
        return J[:3] - skew(r) @ J[3:]

    def capsule_jacobian(self, capsule: int, p_world: np.ndarray) -> np.ndarray:
        return self.point_jacobian(self.capsule_joint[capsule], p_world)
