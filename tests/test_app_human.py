"""The demo's 3D scene with the replayed human as a moving protection zone, and the SSM checkbox."""

import numpy as np
import pytest

from cobotsafety.app.demo_app import DemoApp, DemoConfig
from cobotsafety.geometry.capsule import capsule_distance
from cobotsafety.ports import free_local_port


@pytest.fixture(scope="module")
def app():
    demo = DemoApp(DemoConfig(scene="arm", port=free_local_port()))  # threads not started: driven by hand
    demo.ensure_replay()
    yield demo
    demo.server.stop()


def separation(app, human) -> float:
    """Oracle: the robot capsules but the base against the human, from the geometry."""
    state = app.loop.robot.state
    d, _, _ = capsule_distance(state.capsule_p0[1:, None], state.capsule_p1[1:, None], state.capsule_radius[1:, None],
                               human.p0_b_m[None], human.p1_b_m[None], human.radius_m[None])
    return float(d.min())


def test_replayed_human_reaches_the_controller(app):
    app.replay.playing = False
    app.replay.seek(5.0)  # exp1: the co-worker reaches towards the table
    app.render_once()
    app.loop.step_once()
    human = app.replay.capsules()
    assert human.present
    report = app.loop.snapshot().report
    assert report.min_distance_m == pytest.approx(separation(app, human), abs=1e-6)


def test_ssm_checkbox_drives_the_robot_and_is_disabled_in_the_planar_scene(app):
    assert not app.panel.ssm.disabled
    app.panel.ssm.value = True
    app.apply_ssm()
    assert app.loop.robot.ssm is True
    app.switch_scene("planar")
    assert app.panel.ssm.disabled
    app.switch_scene("ur5")
    assert not app.panel.ssm.disabled and app.loop.robot.ssm is True
    app.panel.ssm.value = False
    app.apply_ssm()
    assert app.loop.robot.ssm is False


def test_the_arm_gives_way_to_the_replayed_human(app):
    """Drive the hand at the human for 2 s of control time: the separation holds."""
    app.switch_scene("panda")
    app.loop.method = "anticipative"
    app.replay.playing = False
    app.loop.reset()
    for t_s in np.arange(0.0, app.replay.duration_s, 0.1):  # the human paused 0.35-0.5 m away
        app.replay.seek(t_s)
        human = app.replay.capsules()
        if human.present and 0.35 < separation(app, human) < 0.5:
            break
    else:
        pytest.fail("the bundled recording never comes within 0.5 m of the home pose")
    critical = app.loop.robot.human.critical_m
    app.render_once()
    ee = app.loop.snapshot().p_base_ee_m
    centre = (human.p0_b_m[0] + human.p1_b_m[0]) / 2
    app.loop.set_gizmo_target(ee + 0.3 * (centre - ee) / np.linalg.norm(centre - ee))
    distances = []
    for _ in range(1000):
        app.loop.step_once()
        distances.append(app.loop.snapshot().report.min_distance_m)
    app.loop.release_gizmo()
    assert min(distances) >= critical - 1e-6
    assert np.linalg.norm(app.loop.snapshot().p_base_ee_m - ee) > 0.02  # it did move toward them


def test_the_person_is_drawn_opaque_and_never_below_the_floor(app):
    """Issue 25 item 11: no translucent overlaps (the dark speckles), and the floor drawn at the
    recordings' floor, under every capsule of every bundled recording."""
    from cobotsafety.app.demo_app import BUNDLED_RECORDINGS
    from cobotsafety.app.replay_control import ReplayControl
    from cobotsafety.human.recording import bundled_recording

    assert app.human.bodies.opacity is None and app.human.ends.opacity is None  # viser: None = opaque
    floor_z = float(app.scene.view.grid.position[2])
    assert floor_z == pytest.approx(-0.75)
    for name, _ in BUNDLED_RECORDINGS:
        control = ReplayControl()
        assert control.load(bundled_recording(name)) == ""
        lowest = np.inf
        for t_s in np.arange(0.0, control.duration_s, 0.5):
            control.seek(t_s)
            human = control.capsules()
            # (the body's capsules: a one-capsule envelope of any arm pose, ``body`` / ``body 2``
            # (another person the laser tracks), reaches 0.86 m around the torso's axis, floor included)
            body = np.array([not n.startswith("body") for n in human.names], dtype=bool)
            if body.any():
                lowest = min(lowest, float((np.minimum(human.p0_b_m[body, 2], human.p1_b_m[body, 2])
                                            - human.radius_m[body]).min()))
        assert floor_z < lowest < np.inf, (name, lowest)


def test_the_control_loop_alone_keeps_the_controllers_human_fresh(app):
    """Safety data flows through the control thread: with no frame rendered, the replayed human
    reaches the controller every ``human_period_s`` of loop time and moves with the replay."""
    app.replay.seek(4.0)
    app.replay.playing = True
    app.replay.speed = 1.0
    controller = app.loop.robot
    given = []
    original = controller.set_human
    controller.set_human = lambda human: (given.append((app.loop.snapshot().t_s, human)), original(human))[1]
    try:
        for _ in range(300):  # 0.3 s of control at 1 kHz, no render_once
            app.loop.step_once()
    finally:
        del controller.set_human
    times = np.array([t for t, _ in given])
    assert len(given) >= 0.3 / app.loop.settings.human_period_s - 2
    assert np.max(np.diff(times)) <= app.loop.settings.human_period_s + 1.5e-3
    last = given[-1][1]
    sensor_age = max([0.0, *(a for a in last.ages_s.values() if np.isfinite(a))])  # the scans' own age
    assert controller.human_age_s() - sensor_age <= app.loop.settings.human_period_s + 1.5e-3
    stamps = [h.t_s for _, h in given if h is not None]
    assert stamps[-1] - stamps[0] == pytest.approx(0.3, abs=0.01)  # the replay's time, moving on
    app.replay.playing = False


def test_a_source_that_stops_lets_the_watchdog_grow_then_stop_the_arm(app):
    """The human source goes quiet (the loop no longer gives the controller a human): the model
    ages, first grows (the distance shrinks), then the arm is stopped and the status says why."""
    app.replay.playing = False
    app.replay.seek(5.0)
    app.loop.reset()
    app.loop.step_once()  # one fresh human
    source, app.loop.human_source = app.loop.human_source, None
    try:
        watchdog = app.loop.robot.watchdog
        reports = []
        for _ in range(int((watchdog.stop_after_s + 0.1) / app.loop.settings.dt_s)):
            reports.append(app.loop.step_once())
        grown = [r for r in reports if "grown" in r.human_status]
        assert grown and "stopped" in reports[-1].human_status and reports[-1].stopped
        assert grown[-1].min_distance_m < reports[0].min_distance_m  # the grown model is nearer
    finally:
        app.loop.human_source = source
        app.loop.reset()
