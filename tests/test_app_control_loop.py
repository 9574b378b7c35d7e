"""The control loop: inputs, threads, timing, against the planar robot."""

import threading
import time
import types

import numpy as np
import pytest

from cobotsafety.app.control_loop import ControlLoop, LoopSettings, LoopStats
from cobotsafety.app.gizmo import GizmoSettings
from cobotsafety.errors import CobotSafetyError
from cobotsafety.planar.planar_teleop import PlanarTeleop


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
    cap = loop.gizmo.max_speed_m_s
    previous = loop.snapshot().p_base_ee_m
    for _ in range(300):
        for _ in range(20):  # 20 updates per control period, all over the place
            loop.set_gizmo_target(rng.uniform(-1e6, 1e6, 3))
        report = loop.step_once()
        now = loop.snapshot().p_base_ee_m
        assert np.linalg.norm(report.v_desired_m_s) <= cap + 1e-9  # the gizmo's cap
        # the robot's speed stays under the cap (the filter only slows it down)
        assert np.linalg.norm(now - previous) <= cap * settings.dt_s * 1.01
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


def test_a_non_finite_jog_is_ignored_and_the_running_jog_goes_on():
    loop = make_loop(jog_hold_s=0.5)
    loop.jog(np.array([0.0, -0.05]))
    for _ in range(20):
        loop.step_once()
    sent = loop.snapshot().v_sent_m_s.copy()
    assert sent[1] < 0.0
    for bad in ([np.nan, 0.0], [0.0, np.inf], [0.1, 0.0, 0.0]):
        loop.jog(np.array(bad))
        loop.step_once()
        now = loop.snapshot().v_sent_m_s
        assert np.all(np.isfinite(now)) and now[1] < 0.0, bad  # still the first jog


@pytest.mark.parametrize("far_m", [3.0, 1e3])
def test_a_gizmo_beyond_the_workspace_pulls_toward_its_point_on_the_sphere(far_m):
    loop = make_loop()
    radius = loop.settings.workspace_radius_m
    assert far_m > radius
    ee = np.asarray(loop.snapshot().p_base_ee_m, dtype=float)
    side = np.array([-ee[1], ee[0], 0.0]) / np.linalg.norm(ee[:2])  # across the hand's direction
    far = far_m * side
    assert loop.set_gizmo_target(far)
    v = np.zeros(3)
    v_desired = loop.step_once().v_desired_m_s
    v[:v_desired.shape[0]] = v_desired
    unit = lambda x: x / np.linalg.norm(x)  # noqa: E731
    toward = unit(radius * side - ee)
    assert np.linalg.norm(unit(far - ee) - toward) > 0.02  # (the two points lie apart as seen from the hand)
    assert np.allclose(unit(v), toward, atol=1e-9)


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
        assert loop.running and loop.hook_failures == 1
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


class HandOverRobot(SlowRobot):
    """A robot whose hand goes over its own limits at step 10 only (``hand_over_limit``)."""

    def step(self, v, dt_s, method="anticipative"):
        self.dts.append(dt_s)
        return types.SimpleNamespace(hand_over_limit=len(self.dts) == 10)


def test_a_hand_over_its_limits_stays_in_the_snapshot_for_a_second():
    """The excess lasts tens of steps; the status block refreshes every few frames: the snapshot
    says so from that step until ``HAND_OVER_SHOWN_S`` of the loop's time later, then not."""
    from cobotsafety.app.control_loop import HAND_OVER_SHOWN_S

    loop = ControlLoop(HandOverRobot())
    dt = loop.settings.dt_s
    seen = []
    for _ in range(9 + int(round(HAND_OVER_SHOWN_S / dt)) + 5):
        loop.step_once()
        seen.append(loop.snapshot().hand_over_limit)
    assert not any(seen[:9]) and seen[9]
    shown = int(np.argmin(seen[9:]))  # steps it stayed shown, from the step over
    assert abs(shown - (HAND_OVER_SHOWN_S / dt + 1)) <= 1 and not any(seen[9 + shown:])  # (the clock's rounding)
    loop.reset()
    assert not loop.snapshot().hand_over_limit
