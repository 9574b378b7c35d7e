"""The settings of every human-approach run: paper 2's experiments, the stress case, the campaign.

Fixed before any of the numbers they produce was measured (issue 24, item 1), the same for
every scenario, robot and controller, each from the paper, from ISO/TS 15066's protective
separation distance (``cobotsafety.arm.ssm``) or from a stated principle; nothing here was
chosen by looking at a result. Speeds the robot reaches are results, reported, never capped to
match the paper.

``S = v_h (T_r + T_s) + v_r T_r + B + C + Z_d + Z_r`` with ``SSM`` (v_h = 1.6 m/s from ISO
13855, T_r = 0.1 s, C = 0, Z_d = 0.05 m, Z_r = 0.01 m, braking at 3 m/s^2: T_s = v_r / a,
B = v_r^2 / 2a):

* ``SPEED_LIMIT_M_S`` = 0.5 m/s: the end-effector speed cap of the arm's command, the
  controller's default (``FilterSettings.max_speed_m_s``) since the first session, before any
  human experiment existed. These settings were fixed when that cap was per axis, so ``S`` takes
  the diagonal's ``ROBOT_SPEED_MAX_M_S`` = sqrt(3) x 0.5 = 0.87 m/s; the cap is now a norm (a
  command never exceeds 0.5 m/s; a retreat from a person may, up to the robot's own limit), and
  the settings are kept as fixed (conservative for commanded motion), not re-chosen after the
  results. Paper 2 gives no speed limit (its 355 / 548 mm/s are measured peaks, compared as
  results).
* ``CRITICAL_M`` = S without its stopping terms at that speed: v_h T_r + v_r T_r + C + Z_d + Z_r
  = 0.16 + 0.087 + 0.06 = 0.307 m. The distance every controller is told to keep (the
  anticipative filter's and the stop baseline's critical distance, the field's ``d_cr``):
  they act at every control step on the current human (the filter retreats with the human's
  measured velocity, the stop baseline halts the command within the step), so what they cannot
  see is one reaction time of both movements plus the margins. A *breach* is a true (ground
  truth) separation below it.
* ``ACTIVATION_M`` = S at that speed with the stopping terms = 0.894 m: where a robot that only
  stops would have to start braking; the field's ``d_cr + d_o`` and the filter's activation.
* ``K_REP_M_S`` = ``SPEED_LIMIT_M_S``: the field's repulsion (eq. 18, ``k_rep (d_o / (d - d_cr)
  - 1)``) equals the arm's speed limit at the middle of its band, ``d = d_cr + d_o / 2``.
* ``TASK_SPEED_M_S`` = 0.12 m/s along the task path (paper 2 gives no task speed; slow next to
  the limit, so the peaks are the evasions), ``ATTRACTION_LIMIT_M_S`` = ``SPEED_LIMIT_M_S`` for
  the PI's saturation (eq. 15).
* ``CONTROL_RATE_HZ`` = 275 Hz (paper 2's robot update rate).
* SSM's protective stop (``--ssm stop``) assumes braking at the smaller of ``SSM``'s 3 m/s^2 and
  the deceleration the robot's joint acceleration limits allow at its home pose
  (``ssm.braking_deceleration_m_s2``; limits from ``assets/limits/robot_limits.toml``).
"""

from __future__ import annotations

import math

from cobotsafety.arm.ssm import SsmParams, protective_separation_m

SSM = SsmParams()
SPEED_LIMIT_M_S = 0.5
ROBOT_SPEED_MAX_M_S = math.sqrt(3.0) * SPEED_LIMIT_M_S
CRITICAL_M = float(SSM.human_speed_m_s * SSM.reaction_time_s + ROBOT_SPEED_MAX_M_S * SSM.reaction_time_s
                   + SSM.margin_m)
ACTIVATION_M = float(protective_separation_m(ROBOT_SPEED_MAX_M_S, SSM))
K_REP_M_S = SPEED_LIMIT_M_S
TASK_SPEED_M_S = 0.12
ATTRACTION_LIMIT_M_S = SPEED_LIMIT_M_S
CONTROL_RATE_HZ = 275.0


def as_dict() -> dict:
    """The settings in a JSON report."""
    return {"speed_limit_m_s": SPEED_LIMIT_M_S, "critical_m": round(CRITICAL_M, 4),
            "activation_m": round(ACTIVATION_M, 4), "k_rep_m_s": K_REP_M_S, "task_speed_m_s": TASK_SPEED_M_S,
            "control_rate_hz": CONTROL_RATE_HZ}
