"""The iiwa's resolved URDF and paper 2's three-capsule model on every arm."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from cobotsafety.arm.robot_capsules import PAPER_CAPSULES, load_capsules
from cobotsafety.arm.controller import ArmController
from cobotsafety.arm.robots import ROBOTS, load_robot, urdf_path
from cobotsafety.errors import UnknownRobotError

ARMS = [name for name, spec in ROBOTS.items() if spec.arm_joints]


def test_iiwa_urdf_has_only_existing_absolute_meshes():
    text = urdf_path("iiwa").read_text()
    meshes = re.findall(r'filename="([^"]+)"', text)
    assert len(meshes) == 16  # 8 links x (visual .dae + collision .stl)
    assert all(Path(m).is_absolute() and Path(m).is_file() for m in meshes)
    assert "package://" not in text


def test_iiwa_is_the_14_r820():
    model, collision, spec = load_robot("iiwa")
    assert model.nq == 7 and len(collision.geometryObjects) == 8
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.zeros(7))
    # Stretched upright: 0.36 + 0.42 + 0.40 + 0.126 m (KUKA's data sheet for the 14 R820).
    np.testing.assert_allclose(data.oMf[model.getFrameId(spec.ee_frame)].translation, [0, 0, 1.306], atol=1e-3)


@pytest.mark.parametrize("robot", ARMS)
def test_paper_capsules_have_the_papers_sizes_and_follow_the_arm(robot):
    capsules = load_capsules(robot, "paper")
    base = load_capsules(robot)[0]
    assert capsules[0].name == f"{base.name} (base, not checked)"
    assert (capsules[0].p0_joint, capsules[0].p1_joint, capsules[0].radius_m) == (base.p0_joint, base.p1_joint, base.radius_m)
    for capsule, (name, length, radius) in zip(capsules[1:], PAPER_CAPSULES, strict=True):
        assert capsule.name == name and capsule.radius_m == radius
        assert np.linalg.norm(np.subtract(capsule.p1_joint, capsule.p0_joint)) == pytest.approx(length, abs=2e-6)
    controller = ArmController(robot, capsules="paper")
    state = controller.state
    model = state.model
    shoulder, elbow, wrist = (model.getJointId(j) for j in state.spec.arm_joints)
    # On the iiwa (joint centres on the links' axes) in any pose; on the other arms (offset
    # elbows) at the home pose the tables are measured in.
    poses = 20 if robot == "iiwa" else 1
    for k in range(poses):
        if k:
            controller.set_configuration(pin.randomConfiguration(model, np.maximum(state.lower, -3),
                                                                 np.minimum(state.upper, 3)))
        data = state.data
        for i, (a, b) in enumerate(((shoulder, elbow), (elbow, wrist)), start=1):
            p0, p1 = state.capsule_p0[i], state.capsule_p1[i]
            axis = (p1 - p0) / np.linalg.norm(p1 - p0)
            for j in (a, b):
                off = data.oMi[j].translation - p0
                assert np.linalg.norm(off - (off @ axis) * axis) < 1e-5, (robot, i, j)
        # The tool capsule starts at the wrist centre and points at the end-effector.
        np.testing.assert_allclose(state.capsule_p0[3], data.oMi[wrist].translation, atol=1e-5)
        to_ee = state.p_world_ee - state.capsule_p0[3]
        axis = state.capsule_p1[3] - state.capsule_p0[3]
        assert np.linalg.norm(np.cross(to_ee, axis)) < 1e-5 * np.linalg.norm(axis)


def test_unknown_capsule_model_and_planar_paper_model_are_refused():
    with pytest.raises(UnknownRobotError, match="known: fitted, paper"):
        load_capsules("panda", "tight")
    with pytest.raises(UnknownRobotError, match="no 'paper' capsule table"):
        load_capsules("planar", "paper")
