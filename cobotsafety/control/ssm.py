"""ISO/TS 15066 speed and separation monitoring, as a layer on any controller.

Protective separation distance (ISO/TS 15066, 5.5.4)::

    S_p = S_h + S_r + S_s + C + Z_d + Z_r
    S_h = v_h (T_r + T_s)      the human's approach while the robot reacts and stops
    S_r = v_r T_r              the robot's travel during its reaction time
    S_s = v_r T_s / 2          its travel while braking (constant deceleration)

Given the current separation ``S`` (the capsule distance), S >= S_p holds while the robot's
speed *toward* the human is at most

    v_r_max = (S - v_h (T_r + T_s) - C - Z_d - Z_r) / (T_r + T_s / 2)   (0 if negative).

Motion away from the human is not slowed (paper 2's own proposal). As half-spaces on the
command: for each robot capsule near the human, ``u . J_c qdot >= -v_r_max``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cobotsafety.arm.constraints import Measures
from cobotsafety.constraint import HalfSpaces


@dataclass(frozen=True)
class SsmParams:
    """ISO/TS 15066 SSM parameters (units in the names)."""

    human_speed_m_s: float = 1.6
    """ISO 13855 walking speed."""
    reaction_time_s: float = 0.1
    """T_r: sensing + processing + robot reaction."""
    stopping_time_s: float = 0.3
    """T_s: time to brake to standstill."""
    intrusion_m: float = 0.0
    """C: intrusion distance (the capsules already cover the arms)."""
    sensor_uncertainty_m: float = 0.05
    """Z_d: human position uncertainty (the laser/IMU pipeline's error)."""
    robot_uncertainty_m: float = 0.01
    """Z_r: robot position uncertainty."""

    def protective_distance_m(self, robot_speed_m_s: float) -> float:
        """S_p for a robot approaching at ``robot_speed_m_s``."""
        t_r, t_s = self.reaction_time_s, self.stopping_time_s
        s_h = self.human_speed_m_s * (t_r + t_s)
        s_r = robot_speed_m_s * t_r
        s_s = robot_speed_m_s * t_s / 2.0
        return s_h + s_r + s_s + self.intrusion_m + self.sensor_uncertainty_m + self.robot_uncertainty_m

    def max_approach_speed_m_s(self, separation_m) -> np.ndarray:
        """The largest speed toward the human that keeps ``separation_m >= S_p`` (>= 0)."""
        t_r, t_s = self.reaction_time_s, self.stopping_time_s
        margin = (np.asarray(separation_m, dtype=float) - self.human_speed_m_s * (t_r + t_s)
                  - self.intrusion_m - self.sensor_uncertainty_m - self.robot_uncertainty_m)
        return np.maximum(margin / (t_r + t_s / 2.0), 0.0)


def ssm_halfspaces(human_measures: Measures, critical_m: float, M: np.ndarray, c: np.ndarray,
                   params: SsmParams) -> HalfSpaces:
    """Half-spaces limiting each robot capsule's speed toward the human (command space).

    ``human_measures`` are the human constraint's measures (distance = separation - critical).
    """
    if human_measures.distance.size == 0:
        return HalfSpaces.empty(M.shape[1])
    separation = human_measures.distance + critical_m
    normals = human_measures.A @ M
    bounds = -params.max_approach_speed_m_s(separation) - human_measures.A @ c
    return HalfSpaces(normals, bounds, tuple(f"SSM {n}" for n in human_measures.names))
