"""The human-aware controllers, for autonomous paths and for teleoperation.

``HumanAwareArm`` wraps an ``ArmTeleop`` and a human model (capsules + estimated velocities)
and offers one ``step`` for the three controllers:

* ``anticipative``: the sliding filter with the human capsules as moving zones
  (``HumanCapsulesConstraint``): the robot slides around the human.
* ``stop``: the standard implementation: zero velocity when the command (or the human's
  approach) would bring any robot capsule within the critical distance.
* ``reactive``: paper 2's potential field (eqs. 16-21) at the robot's closest point.

With ``ssm=True`` the ISO/TS 15066 layer first limits the command's speed toward the human
(``cobotsafety.control.ssm``), away-from-human motion untouched; for the reactive controller
the same half-spaces are applied to its joint velocities.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from cobotsafety.arm.step import ArmParams, integrate_with_safety_net, mapping
from cobotsafety.arm.teleop import ArmTeleop
from cobotsafety.control.human_constraint import HumanCapsulesConstraint
from cobotsafety.control.human_velocity import HumanVelocityEstimator
from cobotsafety.control.potential_field import PotentialFieldParams, potential_field_qdot
from cobotsafety.control.ssm import SsmParams, ssm_halfspaces
from cobotsafety.human.body import HumanCapsules
from cobotsafety.projection import slide
from cobotsafety.teleoperated import StepReport

CONTROLLERS = ("anticipative", "reactive", "stop")
#: How long the anticipative arm yields [s] once contradicting retreats left it no motion.
YIELD_DWELL_S = 0.3


@dataclass
class HumanStep:
    report: StepReport
    min_distance_m: float
    p_robot: np.ndarray
    p_human: np.ndarray


class HumanAwareArm:
    """An arm that knows where the human is. ``set_human(HumanCapsules)`` before every ``step``.

    ``fast=False`` steps on the reference path instead of the packed one (``ArmTeleop``)."""

    def __init__(self, robot: str = "panda", zones: list | None = None, params: ArmParams | None = None,
                 human: HumanCapsulesConstraint | None = None, ssm: SsmParams | None = None,
                 field: PotentialFieldParams | None = None, fast: bool = True):
        self.human = human or HumanCapsulesConstraint()
        self.teleop = ArmTeleop(robot, zones=zones if zones is not None else [], extra_constraints=[self.human],
                                params=params, fast=fast)
        self.ssm_params = ssm or SsmParams()
        self.field = field or PotentialFieldParams(critical_m=self.human.critical_m,
                                                   influence_m=self.human.activation_m - self.human.critical_m)
        self.velocity = HumanVelocityEstimator()
        self.clock_s = 0.0
        """Time stepped so far [s] (the yield decision's clock)."""
        self.yield_until_s = -np.inf
        """Until then the anticipative arm yields: it takes no command and only gives way."""

    @property
    def state(self):
        return self.teleop.state

    def set_human(self, human: HumanCapsules | None) -> None:
        """The human now (robot base frame); None or an absent human clears it. Without
        end-point velocities, they are estimated here (``HumanVelocityEstimator``)."""
        if human is not None and human.present and human.v0_b_m_s is None:
            human = self.velocity.update(human)
        elif human is None or not human.present:
            self.velocity.reset()
        self.human.set_human(human)

    def clear_human(self) -> None:
        self.set_human(None)

    def _ssm_rows(self, M, c):
        measures = self.human.measures(self.state)
        return ssm_halfspaces(measures, self.human.critical_m, M, c, self.ssm_params), measures

    def step(self, v_desired_m_s: np.ndarray, dt_s: float, controller: str = "anticipative",
             ssm: bool = False) -> HumanStep:
        if controller not in CONTROLLERS:
            raise ValueError(f"controller must be one of {CONTROLLERS}, got {controller!r}")
        v = np.asarray(v_desired_m_s, dtype=float)
        if not math.isfinite(sum(v.ravel().tolist())):
            v = np.zeros(3)
        state = self.state
        if controller == "reactive":
            report = self._reactive_step(v, dt_s, ssm)
        else:
            if ssm:
                M, c = mapping(state, self.teleop.params, self.teleop.R_world_ee_ref)
                rows, _ = self._ssm_rows(M, c)
                if rows.normals.shape[0]:
                    try:
                        v = slide(v, rows.normals, rows.bounds)
                    except ValueError:
                        v = np.zeros(3)
            yielding = controller == "anticipative" and self.clock_s < self.yield_until_s
            report = self.teleop.step(np.zeros(3) if yielding else v, dt_s, controller)
            if controller == "anticipative":
                report = self._yield_decision(report, yielding)
        self.clock_s += dt_s
        d, pr, ph = self.human.minimum(state)
        return HumanStep(report, d, pr, ph)

    def _yield_decision(self, report: StepReport, yielding: bool) -> StepReport:
        """When contradicting retreats leave the arm no motion, it *decides* to yield for
        ``YIELD_DWELL_S`` (zero command: it only gives way), instead of stopping and going
        at every step while the human stays; the report says so."""
        blocked = report.reason.startswith("retreats contradict") and np.linalg.norm(report.v_commanded_m_s) < 1e-3
        if blocked:
            self.yield_until_s = self.clock_s + YIELD_DWELL_S
        if blocked or yielding:
            reason = "yielding: " + (report.reason or "the retreats contradicted each other")
            return dataclasses.replace(report, stopped=True, reason=reason)
        return report

    def _reactive_step(self, v_att: np.ndarray, dt_s: float, ssm: bool) -> StepReport:
        state = self.state
        before = state.p_world_ee.copy()
        d, pr, ph = self.human.minimum(state)
        J_cp = None
        if np.isfinite(d):
            dists = self.human.pairs(state)[0]
            capsule = int(np.unravel_index(np.argmin(dists), dists.shape)[0]) + self.human.skip_capsules
            J_cp = state.point_jacobian(capsule, pr)
        qdot, stopped = potential_field_qdot(state.J_ee, v_att, d, pr, ph, J_cp, self.field)
        if ssm and not stopped:
            measures = self.human.measures(state)
            if measures.distance.size:
                limit = self.ssm_params.max_approach_speed_m_s(measures.distance + self.human.critical_m)
                qdot = slide(qdot, measures.A, -limit)
        vmax = state.model.velocityLimit
        ratio = float(np.max(np.abs(qdot) / vmax))
        if ratio > 1.0:
            qdot = qdot / ratio
        # The field knows only the human: the zones, the table, the reach and the joint limits
        # hold through the same safety net as the other controllers (a step that would cross
        # one is scaled down).
        constraints = self.teleop.constraints
        integrate_with_safety_net(state, qdot, dt_s, constraints, [con.distances(state) for con in constraints])
        executed = (state.p_world_ee - before) / dt_s
        return StepReport(v_att, v_att, executed, state.p_world_ee.copy(), (), stopped)
