"""The bundled motion-limit table: every robot loads for its own model, each value has its
source, the numbers equal their documents (libfranka, KUKA, UFACTORY, Kinova), the values that
follow the stated principle follow it, and bad tables fail with a message naming robot and joint.
"""

import copy
import math
import re
import tomllib

import numpy as np
import pytest

from cobotsafety.arm.motion_limits import (EE_FIELDS, JOINT_FIELDS, SOURCE_KEYS, MotionLimits, bundled_table,
                                           load_motion_limits, table_robots)
from cobotsafety.arm.robots import ROBOTS, load_robot
from cobotsafety.errors import CobotSafetyError, MotionLimitsError


def velocity_joint_names(model) -> list[str]:
    """The model's joint names in velocity order (one velocity coordinate each)."""
    joints = [j for j in range(1, model.njoints) if model.nvs[j] > 0]
    assert all(model.nvs[j] == 1 for j in joints), "a joint with several velocities needs per-coordinate limits"
    return [model.names[j] for j in sorted(joints, key=lambda j: model.idx_vs[j])]


@pytest.fixture(scope="module")
def models():
    """Every offered robot's reduced model, loaded once for this module."""
    return {name: load_robot(name)[0] for name in ROBOTS}


@pytest.fixture
def table():
    return copy.deepcopy(bundled_table())


def test_the_table_covers_exactly_the_offered_robots():
    """Every 3D arm, and paper 1's planar arm (``cobotsafety.planar``, the JACO's limits)."""
    assert sorted(table_robots()) == sorted([*ROBOTS, "planar"])


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_every_robot_loads_for_its_model(robot, models):
    model = models[robot]
    names = velocity_joint_names(model)
    limits = load_motion_limits(robot, names)
    assert isinstance(limits, MotionLimits)
    assert limits.robot == robot and limits.joint_names == tuple(names)
    for field in JOINT_FIELDS:
        values = getattr(limits, field)
        assert values.shape == (model.nv,)
        assert np.all(np.isfinite(values)) and np.all(values > 0)
        with pytest.raises(ValueError):
            values[0] = 1.0  # read-only
    for field in EE_FIELDS:
        value = getattr(limits, field)
        assert isinstance(value, float) and math.isfinite(value) and value > 0
    # Never faster than the model's own URDF limit, beyond its rounding of the data sheets
    # (the iiwa URDF truncates 85 deg/s to 1.4834 rad/s: 9e-5 relative).
    assert np.all(limits.velocity_rad_s <= model.velocityLimit * (1 + 1e-4)), model.velocityLimit
    # Full acceleration is reached in under a second (a table with the columns swapped fails).
    assert np.all(limits.acceleration_rad_s2 < limits.jerk_rad_s3)


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_every_value_names_its_source(robot):
    section = bundled_table()["robots"][robot]
    limits = load_motion_limits(robot, list(section["joints"]))
    assert set(limits.sources) == set(SOURCE_KEYS)
    for key in SOURCE_KEYS:
        text = section[key]
        assert isinstance(text, str) and len(text.strip()) > 10, (robot, key)
        assert limits.sources[key] == text
    # A value group citing the principle cites one of its three rules.
    for key in SOURCE_KEYS[1:]:
        if "[principle]" in section[key]:
            assert re.search(r"\[principle\] \([123]\)", section[key]), (robot, key)


def test_panda_equals_libfranka_rate_limiting_h():
    """libfranka 0.7.1 include/franka/rate_limiting.h, its expressions typed again here."""
    k_limit_eps, k_delta_t, k_packets_lost = 1e-3, 1e-3, 3.0
    acceleration = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]) - k_limit_eps
    jerk = np.array([7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0]) - k_limit_eps
    velocity = np.array([2.175] * 4 + [2.61] * 3) - k_limit_eps - k_packets_lost * k_delta_t * acceleration
    translational_acceleration = 13.0 - k_limit_eps
    translational_velocity = 1.7 - k_limit_eps - k_packets_lost * k_delta_t * translational_acceleration
    limits = load_motion_limits("panda", [f"panda_joint{i}" for i in range(1, 8)])
    np.testing.assert_allclose(limits.acceleration_rad_s2, acceleration, rtol=1e-12)
    np.testing.assert_allclose(limits.jerk_rad_s3, jerk, rtol=1e-12)
    np.testing.assert_allclose(limits.velocity_rad_s, velocity, rtol=1e-12)
    assert limits.ee_speed_m_s == pytest.approx(translational_velocity, rel=1e-12)
    assert limits.ee_acceleration_m_s2 == pytest.approx(translational_acceleration, rel=1e-12)
    assert limits.ee_jerk_m_s3 == pytest.approx(6500.0 - k_limit_eps, rel=1e-12)


def test_iiwa_speeds_equal_kukas_data_sheet():
    limits = load_motion_limits("iiwa", [f"joint_a{i}" for i in range(1, 8)])
    np.testing.assert_allclose(limits.velocity_rad_s, np.deg2rad([85, 85, 100, 75, 130, 135, 135]), rtol=1e-12)


def test_documented_degree_figures():
    xarm = load_motion_limits("xarm7", [f"joint{i}" for i in range(1, 8)])
    np.testing.assert_allclose(xarm.acceleration_rad_s2, np.deg2rad(1146.0), rtol=1e-12)
    np.testing.assert_allclose(xarm.jerk_rad_s3, np.deg2rad(28647.0), rtol=1e-12)
    assert (xarm.ee_speed_m_s, xarm.ee_acceleration_m_s2, xarm.ee_jerk_m_s3) == (1.0, 50.0, 100.0)
    kinova = load_motion_limits("kinova", [f"j2s6s200_joint_{i}" for i in range(1, 7)])
    np.testing.assert_allclose(kinova.velocity_rad_s, np.deg2rad([36, 36, 36, 48, 48, 48]), rtol=1e-11)
    np.testing.assert_allclose(kinova.acceleration_rad_s2, np.deg2rad(200.0), rtol=1e-12)
    assert (kinova.ee_speed_m_s, kinova.ee_acceleration_m_s2) == (0.2, 0.64)
    ur5 = load_motion_limits("ur5", ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                     "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"])
    np.testing.assert_allclose(ur5.velocity_rad_s, np.deg2rad(180.0), rtol=1e-15)
    np.testing.assert_allclose(ur5.acceleration_rad_s2, 5.0)


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_values_from_the_principle_follow_it(robot):
    """Where a source cites the principle, the value is the principle's arithmetic."""
    principle = bundled_table()["principle"]
    to_speed_s, to_acceleration_s = principle["time_to_speed_s"], principle["time_to_acceleration_s"]
    section = bundled_table()["robots"][robot]
    limits = load_motion_limits(robot, list(section["joints"]))
    cites = {key: "[principle]" in section[key] for key in SOURCE_KEYS}
    if cites["acceleration_source"]:
        np.testing.assert_allclose(limits.acceleration_rad_s2, limits.velocity_rad_s / to_speed_s, rtol=1e-12)
    if cites["jerk_source"]:
        np.testing.assert_allclose(limits.jerk_rad_s3, limits.acceleration_rad_s2 / to_acceleration_s, rtol=1e-12)
    if cites["ee_speed_source"]:
        assert limits.ee_speed_m_s == principle["ee_speed_m_s"]
    if cites["ee_acceleration_source"]:
        assert limits.ee_acceleration_m_s2 == pytest.approx(limits.ee_speed_m_s / to_speed_s, rel=1e-12)
    if cites["ee_jerk_source"]:
        assert limits.ee_jerk_m_s3 == pytest.approx(limits.ee_acceleration_m_s2 / to_acceleration_s, rel=1e-12)
    # The principle's times are at least the slowest documented ones: panda joint 2 reaches
    # 2.175 rad/s at 7.5 rad/s^2; the xArm ramps to 20 rad/s^2 at 500 rad/s^3.
    assert to_speed_s >= 2.175 / 7.5 and to_acceleration_s >= 20.0 / 500.0


def test_limits_follow_the_order_of_joint_names():
    names = [f"panda_joint{i}" for i in range(1, 8)]
    forward = load_motion_limits("panda", names)
    backward = load_motion_limits("panda", names[::-1])
    assert backward.joint_names == tuple(names[::-1])
    for field in JOINT_FIELDS:
        np.testing.assert_array_equal(getattr(backward, field), getattr(forward, field)[::-1])


PANDA = [f"panda_joint{i}" for i in range(1, 8)]


def refused(message: str):
    """Expect a MotionLimitsError whose message contains ``message`` verbatim."""
    return pytest.raises(MotionLimitsError, match=re.escape(message))


def test_unknown_robot_names_it_and_the_known_ones():
    with refused("no motion limits for robot 'fanuc'; the table has panda, iiwa"):
        load_motion_limits("fanuc", PANDA)


def test_missing_joint_names_robot_and_joint(table):
    del table["robots"]["panda"]["joints"]["panda_joint4"]
    with refused("motion limits of 'panda': no entry for joint 'panda_joint4'"):
        load_motion_limits("panda", PANDA, table=table)


def test_joint_the_model_lacks_is_named():
    with refused("motion limits of 'panda': no entry for joint 'panda_finger_joint1'"):
        load_motion_limits("panda", PANDA + ["panda_finger_joint1"])


def test_extra_joint_names_robot_and_joint():
    with refused("motion limits of 'panda': joint 'panda_joint7' is in the table but not in the model"):
        load_motion_limits("panda", PANDA[:-1])


def test_repeated_joint_name_is_refused():
    with refused("motion limits of 'panda': joint 'panda_joint2' is named twice"):
        load_motion_limits("panda", PANDA[:2] + PANDA[1:])


@pytest.mark.parametrize("bad, shown", [(0.0, "0.0"), (-7.5, "-7.5"), (math.nan, "nan"), (math.inf, "inf"), (0, "0")])
def test_non_positive_or_non_finite_limit_names_robot_joint_and_field(table, bad, shown):
    table["robots"]["panda"]["joints"]["panda_joint2"]["acceleration_rad_s2"] = bad
    message = f"motion limits of 'panda': joint 'panda_joint2' acceleration_rad_s2 must be finite and > 0, got {shown}"
    with refused(message):
        load_motion_limits("panda", PANDA, table=table)


def test_nan_written_in_toml_is_refused(table):
    """TOML has nan and inf literals: a table written with them fails the same way."""
    table["robots"]["panda"]["joints"]["panda_joint3"] = tomllib.loads(
        "x = { velocity_rad_s = 2.1, acceleration_rad_s2 = 10.0, jerk_rad_s3 = nan }")["x"]
    with refused("joint 'panda_joint3' jerk_rad_s3 must be finite and > 0, got nan"):
        load_motion_limits("panda", PANDA, table=table)


def test_non_number_and_missing_field_are_named(table):
    joints = table["robots"]["panda"]["joints"]
    joints["panda_joint1"]["velocity_rad_s"] = "2.1"
    with refused("joint 'panda_joint1' velocity_rad_s must be a number, got '2.1'"):
        load_motion_limits("panda", PANDA, table=table)
    joints["panda_joint1"]["velocity_rad_s"] = True
    with refused("joint 'panda_joint1' velocity_rad_s must be a number, got True"):
        load_motion_limits("panda", PANDA, table=table)
    del joints["panda_joint1"]["velocity_rad_s"]
    with refused("motion limits of 'panda': joint 'panda_joint1' has no velocity_rad_s"):
        load_motion_limits("panda", PANDA, table=table)


def test_bad_end_effector_value_is_named(table):
    table["robots"]["ur5"]["ee_jerk_m_s3"] = -40.0
    with refused("motion limits of 'ur5': end-effector ee_jerk_m_s3 must be finite and > 0, got -40.0"):
        load_motion_limits("ur5", list(table["robots"]["ur5"]["joints"]), table=table)
    del table["robots"]["ur5"]["ee_jerk_m_s3"]
    with refused("motion limits of 'ur5': end-effector ee_jerk_m_s3 is missing"):
        load_motion_limits("ur5", list(table["robots"]["ur5"]["joints"]), table=table)


@pytest.mark.parametrize("key", SOURCE_KEYS)
def test_missing_source_is_an_error(table, key):
    table["robots"]["z1"][key] = "  "
    with refused(f"motion limits of 'z1': {key} is missing"):
        load_motion_limits("z1", list(table["robots"]["z1"]["joints"]), table=table)


def test_foreign_table_is_refused(table):
    table["format"] = "something-else"
    with pytest.raises(MotionLimitsError, match="table is not 'cobotsafety-motion-limits' version 1"):
        load_motion_limits("panda", PANDA, table=table)


def test_error_is_a_package_error():
    assert issubclass(MotionLimitsError, CobotSafetyError) and issubclass(MotionLimitsError, ValueError)
