"""``ArmTeleop``: a pinocchio arm behind the ``cobotsafety.teleoperated.Teleoperated`` protocol."""

from __future__ import annotations

import logging

import numpy as np

from cobotsafety.arm.constraints import ArmConstraint, JointPositionLimits, ReachLimits, TablePlane, ZoneConstraint
from cobotsafety.arm.packed import PackedArm
from cobotsafety.arm.robot_state import RobotState
from cobotsafety.arm.robots import DEFAULT_ROBOT
from cobotsafety.arm.step import ArmParams, step
from cobotsafety.arm.zones import BoxZone, HalfSpaceZone, SphereZone
from cobotsafety.teleoperated import METHODS, StepReport

logger = logging.getLogger(__name__)


def default_zones(state: RobotState) -> list:
    """A demo cell around the home pose: a box and a sphere to slide along, a wall behind."""
    p = state.p_world_ee
    return [
        BoxZone("box zone", (p[0] + 0.15, p[1] - 0.25, 0.10), (0.08, 0.08, 0.10)),
        SphereZone("sphere zone", (p[0], p[1] + 0.30, p[2]), 0.08),
        HalfSpaceZone("wall", (-0.45, 0.0, 0.0), (-1.0, 0.0, 0.0)),
    ]


def reach_limits(state: RobotState) -> ReachLimits:
    """Inner 0.15 m and extended reach from the first link's capsule, sized at the home pose
    (1.4 x the home reach, at least 0.5 m)."""
    reach = float(np.linalg.norm(state.p_world_ee - state.capsule_p0[0]))
    return ReachLimits(tuple(state.capsule_p0[0]), inner_m=0.15, outer_m=max(0.5, 1.4 * reach))


def default_constraints(state: RobotState, zones: list | None, reach: ReachLimits | None = None) -> list[ArmConstraint]:
    """Joint limits, reach, the table (z = 0) for everything but the base links, and the zones."""
    constraints: list[ArmConstraint] = [JointPositionLimits()]
    if state.name != "planar":
        constraints += [reach or reach_limits(state), TablePlane(0.0, skip_capsules=2)]
    for zone in zones if zones is not None else default_zones(state):
        constraints.append(ZoneConstraint(zone, skip_capsules=1))
    return constraints


class ArmTeleop:
    """A 3D arm driven by the end-effector's translational velocity [m/s].

    ``extra_constraints`` (e.g. human capsules as moving zones) are added to the defaults;
    ``zones`` replaces the default protection zones. ``fast`` (default) steps on the packed
    compiled path (``cobotsafety.arm.packed``, equal to the reference ``arm.step.step``, which
    ``fast=False`` selects).
    """

    dim = 3

    def __init__(self, robot: str = DEFAULT_ROBOT, zones: list | None = None,
                 extra_constraints: list[ArmConstraint] | None = None, params: ArmParams | None = None,
                 fast: bool = True):
        self.state = RobotState(robot)
        self.packed = PackedArm(self.state) if fast else None
        self.params = params or ArmParams()
        self.zones = zones if zones is not None else default_zones(self.state)
        self.extra_constraints = list(extra_constraints or [])
        self.R_world_ee_ref = self.state.R_world_ee.copy()
        self.last_qdot = np.zeros(self.state.nv)
        self.last_command = np.zeros(3)
        """The previous step's command [m/s]: the acceleration bound starts from it."""
        self.contradictions = 0
        """Steps of this episode (since ``reset``) whose required retreats contradicted each other."""
        # Sized once at the home pose: a reach limit recomputed from the current pose would move
        # with the arm.
        self.reach = reach_limits(self.state) if self.state.name != "planar" else None
        self._cache_key: tuple | None = None
        self._constraints: list[ArmConstraint] = []

    @property
    def constraints(self) -> list[ArmConstraint]:
        """Built once, rebuilt when a zone, an extra constraint or ``reach`` is added, replaced or removed."""
        key = (tuple(map(id, self.zones)), tuple(map(id, self.extra_constraints)), id(self.reach))
        if key != self._cache_key:
            self._constraints = default_constraints(self.state, self.zones, self.reach) + self.extra_constraints
            self._cache_key = key
        return self._constraints

    def reset(self) -> None:
        self.state.q = np.array(self.state.spec.home_q, dtype=float)
        self.state.update()
        self.last_qdot = np.zeros(self.state.nv)
        self.last_command = np.zeros(3)
        self.contradictions = 0

    @property
    def p_base_ee_m(self) -> np.ndarray:
        return self.state.p_world_ee.copy()

    def step(self, v_desired_m_s: np.ndarray, dt_s: float, method: str = "anticipative") -> StepReport:
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        v = np.asarray(v_desired_m_s, dtype=float).reshape(-1)
        if v.shape != (3,):
            raise ValueError(f"v_desired_m_s must have shape (3,), got {np.shape(v_desired_m_s)}")
        before = self.state.p_world_ee  # the step replaces this array, never writes into it
        stepper = self.packed.step if self.packed is not None else step
        info = stepper(self.state, v, dt_s, self.constraints, self.params, method, self.R_world_ee_ref, self.last_qdot,
                       self.last_command)
        self.last_qdot = info.qdot
        self.last_command = info.v_commanded
        if info.relaxed:
            self.contradictions += 1
            if self.contradictions == 1:  # once per episode; the count is in every StepReport
                logger.warning("%s (further contradictions this episode are counted, not logged)", info.reason)
        after = self.state.p_world_ee
        return StepReport(
            v_desired_m_s=info.v_desired,
            v_commanded_m_s=info.v_commanded,
            v_executed_m_s=(after - before) / dt_s,
            p_base_ee_m=after.copy(),
            binding=info.binding,
            stopped=info.stopped,
            reason=info.reason,
            contradictions=self.contradictions,
            extras={"net_scale": info.net_scale},
        )
