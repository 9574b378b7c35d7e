"""Scoring rule and course geometry (the participant model: ``test_trial_simulation.py``)."""

from __future__ import annotations

import numpy as np
import pytest

from cobotsafety.trial.course import arm_course, planar_course
from cobotsafety.trial.scoring import ANSWER_WINDOW_S, error_score, stimulus_scored
from cobotsafety.trial.session import TrialRun


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


def test_the_triangles_stand_beside_the_straight_routes():
    for course in (planar_course(), arm_course()):
        assert course.route_clearance_m() > 0.03


def test_point_triangle_distance_against_shapely_like_brute_force():
    """The course's touch test: 0 inside, else the distance to the nearest edge (dense sampling)."""
    from cobotsafety.trial.course import _point_triangle_distance

    rng = np.random.default_rng(2)
    tri = np.array([[0.0, 0.0], [0.1, 0.0], [0.03, 0.08]])
    edges = np.concatenate([a + np.linspace(0, 1, 4001)[:, None] * (b - a)
                            for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0]))])
    for p in rng.uniform(-0.05, 0.15, (200, 2)):
        d = _point_triangle_distance(p, tri)
        # inside: barycentric coordinates all >= 0
        m = np.array([tri[1] - tri[0], tri[2] - tri[0]]).T
        u, v = np.linalg.solve(m, p - tri[0])
        if u >= 0 and v >= 0 and u + v <= 1:
            assert d == 0.0
        else:
            assert d == pytest.approx(np.min(np.linalg.norm(edges - p, axis=1)), abs=5e-5)
