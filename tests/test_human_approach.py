"""Paper 2's experiments: the bundled recordings (deterministic, scripted as section 5 says),
the task paths, the run metrics, the CLI's JSON shape, and a short experiment-2 run."""

from __future__ import annotations

import json
from importlib.resources import files

import numpy as np
import pytest

from cobotsafety.control.nominal_path import NominalPath, hold
from cobotsafety.experiments.approach_metrics import run_metrics
from cobotsafety.paper_figures import PAPER_RESULTS
from cobotsafety.experiments.human_approach import experiment_arm_params, load_replay, run_approach
from cobotsafety.tools.generate_recording import generate, main as generate_main, truth_path

ASSETS = files("cobotsafety.assets") / "recordings"
JSON_KEYS = {"scenario", "robot", "controller", "ssm", "min_distance_m", "min_distance_plain_m", "peak_ee_speed_m_s",
             "completion_time_s", "stopped_time_s", "stop_go_transitions", "max_ee_accel_m_s2"}


@pytest.mark.parametrize("scenario", ["exp1", "exp2", "reach-over"])
def test_bundled_recordings_regenerate_byte_identical(scenario, tmp_path):
    out = tmp_path / f"{scenario}.jsonl.gz"
    generate_main(["--scenario", scenario, "--out", str(out)])
    assert out.read_bytes() == (ASSETS / f"{scenario}.jsonl.gz").read_bytes()
    fresh, bundled = np.load(truth_path(out)), np.load(ASSETS / f"{scenario}_truth.npz")
    assert set(fresh.files) == set(bundled.files)
    for key in bundled.files:
        np.testing.assert_array_equal(fresh[key], bundled[key])


def test_exp1_is_scripted_as_paper_2_section_5():
    truth = np.load(ASSETS / "exp1_truth.npz")
    t, torso = truth["t_s"], truth["torso_xy_b_m"]
    speed = np.linalg.norm(np.gradient(torso, t, axis=0), axis=1)
    walk_in = (t > 1.0) & (t < 3.4)
    assert 0.9 <= speed[walk_in].max() <= 1.2  # walks in at about 1 m/s
    wrist = truth["p1_b_m"][:, 4]  # right wrist
    for hold_s, torso_range, hand_range in (((4.6, 6.1), (1.0, 1.1), (0.6, 0.7)), ((20.8, 21.8), (1.0, 1.15), (0.65, 0.75))):
        held = (t >= hold_s[0]) & (t <= hold_s[1])
        assert hold_s[1] - hold_s[0] >= 1.0
        assert np.all((np.linalg.norm(torso[held], axis=1) >= torso_range[0]) & (np.linalg.norm(torso[held], axis=1) <= torso_range[1]))
        hand = np.linalg.norm(wrist[held, :2], axis=1)
        assert np.all((hand >= hand_range[0]) & (hand <= hand_range[1])), hand


def test_exp2_walks_past_along_minus_y():
    truth = np.load(ASSETS / "exp2_truth.npz")
    t, torso = truth["t_s"], truth["torso_xy_b_m"]
    velocity = np.gradient(torso, t, axis=0)
    passing = np.abs(torso[:, 1]) < 0.5
    assert np.all(velocity[passing, 1] < -1.0) and velocity[:, 1].min() >= -1.4
    assert np.all((torso[:, 0] >= 0.8) & (torso[:, 0] <= 1.0))
    assert np.all(truth["p1_b_m"][:, :, 0] > 0.6)  # no reach toward the robot


def test_task_path_waits_dwells_and_holds():
    path = NominalPath(np.array([[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0]]), speed_m_s=0.1, start_after_s=1.0, dwell_s={1: 0.5})
    p = np.zeros(3)
    reached = {}
    for k in range(1, 4000):
        p = path.advance(p, 0.001)  # the end-effector follows the target exactly
        reached.setdefault(round(float(p[0]), 6), k * 0.001)
        if path.finished:
            break
    assert reached[0.0] == pytest.approx(0.001) and min(v for x, v in reached.items() if x > 0) >= 0.999
    # 1 s wait + 1 s to the middle + 0.5 s dwell + 1 s to the end.
    assert k * 0.001 == pytest.approx(3.5, abs=0.01)
    still = hold(np.array([0.3, 0.0, 0.5]), until_s=2.0)
    for _ in range(1999):
        still.advance(np.array([0.3, 0.0, 0.5]), 0.001)
    assert not still.finished
    still.advance(np.array([0.3, 0.0, 0.5]), 0.002)
    assert still.finished


def test_run_metrics_count_stops_transitions_and_acceleration():
    dt = 0.01
    v = np.zeros((10, 3))
    v[2:4, 0] = 0.2  # moves, stops (wanted motion), moves again
    v[6:, 0] = 0.2
    wanted = np.full((10, 3), 0.1)
    m = run_metrics(dt, np.linspace(1, 0.5, 10), np.linspace(1.1, 0.6, 10), v, wanted, np.zeros(10, bool), None)
    assert m.min_distance_m == 0.5 and m.min_distance_plain_m == pytest.approx(0.6)
    assert m.stopped_time_s == pytest.approx(4 * dt)  # steps 0, 1, 4, 5: wanted motion, none came
    assert m.stop_go_transitions == 3  # held -> go -> held -> go
    assert m.max_ee_accel_m_s2 == pytest.approx(0.2 / dt)
    assert m.peak_ee_speed_m_s == pytest.approx(0.2)


def test_cli_json_has_exactly_the_documented_keys(capsys, tmp_path):
    from cobotsafety.cli import main

    assert main(["experiment", "human-approach", "--scenario", "exp2", "--controller", "stop", "--json",
                 "--dt", "0.02", "--out", str(tmp_path)]) == 0
    (result,) = json.loads(capsys.readouterr().out)
    assert set(result) == JSON_KEYS
    assert (result["scenario"], result["robot"], result["controller"], result["ssm"]) == ("exp2", "iiwa", "stop", False)
    assert result["min_distance_plain_m"] >= result["min_distance_m"]  # inflation only shrinks distances
    assert len(list(tmp_path.glob("*.png"))) == 2


def test_short_exp2_anticipative_keeps_the_papers_distance_and_the_field_reproduces_it():
    replay = load_replay("exp2", None)
    paper_distance, paper_speed = PAPER_RESULTS["exp2"]
    anticipative = run_approach("anticipative", scenario="exp2", duration_s=7.0, replay=replay).metrics
    assert anticipative.min_distance_plain_m >= paper_distance
    assert anticipative.peak_ee_speed_m_s <= paper_speed  # issue 11: no faster than the paper's robot
    assert anticipative.stopped_time_s == 0.0 and anticipative.stop_go_transitions == 0
    field = run_approach("reactive", scenario="exp2", duration_s=7.0, replay=replay).metrics
    assert field.min_distance_plain_m == pytest.approx(paper_distance, rel=0.2)
    assert field.peak_ee_speed_m_s == pytest.approx(paper_speed, rel=0.2)


@pytest.mark.parametrize("scenario", ["exp1", "exp2"])
def test_experiment_speed_cap_keeps_every_direction_under_the_papers_peak(scenario):
    """The filter caps each axis: its worst direction (a cube's diagonal) stays under the paper's peak."""
    cap = experiment_arm_params(scenario).max_speed_m_s
    assert cap * np.sqrt(3.0) <= PAPER_RESULTS[scenario][1]
    assert experiment_arm_params("exp2", replayed=True).max_speed_m_s == experiment_arm_params("exp1").max_speed_m_s


def test_paper_experiments_find_legs_with_the_papers_rule():
    """Issue 14: ``method="paper"`` keeps paper 2's rule for the experiments that reproduce it."""
    assert load_replay("exp2", None).tracker.leg_method == "paper"
