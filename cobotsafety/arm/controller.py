"""``ArmController``: one 3D arm, its limitations and the human, behind ``Teleoperated``.

One object per robot owns the state (``q`` and the previous step's joint velocity and
acceleration), the scene (joint limits, reach, table, protection zones, the human) and the
settings, and steps them with one compiled call (``step_kernel.arm_step``). The strategies are
paper 1's comparison set and paper 2's field:

* ``anticipative``: the joint-space sliding filter (``joint_filter``);
* ``stop``: the standard implementation: the arm brakes to a stop as soon as the command would
  break a limitation's bound;
* ``reactive``: paper 2's potential field at the human's closest point (eqs. 16-21), sliding off
  every other limitation as the anticipative filter does;
* ``off``: no safety filter: only the robot's own speed, acceleration and jerk limits.

``step(v)`` takes the hand's velocity; ``step_joints(qdot)`` a joint velocity (a posture move,
``control.recovery``), followed in joint space by the same filter. The command is checked once,
here: a non-finite velocity or period gives the zero-change command (the arm holds its
motion's decay) and a logged reason, never a NaN state; a period longer than ``MAX_STEP_S`` is
split into steps of at most that (at most ``MAX_PERIOD_S`` in all, else refused). Around the
filter:

* **Hold and return**: a zero command (the gizmo released) holds the pose the hand was left at:
  the command becomes an attraction to that point (``HOLD_GAIN_PER_S``, at most
  ``RETURN_SPEED_M_S``), filtered like any command; pushed away by the human, the hand returns
  when the human has gone.
* **Yield**: when contradicting retreats leave the anticipative arm no motion, it yields for
  ``YIELD_DWELL_S`` (the user's command is set aside; the arm only gives way) instead of
  stopping and going at every step while the human stays.
* **Human watchdog** (``HumanWatchdog``): the human model's age is the time since it was last
  given (``set_human``) plus the age of its newest sensor data then. Older than
  ``grow_after_s`` it grows: every capsule's radius by ``growth_speed_m_s`` times the excess
  age (a person can have moved that far); older than ``stop_after_s`` the arm brakes to a stop.
  ``StepReport.human_status`` says which.
* **SSM** (``ssm``: ``"off"``, ``"scaling"``, ``"stop"`` or ``"both"``; ``True`` is ``"both"``):
  ISO/TS 15066 speed and separation monitoring (``arm.ssm``): *speed scaling*, the arm's approach
  to the human at most the standard's speed for the separation; the *protective stop*, the arm
  brakes to a stop while the separation is below the protective distance ``S`` at its approach
  speed, and stays stopped until the separation is at least ``S`` at the speed cap (the speed it
  may take when it goes again), so it does not stop and go where the separation hovers at ``S``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from cobotsafety.arm.filter_settings import FilterSettings
from cobotsafety.arm.joint_filter import LEVEL_APPROACH_NOTHING, LEVEL_RELAXED, LEVEL_SMOOTHNESS, LEVEL_STOPPED
from cobotsafety.arm.limitations import BoxZone, HalfSpaceZone, HumanLimitation, JointPositionLimits, ReachLimits, \
    SphereZone, TablePlane
from cobotsafety.arm.limitations.human import human_buffer
from cobotsafety.arm.limitations.registry import pack_scene
from cobotsafety.arm.robot_model import RobotModel
from cobotsafety.arm.robot_state import RobotState
from cobotsafety.arm.robots import DEFAULT_ROBOT
from cobotsafety.arm.step_kernel import (FLAG_JOINT_COMMAND, FLAG_ORIENTATION, FLAG_PROTECTIVE,
                                         FLAG_PROTECTIVE_HELD, FLAG_SSM, FLAG_STOP, GAVE_WAY_HAND, GAVE_WAY_JOINTS,
                                         OUT_I_HEADER, OWNER_EE_MOTION, OWNER_MOTION, OWNER_SPEED, OWNER_VELOCITY,
                                         STATUS_DONE, STRATEGIES, arm_step, decode_row, output_layout)
from cobotsafety.arm.step_report import ArmStepReport
from cobotsafety.errors import CobotSafetyError
from cobotsafety.human.body import HumanCapsules
from cobotsafety.teleoperated import METHODS, StepReport

logger = logging.getLogger(__name__)

#: Hold and return: the attraction to the held point [1/s], its speed cap [m/s], and the offset
#: below which the hand counts as back [m].
HOLD_GAIN_PER_S = 2.0
RETURN_SPEED_M_S = 0.25
HOLD_DEADBAND_M = 1e-3
#: How long the anticipative arm yields [s] once contradicting retreats left it no motion.
YIELD_DWELL_S = 0.3
#: Longest period integrated in one step [s]; a longer one is split (the filters are tested for
#: periods up to 10 ms). Longer than ``MAX_PERIOD_S`` [s]: refused.
MAX_STEP_S = 0.010
MAX_PERIOD_S = 1.0
SSM_MODES = ("off", "scaling", "stop", "both")
SSM_MODES_BY_VALUE = {False: "off", True: "both"}
#: The step's flags for each ``ssm`` value (orientation always).
_SSM_FLAGS = {mode: FLAG_ORIENTATION | (FLAG_SSM if mode in ("scaling", "both") else 0)
              | (FLAG_PROTECTIVE if mode in ("stop", "both") else 0) for mode in SSM_MODES}
_SSM_FLAGS.update({value: _SSM_FLAGS[mode] for value, mode in SSM_MODES_BY_VALUE.items()})
_STRATEGY_CODES = {name: code for code, name in enumerate(STRATEGIES)}
_ANTICIPATIVE, _OFF, _STOP = _STRATEGY_CODES["anticipative"], _STRATEGY_CODES["off"], _STRATEGY_CODES["stop"]
_FLOAT = np.dtype(float)
_ZERO3 = np.zeros(3)
_EMPTY = np.zeros(0)
_GAVE_WAY_REASONS = {GAVE_WAY_JOINTS: "safety over smoothness: the joints' motion limits gave way",
                     GAVE_WAY_HAND: "safety over smoothness: the hand's motion limits gave way (the joints' kept)"}
_LEVEL_REASONS = {LEVEL_RELAXED: "retreats contradict",
                  LEVEL_APPROACH_NOTHING: "limits contradict: approaching nothing",
                  LEVEL_STOPPED: "limits contradict: stopped"}


class StepError(CobotSafetyError, ValueError):
    """A step that cannot be taken (a period far beyond the control period)."""


@dataclass(frozen=True)
class HumanWatchdog:
    """Ages [s] at which an unrefreshed human model grows, then stops the arm; the speed [m/s]
    it grows at (ISO 13855's hand speed, 2 m/s). Defaults: 0.05 s (2.5 frames of paper 2's
    50 Hz laser) and 0.5 s."""

    grow_after_s: float = 0.05
    stop_after_s: float = 0.5
    growth_speed_m_s: float = 2.0


def default_zones(p_world_ee_m: np.ndarray) -> list:
    """A demo cell around the home pose: a box and a sphere to slide along, a wall behind."""
    p = p_world_ee_m
    return [
        BoxZone("box zone", (p[0] + 0.15, p[1] - 0.25, 0.10), (0.08, 0.08, 0.10)),
        SphereZone("sphere zone", (p[0], p[1] + 0.30, p[2]), 0.08),
        HalfSpaceZone("wall", (-0.45, 0.0, 0.0), (-1.0, 0.0, 0.0)),
    ]


#: The extended reach is at most this share of the arm's farthest reach: a fully stretched arm
#: is singular (the hand cannot be moved along the arm, nor braked along it, with bounded joint
#: accelerations).
REACH_SHARE = 0.9


#: ``farthest_reach_m``'s results by robot, centre and sampling: the same for every controller of
#: a robot (a campaign builds several per person), so it is computed once per process.
_FARTHEST_REACH_M: dict = {}


def farthest_reach_m(model: RobotModel, centre: np.ndarray, samples: int = 4000, seed: int = 0) -> float:
    """The farthest the end-effector gets from ``centre`` [m] over ``samples`` configurations
    drawn uniformly within the joint limits (a generator of our own, seeded); remembered per
    robot, centre and sampling."""
    key = (model.name, model.ee_frame_id, np.asarray(centre, dtype=float).tobytes(), samples, seed)
    found = _FARTHEST_REACH_M.get(key)
    if found is None:
        found = _FARTHEST_REACH_M[key] = _sample_farthest_reach_m(model, centre, samples, seed)
    return found


def _sample_farthest_reach_m(model: RobotModel, centre: np.ndarray, samples: int, seed: int) -> float:
    import pinocchio as pin  # noqa: PLC0415

    rng = np.random.default_rng(seed)
    lower = np.where(np.isfinite(model.lower) & (model.lower > -10), model.lower, -np.pi)
    upper = np.where(np.isfinite(model.upper) & (model.upper < 10), model.upper, np.pi)
    data = model.model.createData()
    farthest = 0.0
    for _ in range(samples):
        q = pin.neutral(model.model)
        for j in range(1, model.model.njoints):
            joint = model.model.joints[j]
            if joint.nq == 2:  # continuous: (cos, sin)
                angle = rng.uniform(-np.pi, np.pi)
                q[joint.idx_q:joint.idx_q + 2] = (np.cos(angle), np.sin(angle))
            else:
                q[joint.idx_q] = rng.uniform(lower[joint.idx_q], upper[joint.idx_q])
        pin.framesForwardKinematics(model.model, data, q)
        farthest = max(farthest, float(np.linalg.norm(data.oMf[model.ee_frame_id].translation - centre)))
    return farthest


def reach_limits(state: RobotState) -> ReachLimits:
    """Inner 0.15 m and extended reach from the first capsule's end, sized at the home pose:
    1.4 x the home reach (at least 0.5 m), at most ``REACH_SHARE`` of the farthest reach."""
    centre = np.array(state.capsule_p0[0], dtype=float)
    reach = float(np.linalg.norm(state.p_world_ee - centre))
    outer = min(max(0.5, 1.4 * reach), REACH_SHARE * farthest_reach_m(state.robot, centre))
    return ReachLimits(tuple(float(x) for x in centre), inner_m=0.15, outer_m=outer)


class ArmController:
    """A 3D arm driven by its end-effector's translational velocity [m/s] (``Teleoperated``).

    ``zones``: the protection zones (None: ``default_zones`` around the home pose; ``[]``:
    none); ``human``: the human limitation (its critical and activation distances);
    ``capsules``: the robot's capsule table ("fitted" or "paper").
    """

    dim = 3

    def __init__(self, robot: str = DEFAULT_ROBOT, zones: list | None = None, *,
                 settings: FilterSettings | None = None, human: HumanLimitation | None = None,
                 capsules: str = "fitted", ssm: bool | str = "off", watchdog: HumanWatchdog = HumanWatchdog(),
                 table: bool = True, reach: bool = True):
        self.model = RobotModel.load(robot, capsules)
        self.settings = settings or FilterSettings()
        self.human = human or HumanLimitation()
        self.ssm = ssm
        self.watchdog = watchdog
        nq, nv, c = self.model.nq, self.model.nv, len(self.model.capsules)
        self._offsets = tuple(int(o) for o in output_layout(nq, nv, c, int(self.model.robot_i[0])))
        self._state_f = np.zeros(nq + 2 * nv + 6)
        self._reference_f = np.zeros(10)
        self._settings_f = self.settings.vector()
        self._out_size = int(self._offsets[-1])
        self._out_i_size = OUT_I_HEADER + 1024
        self.state = RobotState(self.model)
        self._set_q(self.model.home_q)
        self.R_world_ee_ref = self.state.R_world_ee.copy()
        self._reference_f[:9] = self.R_world_ee_ref.ravel()
        self.reach = reach_limits(self.state) if reach else None
        self.table = TablePlane(0.0) if table else None
        self.zones = zones if zones is not None else default_zones(self.state.p_world_ee)
        self._packed: list = []
        self._pack = None
        self._names: dict = {}
        # A person's compiled packing (``human_buffer``) compiled or loaded from the cache here,
        # not in the control thread when the first person is seen.
        nobody = np.zeros((0, 3))
        human_buffer(nobody, nobody, _EMPTY, nobody, nobody)
        self.set_human(None)  # nobody expected yet
        self.clock_s = 0.0
        """Time stepped since the start [s] (the watchdog's and the yield's clock)."""
        self.reset()
        assert set(STRATEGIES) == set(METHODS), "the kernel's strategies are the Teleoperated methods"

    # ---- state ------------------------------------------------------------------------------
    def _set_q(self, q: np.ndarray) -> None:
        """Put the arm at ``q`` at rest and compute its kinematics (one zero-velocity step; the
        stop strategy, which, unlike ``off``, does not hold the joints at their end stops, so a
        ``q`` beyond a joint limit stays where it is)."""
        nq = self.model.nq
        self._state_f[:] = 0.0
        self._state_f[:nq] = q
        self._reference_f[9] = self.settings.max_speed_m_s
        out_f, out_i = np.empty(self._out_size), np.empty(self._out_i_size, dtype=np.int64)
        # Stopped from rest, nothing in the scene: the arm stays put and the step computes its kinematics.
        arm_step(self._state_f, _EMPTY, np.zeros(3), 1e-3, _STOP, FLAG_STOP, 0.0, self._reference_f, self.model.robot_i,
                 self.model.robot_f, np.zeros((0, 2), dtype=np.int64), np.zeros((0, 12)), np.zeros(0),
                 self._settings_f, out_f, out_i)
        self._state_f[:nq] = q
        self._state_f[nq:] = 0.0
        self.state.refresh(out_f, self._offsets)

    def set_configuration(self, q: np.ndarray) -> None:
        """Put the arm at rest at ``q`` (shape (nq,)), e.g. a test's random state; the hold point,
        the yield and the counters are kept."""
        q = np.array(q, dtype=float).reshape(-1)
        if q.shape != (self.model.nq,) or not np.all(np.isfinite(q)):
            raise ValueError(f"q must be {self.model.nq} finite numbers, got {q}")
        self._set_q(q)

    def set_measured_state(self, q: np.ndarray, qdot_rad_s: np.ndarray, qddot_rad_s2: np.ndarray) -> None:
        """Closed loop: the arm is at ``q`` (nq,) moving at ``qdot_rad_s`` (nv,) with the
        acceleration ``qddot_rad_s2`` (nv,), as measured (or as the robot's own rate limiter let
        it move, ``rate_limiter``); the next step starts from this state (the hand's velocity
        too: ``J qdot`` at ``q``, and its acceleration ``J qddot``, which leaves out the path's
        curvature: the next step's report of the hand's jerk is that much approximate). The hold
        point, the yield, the clock and the counters are kept."""
        nq, nv = self.model.nq, self.model.nv
        q = np.array(q, dtype=float).reshape(-1)
        qdot = np.array(qdot_rad_s, dtype=float).reshape(-1)
        qddot = np.array(qddot_rad_s2, dtype=float).reshape(-1)
        if q.shape != (nq,) or qdot.shape != (nv,) or qddot.shape != (nv,) or not (
                np.all(np.isfinite(q)) and np.all(np.isfinite(qdot)) and np.all(np.isfinite(qddot))):
            raise ValueError(f"a measured state is q ({nq}), qdot ({nv}) and qddot ({nv}) finite numbers, got "
                             f"{q}, {qdot}, {qddot}")
        self._set_q(q)
        self._state_f[nq:nq + nv] = qdot
        self._state_f[nq + nv:nq + 2 * nv] = qddot
        J = self.state.J_ee
        self._state_f[nq + 2 * nv:nq + 2 * nv + 3] = J @ qdot
        self._state_f[nq + 2 * nv + 3:nq + 2 * nv + 6] = J @ qddot

    @property
    def joint_velocity_rad_s(self) -> np.ndarray:
        """The joint velocity (nv,) [rad/s] of the last step (a copy)."""
        nq, nv = self.model.nq, self.model.nv
        return self._state_f[nq:nq + nv].copy()

    @property
    def joint_acceleration_rad_s2(self) -> np.ndarray:
        """The joint acceleration (nv,) [rad/s²] of the last step (a copy)."""
        nq, nv = self.model.nq, self.model.nv
        return self._state_f[nq + nv:nq + 2 * nv].copy()

    def reset(self) -> None:
        """Home pose at rest; hold, yield and the episode's counters cleared."""
        self._set_q(self.model.home_q)
        self.p_hold_m: np.ndarray | None = None
        self.yield_until_s = -math.inf
        self.contradictions = 0
        self.smoothness_steps = 0
        self.hand_over_limit_steps = 0
        """Steps whose executed hand path went over the robot's end-effector acceleration or jerk
        limit (``ArmStepReport.hand_over_limit``), this episode."""
        self.last_report: StepReport | None = None

    @property
    def p_base_ee_m(self) -> np.ndarray:
        return self.state.p_world_ee.copy()

    @property
    def limitations(self) -> list:
        """Joint limits, reach, table, the zones and the human, in the filter's order."""
        found = [JointPositionLimits()]
        found += [lim for lim in (self.reach, self.table) if lim is not None]
        return found + list(self.zones) + [self.human]

    def blocked_by_joint_limits(self, report: ArmStepReport) -> bool:
        """``report`` (a step of this arm) slides on a joint limit and on no person's row: the
        posture's deadlock (``control.recovery``) rather than a person in the way."""
        owners = report.binding_owners
        return 0 in owners and len(self.limitations) - 1 not in owners

    def _scene(self):
        """The packed scene, packed again when a zone is added, replaced or removed, or the
        reach, table or human limitation replaced (limitations are frozen values: a change is a
        new object; one equal to the one it replaces packs the same)."""
        current = [*self.zones, self.reach, self.table, self.human]
        if current != self._packed:  # (each the same object: no comparison of values)
            self._pack = pack_scene(self.limitations, self.model)
            self._packed = current
            self._scene_i = np.ascontiguousarray(np.stack([self._pack.kinds, self._pack.skips], axis=1))
            self._scene_f = np.ascontiguousarray(self._pack.reals)
            self._names = {}
        return self._pack

    # ---- the human ---------------------------------------------------------------------------
    def set_human(self, human: HumanCapsules | None) -> None:
        """The human now (robot base frame), from the human source; ``None`` clears it (no
        human expected: the watchdog rests). Velocities come with the capsules (the person
        tracker's estimate); without them the human counts as still."""
        if human is None:
            self._human_given_s, human = -math.inf, HumanCapsules.absent()
        else:
            self._human_given_s = self.clock_s
        self._human = human
        self._human_age_s = 0.0
        if human.names:  # present (``HumanCapsules.present``, without the property's call: every step)
            ages = human.ages_s
            if ages:
                self._human_age_s = max([0.0, *(a for a in ages.values() if math.isfinite(a))])
            v0, v1 = human.v0_b_m_s, human.v1_b_m_s
            if v0 is None:
                v0 = v1 = np.zeros_like(human.p0_b_m)
            self._human_f = human_buffer(human.p0_b_m, human.p1_b_m, human.radius_m, v0, v1)
        else:
            self._human_f = _EMPTY

    def clear_human(self) -> None:
        self.set_human(None)

    @property
    def human_frame(self) -> HumanCapsules:
        return self._human

    def human_age_s(self) -> float:
        """How old the human model is now [s] (0 without one expected)."""
        if not math.isfinite(self._human_given_s):
            return 0.0
        return self.clock_s - self._human_given_s + self._human_age_s

    # ---- Teleoperated -------------------------------------------------------------------------
    def step(self, v_desired_m_s, dt_s: float, method: str = "anticipative") -> ArmStepReport:
        """Filter ``v_desired_m_s`` (shape (3,)) [m/s] with ``method``, integrate over ``dt_s``
        [s], report. See the module docstring for bad input."""
        return self._step(v_desired_m_s, "v_desired_m_s", 3, False, dt_s, method)

    def step_joints(self, qdot_desired_rad_s, dt_s: float, method: str = "anticipative") -> ArmStepReport:
        """A posture move: follow the joint velocity ``qdot_desired_rad_s`` (shape (nv,)) [rad/s]
        as closely as every limitation allows (least squares in joint space; the same rows, motion
        limits and speed cap as ``step``), integrate over ``dt_s`` [s], report (its
        ``v_desired_m_s``: the hand velocity the command alone would give). A task's recovery
        from a joint-limit deadlock uses it (``control.recovery``). Bad input as for ``step``."""
        return self._step(qdot_desired_rad_s, "qdot_desired_rad_s", self.model.nv, True, dt_s, method)

    def _step(self, command, name: str, size: int, joint: bool, dt_s: float, method: str) -> ArmStepReport:
        strategy = _STRATEGY_CODES.get(method)
        if strategy is None:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        v = command
        if not (type(v) is np.ndarray and v.shape == (size,) and v.dtype == _FLOAT):
            v = np.asarray(command, dtype=float).reshape(-1)
            if v.shape != (size,):
                raise ValueError(f"{name} must have shape ({size},), got {np.shape(command)}")
        reason = ""
        if not (type(dt_s) in (float, int) or isinstance(dt_s, (float, int, np.floating))) or not math.isfinite(dt_s) \
                or dt_s <= 0.0:
            logger.warning("step period %r is not a finite positive number: holding", dt_s)
            return self._hold_report(self._hand_velocity(v) if joint else v, f"period {dt_s!r} s refused: holding")
        values = v.tolist()
        if not all(map(math.isfinite, values)):
            logger.warning("desired %s %s is not finite: commanding zero", "joint velocity" if joint else "velocity", v)
            v, reason = np.zeros(size), f"desired {'joint ' if joint else ''}velocity not finite: commanding zero"
            values = [0.0]
        moving = any(values)  # (finite floats: non-zero is true)
        if dt_s <= MAX_STEP_S:
            return self._step_once(v, moving, float(dt_s), strategy, reason, joint)
        if dt_s > MAX_PERIOD_S:
            raise StepError(f"a step of {dt_s} s is longer than {MAX_PERIOD_S} s: refused (the arm would be "
                            "integrated over a jump)")
        pieces = math.ceil(dt_s / MAX_STEP_S - 1e-9)
        for _ in range(pieces):
            report = self._step_once(v, moving, dt_s / pieces, strategy, reason, joint)
        return report

    def _hand_velocity(self, qdot: np.ndarray) -> np.ndarray:
        """The hand's velocity [m/s] a joint velocity gives at ``q`` (non-finite: zero)."""
        return self.state.J_ee @ qdot if np.all(np.isfinite(qdot)) else np.zeros(3)

    def _hold_report(self, v: np.ndarray, reason: str) -> StepReport:
        p = self.state.p_world_ee.copy()
        return StepReport(v_desired_m_s=v if np.all(np.isfinite(v)) else np.zeros(3), v_commanded_m_s=np.zeros(3),
                          v_executed_m_s=np.zeros(3), p_base_ee_m=p, stopped=True, reason=reason,
                          contradictions=self.contradictions,
                          safety_over_smoothness_steps=self.smoothness_steps)

    def _command(self, v: np.ndarray, moving: bool, strategy: int, joint: bool) -> np.ndarray:
        """The user's command, or (released: zero, and not ``off``) the attraction back to the
        held point."""
        if moving or strategy == _OFF or joint:
            self.p_hold_m = None
            return v
        p = self.state.p_world_ee
        if self.p_hold_m is None:
            self.p_hold_m = p.copy()
        offset = self.p_hold_m - p
        distance = math.sqrt(float(offset @ offset))
        if distance < HOLD_DEADBAND_M:
            return v
        return offset * min(HOLD_GAIN_PER_S, RETURN_SPEED_M_S / distance)

    def _human_now(self) -> tuple[np.ndarray, str, bool]:
        """The human buffer grown for its age, the watchdog's words, and whether it stops the arm."""
        if not math.isfinite(self._human_given_s):
            return self._human_f, "", False
        age = self.clock_s - self._human_given_s + self._human_age_s
        if not self._human.names:  # absent
            if age > self.watchdog.stop_after_s and self._human.stale:
                return self._human_f, f"human sensors silent for {age:.2f} s: stopped", True
            return self._human_f, "", False
        excess = age - self.watchdog.grow_after_s
        if excess <= 0.0:
            return self._human_f, "", False
        grown = self._human_f.copy()
        h = grown.shape[0] // 13
        grown[6 * h:7 * h] += self.watchdog.growth_speed_m_s * excess
        if age > self.watchdog.stop_after_s:
            return grown, f"human model {age:.2f} s old: stopped", True
        return grown, f"human model {age:.2f} s old: grown by {self.watchdog.growth_speed_m_s * excess:.2f} m", False

    def _step_once(self, v_user: np.ndarray, moving: bool, dt_s: float, strategy: int, reason: str,
                   joint: bool = False) -> ArmStepReport:
        self._scene()
        v = self._command(v_user, moving, strategy, joint)
        desired = self._hand_velocity(v_user) if joint else v_user  # (the kinematics at q: before the step)
        yielding = strategy == _ANTICIPATIVE and self.clock_s < self.yield_until_s
        human_f, human_status, watchdog_stop = self._human_now()
        ssm_flags = _SSM_FLAGS.get(self.ssm)
        if ssm_flags is None:
            raise ValueError(f"ssm must be one of {SSM_MODES}, got {self.ssm!r}")
        held = self.last_report is not None and self.last_report.protective_stop  # a stop under way
        flags = ssm_flags | (FLAG_STOP if watchdog_stop else 0) | (FLAG_PROTECTIVE_HELD if held else 0) | (
            FLAG_JOINT_COMMAND if joint else 0)
        ahead = self.clock_s - self._human_given_s if self._human.names else 0.0
        out_f, out_i = np.empty(self._out_size), np.empty(self._out_i_size, dtype=np.int64)
        before = self.state.out_f  # the previous step's output: the kinematics at q
        if yielding:
            v = np.zeros_like(v) if joint else _ZERO3
        status = arm_step(self._state_f, before, v, dt_s, strategy, flags, ahead, self._reference_f,
                          self.model.robot_i, self.model.robot_f, self._scene_i, self._scene_f, human_f,
                          self._settings_f, out_f, out_i)
        if status != STATUS_DONE:
            raise CobotSafetyError(f"the compiled step refused the scene (status {status})")
        self.clock_s += dt_s
        self.state.refresh(out_f, self._offsets)
        _, level, stopped, _, relaxed_rows, worst, _, smoothness, protective, _, _, hand_over = out_i[:12].tolist()
        stopped = stopped != 0
        relaxed = level in (LEVEL_RELAXED, LEVEL_APPROACH_NOTHING) and relaxed_rows > 0
        if level > LEVEL_SMOOTHNESS:
            detail = (f" ({relaxed_rows} row(s), at most {out_f[self._offsets[13]]:.3g} m/s: {self._name(worst)})"
                      if relaxed_rows and worst >= 0 else "")
            reason = reason or _LEVEL_REASONS[level] + detail
        elif smoothness in _GAVE_WAY_REASONS:
            reason = reason or _GAVE_WAY_REASONS[smoothness]
        elif smoothness:  # the filter's command kept every row; integrated, it would have crossed one
            reason = reason or (f"safety over smoothness: the safety net executed {out_f[self._offsets[12]]:.3g} "
                                "of the step to keep a limitation")
        if protective:
            reason = reason or "SSM protective stop: the human is within the protective separation distance"
        if watchdog_stop:
            reason = reason or human_status
        if relaxed:
            self.contradictions += 1
            if self.contradictions == 1:  # once per episode; the count is in every report
                logger.warning("%s (further contradictions this episode are counted, not logged)", reason)
        if smoothness:
            self.smoothness_steps += 1
        if hand_over:
            self.hand_over_limit_steps += 1
        if strategy == _ANTICIPATIVE:
            if relaxed:
                o = self._offsets[7]
                commanded = out_f[o:o + 3].tolist()
                if math.sqrt(commanded[0] ** 2 + commanded[1] ** 2 + commanded[2] ** 2) < 1e-3:
                    self.yield_until_s = self.clock_s + YIELD_DWELL_S
                    yielding = True
            if yielding:
                stopped, reason = True, "yielding: " + (reason or "the retreats contradicted each other")
        if self.p_hold_m is not None and not (watchdog_stop or protective):
            stopped = False  # released: the return is ours, not a command refused
        report = ArmStepReport(out_f, out_i, self._offsets, self._name, desired, stopped, reason, self.contradictions,
                               smoothness != 0, self.smoothness_steps, human_status, before)
        if stopped and not reason and report.binding:
            report.reason = "blocked by " + ", ".join(report.binding)
        self.last_report = report
        return report

    def _name(self, code: int) -> str:
        """The words of a row code (memoised per scene and human model)."""
        key = (code, self._human.names)
        name = self._names.get(key)
        if name is None:
            owner, a, b = decode_row(code)
            joints = self.model.joint_names
            if owner == OWNER_VELOCITY:
                name = f"{joints[a]} speed"
            elif owner == OWNER_MOTION:
                name = f"{joints[a]} acceleration"
            elif owner == OWNER_EE_MOTION:
                name = "end-effector acceleration"
            elif owner == OWNER_SPEED:
                name = "speed"
            else:
                name = self._pack.row_name(self.model, owner, a, b, self._human.names)
            self._names[key] = name
        return name
