"""The control loop: guard (NaN, cap, rate limit), inputs, threads, against the planar robot."""

import threading
import time

import numpy as np
import pytest
from hypothesis import given, strategies as st

from cobotsafety.app.control_loop import ControlLoop, LoopSettings, LoopStats, guard_command
from cobotsafety.app.gizmo import GizmoSettings
from cobotsafety.errors import CobotSafetyError
from cobotsafety.planar.planar_teleop import PlanarTeleop


def test_guard_hand_worked():
    # target 1 m/s along x from rest, cap 0.25, accel 2 m/s^2 at dt 2 ms: change <= 0.004 m/s.
    v = guard_command(np.array([1.0, 0.0]), np.zeros(2), 0.002, 0.25, 2.0)
    np.testing.assert_allclose(v, [0.004, 0.0])
    # already at 0.1 along y, target 0.1 along y: no change.
    np.testing.assert_allclose(guard_command(np.array([0.0, 0.1]), np.array([0.0, 0.1]), 0.002, 0.25, 2.0), [0, 0.1])


def test_guard_nan_and_wrong_shape_decelerate_towards_zero():
    previous = np.array([0.1, 0.0, 0.0])
    for bad in (np.array([np.nan, 0.0, 0.0]), np.array([1.0, 2.0])):
        v = guard_command(bad, previous, 0.002, 0.25, 2.0)
        np.testing.assert_allclose(v, [0.096, 0.0, 0.0])


vectors = st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=2, max_size=2)


@given(vectors, st.lists(st.floats(-0.25, 0.25), min_size=2, max_size=2))
def test_guard_invariants(target, previous):
    previous = np.array(previous) * (0.25 / max(0.25, np.linalg.norm(previous)))
    v = guard_command(np.array(target), previous, 0.002, 0.25, 2.0)
    assert np.all(np.isfinite(v))
    assert np.linalg.norm(v) <= 0.25 + 1e-9
    assert np.linalg.norm(v - previous) <= 0.004 + 1e-12


def guard_reference(v_target, v_previous, dt_s, max_speed, max_accel):
    """The guard written with numpy norms (its first implementation): the oracle."""
    v_previous = np.asarray(v_previous, dtype=float)
    v_target = np.asarray(v_target, dtype=float)
    if v_target.shape != v_previous.shape or not np.all(np.isfinite(v_target)):
        v_target = np.zeros_like(v_previous)
    with np.errstate(over="ignore"):
        speed = float(np.linalg.norm(v_target))
    if not np.isfinite(speed):
        v_target, speed = np.zeros_like(v_previous), 0.0
    if speed > max_speed:
        v_target = v_target * (max_speed / speed)
    change = v_target - v_previous
    size = float(np.linalg.norm(change))
    if size > max_accel * dt_s:
        change = change * (max_accel * dt_s / size)
    return v_previous + change


# below 1e150 the reference's squared norm cannot overflow (see the test after this one)
components = st.one_of(st.floats(-1e150, 1e150), st.sampled_from([np.nan, np.inf, -np.inf]))


@given(st.lists(components, min_size=2, max_size=3), st.lists(st.floats(-0.25, 0.25), min_size=3, max_size=3),
       st.sampled_from([0.001, 0.002, 0.01]))
def test_guard_equals_the_numpy_reference(target, previous, dt_s):
    previous = np.array(previous)
    v = guard_command(np.array(target), previous, dt_s, 0.25, 2.0)
    assert v.shape == previous.shape
    np.testing.assert_allclose(v, guard_reference(np.array(target), previous, dt_s, 0.25, 2.0), rtol=1e-12, atol=1e-15)


def test_guard_caps_a_huge_finite_target_along_its_direction():
    # the reference's squared norm overflowed for 1e154 and dropped it as garbage; hypot does
    # not overflow, so it is capped like any other command (only the acceleration step moves)
    v = guard_command(np.array([0.0, 0.0, 1.34e154]), np.zeros(3), 0.001, 0.25, 2.0)
    np.testing.assert_allclose(v, [0.0, 0.0, 0.002])
    v = guard_command(np.array([1.5e308, 1.5e308, 0.0]), np.array([0.0, 0.1, 0.0]), 0.001, 0.25, 2.0)
    np.testing.assert_allclose(v, [0.0, 0.098, 0.0])  # the norm overflows even for hypot: zero target


def test_stats_percentiles():
    stats = LoopStats(window=100)
    for period in [0.002] * 98 + [0.010, 0.012]:
        stats.add(period)
    s = stats.summary()
    assert s["p50_ms"] == pytest.approx(2.0)
    assert s["max_ms"] == pytest.approx(12.0)
    assert s["rate_hz"] == pytest.approx(1.0 / np.mean([0.002] * 98 + [0.010, 0.012]))


def make_loop(**kw):
    return ControlLoop(PlanarTeleop(), LoopSettings(**kw), GizmoSettings(dead_band_m=0.0, gain_per_s=2.0))


def test_gizmo_drag_moves_end_effector_towards_gizmo_and_release_stops():
    loop = make_loop()
    start = loop.snapshot().p_base_ee_m
    target = start + np.array([0.05, 0.0, 0.0])
    assert loop.set_gizmo_target(target)
    for _ in range(500):
        loop.step_once()
    moved = loop.snapshot().p_base_ee_m
    assert moved[0] - start[0] > 0.02  # pulled towards +x
    assert np.linalg.norm(target - moved) < np.linalg.norm(target - start)
    loop.release_gizmo()
    for _ in range(200):  # decelerates at <= 2 m/s^2 then holds still
        loop.step_once()
    before = loop.snapshot().p_base_ee_m
    for _ in range(50):
        loop.step_once()
    np.testing.assert_array_equal(loop.snapshot().p_base_ee_m, before)


def test_garbage_gizmo_updates_are_ignored():
    loop = make_loop()
    for bad in ([np.nan, 0, 0], [1, 2], "x", None, [np.inf, 0, 0]):
        assert not loop.set_gizmo_target(bad)
    assert not loop.snapshot().dragging


def test_flood_of_far_gizmo_updates_cannot_make_the_robot_jump():
    loop = make_loop()
    rng = np.random.default_rng(0)
    settings = loop.settings
    previous = loop.snapshot().p_base_ee_m
    for _ in range(300):
        for _ in range(20):  # 20 updates per control period, all over the place
            loop.set_gizmo_target(rng.uniform(-1e6, 1e6, 3))
        report = loop.step_once()
        now = loop.snapshot().p_base_ee_m
        assert np.linalg.norm(report.v_desired_m_s) <= settings.max_speed_m_s + 1e-9
        # the robot's speed stays under the cap (the filter only slows it down)
        assert np.linalg.norm(now - previous) <= settings.max_speed_m_s * settings.dt_s * 1.01
        previous = now


def test_jog_expires():
    loop = make_loop(jog_hold_s=0.1)
    loop.jog(np.array([0.0, -0.05]))
    for _ in range(30):
        loop.step_once()
    assert loop.snapshot().v_sent_m_s[1] < 0.0
    for _ in range(100):
        loop.step_once()
    np.testing.assert_allclose(loop.snapshot().v_sent_m_s, 0.0)


def test_bad_method_is_refused():
    loop = make_loop()
    with pytest.raises(CobotSafetyError, match="method"):
        loop.method = "fast"
    assert loop.method == "anticipative"


def test_reset_returns_home():
    loop = make_loop()
    home = loop.snapshot().p_base_ee_m
    loop.jog(np.array([0.1, 0.0]))
    for _ in range(100):
        loop.step_once()
    assert not np.allclose(loop.snapshot().p_base_ee_m, home)
    loop.reset()
    np.testing.assert_allclose(loop.snapshot().p_base_ee_m, home)
    assert loop.snapshot().steps == 0


def test_thread_runs_and_survives_a_failing_hook_and_concurrent_inputs():
    loop = make_loop()
    calls = {"n": 0}

    def flaky(t_s):
        calls["n"] += 1
        if calls["n"] == 5:
            raise RuntimeError("sensor glitch")

    loop.before_step.append(flaky)
    loop.start()
    try:
        stop = threading.Event()

        def spam():
            rng = np.random.default_rng(1)
            while not stop.is_set():
                loop.set_gizmo_target(rng.normal(size=3))
                loop.method = "stop"
                loop.method = "anticipative"

        spammer = threading.Thread(target=spam)
        spammer.start()
        deadline = time.monotonic() + 30
        while loop.snapshot().steps < 200 and time.monotonic() < deadline:
            time.sleep(0.02)
        stop.set()
        spammer.join()
        assert loop.running
        assert loop.snapshot().steps >= 200
        assert np.all(np.isfinite(loop.snapshot().p_base_ee_m))
    finally:
        loop.stop()
    assert not loop.running


class SlowRobot:
    """A robot whose step takes 6 ms: the loop cannot hold 500 Hz with it."""

    dim = 2

    def __init__(self):
        self.dts: list[float] = []

    def reset(self) -> None:
        pass

    @property
    def p_base_ee_m(self) -> np.ndarray:
        return np.zeros(3)

    def step(self, v, dt_s, method="anticipative"):
        time.sleep(0.006)
        self.dts.append(dt_s)
        return None


def test_an_overrunning_loop_integrates_the_time_that_passed_up_to_10_ms():
    robot = SlowRobot()
    loop = ControlLoop(robot)
    loop.start()
    start = time.perf_counter()
    time.sleep(0.6)
    loop.stop()
    wall = time.perf_counter() - start
    dts = np.array(robot.dts)
    assert dts.min() >= loop.settings.dt_s - 1e-12 and dts.max() <= 0.010 + 1e-12
    assert np.median(dts) > 0.005  # not the nominal 2 ms: the robot keeps real time
    assert dts.sum() == pytest.approx(wall, rel=0.25)


def test_stats_running_rate_matches_the_window_mean_after_wrapping():
    stats = LoopStats(window=100)
    rng = np.random.default_rng(3)
    periods = rng.uniform(0.0008, 0.004, 1234)
    for period in periods:
        stats.add(period, late_s=period / 2)
    assert stats.rate_hz == pytest.approx(1.0 / periods[-100:].mean(), rel=1e-12)
    s = stats.summary()
    assert s["rate_hz"] == pytest.approx(stats.rate_hz, rel=1e-12)
    assert s["late_p99_ms"] == pytest.approx(np.percentile(periods[-100:] / 2, 99) * 1e3)
    assert LoopStats().rate_hz == 0.0


class SimulatedClock:
    """Time that passes only when the loop sleeps or the robot works."""

    def __init__(self):
        self.now_s = 50.0
        self.sleeps: list[float] = []

    def __call__(self) -> float:
        return self.now_s

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now_s += seconds + 60e-6  # a sleep wakes 60 us late


class StallingRobot(SlowRobot):
    """Works 200 us a step, 6 ms every 100th step; stops the loop after ``steps`` steps."""

    def __init__(self, clock: SimulatedClock, loop_ref: list, steps: int):
        super().__init__()
        self.clock, self.loop_ref, self.steps = clock, loop_ref, steps

    def step(self, v, dt_s, method="anticipative"):
        self.dts.append(dt_s)
        self.clock.now_s += 0.006 if len(self.dts) % 100 == 0 else 0.0002
        if len(self.dts) == self.steps:
            self.loop_ref[0]._stop.set()


def test_the_loop_catches_up_after_a_stall_on_a_simulated_clock():
    clock = SimulatedClock()
    loop_ref: list = []
    robot = StallingRobot(clock, loop_ref, steps=1000)
    loop = ControlLoop(robot, LoopSettings(rate_hz=1000.0))
    loop_ref.append(loop)
    loop.clock, loop.sleep = clock, clock.sleep
    start_s = clock.now_s
    loop._run()
    assert robot.dts == [0.001] * 1000  # every tick a nominal step, also around the stalls
    assert loop.stats.overruns == 0
    # 1000 ticks in 1000 periods of wall time (plus the last tick's work and the stall): held
    assert clock.now_s - start_s == pytest.approx(1.0, abs=0.007)
    summary = loop.stats.summary()
    assert summary["rate_hz"] == pytest.approx(1000.0, rel=0.01)
    assert summary["max_ms"] == pytest.approx(6.0)  # the stall shows in the periods
    assert loop.snapshot().t_s == pytest.approx(1.0)
