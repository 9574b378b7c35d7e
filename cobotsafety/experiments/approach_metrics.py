"""What one human-approach run is judged by, from its per-step log (``EpisodeLog``).

Distances [m], each its own named quantity:

* ``min_distance_seen_m``: what the controller saw (the pipeline's human with radii grown while
  a sensor is old, one capsule while an IMU is silent);
* ``min_distance_estimate_m``: the pipeline's five-capsule human with the body's own radii (no
  growth), as paper 2 measured it; steps where the pipeline fell back to one capsule are not in
  it, they are in
* ``min_distance_one_capsule_m``: the one-capsule fallback (an IMU silent), body radius; None
  when it never happened;
* ``min_distance_true_m``: the ground-truth human (the generator's), None without a truth;
* ``estimate_error_at_closest_m``: at the step of the smallest true distance, the pipeline's
  estimate (five capsules, or the fallback) minus the truth (negative: the estimate was nearer).

Motion: ``peak_ee_speed_m_s``, ``max_ee_accel_m_s2`` (largest change of the executed velocity
between steps over the step), ``max_joint_velocity_ratio``, ``max_joint_acceleration_ratio``,
``max_joint_jerk_ratio`` (largest |value_i| / limit_i over the run, backward differences of the
commanded joint positions from rest, ``experiments.motion_ratios``), ``max_ee_jerk_m_s3``,
``max_ee_speed_ratio``, ``max_ee_acceleration_ratio``, ``max_ee_jerk_ratio`` (the same differences of
the commanded hand path, their norms over the robot's end-effector limits),
``safety_over_smoothness_steps`` (steps where a limitation was kept over the robot's
acceleration or jerk limits, counted by the controller), ``hand_over_limit_steps`` (steps whose
executed hand path went over the robot's end-effector acceleration or jerk limit, reported by the
controller: the path's curvature, not a limitation kept). Task: ``completion_time_s``;
``stopped_time_s``, time held although the task wanted motion (the controller said stopped, or
the attraction asked for more than ``MOVING_M_S`` while the end-effector moved slower than
``STOPPED_M_S``); ``stop_go_transitions``, changes of that flag; ``protective_stop_time_s``,
time SSM's protective stop held the robot.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from cobotsafety.experiments.approach_truth import min_capsule_distance_m
from cobotsafety.human.body import BodyDimensions, HumanCapsules

STOPPED_M_S = 1e-3
MOVING_M_S = 1e-2


def nominal_radii(capsules: HumanCapsules, body: BodyDimensions) -> np.ndarray:
    """The human's own radii (k,) [m] for ``capsules.names`` (no stale growth)."""
    by_name = {"torso": body.torso_radius_m, "body": body.one_capsule_radius_m}  # ("body 2": another person's)
    return np.array([by_name.get(n.split()[0], body.forearm_radius_m if n.startswith("forearm")
                                 else body.upper_arm_radius_m) for n in capsules.names])


def plain_distance_m(robot_p0, robot_p1, robot_radius, capsules: HumanCapsules, body: BodyDimensions) -> float:
    """Minimum distance [m] between robot capsules (c, 3), (c, 3), (c,) and the human's own capsules."""
    return min_capsule_distance_m(robot_p0, robot_p1, robot_radius, capsules.p0_b_m, capsules.p1_b_m,
                                  nominal_radii(capsules, body))


def _min_or_none(values) -> float | None:
    values = np.asarray(values, dtype=float)
    finite = values[np.isfinite(values)]
    return float(finite.min()) if finite.size else None


@dataclass(frozen=True)
class RunMetrics:
    min_distance_seen_m: float | None
    min_distance_estimate_m: float | None
    min_distance_one_capsule_m: float | None
    min_distance_true_m: float | None
    estimate_error_at_closest_m: float | None
    closest_time_s: float | None
    peak_ee_speed_m_s: float
    completion_time_s: float | None
    stopped_time_s: float
    stop_go_transitions: int
    protective_stop_time_s: float
    max_ee_accel_m_s2: float
    max_joint_velocity_ratio: float
    max_joint_acceleration_ratio: float
    max_joint_jerk_ratio: float
    max_ee_jerk_m_s3: float | None
    max_ee_speed_ratio: float | None
    max_ee_acceleration_ratio: float | None
    max_ee_jerk_ratio: float | None
    safety_over_smoothness_steps: int
    hand_over_limit_steps: int = 0

    def as_dict(self, digits: int = 4) -> dict:
        return {k: (round(v, digits) if isinstance(v, float) and np.isfinite(v) else
                    (None if isinstance(v, float) else v)) for k, v in asdict(self).items()}


def run_metrics(dt_s: float, t_s, seen_m, estimate_m, one_capsule_m, true_m, v_executed_m_s, v_desired_m_s,
                stopped, protective, ratios, completion_time_s: float | None,
                safety_over_smoothness_steps: int = 0, hand_over_limit_steps: int = 0) -> RunMetrics:
    """Metrics from per-step arrays (n,) [m] (NaN where a quantity does not apply, inf where
    nobody is there), executed and desired end-effector velocities (n, 3) [m/s], the
    controller's stopped flags and SSM's protective stops (n,), the run's ``MotionRatios``
    (``experiments.motion_ratios``: the commanded joint path against the robot's limits) and
    the steps where safety was kept over the acceleration or jerk limits, and those the controller
    reported over the hand's own limits."""
    v = np.asarray(v_executed_m_s, float).reshape(-1, 3)
    speed = np.linalg.norm(v, axis=1)
    wanted = np.linalg.norm(np.asarray(v_desired_m_s, float).reshape(-1, 3), axis=1)
    held = np.asarray(stopped, bool) | ((wanted > MOVING_M_S) & (speed < STOPPED_M_S))
    accel = np.linalg.norm(np.diff(v, axis=0, prepend=np.zeros((1, 3))), axis=1) / dt_s  # from rest
    true = np.asarray(true_m, float)
    estimate = np.where(np.isfinite(np.asarray(estimate_m, float)), estimate_m, one_capsule_m)
    error = closest = None
    if np.isfinite(true).any():
        k = int(np.nanargmin(np.where(np.isfinite(true), true, np.nan)))
        closest = float(np.asarray(t_s)[k])
        error = float(estimate[k] - true[k]) if np.isfinite(estimate[k]) else None
    return RunMetrics(_min_or_none(seen_m), _min_or_none(estimate_m), _min_or_none(one_capsule_m), _min_or_none(true),
                      error, closest, float(speed.max()) if speed.size else 0.0, completion_time_s,
                      float(held.sum() * dt_s), int(np.count_nonzero(np.diff(held.astype(int)))),
                      float(np.sum(protective) * dt_s), float(accel.max()) if accel.size else 0.0,
                      ratios.max_joint_velocity_ratio, ratios.max_joint_acceleration_ratio,
                      ratios.max_joint_jerk_ratio, ratios.max_ee_jerk_m_s3, ratios.max_ee_speed_ratio,
                      ratios.max_ee_acceleration_ratio, ratios.max_ee_jerk_ratio, int(safety_over_smoothness_steps),
                      int(hand_over_limit_steps))
