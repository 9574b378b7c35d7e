"""Scoring rule, course geometry and the simulated participant's divided-attention model."""

from __future__ import annotations

import numpy as np

from cobotsafety.planar.planar_teleop import PlanarTeleop
from cobotsafety.trial.course import arm_course, planar_course
from cobotsafety.trial.scoring import ANSWER_WINDOW_S, error_score, stimulus_scored
from cobotsafety.trial.session import TrialRun, simulate_trial
from cobotsafety.trial.simulated_participant import SimulatedParticipant


def test_stimuli_before_the_start_or_in_the_last_answer_window_are_not_scored():
    assert not stimulus_scored(-0.5, 10.0)
    assert stimulus_scored(0.0, 10.0)
    assert stimulus_scored(10.0 - ANSWER_WINDOW_S, 10.0)
    assert not stimulus_scored(10.0 - ANSWER_WINDOW_S + 0.01, 10.0)
    assert stimulus_scored(50.0, None)  # an unfinished trial: everything after the start


def test_an_old_browser_log_is_rescored_by_the_rule():
    """The browser logged words shown before the first motion at negative times and scored them."""
    record = {"completion_time_s": 12.0, "errors": [
        {"kind": "missed", "t_s": -33.0, "points": -2}, {"kind": "missed", "t_s": -1.0, "points": -2},
        {"kind": "wrong", "t_s": 3.0, "points": -1}, {"kind": "obstacle", "t_s": 5.0, "points": -3},
        {"kind": "missed", "t_s": 10.5, "points": -2}], "error_score": -10}
    assert error_score(record) == -4  # the wrong answer at 3 s and the obstacle


def test_the_colour_task_runs_from_the_start_to_the_end_of_the_trial():
    course = planar_course()
    run = TrialRun(course, divided=True, seed=3)
    assert run.tick_colour(0.5) is None  # not started: no word
    run.update(1.0, np.array([-0.2, 0.03, 0.0]), moving=True)
    assert run.tick_colour(1.0) is not None
    reach_steps = [4, 8, 12, 16, 20, 23]  # the clock every 0.5 s; the last target at 12.5 s
    for step in range(1, 25):
        t = 1.0 + 0.5 * step
        at = course.targets_m[reach_steps.index(step)] if step in reach_steps else (-0.2, 0.03)
        run.update(t, np.array([*at, 0.0]), moving=True)
        run.tick_colour(t)
    assert run.finished and run.finished_s == 12.5
    assert run.tick_colour(run.finished_s + 5.0) is None  # ended: no more words
    record = run.record("P01", "stop", 1, 3)
    completion = record["completion_time_s"]
    assert completion == 11.5
    scored = [s for s in record["stimuli"] if s["scored"]]
    assert [s["shown_s"] for s in record["stimuli"]] == [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
    assert all(s["shown_s"] + ANSWER_WINDOW_S <= completion for s in scored)
    assert len(scored) == 5 and not record["stimuli"][-1]["scored"]
    assert record["error_score"] == -2 * len(scored)  # all missed, the last one not counted


def _straight_bindings(method):
    """Drive the course straight (no participant): how many times a limitation starts binding."""
    course, robot = planar_course(), PlanarTeleop()
    assert np.allclose(robot.p_base_ee_m[:2], course.start_m)
    meetings, was, k, t = [], False, 0, 0.0
    while k < len(course.targets_m) and t < 60.0:
        offset = np.array(course.targets_m[k]) - robot.p_base_ee_m[:2]
        if np.linalg.norm(offset) < course.target_radius_m:
            k += 1
            continue
        v = 2.5 * offset * min(1.0, 0.25 / (2.5 * np.linalg.norm(offset)))
        report = robot.step(v, 0.01, method)
        t += 0.01
        if report.binding and not was:
            meetings.append(report.binding)
        was = bool(report.binding)
    return k, meetings


def test_the_course_meets_the_workspace_limits_and_its_triangles_are_beside_the_routes():
    for course in (planar_course(), arm_course()):
        assert course.route_clearance_m() > 0.03
    reached, meetings = _straight_bindings("anticipative")
    assert reached == len(planar_course().targets_m)
    names = " ".join(n for m in meetings for n in m)
    assert len(meetings) >= 3
    assert "B joint 2" in names and "D joint 1" in names


def _mean_times(condition, divided, seeds):
    robot, course = PlanarTeleop(), planar_course()
    times = []
    for seed in seeds:
        run, _ = simulate_trial(robot, course, SimulatedParticipant(seed=seed), condition, divided, seed)
        assert run.finished
        times.append(run.finished_s - run.started_s)
    return float(np.mean(times))


def test_simulated_sliding_advantage_is_larger_in_divided_attention():
    seeds = range(3)
    full = _mean_times("stop", False, seeds) - _mean_times("anticipative", False, seeds)
    divided = _mean_times("stop", True, seeds) - _mean_times("anticipative", True, seeds)
    assert full > 0
    assert divided > full + 1.0  # seconds


def test_a_stop_seen_while_answering_is_noticed_only_after_looking_back():
    agent = SimulatedParticipant(seed=0, colour_miss_rate=0.0, colour_error_rate=0.0)
    agent.colour_shown(0.0, "red", ("red", "green", "blue", "yellow"))
    back = agent._eyes_back_s
    t = 0.0
    while t < back + agent.look_back_s - 0.02:
        t += 0.01
        agent.observe(t, moving=False)
        assert not agent.dealing_with_stop(t)
    while not agent.dealing_with_stop(t):
        t += 0.01
        agent.observe(t, moving=False)
    assert t >= back + agent.look_back_s + agent.notice_stop_s - 0.011
