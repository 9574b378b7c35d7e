"""One robot, loaded once: its pinocchio model, capsules and motion limits, and the two flat
buffers the compiled step reads them from.

``RobotModel.load(name, capsules="fitted")`` builds it; it never changes afterwards (another
capsule model is another ``RobotModel``). ``robot_buffers`` lays the kinematic chain out
(joint types, axes, parents, placements, the support of each joint), the capsules' attachments,
the joint position limits and the motion limits; ``step_kernel.unpack_robot`` reads it back.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cobotsafety.arm.kinematics import JOINT_CODES, joint_axis_local
from cobotsafety.arm.motion_limits import MotionLimits, load_motion_limits
from cobotsafety.arm.robot_capsules import RobotCapsule, load_capsules
from cobotsafety.arm.robots import DEFAULT_ROBOT, RobotSpec, load_robot
from cobotsafety.errors import UnknownRobotError


#: ``RobotModel.load``'s models by (robot, capsule table).
_LOADED: dict = {}


@dataclass(frozen=True, eq=False)
class RobotModel:
    """A robot as the controller uses it. Arrays are read-only."""

    name: str
    spec: RobotSpec
    model: object
    """pinocchio's ``Model`` (reduced: grippers locked)."""
    collision_model: object
    capsules: tuple[RobotCapsule, ...]
    capsule_model: str
    limits: MotionLimits
    ee_frame_id: int
    lower: np.ndarray
    """Shape (nq,): position limits [rad] (continuous joints: none)."""
    upper: np.ndarray
    limited: np.ndarray
    """Shape (L, 2): (q index, v index) of each joint with finite position limits."""
    limited_names: tuple[str, ...]
    joint_names: tuple[str, ...]
    """One per velocity coordinate, in the model's order."""
    lever_m: float
    """An upper bound [m] on how far any capsule end point or the end-effector moves per radian
    of any joint, in every configuration (the safety net's reach)."""
    robot_i: np.ndarray
    robot_f: np.ndarray

    @property
    def nq(self) -> int:
        return int(self.model.nq)

    @property
    def nv(self) -> int:
        return int(self.model.nv)

    @property
    def home_q(self) -> np.ndarray:
        return np.array(self.spec.home_q, dtype=float)

    def difference(self, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
        """The joint motion (nv,) from ``q0`` to ``q1`` (nq,) (``pin.difference``: a continuous
        joint stored as cos / sin the short way round; a revolute one ``q1 - q0``)."""
        import pinocchio as pin

        return pin.difference(self.model, q0, q1)

    def integrate(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """The configuration (nq,) reached from ``q`` (nq,) by the joint motion ``dq`` (nv,)
        (``pin.integrate``, the inverse of ``difference``)."""
        import pinocchio as pin

        return pin.integrate(self.model, q, dq)

    @classmethod
    def load(cls, name: str = DEFAULT_ROBOT, capsules: str = "fitted") -> "RobotModel":
        """Load robot ``name`` with its ``capsules`` table ("fitted" or "paper"): once per
        process, the same object afterwards (it never changes; parsing the panda's URDF with its
        meshes takes ~0.8 s, and a campaign builds several controllers per person). Raises
        ``UnknownRobotError`` (unknown robot, capsule table or joint type) and
        ``MotionLimitsError`` (a missing or invalid motion limit); a failure is not remembered."""
        key = (name, capsules)
        loaded = _LOADED.get(key)
        if loaded is None:
            loaded = _LOADED[key] = cls._build(name, capsules)
        return loaded

    @classmethod
    def _build(cls, name: str, capsules: str) -> "RobotModel":
        model, collision, spec = load_robot(name)
        for j in range(1, model.njoints):
            kind = model.joints[j].shortname()
            if kind not in JOINT_CODES:
                raise UnknownRobotError(f"robot {name!r}: joint {model.names[j]!r} of type {kind} is not supported")
        joint_names = tuple(model.names[j] for j in range(1, model.njoints))
        limits = load_motion_limits(name, joint_names)
        table = tuple(load_capsules(name, capsules))
        lower, upper = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()
        limited, limited_names = [], []
        for j in range(1, model.njoints):
            joint = model.joints[j]
            iq = joint.idx_q
            if joint.nq == 1 and np.isfinite(lower[iq]) and np.isfinite(upper[iq]) and upper[iq] - lower[iq] < 1e9:
                limited.append((iq, joint.idx_v))
                limited_names.append(model.names[j])
        limited_array = np.array(limited, dtype=np.int64).reshape(-1, 2)
        ee_frame_id = int(model.getFrameId(spec.ee_frame))
        lever = _lever_bound_m(model, ee_frame_id, table)
        robot_i, robot_f = robot_buffers(model, ee_frame_id, table, lower, upper, limited_array, limits, lever)
        for array in (lower, upper, limited_array, robot_i, robot_f):
            array.setflags(write=False)
        return cls(name, spec, model, collision, table, capsules, limits, ee_frame_id, lower, upper, limited_array,
                   tuple(limited_names), joint_names, lever, robot_i, robot_f)


def _lever_bound_m(model, ee_frame_id: int, capsules) -> float:
    """The length of the kinematic chain (joint offsets, then the farthest attached point), and
    at least 1 (prismatic joints)."""
    chain = sum(float(np.linalg.norm(model.jointPlacements[j].translation)) for j in range(1, model.njoints))
    attached = [float(np.linalg.norm(model.frames[ee_frame_id].placement.translation))]
    attached += [float(np.linalg.norm(p)) for c in capsules for p in (c.p0_joint, c.p1_joint)]
    return max(1.0, chain + max(attached))


def robot_buffers(model, ee_frame_id: int, capsules, lower, upper, limited, limits: MotionLimits,
                  lever_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The robot in two flat buffers, int64 and float64 (``step_kernel.unpack_robot``): a header
    (joints, nq, nv, end-effector joint, capsules, limited joints), then every array in a fixed
    order."""
    nj = model.njoints
    jtype = [0] + [JOINT_CODES[model.joints[j].shortname()] for j in range(1, nj)]
    axes = np.array([(0.0, 0.0, 1.0)] + [joint_axis_local(model.joints[j]) for j in range(1, nj)])
    parent = [model.parents[j] for j in range(nj)]
    idx_q = [model.joints[j].idx_q if j else 0 for j in range(nj)]
    idx_v = [model.joints[j].idx_v if j else 0 for j in range(nj)]
    support = np.zeros((nj, nj), dtype=np.int64)
    for k in range(1, nj):
        i = k
        while i > 0:
            support[k, i] = 1
            i = model.parents[i]
    frame = model.frames[ee_frame_id]
    cap_joint = [int(model.getJointId(c.joint)) for c in capsules]
    header = [nj, model.nq, model.nv, int(frame.parentJoint), len(capsules), len(limited)]
    robot_i = np.concatenate([np.array(header + jtype + parent + idx_q + idx_v, dtype=np.int64), support.ravel(),
                              np.array(cap_joint, dtype=np.int64), limited.ravel()]).astype(np.int64)
    placement_R = np.array([model.jointPlacements[j].rotation for j in range(nj)])
    placement_t = np.array([model.jointPlacements[j].translation for j in range(nj)])
    p0l = np.array([c.p0_joint for c in capsules], dtype=float).reshape(-1, 3)
    p1l = np.array([c.p1_joint for c in capsules], dtype=float).reshape(-1, 3)
    radius = np.array([c.radius_m for c in capsules], dtype=float)
    ee = [limits.ee_speed_m_s, limits.ee_acceleration_m_s2, limits.ee_jerk_m_s3, lever_m]
    floats = (axes, placement_R, placement_t, frame.placement.rotation, frame.placement.translation, p0l, p1l, radius,
              lower, upper, limits.velocity_rad_s, limits.acceleration_rad_s2, limits.jerk_rad_s3, np.array(ee))
    robot_f = np.concatenate([np.asarray(a, dtype=float).ravel() for a in floats])
    return np.ascontiguousarray(robot_i), np.ascontiguousarray(robot_f)
