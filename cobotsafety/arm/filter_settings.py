"""The arm filter's settings, each with its unit and the principle it was chosen by.

``FilterSettings.vector()`` lays them out in the order the compiled step reads them
(``step_kernel.arm_step`` unpacks them in the same order).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from cobotsafety.arm.ssm import SsmParams
from cobotsafety.errors import CobotSafetyError


class SettingsError(CobotSafetyError, ValueError):
    """A filter setting out of its range; the message names it."""


@dataclass(frozen=True)
class FilterSettings:
    """Units in the names. Defaults and why:

    * ``max_speed_m_s`` 0.5: the end-effector speed cap (a norm), at most the robot's own
      (``MotionLimits.ee_speed_m_s``); the demo's gizmo asks for 0.25 (ISO/TS 15066's
      reduced speed suggestion for collaborative operation), the filter never more than this for
      a command; a retreat from a person walking at the arm may exceed it (the cap is planned and
      gives way to safety; the anticipative arm's cap is then ``motion_box.EE_MOTION_SHARE``
      (0.9) of the robot's own ``ee_speed_m_s`` when that is more), never the robot's own
      ``ee_speed_m_s``.
    * ``activation_m`` 0.15: metric limitations (zones, table, reach) farther than this do not
      enter the filter unless the arm moves fast enough to need more: they enter from the plan's
      braking distance (``brake_share`` of the hand's per-axis box) of the arm's fastest capsule
      end at its speed now, when that is farther (the panda's hand at the cap of 0.5 m/s brakes
      in 0.04 m, the iiwa's in 0.25 m).
    * ``buffer_m`` / ``buffer_rad`` 1e-3: the filter keeps this clearance, so the second-order
      motion while sliding (curved limitations, rotating links) never reaches the limit itself.
    * ``recovery_gain_per_s`` 1.0: inside the buffer the arm drifts back out at this rate times
      the intrusion.
    * ``damping_width_m`` / ``damping_width_rad`` 0: paper 1's damped zone (III.C.1), an option:
      within this width of a limitation the allowed approach shrinks linearly to zero. The
      braking bound already makes sliding start early enough to turn smoothly.
    * ``brake_share`` 0.5: the share of the joints' acceleration and jerk limits a limitation
      may count on to brake (the rest is left for the curvature of the motion, the other
      limitations and the user's own command).
    * ``null_weight_m_rad`` 0.01: ``eps`` of ``joint_filter``: 1 rad/s of posture change
      weighs as 1 cm/s of deviation of the hand, so the body moves out of a limitation's way
      before the hand gives way.
    * ``w_threshold`` 0.01 and ``damping_max`` 0.05 m: the singularity safeguard (the
      pseudo-inverse's damping grows below this manipulability, up to this damping).
    * ``orientation_gain_per_s`` 2.0, ``centering_gain_per_s`` 0.2: the secondary task.
    * ``field_*``: paper 2's potential field (the ``reactive`` strategy): repulsion
      ``k_rep (d_o / (d - d_cr) - 1)`` within ``d_cr + d_o`` of the human (eq. 18), at most
      ``field_max_repulsion_m_s``; ``field_damping`` is eqs. 16 and 20's lambda.
    * ``evasion_gain`` 1.0: next to a person, the anticipative filter's command is the user's
      plus this times paper 2's repulsion (the ``field_*`` settings) at the arm's closest point,
      so the arm moves out of a person's way as paper 2's field does while the filter keeps
      every limitation (the human's critical distance among them) as rows; 0: the user's command
      alone (pure sliding, the arm only yields).
    * ``ssm``: ISO/TS 15066 speed and separation monitoring's terms (``cobotsafety.arm.ssm``):
      the human's speed (ISO 13855's 1.6 m/s walking), the reaction time, the robot's braking,
      the intrusion and the position uncertainties of human and robot.
    """

    max_speed_m_s: float = 0.5
    activation_m: float = 0.15
    buffer_m: float = 1e-3
    buffer_rad: float = 1e-3
    recovery_gain_per_s: float = 1.0
    damping_width_m: float = 0.0
    damping_width_rad: float = 0.0
    brake_share: float = 0.5
    null_weight_m_rad: float = 0.01
    w_threshold: float = 0.01
    damping_max: float = 0.05
    orientation_gain_per_s: float = 2.0
    centering_gain_per_s: float = 0.2
    field_critical_m: float = 0.25
    field_influence_m: float = 0.35
    field_k_rep_m_s: float = 0.08
    field_max_repulsion_m_s: float = 1.0
    field_damping: float = 1e-3
    evasion_gain: float = 1.0
    ssm: SsmParams = field(default_factory=SsmParams)

    def __post_init__(self):
        for f in fields(self):
            if f.name == "ssm":
                continue
            value = getattr(self, f.name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise SettingsError(f"FilterSettings.{f.name} must be a finite number, got {value!r}")
            positive = f.name in ("max_speed_m_s", "brake_share", "null_weight_m_rad", "w_threshold",
                                  "field_influence_m")
            if value < 0 or (positive and value == 0):
                raise SettingsError(f"FilterSettings.{f.name} must be {'> 0' if positive else '>= 0'}, got {value}")
        if self.brake_share > 1.0:
            raise SettingsError(f"FilterSettings.brake_share must be <= 1, got {self.brake_share}")

    def vector(self) -> np.ndarray:
        """The settings as the compiled step reads them: the numbers in field order, then
        ``ssm.vector()``."""
        numbers = [getattr(self, f.name) for f in fields(self) if f.name != "ssm"]
        return np.concatenate([np.array(numbers, dtype=float), self.ssm.vector()])
