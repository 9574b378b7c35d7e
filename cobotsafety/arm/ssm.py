"""ISO/TS 15066 speed and separation monitoring (SSM): pure functions and their parameters.

Protective separation distance (ISO/TS 15066:2016, 5.5.4.2.3, eq. 1 with the constant-speed
simplification of eq. 2)::

    S = v_h (T_r + T_s) + v_r T_r + B + C + Z_d + Z_r

* ``v_h`` the human's speed toward the robot (ISO 13855: 1.6 m/s), ``v_r`` the robot's speed
  toward the human [m/s];
* ``T_r`` the reaction time (sensing, processing, the robot's reaction) [s];
* ``T_s`` and ``B``, the robot's stopping time [s] and distance [m] from ``v_r``. The robot
  brakes at ``a`` [m/s^2] at the point that approaches (``braking_deceleration_m_s2`` gives the
  deceleration its joint acceleration limits allow in every direction), so ``T_s = v_r / a``
  and ``B = v_r^2 / (2 a)`` (``stopping_time_s``, ``stopping_distance_m``);
* ``C`` the intrusion distance, ``Z_d`` and ``Z_r`` the human's and the robot's position
  uncertainties [m].

Two uses of it, named apart:

* **protective stop** (``protective_stop``): the standard's SSM. When the separation falls
  below ``S`` at the robot's current speed toward the human, the robot stops (and may resume
  once the separation is above ``S`` again);
* **speed scaling** (``max_approach_speed_m_s``): the largest ``v_r`` with ``S(v_r) <=`` the
  separation, the bound on the speed toward the human that keeps ``S`` met (motion away from
  the human is not limited). ``ssm_halfspaces`` writes that bound as half-spaces on a command.

Everything here is stateless. ``separation_kernel`` and ``approach_speed_kernel`` are the one
implementation (compiled: the arm's step calls them on each human row, with
``SsmParams.vector()``); the functions below take arrays and call them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from cobotsafety.arm.braking import positive_root

#: ISO 13855's walking speed [m/s] (used by ISO/TS 15066 when the human's speed is not measured).
ISO_13855_HUMAN_SPEED_M_S = 1.6


@dataclass(frozen=True)
class SsmParams:
    """The terms of ``S`` that do not change while the robot runs (units in the names)."""

    human_speed_m_s: float = ISO_13855_HUMAN_SPEED_M_S
    """v_h: the human's speed toward the robot [m/s]."""
    reaction_time_s: float = 0.1
    """T_r: sensing + processing + the robot's reaction [s]. Our chain: a 50 Hz scan (20 ms),
    paper 2's time filter (eq. 1, alpha 0.8: one scan's lag), the tracker, one control period
    (3.6 ms at 275 Hz); 0.1 s covers it with a margin."""
    braking_m_s2: float = 3.0
    """a: the robot's deceleration at the approaching point [m/s^2] (T_s = v_r / a,
    B = v_r^2 / 2a). Default 3 m/s^2 (a conservative arm's braking); take the smaller of it and
    ``braking_deceleration_m_s2`` of the robot's joint acceleration limits."""
    intrusion_m: float = 0.0
    """C: intrusion distance [m]; the capsules already cover the arms and hands."""
    sensor_uncertainty_m: float = 0.05
    """Z_d: the human's position uncertainty [m] (the laser/IMU pipeline's error)."""
    robot_uncertainty_m: float = 0.01
    """Z_r: the robot's position uncertainty [m]."""

    @property
    def margin_m(self) -> float:
        """C + Z_d + Z_r [m]: what ``S`` keeps even with both at rest."""
        return self.intrusion_m + self.sensor_uncertainty_m + self.robot_uncertainty_m

    def protective_distance_m(self, robot_speed_m_s):
        """``protective_separation_m(robot_speed_m_s, self)``."""
        return protective_separation_m(robot_speed_m_s, self)

    def max_approach_speed_m_s(self, separation_m):
        """``max_approach_speed_m_s(separation_m, self)``."""
        return max_approach_speed_m_s(separation_m, self)


    def vector(self) -> np.ndarray:
        """``(v_h, T_r, a, C, Z_d, Z_r)`` as the compiled functions read them."""
        return np.array([self.human_speed_m_s, self.reaction_time_s, self.braking_m_s2, self.intrusion_m,
                         self.sensor_uncertainty_m, self.robot_uncertainty_m], dtype=float)


@numba.njit(cache=True)
def separation_kernel(robot_speed_m_s, params):  # pragma: no cover - compiled
    """S [m] for a robot approaching at ``robot_speed_m_s`` [m/s] (negative: moving away, 0);
    ``params`` is ``SsmParams.vector()``."""
    v_h, t_r, a, c, z_d, z_r = params[0], params[1], params[2], params[3], params[4], params[5]
    v_r = max(robot_speed_m_s, 0.0)
    t_s = v_r / a
    return v_h * (t_r + t_s) + v_r * t_r + v_r * v_r / (2.0 * a) + c + z_d + z_r


@numba.njit(cache=True)
def approach_speed_kernel(separation_m, params):  # pragma: no cover - compiled
    """The largest ``v_r`` >= 0 [m/s] with ``S(v_r) <= separation_m``: the positive root of
    ``v^2 / 2a + v (T_r + v_h / a) + (v_h T_r + C + Z_d + Z_r - separation) = 0`` (0 where even a
    robot at rest is too close)."""
    v_h, t_r, a, c, z_d, z_r = params[0], params[1], params[2], params[3], params[4], params[5]
    return positive_root(a, t_r + v_h / a, separation_m - (v_h * t_r + c + z_d + z_r))


def stopping_time_s(robot_speed_m_s, braking_m_s2: float):
    """T_s [s]: time to brake from ``robot_speed_m_s`` [m/s] to standstill at ``braking_m_s2``."""
    return np.maximum(np.asarray(robot_speed_m_s, dtype=float), 0.0) / braking_m_s2


def stopping_distance_m(robot_speed_m_s, braking_m_s2: float):
    """B [m]: distance travelled while braking from ``robot_speed_m_s`` at ``braking_m_s2``."""
    v = np.maximum(np.asarray(robot_speed_m_s, dtype=float), 0.0)
    return v * v / (2.0 * braking_m_s2)


def protective_separation_m(robot_speed_m_s, params: SsmParams = SsmParams()):
    """S [m] (ISO/TS 15066 eq. 2) for a robot approaching at ``robot_speed_m_s`` [m/s] (scalar
    or array; negative speeds, i.e. moving away, count as 0)."""
    vector = params.vector()
    v = np.asarray(robot_speed_m_s, dtype=float)
    out = np.array([separation_kernel(float(x), vector) for x in v.ravel()]).reshape(v.shape)
    return out if out.ndim else float(out)


def protective_stop(separation_m, robot_speed_m_s, params: SsmParams = SsmParams()):
    """True where the separation [m] is below ``S`` at the robot's speed toward the human: the
    robot must stop (ISO/TS 15066 5.5.4: SSM's protective stop)."""
    return np.asarray(separation_m, dtype=float) < protective_separation_m(robot_speed_m_s, params)


def max_approach_speed_m_s(separation_m, params: SsmParams = SsmParams()):
    """The largest ``v_r`` >= 0 [m/s] with ``S(v_r) <= separation_m`` (0 where even a robot at
    rest is too close): speed scaling."""
    vector = params.vector()
    s = np.asarray(separation_m, dtype=float)
    out = np.array([approach_speed_kernel(float(x), vector) for x in s.ravel()]).reshape(s.shape)
    return out if out.ndim else float(out)


def braking_deceleration_m_s2(J_point: np.ndarray, max_joint_accel_rad_s2: np.ndarray,
                              damping: float = 1e-3) -> float:
    """The deceleration [m/s^2] a point can reach in *every* direction within the joint
    acceleration limits: ``min_i qdd_max_i / ||row_i(J^+)||`` with ``J^+`` the damped
    pseudo-inverse of the point's translation Jacobian ``J_point`` (3, n) and
    ``max_joint_accel_rad_s2`` (n,) [rad/s^2] (the minimum-norm joint acceleration for a
    Cartesian one ``a u`` is ``J^+ a u``; its joint i is at most ``a ||row_i(J^+)||``)."""
    J = np.asarray(J_point, dtype=float)
    pinv = J.T @ np.linalg.inv(J @ J.T + damping * damping * np.eye(J.shape[0]))
    rows = np.linalg.norm(pinv, axis=1)
    limits = np.asarray(max_joint_accel_rad_s2, dtype=float)
    moving = rows > 1e-12
    return float(np.min(limits[moving] / rows[moving])) if moving.any() else math.inf
