"""The one place the human-approach experiments and the campaign touch the controller.

    controller = make_controller("iiwa", "anticipative", ssm="stop")
    out = step(controller, human, v_att_m_s, dt_s)     # -> ApproachStep

Strategies: ``anticipative`` (the sliding filter with the human as moving zones), ``reactive``
(paper 2's potential field), ``stop`` (the standard stop baseline). ``ssm``: ``"off"``,
``"scaling"`` (ISO/TS 15066 speed scaling: the speed toward the human bounded by
``ssm.max_approach_speed_m_s``) or ``"stop"`` (the standard's protective stop: the robot holds
still while the separation is below ``S`` at its current speed toward the human,
``ssm.protective_stop``). Today this wraps ``cobotsafety.control.controllers.HumanAwareArm``;
when the new controller lands only this file changes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cobotsafety.control.ssm import SsmParams, braking_deceleration_m_s2, protective_stop
from cobotsafety.experiments import approach_settings as settings
from cobotsafety.human.body import HumanCapsules
from cobotsafety.teleoperated import StepReport

STRATEGIES = ("anticipative", "reactive", "stop")
SSM_MODES = ("off", "scaling", "stop")


@dataclass
class Controller:
    arm: object
    """Today a ``HumanAwareArm``."""
    strategy: str
    ssm: str
    ssm_params: SsmParams
    robot: str
    human_set: bool = False
    """A human was given to the arm and not cleared since."""
    qdot_last: np.ndarray | None = None
    """The joint rates the last step executed (nv,) [rad/s]."""


@dataclass(frozen=True)
class ApproachStep:
    report: StepReport
    min_distance_m: float
    """The separation the controller sees [m] (inf when nobody is there)."""
    q: np.ndarray
    """Joint positions after the step (nq,) [rad]."""
    protective_stop: bool
    """SSM held the robot this step."""


def make_controller(robot: str, strategy: str, ssm: str = "off", capsules: str = "paper",
                    critical_m: float = settings.CRITICAL_M, activation_m: float = settings.ACTIVATION_M,
                    k_rep_m_s: float = settings.K_REP_M_S) -> Controller:
    """A human-aware controller of ``robot`` with the experiments' settings (``approach_settings``)."""
    from cobotsafety.arm.step import ArmParams
    from cobotsafety.control.controllers import HumanAwareArm
    from cobotsafety.control.human_constraint import HumanCapsulesConstraint
    from cobotsafety.control.potential_field import PotentialFieldParams

    if strategy not in STRATEGIES:
        raise ValueError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    if ssm not in SSM_MODES:
        raise ValueError(f"ssm must be one of {SSM_MODES}, got {ssm!r}")
    human = HumanCapsulesConstraint(critical_m=critical_m, activation_m=activation_m)
    field = PotentialFieldParams(critical_m=critical_m, influence_m=activation_m - critical_m, k_rep_m_s=k_rep_m_s)
    params = ArmParams(max_speed_m_s=settings.SPEED_LIMIT_M_S)
    arm = HumanAwareArm(robot, human=human, field=field, params=params)
    arm.state.use_capsules(capsules)
    limits, _ = settings.joint_acceleration_limits(robot)
    braking = min(params.max_accel_m_s2, braking_deceleration_m_s2(arm.state.J_ee[:3], limits[: arm.state.nv]))
    ssm_params = SsmParams(braking_m_s2=braking)
    arm.ssm_params = ssm_params
    return Controller(arm, strategy, ssm, ssm_params, robot)


def state(controller: Controller):
    """The robot state (``RobotState``: ``q``, ``p_world_ee``, capsules)."""
    return controller.arm.state


def _speed_toward_human(controller: Controller) -> tuple[float, float]:
    """(separation [m], the robot's closest point's speed toward the human [m/s]) from the last joint rates."""
    arm = controller.arm
    d, p_robot, p_human = arm.human.minimum(arm.state)
    if not np.isfinite(d):
        return np.inf, 0.0
    dists = arm.human.pairs(arm.state)[0]
    capsule = int(np.unravel_index(np.argmin(dists), dists.shape)[0]) + arm.human.skip_capsules
    qdot = controller.qdot_last if controller.qdot_last is not None else np.zeros(arm.state.nv)
    v_point = arm.state.point_jacobian(capsule, p_robot) @ qdot
    gap = p_human - p_robot
    u = gap / max(float(np.linalg.norm(gap)), 1e-9)
    return float(d), max(0.0, float(u @ v_point))


def step(controller: Controller, human: HumanCapsules | None, v_att_m_s: np.ndarray, dt_s: float) -> ApproachStep:
    """One control step toward ``v_att_m_s`` (3,) [m/s] with ``human`` (None: nobody in range)."""
    arm = controller.arm
    if human is not None and human.present:
        arm.set_human(human)
        controller.human_set = True
    elif controller.human_set:  # cleared once when the human leaves (the same as every step)
        arm.clear_human()
        controller.human_set = False
    q_before = arm.state.q.copy()
    held = False
    if controller.ssm == "stop":
        separation, v_r = _speed_toward_human(controller)
        held = bool(np.isfinite(separation) and protective_stop(separation, v_r, controller.ssm_params))
    if held:  # the protective stop: standstill (the robot's braking is in S's T_s and B)
        p = arm.state.p_world_ee.copy()
        arm.teleop.last_qdot = np.zeros(arm.state.nv)
        arm.teleop.last_command = np.zeros(3)
        arm.clock_s += dt_s
        report = StepReport(np.asarray(v_att_m_s, float), np.zeros(3), np.zeros(3), p, (), True,
                            reason="SSM protective stop")
        d = arm.human.minimum(arm.state)[0]
    else:
        out = arm.step(v_att_m_s, dt_s, controller.strategy, controller.ssm == "scaling")
        report, d = out.report, out.min_distance_m
    q = arm.state.q.copy()
    controller.qdot_last = (q - q_before) / dt_s  # revolute arms: nq == nv
    return ApproachStep(report, float(d), q, held)
