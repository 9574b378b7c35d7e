"""One campaign task: one drawn person (or two), one robot, every controller on the same people.

``run_person(robot, index, seed, controllers, ...)`` draws the scene with
``np.random.default_rng([seed, index])`` (so each person depends only on the seed and its
index, whatever worker runs it), synthesises its laser and IMU data and ground truth
(``generate_recording.generate``, in memory), runs the pipeline once (``Replay``, the shared
``HumanSeries``), then the task with each controller (``human_approach.run_episode`` through
``approach_step``), and returns one result dict per controller (``RESULT_KEYS``).

The task (``campaign_task``): from home above the pick pose, over to the place pose and home,
at ``TASK_SPEED_M_S``, started at once; done when the end-effector is back home. Completed when
done before ``nominal + TIMEOUT_EXTRA_S``; time lost = completion - the same task with nobody
there (computed once per robot). A task stalled at joint limits moves its posture home and
resumes (``control.recovery``; ``posture_recoveries`` counts those moves).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from cobotsafety.errors import TaskError
from cobotsafety.experiments import approach_settings as settings

TIMEOUT_EXTRA_S = 30.0
RESULT_KEYS = ("robot", "controller", "person", "seed", "drawn", "true_min_distance_m", "seen_min_distance_m",
               "estimate_error_at_closest_m", "closest_time_s", "breach", "escape_exists",
               "escape_best_min_distance_m", "escape_after_detection", "detected_before_closest_s",
               "escape_after_approach_onset", "approach_onset_before_closest_s", "completed",
               "completion_time_s", "time_lost_s", "peak_ee_speed_m_s", "max_joint_acceleration_ratio",
               "stopped_time_s", "protective_stop_time_s", "posture_recoveries", "plant", "ssm", "rate_limited_steps",
               "safety_over_smoothness_steps", "max_ee_acceleration_ratio", "max_ee_jerk_ratio")
#: How the arm follows the controller's command: through the robot's rate limiter
#: (``rate-limited``, closed loop: ``arm.rate_limiter``; the default: a real arm does not follow a
#: command beyond its motion limits), or exactly (``ideal``).
PLANTS = ("rate-limited", "ideal")
DEFAULT_PLANT = PLANTS[0]
#: ISO/TS 15066 speed and separation monitoring on every controller (``approach_step.SSM_MODES``):
#: none (the default: each controller as it is), speed scaling, or the protective stop.
DEFAULT_SSM = "off"


def campaign_task(home_m: np.ndarray):
    """Home -> above the pick pose -> above the place pose -> home (``NominalPath``)."""
    from cobotsafety.control.nominal_path import IIWA_CARRY_HEIGHT_M, IIWA_PICK_M, IIWA_PLACE_M, NominalPath

    above = lambda p: np.array([p[0], p[1], IIWA_CARRY_HEIGHT_M])  # noqa: E731
    waypoints = [home_m, above(IIWA_PICK_M), above(IIWA_PLACE_M), home_m]
    return NominalPath(np.array(waypoints, dtype=float), speed_m_s=settings.TASK_SPEED_M_S)


class _Nobody:
    """A human series with nobody in it."""

    def __getitem__(self, k):
        return None


@lru_cache(maxsize=None)
def nominal_completion_s(robot: str, dt_s: float) -> float:
    """The campaign task's completion time [s] with nobody there (anticipative controller)."""
    from cobotsafety.experiments import approach_step
    from cobotsafety.experiments.human_approach import run_episode
    from cobotsafety.human.body import BodyDimensions

    controller = approach_step.make_controller(robot, "anticipative")
    path = campaign_task(approach_step.state(controller).p_world_ee.copy())
    log = run_episode(controller, _Nobody(), BodyDimensions(), path, dt_s, 120.0)
    if log.completion_s is None:
        raise TaskError(f"{robot}: the campaign task does not complete with nobody there (in 120 s): no time "
                        f"lost or completion can be measured on it")
    return float(log.completion_s)


def draw_scene(index: int, seed: int):
    """``(scene, drawn, generator seed)`` of person ``index`` under campaign seed ``seed``."""
    from cobotsafety.tools.scripted_people import draw_person

    rng = np.random.default_rng([seed, index])
    scene, drawn = draw_person(rng, f"person-{index}")
    return scene, drawn, int(rng.integers(2**31 - 1))


def step_at(t_s: np.ndarray, time_s: float, dt_s: float) -> int:
    """The index of the step (its end in ``t_s``, steps ``dt_s`` apart) holding ``time_s``."""
    return int(np.clip(np.searchsorted(t_s, time_s - 0.5 * dt_s), 0, len(t_s) - 1))


def detection_time_s(t_s: np.ndarray, seen_m: np.ndarray, closest_s: float, dt_s: float) -> float | None:
    """When the controller began to see someone without a break up to the closest moment [s]
    (the start of the first step of that stretch; ``seen_m`` is inf when it saw nobody, ``t_s``
    each step's end), or None when it saw nobody at the closest moment."""
    k = step_at(t_s, closest_s, dt_s)
    if not np.isfinite(seen_m[k]):
        return None
    unseen = np.flatnonzero(~np.isfinite(seen_m[:k + 1]))
    first = int(unseen[-1]) + 1 if unseen.size else 0
    return float(t_s[first]) - dt_s


def run_person(robot: str, index: int, seed: int, controllers: tuple[str, ...], dt_s: float = 1 / settings.CONTROL_RATE_HZ,
               escape_check: bool = True, nominal_s: float | None = None, plant: str = DEFAULT_PLANT,
               ssm: str = DEFAULT_SSM) -> list[dict]:
    """One result dict (``RESULT_KEYS``) per controller for person ``index``; ``nominal_s``:
    the task's time with nobody there (default ``nominal_completion_s``); ``plant``: the arm
    follows every command (``"ideal"``) or each command through the robot's rate limiter
    (``"rate-limited"``, ``arm.rate_limiter``; the filter sees the state it reached); ``ssm``:
    ISO/TS 15066's speed and separation monitoring on each controller (``"off"``, ``"scaling"``,
    ``"stop"``: ``approach_step.make_controller``)."""
    from cobotsafety.experiments import approach_step

    if plant not in PLANTS:
        raise ValueError(f"plant must be one of {PLANTS}, got {plant!r}")
    if ssm not in approach_step.SSM_MODES:
        raise ValueError(f"ssm must be one of {approach_step.SSM_MODES}, got {ssm!r}")
    from cobotsafety.experiments.approach_truth import TruthHuman
    from cobotsafety.experiments.human_approach import HumanSeries, episode_metrics, run_episode
    from cobotsafety.human.replay import Replay
    from cobotsafety.tools.campaign.escape import _Kinematics, approach_onset_s, escape_exists
    from cobotsafety.tools.generate_recording import generate

    scene, drawn, generator_seed = draw_scene(index, seed)
    recording, truth_dict = generate(scene, seed=generator_seed)
    truth = TruthHuman.from_dict(truth_dict)
    replay = Replay(recording)
    humans = HumanSeries(replay.capsules_at, replay.start_s, replay.start_s + replay.duration_s, dt_s)
    nominal = nominal_s if nominal_s is not None else nominal_completion_s(robot, dt_s)
    results = []
    for name in controllers:
        controller = approach_step.make_controller(robot, name, ssm=ssm)
        path = campaign_task(approach_step.state(controller).p_world_ee.copy())
        end_s = max(nominal + TIMEOUT_EXTRA_S, replay.duration_s)
        log = run_episode(controller, humans, recording.body, path, dt_s, end_s, truth, replay.start_s,
                          rate_limited=plant == "rate-limited")
        m = episode_metrics(log, dt_s, controller)
        true_min = m.min_distance_true_m
        breach = bool(true_min is not None and true_min < settings.CRITICAL_M)
        escape = best = after = detected = after_onset = onset = None
        if breach and escape_check:
            q_log, t_log = np.array(log.q_rad), np.array(log.t_s)
            kin = _Kinematics(robot)  # one robot model for both searches
            found = escape_exists(robot, q_log, t_log, m.closest_time_s, truth, replay.start_s, settings.CRITICAL_M,
                                  kinematics=kin)
            escape, best = found.exists, round(found.best_min_distance_m, 4)
            detected_s = detection_time_s(t_log, np.array(log.seen_m), m.closest_time_s, dt_s)
            detected = None if detected_s is None else round(m.closest_time_s - detected_s, 4)
            after = escape
            after_start = found.window_s[0]
            if escape and (detected_s is None or detected_s > found.window_s[0]):
                after = detected_s is not None and escape_exists(
                    robot, q_log, t_log, m.closest_time_s, truth, replay.start_s, settings.CRITICAL_M,
                    kinematics=kin, earliest_s=detected_s).exists
                after_start = detected_s
            after_onset = after
            if after:  # from the start of the person's final approach, when that came later
                q_closest = q_log[step_at(t_log, m.closest_time_s, dt_s)]
                onset_s = approach_onset_s(kin, q_closest, truth, replay.start_s, after_start, m.closest_time_s)
                onset = None if onset_s is None else round(m.closest_time_s - onset_s, 4)
                if onset_s is not None and onset_s > after_start:
                    after_onset = escape_exists(robot, q_log, t_log, m.closest_time_s, truth, replay.start_s,
                                                settings.CRITICAL_M, kinematics=kin, earliest_s=onset_s).exists
        completed = m.completion_time_s is not None
        results.append({
            "robot": robot, "controller": name, "person": index, "seed": seed, "drawn": drawn,
            "true_min_distance_m": None if true_min is None else round(true_min, 4),
            "seen_min_distance_m": None if m.min_distance_seen_m is None else round(m.min_distance_seen_m, 4),
            "estimate_error_at_closest_m": None if m.estimate_error_at_closest_m is None else round(m.estimate_error_at_closest_m, 4),
            "closest_time_s": None if m.closest_time_s is None else round(m.closest_time_s, 4),
            "breach": breach, "escape_exists": escape, "escape_best_min_distance_m": best,
            "escape_after_detection": after, "detected_before_closest_s": detected,
            "escape_after_approach_onset": after_onset, "approach_onset_before_closest_s": onset,
            "completed": completed,
            "completion_time_s": round(m.completion_time_s, 4) if completed else None,
            "time_lost_s": round(m.completion_time_s - nominal, 4) if completed else None,
            "peak_ee_speed_m_s": round(m.peak_ee_speed_m_s, 4),
            "max_joint_acceleration_ratio": round(m.max_joint_acceleration_ratio, 4),
            "stopped_time_s": round(m.stopped_time_s, 4), "protective_stop_time_s": round(m.protective_stop_time_s, 4),
            "posture_recoveries": log.posture_recoveries, "plant": plant, "ssm": ssm,
            "rate_limited_steps": log.rate_limited_steps,
            "safety_over_smoothness_steps": m.safety_over_smoothness_steps,
            "max_ee_acceleration_ratio": round(m.max_ee_acceleration_ratio, 4),
            "max_ee_jerk_ratio": round(m.max_ee_jerk_ratio, 4),
        })
    return results
