"""Input devices read on the server: axes to velocity, the device-free test double driving the
control loop through ``ControlLoop.set_device_velocity``, the gizmo taking precedence, bad
values dropped, and a missing joystick reported in one line."""

from __future__ import annotations

import numpy as np
import pytest

from cobotsafety.app.control_loop import ControlLoop, LoopSettings
from cobotsafety.app.input_device import AxisSettings, DeviceFeeder, ScriptedDevice, axes_to_velocity, open_device
from cobotsafety.planar.planar_teleop import PlanarTeleop


def test_axes_to_velocity_dead_zone_cap_and_bad_values():
    settings = AxisSettings(max_speed_m_s=0.2, dead_zone=0.1)
    assert np.all(axes_to_velocity((0.05, -0.05, 0.0), settings) == 0.0)  # inside the dead zone
    full = axes_to_velocity((1.0, 0.0, 0.0), settings)
    assert full == pytest.approx([0.2, 0.0, 0.0])
    assert np.linalg.norm(axes_to_velocity((5.0, 5.0, 5.0), settings)) == pytest.approx(0.2)  # capped
    just_out = axes_to_velocity((0.1001, 0.0, 0.0), settings)
    assert 0.0 < just_out[0] < 1e-3  # continuous from the dead zone's edge
    half = axes_to_velocity((0.0, -0.55, 0.0), settings)
    assert half == pytest.approx([0.0, -0.2 * (0.55 - 0.1) / 0.9, 0.0])
    assert np.all(axes_to_velocity((np.nan, 1.0, 0.0), settings) == 0.0)
    assert axes_to_velocity((0.5,), settings).shape == (3,)


def test_the_scripted_device_drives_the_robot_when_no_gizmo_drag_is_in_progress():
    robot = PlanarTeleop()
    loop = ControlLoop(robot, LoopSettings())
    device = ScriptedDevice([(0.0, 1.0, 0.0)])
    feeder = DeviceFeeder(device, loop.set_device_velocity, dim=2)
    assert feeder.poll_once() == pytest.approx([0.0, 0.25])
    start = robot.p_base_ee_m.copy()
    for _ in range(200):
        loop.step_once()
    moved = robot.p_base_ee_m - start
    assert moved[1] > 0.03 and abs(moved[0]) < 0.2 * moved[1]  # along +y, as the stick asked
    # A gizmo drag takes precedence: toward a target on the other side.
    target = robot.p_base_ee_m + np.array([0.05, -0.05, 0.0])
    loop.set_gizmo_target(target)
    before = np.linalg.norm(target[:2] - robot.p_base_ee_m[:2])
    for _ in range(200):
        loop.step_once()
    assert np.linalg.norm(target[:2] - robot.p_base_ee_m[:2]) < before
    loop.release_gizmo()
    # No device: nothing moves.
    feeder.sink(None)
    for _ in range(300):  # let the acceleration limit bring the command to rest
        loop.step_once()
    rest = robot.p_base_ee_m.copy()
    loop.step_once()
    assert np.allclose(robot.p_base_ee_m, rest)


def test_a_lost_or_broken_device_commands_nothing():
    loop = ControlLoop(PlanarTeleop())
    assert not loop.set_device_velocity(np.array([np.nan, 0.1]))
    assert loop.desired_velocity() == pytest.approx([0.0, 0.0])
    assert not loop.set_device_velocity("fast")
    assert loop.set_device_velocity(np.array([0.1, 0.0, 0.3]))  # a 3-axis device on the planar arm: x, y used
    assert loop.desired_velocity() == pytest.approx([0.1, 0.0])
    feeder = DeviceFeeder(ScriptedDevice([None]), loop.set_device_velocity, dim=2)
    assert feeder.poll_once() is None
    assert loop.desired_velocity() == pytest.approx([0.0, 0.0])

    class Broken:
        def velocity_m_s(self):
            raise OSError("unplugged")

    loop.set_device_velocity(np.array([0.1, 0.0]))
    assert DeviceFeeder(Broken(), loop.set_device_velocity, dim=2).poll_once() is None
    assert loop.desired_velocity() == pytest.approx([0.0, 0.0])


def test_no_joystick_is_one_clear_line():
    with pytest.raises(RuntimeError, match=r"^joystick: no joystick or gamepad #0 found \(0 connected\)$"):
        open_device("joystick")
    with pytest.raises(RuntimeError, match="unknown device 'wheel'"):
        open_device("wheel")
