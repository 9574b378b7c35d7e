"""The one place the human-approach experiments and the campaign touch the controller.

    controller = make_controller("iiwa", "anticipative", ssm="stop")
    out = step(controller, human, v_att_m_s, dt_s)     # -> ApproachStep
    out = step(controller, human, qdot_rad_s, dt_s, joints=True)  # a posture move (control.recovery)

Strategies: ``anticipative`` (the joint-space sliding filter with the human as a moving zone),
``reactive`` (paper 2's potential field, sliding off every other limitation), ``stop`` (the
standard stop baseline). ``ssm``: ``"off"``, ``"scaling"`` (ISO/TS 15066 speed scaling: the
approach to the human at most ``arm.ssm.max_approach_speed_m_s`` of the separation) or
``"stop"`` (the standard's protective stop: the robot brakes to a stop while the separation is
below ``S`` at its speed toward the human), both in ``ArmController``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cobotsafety.arm.ssm import SsmParams, braking_deceleration_m_s2
from cobotsafety.experiments import approach_settings as settings
from cobotsafety.human.body import HumanCapsules

STRATEGIES = ("anticipative", "reactive", "stop")
SSM_MODES = ("off", "scaling", "stop")


@dataclass
class Controller:
    arm: object
    """The ``ArmController``."""
    strategy: str
    ssm: str
    ssm_params: SsmParams
    robot: str
    human_set: bool = False
    """A human was given to the arm and not cleared since."""


@dataclass(frozen=True)
class ApproachStep:
    report: object
    """The step's ``StepReport`` (an ``ArmStepReport``)."""
    min_distance_m: float
    """The separation the controller sees [m] (inf when nobody is there)."""
    q: np.ndarray
    """Joint positions after the step (nq,) [rad]."""
    protective_stop: bool
    """SSM's protective stop held the robot this step."""


def make_controller(robot: str, strategy: str, ssm: str = "off", capsules: str = "paper",
                    critical_m: float = settings.CRITICAL_M, activation_m: float = settings.ACTIVATION_M,
                    k_rep_m_s: float = settings.K_REP_M_S):
    """An ``ArmController`` of ``robot`` with the experiments' settings (``approach_settings``),
    no protection zones (the cell of paper 2 has the table only)."""
    from cobotsafety.arm.controller import ArmController
    from cobotsafety.arm.filter_settings import FilterSettings
    from cobotsafety.arm.limitations import HumanLimitation

    if strategy not in STRATEGIES:
        raise ValueError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    if ssm not in SSM_MODES:
        raise ValueError(f"ssm must be one of {SSM_MODES}, got {ssm!r}")
    probe = ArmController(robot, zones=[], capsules=capsules)
    limits = probe.model.limits.acceleration_rad_s2
    braking = min(settings.SSM.braking_m_s2, braking_deceleration_m_s2(probe.state.J_ee, limits))
    ssm_params = SsmParams(braking_m_s2=braking)
    filter_settings = FilterSettings(max_speed_m_s=settings.SPEED_LIMIT_M_S, field_critical_m=critical_m,
                                     field_influence_m=activation_m - critical_m, field_k_rep_m_s=k_rep_m_s,
                                     ssm=ssm_params)
    arm = ArmController(robot, zones=[], capsules=capsules, settings=filter_settings,
                        human=HumanLimitation(critical_m=critical_m, activation_m=activation_m), ssm=ssm)
    return Controller(arm, strategy, ssm, ssm_params, robot)


def state(controller: Controller):
    """The robot state (``RobotState``: ``q``, ``p_world_ee``, capsules)."""
    return controller.arm.state


def step(controller: Controller, human: HumanCapsules | None, v_att_m_s: np.ndarray, dt_s: float,
         joints: bool = False) -> ApproachStep:
    """One control step toward ``v_att_m_s`` (3,) [m/s] (``joints``: a joint velocity (nv,)
    [rad/s], ``ArmController.step_joints``) with ``human`` (None: nobody in range)."""
    arm = controller.arm
    if human is not None and human.present:
        arm.set_human(human)
        controller.human_set = True
    elif controller.human_set:  # cleared once when the human leaves
        arm.clear_human()
        controller.human_set = False
    report = (arm.step_joints if joints else arm.step)(np.asarray(v_att_m_s, dtype=float), dt_s, controller.strategy)
    d = report.min_distance_m
    held = report.protective_stop
    return ApproachStep(report, float(d) if d is not None else float("inf"), arm.state.q.copy(), held)
