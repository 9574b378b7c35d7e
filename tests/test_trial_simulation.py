"""The simulated study: one scene for people and simulation, the course's claims measured in it,
the participant model's mechanisms (learning the limits, load), its parameters and their
sources, and ``--repeat`` / ``--vary`` run through the CLI at small sizes."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cobotsafety.cli import main
from cobotsafety.ports import free_local_port
from cobotsafety.trial.participant_parameters import PARAMETERS, parse_vary, population
from cobotsafety.trial.session import simulate_trial
from cobotsafety.trial.simulated_participant import Experience, SimulatedParticipant
from cobotsafety.trial.trial_scene import make_trial_robot, straight_drive


def test_the_simulation_drives_exactly_the_scene_and_course_people_drive(tmp_path):
    from cobotsafety.trial.trial_app import TrialServer

    robot, course = make_trial_robot("planar")
    server = TrialServer(tmp_path, ["P01"], port=free_local_port())
    try:
        people = server.teleop
        assert [lim for lim in people.scene.limitations] == [lim for lim in robot.scene.limitations]
        assert people.scene.damping == robot.scene.damping
        assert server.course == course
        assert np.allclose(people.p_base_ee_m, robot.p_base_ee_m) and np.allclose(robot.p_base_ee_m[:2], course.start_m)
        assert not any(lim.name.startswith(("F ", "G ")) for lim in robot.scene.limitations)
    finally:
        server.stop()


def test_the_courses_claims_are_measured_in_the_trial_scene():
    """``course.planar_course``'s docstring: B on start -> 1, D on 2 -> 3, B on 3 -> 4, three
    episodes, nothing else; the stop drive stalls at the first."""
    robot, course = make_trial_robot("planar")
    reached, routes = straight_drive(robot, course)
    assert reached == len(course.targets_m)
    assert [r.limitations for r in routes] == [("B joint 2 upper",), (), ("D joint 1 lower",), ("B joint 2 upper",), (),
                                               ()]
    assert sum(r.episodes for r in routes) == 3
    assert straight_drive(robot, course, "stop")[0] == 0
    radius = 0.57
    gaps = [radius - np.hypot(*course.targets_m[k]) for k in (1, 4, 5)]
    assert all(0.015 <= g <= 0.065 for g in gaps)  # "targets 2, 5 and 6 lie 2-6 cm inside E"


def test_every_model_number_is_a_named_parameter_with_its_source():
    fields = set(SimulatedParticipant.__dataclass_fields__) - {"seed", "experience", "diagnostics"}
    assert fields == set(PARAMETERS)
    assert all(p.source in ("paper", "calibrated", "assumption") and p.why for p in PARAMETERS.values())
    assert PARAMETERS["divided_speed_factor"].default == pytest.approx(31.9 / 43.2, abs=0.005)  # the paper's sliding times
    assert PARAMETERS["colour_error_rate"].default + 2 * PARAMETERS["colour_miss_rate"].default == pytest.approx(
        0.9 / (43.2 / 2), abs=1e-3)  # the paper's sliding points per word
    assert population({"load_miss_rate": (0.0, 0.0)})["load_miss_rate"] == (0.0, 0.0)
    with pytest.raises(ValueError, match="unknown participant parameter 'speed'"):
        population({"speed": (0, 1)})
    assert parse_vary("look_back_s=0.1:0.8") == ("look_back_s", 0.1, 0.8)
    for bad in ("look_back_s", "look_back_s=1", "look_back_s=0.8:0.1", "nope=0:1"):
        with pytest.raises(ValueError, match="--vary"):
            parse_vary(bad)


def _stop_trials(person_seed: int, trials: int, **overrides):
    robot, course = make_trial_robot("planar")
    experience = Experience()
    out = []
    for k in range(trials):
        agent = SimulatedParticipant.from_population(person_seed, 100 + k, experience,
                                                     {n: (v, v) for n, v in overrides.items()})
        run, _ = simulate_trial(robot, course, agent, "stop", False, 100 + k)
        assert run.finished
        out.append((run.finished_s - run.started_s, agent.diagnostics))
    return out


def test_the_stop_user_learns_the_limits_across_trials():
    """Detours shrink with practice: fewer stops and less standing still in the third trial than
    in the first (the way points learned in the first trial are driven through later)."""
    for person in (1, 2, 3):
        trials = _stop_trials(person, 3)
        (t1, first), (_, second), (t3, third) = trials
        assert third.still_s < first.still_s and third.stops_noticed < first.stops_noticed
        assert t3 < t1
        assert first.known_stops == 0


def test_a_word_shown_while_handling_a_stopped_robot_is_missed_at_the_load_rate():
    agent = SimulatedParticipant(seed=0, load_miss_rate=1.0, colour_miss_rate=0.0, colour_error_rate=0.0)
    agent.command(0.0, np.array([0.0, 0.3]), np.array([0.3, 0.3]), False, route=0)
    t = 0.0
    while not agent.dealing_with_stop(t):  # the robot does not follow the drag
        t += 0.01
        agent.command(t, np.array([0.0, 0.3]), np.array([0.3, 0.3]), False, route=0)
        agent.observe(t, moving=False)
    assert agent.loaded(t)
    agent.colour_shown(t, "red", ("red", "green", "blue", "yellow"))
    assert agent._pending is None and agent.diagnostics.loaded_words == 1  # missed
    calm = SimulatedParticipant(seed=0, load_miss_rate=1.0, colour_miss_rate=0.0, colour_error_rate=0.0)
    calm.colour_shown(0.0, "red", ("red", "green", "blue", "yellow"))
    assert calm._pending is not None and calm._pending[1] == "red"


def test_a_stop_seen_while_answering_is_noticed_only_after_looking_back():
    agent = SimulatedParticipant(seed=0, colour_miss_rate=0.0, colour_error_rate=0.0)
    p, target = np.array([0.0, 0.3]), np.array([0.3, 0.3])
    agent.command(0.0, p, target, True, route=0)
    agent.colour_shown(0.0, "red", ("red", "green", "blue", "yellow"))
    back = agent._eyes_back_s
    t = 0.0
    while t < back + agent.look_back_s - 0.02:
        t += 0.01
        agent.command(t, p, target, True, route=0)
        agent.observe(t, moving=False)
        assert not agent.dealing_with_stop(t)
    while not agent.dealing_with_stop(t):
        t += 0.01
        agent.command(t, p, target, True, route=0)
        agent.observe(t, moving=False)
    assert t >= back + agent.look_back_s + agent.notice_stop_s - 0.011


def test_repeat_runs_simulated_studies_through_the_cli(capsys):
    assert main(["trial", "--simulate", "2", "--repeat", "2", "--seed", "3", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    primary = [r for r in rows if r["role"] == "primary"]
    assert {r["comparison"] for r in primary} == {"full attention: completion time [s]",
                                                  "divided attention: completion time [s]"}
    assert all(r["studies"] == 2 and r["participants"] == 2 for r in rows)
    wilcoxon = [r for r in primary if r["test"].startswith("wilcoxon")]
    assert all(r["power"] == 0.0 for r in wilcoxon)  # 2 pairs cannot reach 0.05
    assert all(r["mean_sliding"] < r["mean_stop"] for r in primary)


def test_vary_runs_a_sensitivity_table_through_the_cli(capsys):
    assert main(["trial", "--simulate", "2", "--repeat", "1", "--seed", "3", "--vary", "load_miss_rate=0:1",
                 "--levels", "2", "--json"]) == 0
    levels = json.loads(capsys.readouterr().out)
    assert [(lv["parameter"], lv["value"]) for lv in levels] == [("(defaults)", None), ("load_miss_rate", 0.0),
                                                                  ("load_miss_rate", 1.0)]
    # The same seeds at both values: every loaded word missed at 1, none at 0.
    assert levels[2]["score_stop"] < levels[1]["score_stop"]
    assert main(["trial", "--simulate", "2", "--repeat", "1", "--vary", "load_miss_rate=0:1", "--levels", "1"]) == 0
    assert "| load_miss_rate | 0 |" in capsys.readouterr().out
    assert main(["trial", "--simulate", "2", "--repeat", "1", "--vary", "speed=0:1"]) == 2
    assert "unknown parameter 'speed'" in capsys.readouterr().err
    assert main(["trial", "--simulate", "2", "--vary", "load_miss_rate=0:1"]) == 2
    assert "--vary needs --repeat" in capsys.readouterr().err


def test_the_course_command_prints_the_measured_course(capsys):
    assert main(["trial", "--course"]) == 0
    text = capsys.readouterr().out
    assert "| start -> target 1 | B joint 2 upper | 1 |" in text and "stalls after 0 target(s)" in text
