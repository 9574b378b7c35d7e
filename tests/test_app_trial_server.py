"""The trial server's operator side without a browser: plan status, Repeat after Abort, the
colour task starting with the trial, "Trial k of 4" kept, touch feedback, no demo zones."""

import time

import numpy as np
import pytest

from cobotsafety.ports import free_local_port
from cobotsafety.trial.trial_app import TrialServer


@pytest.fixture
def server(tmp_path):
    trial_server = TrialServer(tmp_path, ["P01"], seed=2, port=free_local_port())  # threads not started
    yield trial_server
    trial_server.stop()


def drive_to(server, p_xy, steps: int = 4000) -> None:
    """Hold the gizmo at ``p_xy`` [m] and step until the current trial advances a target or ends."""
    start = server.current[1].next_target if server.current else None
    for _ in range(steps):
        server.loop.set_gizmo_target(np.array([*p_xy, server.course.height_m or 0.0]))
        server.loop.step_once()
        if server.current is None or server.current[1].next_target != start:
            return


def test_demo_zones_are_not_in_the_trial_scene(server):
    from cobotsafety.app.scene_planar import is_zone

    assert not any(is_zone(lim) for lim in server.teleop.scene.limitations)
    assert not any(name.startswith(("F ", "G ")) for name in server.scene.view._limit_nodes)


def test_colour_task_starts_at_the_first_motion_and_progress_keeps_the_trial_number(server):
    trial = next(t for t in server.plan if t.attention == "divided")
    server.start(trial)
    for _ in range(3000):  # 3 s of control time without motion: no word yet
        server.loop.step_once()
    run = server.current[1]
    assert run.started_s is None and run.colour.stimuli == []
    server.render_once()
    assert server.word.content == ""
    assert server.progress.content.startswith(f"**Trial {trial.order} of 4.**")
    drive_to(server, server.course.targets_m[0])
    assert run.started_s is not None and run.colour.stimuli
    assert all(s.shown_s >= run.started_s for s in run.colour.stimuli)  # never before the start
    server.render_once()
    assert server.progress.content.startswith(f"**Trial {trial.order} of 4.**")
    assert "target 2" in server.progress.content
    assert server.word.content  # the word shows once the trial runs


def test_abort_then_repeat_restarts_and_the_plan_says_what_happened(server):
    trial = server.start_next()
    assert "Running" in server._plan_text()
    server.abort()
    assert server.current is None and "Aborted" in server._plan_text()
    again = server.repeat_last()
    assert again == trial and server.current is not None and server.current[0] == trial
    # Finish it: visit every target in order.
    for target in server.course.targets_m:
        drive_to(server, target)
    assert server.current is None
    server.render_once()
    assert "Finished" in server.status and "Running" not in server._plan_text()
    assert (trial.participant, trial.attention, trial.condition) in server.store.done()


def test_touching_a_triangle_flashes_it_and_tells_the_participant(server):
    server.start_next()
    run = server.current[1]
    run.started_s = 0.0
    triangle = np.asarray(server.course.obstacles_m[0])
    run.update(0.1, np.array([*triangle.mean(axis=0), 0.0]), moving=True)  # the end-effector on it
    assert run.errors
    server.render_once()
    normal, touched = server.obstacle_nodes[0]
    assert touched.visible and not normal.visible
    assert "touched" in server.feedback.content.lower()


def test_wrong_token_is_refused_and_cleared(server):
    from unittest import mock

    client = mock.MagicMock()
    texts = {}
    client.gui.add_text.side_effect = lambda label, **kw: texts.setdefault("token", mock.MagicMock(value=""))
    feedback = mock.MagicMock(content="")
    client.gui.add_markdown.return_value = feedback
    server._offer_operator_login(client)
    token = texts["token"]
    callback = token.on_update.call_args[0][0]
    token.value = "0" * len(server.token) if server.token != "0" * len(server.token) else "1" * len(server.token)
    callback(None)
    assert token.value == "" and "wrong token" in feedback.content.lower()
    token.value = server.token
    callback(None)  # within the connection's backoff: not compared
    assert token.value == "" and "too soon" in feedback.content.lower()
    server.gate.clock = lambda: time.monotonic() + 3600.0  # the backoff has passed
    token.value = server.token
    callback(None)
    assert [c[0][0] for c in client.gui.add_folder.call_args_list[-2:]] == ["Trial", "Session"]


def test_start_next_never_discards_a_trial_in_progress(server):
    trial = server.start_next()
    drive_to(server, server.course.targets_m[0])
    run = server.current[1]
    assert run.next_target == 1
    assert server.start_next() is None  # refused while running
    assert server.current[1] is run and run.next_target == 1  # progress kept
    assert "Refused" in server.status and "Abort it first" in server.status
    assert server.repeat_last() is None and server.current[1] is run
    server.abort()
    assert server.start_next() is None  # the next trial is the one just aborted: not restarted silently
    assert "Repeat restarts it" in server.status and "Skip" in server.status
    again = server.repeat_last()  # the operator's explicit choice
    assert again == trial and server.current[1].next_target == 0


def test_a_trial_the_participant_cannot_finish_is_skipped_with_the_reason_logged(server, tmp_path):
    from cobotsafety.trial.analysis import analyze
    from cobotsafety.trial.log_store import load

    trial = server.start_next()
    drive_to(server, server.course.targets_m[0])
    assert server.skip("   ") is None and server.current is not None  # a reason is required
    assert "reason" in server.status
    assert server.skip("participant felt unwell\nstopped") == trial
    assert server.current is None and "Skipped" in server.status
    records = load(server.store.directory).records
    assert len(records) == 1
    record = records[0]
    assert record["skipped"] is True and record["skip_reason"] == "participant felt unwell stopped"
    assert record["targets_reached"] == 1 and record["completion_time_s"] is None
    nxt = server.start_next()  # the plan goes on
    assert nxt is not None and nxt != trial
    server.abort()
    assert server.skip("fire alarm") == nxt  # an aborted trial can be skipped too
    assert "participant felt unwell stopped" in analyze(server.store.directory)


def test_answers_aloud_are_judged_in_the_operator_view_and_logged(server):
    from unittest import mock

    assert server.answer_buttons == []  # aloud: no answer buttons on the participant's page
    client = mock.MagicMock()
    server._make_operator_panel(client)
    panel = server._operator_panels[-1]
    trial = next(t for t in server.plan if t.attention == "divided")
    server.start(trial)
    drive_to(server, server.course.targets_m[0])
    run = server.current[1]
    server.render_once()
    stimulus = run.colour.current
    assert stimulus.word.upper() in panel.word.content and stimulus.ink in panel.word.content
    assert all(button.visible for button in panel.verdicts)
    assert server.judge("right")
    assert stimulus.answer == stimulus.ink and stimulus.judged_by == "operator"
    assert not server.judge("wrong")  # the first judgement counts
    for target in server.course.targets_m[1:]:
        drive_to(server, target)
    server.render_once()
    record = next(r for r in __import__("cobotsafety.trial.log_store", fromlist=["load"]).load(
        server.store.directory).records if r["attention"] == "divided")
    judged = [s for s in record["stimuli"] if s["judged_by"] == "operator"]
    assert judged and judged[0]["answer"] == judged[0]["ink"] and record["answers"] == "aloud"


def test_the_operator_view_shows_the_participants_scene_and_progress(server):
    from unittest import mock

    view = server.operator_view
    assert view.server is server.operator_server
    assert len(server.operator_course_nodes.targets) == len(server.course.targets_m)
    client = mock.MagicMock()
    server._make_operator_panel(client)
    panel = server._operator_panels[-1]
    server.start_next()
    drive_to(server, server.course.targets_m[0])
    server.render_once()
    assert np.allclose(view.ee.position, server.teleop.p_base_ee_m, atol=1e-9)  # the mirror follows the robot
    assert "target 2 of 6" in panel.progress.content
    assert server.operator_course_nodes.targets[1].color == (40, 160, 40)  # the next target, as the participant sees


def test_an_input_device_drives_only_while_a_trial_runs(tmp_path):
    from cobotsafety.app.input_device import ScriptedDevice

    device = ScriptedDevice([(1.0, 0.0, 0.0)])
    trial_server = TrialServer(tmp_path, ["P01"], seed=2, port=free_local_port(), device=device)
    try:
        feeder = trial_server.device_feeder
        feeder.poll_once()
        assert trial_server.loop.desired_velocity() == pytest.approx([0.0, 0.0])  # no trial: ignored
        trial_server.start_next()
        feeder.poll_once()
        assert trial_server.loop.desired_velocity()[0] > 0.2
        start = trial_server.teleop.p_base_ee_m.copy()
        for _ in range(300):
            trial_server.loop.step_once()
        assert trial_server.teleop.p_base_ee_m[0] > start[0] + 0.02
        assert trial_server.current[1].started_s is not None  # the trial started at the device's first motion
    finally:
        trial_server.stop()
