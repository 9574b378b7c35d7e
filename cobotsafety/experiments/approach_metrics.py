"""What one human-approach run is judged by (``human_approach``), from its per-step log.

* ``min_distance_m``: the smallest human-robot capsule distance the controller saw (human
  capsules as the pipeline hands them out: radii grown while a sensor is old, 1 capsule while
  an IMU is silent).
* ``min_distance_plain_m``: the same against the human's own capsules (body radii, no growth),
  as paper 2 measured it.
* ``peak_ee_speed_m_s`` / ``max_ee_accel_m_s2``: largest end-effector speed, and largest change
  of the executed velocity between consecutive steps over the step.
* ``stopped_time_s``: time the arm was held although the task wanted it to move: the
  controller said stopped, or the attraction asked for more than ``MOVING_M_S`` while the
  end-effector moved slower than ``STOPPED_M_S``. Holding a pose the task holds is not a stop.
* ``stop_go_transitions``: how often that stopped flag changed (stop -> go or go -> stop).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cobotsafety.geometry.capsule import capsule_distance
from cobotsafety.human.body import BodyDimensions, HumanCapsules

STOPPED_M_S = 1e-3
MOVING_M_S = 1e-2


def nominal_radii(capsules: HumanCapsules, body: BodyDimensions) -> np.ndarray:
    """The human's own radii (k,) [m] for ``capsules.names`` (no stale growth)."""
    by_name = {"torso": body.torso_radius_m, "body": body.one_capsule_radius_m}
    return np.array([by_name.get(n, body.forearm_radius_m if n.startswith("forearm") else body.upper_arm_radius_m)
                     for n in capsules.names])


def plain_distance_m(robot_p0, robot_p1, robot_radius, capsules: HumanCapsules, body: BodyDimensions) -> float:
    """Minimum distance [m] between robot capsules (c, 3), (c, 3), (c,) and the human's own capsules."""
    if not len(capsules.names) or len(robot_radius) == 0:
        return np.inf
    d, _, _ = capsule_distance(robot_p0[:, None], robot_p1[:, None], robot_radius[:, None],
                               capsules.p0_b_m[None], capsules.p1_b_m[None], nominal_radii(capsules, body)[None])
    return float(d.min())


@dataclass(frozen=True)
class RunMetrics:
    min_distance_m: float
    min_distance_plain_m: float
    peak_ee_speed_m_s: float
    completion_time_s: float | None
    stopped_time_s: float
    stop_go_transitions: int
    max_ee_accel_m_s2: float


def run_metrics(dt_s: float, distance_m, plain_m, v_executed_m_s, v_desired_m_s, stopped,
                completion_time_s: float | None) -> RunMetrics:
    """Metrics from per-step arrays: distances (n,) [m], executed and desired end-effector
    velocities (n, 3) [m/s], the controller's stopped flags (n,)."""
    v = np.asarray(v_executed_m_s, float).reshape(-1, 3)
    speed = np.linalg.norm(v, axis=1)
    wanted = np.linalg.norm(np.asarray(v_desired_m_s, float).reshape(-1, 3), axis=1)
    held = np.asarray(stopped, bool) | ((wanted > MOVING_M_S) & (speed < STOPPED_M_S))
    accel = np.linalg.norm(np.diff(v, axis=0, prepend=np.zeros((1, 3))), axis=1) / dt_s  # from rest
    return RunMetrics(float(np.min(distance_m)), float(np.min(plain_m)), float(speed.max()), completion_time_s,
                      float(held.sum() * dt_s), int(np.count_nonzero(np.diff(held.astype(int)))),
                      float(accel.max()))
