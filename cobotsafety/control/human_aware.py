"""``HumanAwareTeleop``: the human-aware controllers behind the ``Teleoperated`` protocol.

The user's desired velocity replaces paper 2's nominal path, so the demo and the trial tool
can drive every controller of ``cobotsafety.control.controllers`` by hand:

* ``anticipative``, ``stop``, ``reactive``: ``HumanAwareArm.step`` with that controller (the
  human capsules as moving zones, the standard stop, paper 2's potential field); every other
  limitation (joints, reach, table, protection zones) holds as in ``ArmTeleop``. ``reactive``
  first adds ``ArmTeleop``'s spring away from those other limitations to the user's command
  (paper 2's field knows only the human), then applies the field.
* ``off``: no filtering at all, the human included (joint limits still clamp).

``ssm = True`` adds the ISO/TS 15066 speed-and-separation layer to the three controllers.
The human model arrives with ``set_human(HumanCapsules)`` at the sensors' rate; between
frames the constraint extrapolates with the estimated human velocity. A stale frame with
nobody in it (the sensors cannot tell) keeps the last model: a dropout never clears the human.

Yield and return: with the gizmo released (a zero command) the arm holds the pose it was left
at: the command becomes an attraction to that point (``hold_gain_per_s`` times the offset,
at most ``return_speed_m_s``), filtered like any command. Pushed away by the human, the arm
returns to the held point when the human has gone (paper 2's attraction to its path).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from cobotsafety.arm.robots import DEFAULT_ROBOT
from cobotsafety.arm.step import ArmParams, all_measures, mapping, reactive_command
from cobotsafety.arm.teleop import default_zones
from cobotsafety.control.controllers import CONTROLLERS, HumanAwareArm
from cobotsafety.human.body import HumanCapsules
from cobotsafety.teleoperated import METHODS, StepReport


#: Yield and return: the attraction to the held point [1/s], its speed cap [m/s], and the
#: offset below which the hand counts as back [m].
HOLD_GAIN_PER_S = 2.0
RETURN_SPEED_M_S = 0.25
HOLD_DEADBAND_M = 1e-3


class HumanAwareTeleop:
    """A 3D arm teleoperated next to a tracked human. ``zones=None``: ``ArmTeleop``'s demo cell."""

    dim = 3

    def __init__(self, robot: str = DEFAULT_ROBOT, zones: list | None = None, params: ArmParams | None = None,
                 ssm: bool = False, **human_aware):
        self.arm = HumanAwareArm(robot, zones=[], params=params, **human_aware)
        self.arm.teleop.zones = zones if zones is not None else default_zones(self.state)
        self.ssm = ssm
        self.human_frame: HumanCapsules | None = None
        """The last frame given to ``set_human`` that was used (None: nobody seen yet)."""
        self.p_hold_m: np.ndarray | None = None
        """Shape (3,): the point the hand holds while the command is zero (None: it is driven)."""

    # ---- what the scene and the zone editor read ------------------------------------------
    @property
    def teleop(self):
        return self.arm.teleop

    @property
    def state(self):
        return self.arm.state

    @property
    def zones(self) -> list:
        return self.arm.teleop.zones

    @zones.setter
    def zones(self, zones: list) -> None:
        self.arm.teleop.zones = zones

    @property
    def constraints(self) -> list:
        return self.arm.teleop.constraints

    @property
    def p_base_ee_m(self) -> np.ndarray:
        return self.arm.teleop.p_base_ee_m

    # ---- the human --------------------------------------------------------------------------
    def set_human(self, human: HumanCapsules | None) -> None:
        """The human now (robot base frame); ``None`` or an absent, fresh frame clears it."""
        if human is None:
            self.human_frame = None
            self.arm.clear_human()
            return
        if not human.present and human.stale and self.human_frame is not None:
            return  # the sensors cannot tell: keep the last (conservative) model
        self.human_frame = human
        self.arm.set_human(human)

    # ---- Teleoperated -----------------------------------------------------------------------
    def reset(self) -> None:
        self.arm.teleop.reset()
        self.arm.yield_until_s = -np.inf
        self.p_hold_m = None

    def _hold(self, v_desired_m_s: np.ndarray) -> np.ndarray:
        """The user's command, or (released: zero) the attraction back to the held point."""
        v = np.asarray(v_desired_m_s, dtype=float)
        if any(x != 0.0 for x in v.ravel().tolist()):  # driven (NaN too: the filter refuses it)
            self.p_hold_m = None
            return v
        p = self.p_base_ee_m
        if self.p_hold_m is None:
            self.p_hold_m = p
        offset = self.p_hold_m - p
        if np.linalg.norm(offset) < HOLD_DEADBAND_M:
            return v
        attraction = HOLD_GAIN_PER_S * offset
        speed = float(np.linalg.norm(attraction))
        return attraction * min(1.0, RETURN_SPEED_M_S / speed)

    def step(self, v_desired_m_s: np.ndarray, dt_s: float, method: str = "anticipative") -> StepReport:
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        user_v = v_desired_m_s
        if method != "off":
            v_desired_m_s = self._hold(v_desired_m_s)
        if method == "off":
            report = self.arm.teleop.step(v_desired_m_s, dt_s, "off")
            distance = self.arm.human.minimum(self.state)[0]
        else:
            assert method in CONTROLLERS
            v, pushing = np.asarray(v_desired_m_s, dtype=float), ()
            if method == "reactive":
                v, pushing = self._spring_from_the_other_limitations(v)
            result = self.arm.step(v, dt_s, method, self.ssm)
            report, distance = result.report, result.min_distance_m
            if pushing:
                report = dataclasses.replace(report, v_desired_m_s=np.asarray(v_desired_m_s, dtype=float),
                                             binding=tuple(dict.fromkeys(pushing + report.binding)))
        if self.p_hold_m is not None:  # released: the return is ours, not a command refused
            report = dataclasses.replace(report, v_desired_m_s=np.asarray(user_v, dtype=float), stopped=False)
        return dataclasses.replace(report, min_distance_m=float(distance) if np.isfinite(distance) else None)

    def _spring_from_the_other_limitations(self, v: np.ndarray) -> tuple[np.ndarray, tuple[str, ...]]:
        """Paper 2's field repels from the human only; under teleoperation the ``reactive`` mode
        also pushes away from the zones, table, reach and joint limits (``ArmTeleop``'s spring)
        before the field, so it repels from every limitation as in the other scenes."""
        if not np.all(np.isfinite(v)):
            return np.zeros(3), ()
        state, teleop = self.state, self.arm.teleop
        others = [con for con in teleop.constraints if con is not self.arm.human]
        measures = all_measures(state, others, teleop.params.activation_m)
        M, _ = mapping(state, teleop.params, teleop.R_world_ee_ref)
        return reactive_command(measures, M, v, teleop.params)
