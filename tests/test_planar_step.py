"""The planar step: never crosses a limitation; baselines; bad input."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest

from cobotsafety.planar.rr_arm import Kinematics, PlanarArm
from cobotsafety.planar.limitations import PolygonZone
from cobotsafety.planar.planar_scenes import arm_limitations, demo_scene
from cobotsafety.planar.planar_step import PlanarScene, PlanarState, measures, step
from cobotsafety.planar.planar_teleop import PlanarTeleop


def run_random_steps(scene, method, n_steps, seed):
    """Random commands (including large ones) and dt up to 10 ms; return the worst crossing."""
    rng = np.random.default_rng(seed)
    t1, t2 = scene.arm.inverse_kinematics(-0.2, 0.03)
    state = PlanarState(t1, t2)
    worst = 0.0
    previous = [m[0] for m in measures(scene, Kinematics(scene.arm, t1, t2))]
    direction = rng.normal(size=2)
    for i in range(n_steps):
        if i % 50 == 0:  # hold a direction for a while, so limitations are reached
            direction = rng.normal(size=2) * rng.choice([0.05, 0.3, 2.0])
        dt_s = rng.uniform(1e-4, 0.01)
        state, _ = step(state, direction, dt_s, scene, method)
        now = [m[0] for m in measures(scene, Kinematics(scene.arm, state.theta_1, state.theta_2))]
        for d0, d1 in zip(previous, now):
            worst = min(worst, d1 - min(d0, 0.0))
        previous = now
    return worst


@pytest.mark.parametrize("method", ["anticipative", "stop", "reactive"])
def test_no_limitation_is_ever_crossed(method):
    # 10^4 steps per method here; `cobotsafety bench planar --invariant 100000` runs 10^5.
    worst = run_random_steps(demo_scene(), method, 10_000, seed=7)
    assert worst >= -1e-9


def triangle_scene():
    """The arm's own limitations and a triangle 9 cm above the start, its bottom edge at y = 0.12 m."""
    arm = PlanarArm()
    return PlanarScene(arm, arm_limitations(arm) + [PolygonZone("F triangle", ((-0.24, 0.12), (-0.10, 0.12), (-0.17, 0.22)))])


def test_anticipative_slides_along_a_limitation_where_stop_halts():
    scene = triangle_scene()
    for method, expect_moving in (("anticipative", True), ("stop", False)):
        robot = PlanarTeleop(scene)
        for _ in range(500):  # push up-left into the triangle's bottom edge for 1 s
            report = robot.step(np.array([-0.02, 0.2]), 0.002, method)
        speed = np.linalg.norm(report.v_executed_m_s)
        if expect_moving:
            assert speed > 0.015  # the tangential part of the command survives
            assert "F triangle" in report.binding
        else:
            assert speed == 0.0 and report.stopped


def test_stop_lets_the_robot_move_away_from_the_limitation():
    robot = PlanarTeleop(triangle_scene())
    for _ in range(1000):
        robot.step(np.array([0.0, 0.2]), 0.002, "stop")
    y_at_limit = robot.p_base_ee_m[1]
    report = robot.step(np.array([0.0, -0.1]), 0.002, "stop")
    assert not report.stopped and robot.p_base_ee_m[1] < y_at_limit


def test_reactive_pushes_back_inside_its_zone():
    robot = PlanarTeleop(triangle_scene())
    for _ in range(3000):
        report = robot.step(np.array([0.0, 0.2]), 0.002, "reactive")
    kin = robot.kinematics
    triangle = robot.scene.limitations[-1]
    # The spring balances the command before the limit: it stalls inside the repulsion zone.
    assert 0.0 < triangle.distance(kin) < robot.scene.reactive.zone_width_m
    assert np.linalg.norm(report.v_executed_m_s) < 1e-3


def test_recovery_from_inside_a_limitation_only_allows_reducing_the_violation():
    scene = demo_scene()
    t1, t2 = scene.arm.inverse_kinematics(-0.38, 0.26)  # inside the rectangle, 3 cm from its top
    state = PlanarState(t1, t2)
    rectangle = next(lim for lim in scene.limitations if lim.name == "F rectangle zone")
    d0 = rectangle.distance(Kinematics(scene.arm, t1, t2))
    assert d0 == pytest.approx(-0.03)
    out, _ = step(state, (0.0, 0.3), 0.002, scene)  # toward the nearest face: allowed
    assert rectangle.distance(Kinematics(scene.arm, out.theta_1, out.theta_2)) > d0 + 1e-4
    deeper, info = step(state, (0.0, -0.3), 0.002, scene)  # deeper: refused
    assert rectangle.distance(Kinematics(scene.arm, deeper.theta_1, deeper.theta_2)) >= d0 - 1e-12
    assert "F rectangle zone" in info.binding


def test_non_finite_command_gives_zero_and_a_warning(caplog):
    robot = PlanarTeleop()
    before = robot.p_base_ee_m
    with caplog.at_level(logging.WARNING):
        report = robot.step(np.array([np.nan, 0.1]), 0.002)
    np.testing.assert_array_equal(report.v_commanded_m_s, [0.0, 0.0])
    np.testing.assert_array_equal(robot.p_base_ee_m, before)
    assert all(math.isfinite(v) for v in robot.p_base_ee_m)
    assert "not finite" in caplog.text


def test_wrong_shapes_name_the_argument():
    robot = PlanarTeleop()
    with pytest.raises(ValueError, match="v_desired_m_s"):
        robot.step(np.zeros(3), 0.002)
    with pytest.raises(ValueError, match="dt_s"):
        step(robot.state, (0.0, 0.0), 0.0, robot.scene)
    with pytest.raises(ValueError, match="method"):
        robot.step(np.zeros(2), 0.002, "teleport")


def test_baselines_do_not_import_the_step():
    """Data flows one way: ``step`` uses ``baselines``, never the reverse (STYLE.md)."""
    import ast
    import inspect

    import cobotsafety.planar.baselines as baselines

    tree = ast.parse(inspect.getsource(baselines))
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    imported |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
    assert "cobotsafety.planar.planar_step" not in imported


def _all_scenes():
    from cobotsafety.planar.planar_scenes import conditioning_scene, fig9_scene

    return [demo_scene(), fig9_scene("a"), fig9_scene("b"), conditioning_scene()]


def test_distances_equal_the_measures_distances_on_random_states():
    rng = np.random.default_rng(11)
    for scene in _all_scenes():
        arm = scene.arm
        for _ in range(500):
            t1 = rng.uniform(arm.theta_1_min_rad - 0.2, arm.theta_1_max_rad + 0.2)
            t2 = rng.uniform(arm.theta_2_min_rad - 0.2, arm.theta_2_max_rad + 0.2)
            full, light = Kinematics(arm, t1, t2), Kinematics(arm, t1, t2, jacobian=False)
            for limitation in scene.limitations:
                assert limitation.distances(light) == pytest.approx([m[0] for m in limitation.measures(full)],
                                                                    abs=1e-15)
                assert all(m[4] == limitation.angular for m in limitation.measures(full))


def test_no_distance_moves_more_than_the_reach_bound_of_a_joint_step():
    """The safety net skips limitations farther than (L1 + L2)|d theta_1| + L2 |d theta_2| (lengths)
    or max |d theta_i| (angles): check that bound against the distances themselves."""
    rng = np.random.default_rng(12)
    for scene in _all_scenes():
        arm = scene.arm
        for _ in range(2000):
            t1, t2 = rng.uniform(-0.6, 3.7), rng.uniform(0.02, 3.12)
            d1, d2 = rng.normal(scale=rng.choice([1e-3, 1e-2, 0.1]), size=2)
            a, b = Kinematics(arm, t1, t2, jacobian=False), Kinematics(arm, t1 + d1, t2 + d2, jacobian=False)
            reach_m = (arm.link_1_m + arm.link_2_m) * abs(d1) + arm.link_2_m * abs(d2)
            for limitation in scene.limitations:
                bound = max(abs(d1), abs(d2)) if limitation.angular else reach_m
                for before, after in zip(limitation.distances(a), limitation.distances(b)):
                    assert abs(after - before) <= bound + 1e-12


@pytest.mark.parametrize("method", ["anticipative", "stop", "reactive"])
def test_the_reachable_only_safety_net_equals_the_full_one(method):
    rng = np.random.default_rng(13)
    nets = 0
    for scene, home in zip(_all_scenes(), [(-0.2, 0.03)] * 3 + [(0.0, 0.45)]):
        state = PlanarState(*scene.arm.inverse_kinematics(*home))
        for i in range(2000):
            if i % 50 == 0:  # large commands and long steps: the net acts on curved limitations
                direction = rng.normal(size=2) * rng.choice([0.3, 2.0])
            dt_s = rng.uniform(2e-3, 0.01)
            fast, info = step(state, direction, dt_s, scene, method)
            reference, ref_info = step(state, direction, dt_s, scene, method, reachable_only=False)
            assert fast == reference and info == ref_info
            nets += info.net_scale < 1.0
            state = fast
    assert method != "anticipative" or nets > 0  # the net did act in these runs
