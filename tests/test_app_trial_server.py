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
    assert client.gui.add_folder.call_args_list[-1][0][0] == "Operator panel"
