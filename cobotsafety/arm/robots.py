"""Supported robots by name: one loader, one end-effector frame, one home pose each.

``load_robot(name)`` returns a ``pinocchio.RobotWrapper``-like triple (model, collision model,
spec). Gripper joints are locked (kinematic arm only). Paper 1's planar RR arm is
``cobotsafety.planar``, not a model here. ``iiwa`` (paper 2's
robot family: KUKA LBR iiwa 14 R820) comes from PyPI ``rtb-data``, whose copy of ROS-Industrial's
``kuka_lbr_iiwa_support`` description (Apache-2.0) names its meshes ``package://`` paths that do
not match its folders: ``urdf_path(name)`` gives a URDF with absolute mesh paths for pinocchio
and the app's ``ViserUrdf``.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cobotsafety.errors import UnknownRobotError


@dataclass(frozen=True)
class RobotSpec:
    """How to load one robot and use it as a teleoperated arm."""

    name: str
    loader: str
    """example-robot-data name, or ``"rtbdata:<urdf path inside rtbdata>"``."""
    ee_frame: str
    home_q: tuple[float, ...]
    """Home configuration in the reduced model's ``nq`` coordinates."""
    locked_joints: tuple[str, ...] = ()
    limit_overrides: dict = field(default_factory=dict)
    """Joint name -> (lower, upper) [rad] replacing the URDF's limits."""
    arm_joints: tuple[str, str, str] = ()
    """(shoulder, elbow, wrist) joints: where paper 2's three capsules sit (``capsules="paper"``)."""


RTBDATA_PREFIX = "rtbdata:"
IIWA_URDF = "xacro/kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf"
#: ``package://`` names in rtb-data's KUKA URDFs -> folders inside ``rtbdata/xacro/kuka_description``.
RTBDATA_PACKAGES = {"kuka_lbr_iiwa_support": "kuka_description/kuka_lbr_iiwa"}


def _rubz(angle: float) -> tuple[float, float]:
    return (np.cos(angle), np.sin(angle))


ROBOTS: dict[str, RobotSpec] = {
    "panda": RobotSpec("panda", "panda", "panda_hand_tcp",
                       (0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785),
                       locked_joints=("panda_finger_joint1", "panda_finger_joint2"),
                       arm_joints=("panda_joint2", "panda_joint4", "panda_joint6")),
    "ur5": RobotSpec("ur5", "ur5", "tool0", (0.0, -1.3, 1.6, -1.87, -1.57, 0.0),
                     # +-2 pi on every joint lets the cable wrap; keep one turn either side.
                     limit_overrides={n: (-np.pi, np.pi) for n in ("shoulder_pan_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")},
                     arm_joints=("shoulder_lift_joint", "elbow_joint", "wrist_1_joint")),
    "kinova": RobotSpec("kinova", "kinova", "j2s6s200_end_effector",
                        (*_rubz(0.0), 2.9, 1.3, *_rubz(-2.07), 1.4, *_rubz(0.0)),
                        arm_joints=("j2s6s200_joint_2", "j2s6s200_joint_3", "j2s6s200_joint_5")),
    "z1": RobotSpec("z1", "z1", "link06", (0.0, 1.2, -1.0, -0.3, 0.0, 0.0),
                    locked_joints=("jointGripper",), arm_joints=("joint2", "joint3", "joint5")),
    "xarm7": RobotSpec("xarm7", "xarm7", "link_eef", (0.0, -0.2, 0.0, 0.9, 0.0, 1.1, 0.0),
                       arm_joints=("joint2", "joint4", "joint6")),
    # Paper 2's pose family: elbow up, tool pointing down at (0.35, 0, 0.70) m in front of the base.
    "iiwa": RobotSpec("iiwa", f"{RTBDATA_PREFIX}{IIWA_URDF}", "tool0", (0.0, -0.1122, 0.0, -1.5612, 0.0, 1.6926, 0.0),
                      arm_joints=("joint_a2", "joint_a4", "joint_a6")),
}

DEFAULT_ROBOT = "panda"


def robot_spec(name: str) -> RobotSpec:
    try:
        return ROBOTS[name]
    except KeyError:
        raise UnknownRobotError(f"unknown robot {name!r}; known robots: {', '.join(ROBOTS)}") from None


def _rtbdata_urdf(relative: str) -> Path:
    """A copy of rtb-data's URDF ``relative`` with every ``package://`` mesh made absolute.

    Written once into a cache folder (``$XDG_CACHE_HOME`` or the temp dir), named by a hash of
    the source text so a new rtb-data version gets a new copy; the write is atomic (rename).
    Raises ``UnknownRobotError`` when rtb-data is missing or a mesh does not exist.
    """
    try:
        import rtbdata
    except ImportError:
        raise UnknownRobotError("the iiwa needs the PyPI package rtb-data (pip install rtb-data)") from None
    root = Path(rtbdata.__file__).parent / "xacro"
    source = root.parent / relative
    text = source.read_text()
    for package, folder in RTBDATA_PACKAGES.items():
        text = text.replace(f"package://{package}/", f"{(root / folder).as_posix()}/")
    if "package://" in text:
        raise UnknownRobotError(f"{source}: unresolved package:// path after mapping {sorted(RTBDATA_PACKAGES)}")
    cache = Path(os.environ.get("XDG_CACHE_HOME") or tempfile.gettempdir()) / "cobotsafety-urdf"
    target = cache / f"{source.stem}-{hashlib.sha256(text.encode()).hexdigest()[:12]}.urdf"
    if not target.exists():
        cache.mkdir(parents=True, exist_ok=True)
        partial = target.with_suffix(f".{os.getpid()}.part")
        partial.write_text(text)
        partial.replace(target)
    return target


def urdf_path(name: str) -> Path:
    """The URDF file of robot ``name`` with loadable mesh paths (for ``ViserUrdf``)."""
    spec = robot_spec(name)
    if spec.loader.startswith(RTBDATA_PREFIX):
        return _rtbdata_urdf(spec.loader[len(RTBDATA_PREFIX):])
    import example_robot_data

    return Path(example_robot_data.load(spec.loader).urdf)


def load_robot(name: str = DEFAULT_ROBOT):
    """Return ``(model, collision_model, spec)`` with gripper joints locked and overrides applied."""
    import pinocchio as pin

    spec = robot_spec(name)
    if spec.loader.startswith(RTBDATA_PREFIX):
        path = str(_rtbdata_urdf(spec.loader[len(RTBDATA_PREFIX):]))
        model = pin.buildModelFromUrdf(path)
        collision = pin.buildGeomFromUrdf(model, path, pin.GeometryType.COLLISION)
    else:
        import example_robot_data

        robot = example_robot_data.load(spec.loader)
        model, collision = robot.model, robot.collision_model
        if spec.locked_joints:
            ids = [model.getJointId(j) for j in spec.locked_joints]
            q_lock = pin.neutral(model)
            model, collision = pin.buildReducedModel(model, collision, ids, q_lock)
    for joint, (lower, upper) in spec.limit_overrides.items():
        j = model.getJointId(joint)
        idx = model.idx_qs[j]
        model.lowerPositionLimit[idx] = lower
        model.upperPositionLimit[idx] = upper
    if not model.existFrame(spec.ee_frame):
        raise UnknownRobotError(f"robot {name!r} has no frame {spec.ee_frame!r}")
    return model, collision, spec
