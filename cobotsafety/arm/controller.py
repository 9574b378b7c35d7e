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

The command is checked once, here: a non-finite velocity or period gives the zero-change
command (the arm holds its motion's decay) and a logged reason, never a NaN state; a period
longer than ``MAX_STEP_S`` is split into steps of at most that (at most ``MAX_PERIOD_S`` in all,
else refused). Around the filter:

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
* **SSM** (``ssm = True``): ISO/TS 15066 speed and separation monitoring: the arm's approach to
  the human limited to the standard's speed for the separation, and a protective stop when the
  separation falls below the protective distance at the arm's approach speed.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from cobotsafety.arm.filter_settings import FilterSettings
from cobotsafety.arm.limitations import BoxZone, HalfSpaceZone, HumanLimitation, JointPositionLimits, ReachLimits, \
    SphereZone, TablePlane
from cobotsafety.arm.limitations.human import human_buffer
from cobotsafety.arm.limitations.registry import pack_scene
from cobotsafety.arm.robot_model import RobotModel
from cobotsafety.arm.robot_state import RobotState
from cobotsafety.arm.robots import DEFAULT_ROBOT
from cobotsafety.arm.step_kernel import (I_BINDING, I_LEVEL, I_MOTION_COUNT, I_PROTECTIVE, I_RELAXED, I_SMOOTHNESS,
                                         I_STOPPED, I_WORST, OUT_I_HEADER, OWNER_EE_MOTION, OWNER_MOTION, OWNER_SPEED,
                                         OWNER_VELOCITY, STATUS_DONE, STRATEGIES, arm_step, decode_row, output_layout)
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
_LEVEL_REASONS = {1: "safety over smoothness: the motion limits gave way", 2: "retreats contradict",
                  3: "limits contradict: approaching nothing", 4: "limits contradict: stopped"}


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


def farthest_reach_m(model: RobotModel, centre: np.ndarray, samples: int = 4000, seed: int = 0) -> float:
    """The farthest the end-effector gets from ``centre`` [m] over ``samples`` configurations
    drawn uniformly within the joint limits (a generator of our own, seeded)."""
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
                 capsules: str = "fitted", ssm: bool = False, watchdog: HumanWatchdog = HumanWatchdog(),
                 table: bool = True, reach: bool = True):
        self.model = RobotModel.load(robot, capsules)
        self.settings = settings or FilterSettings()
        self.human = human or HumanLimitation()
        self.ssm = ssm
        self.watchdog = watchdog
        nq, nv, c = self.model.nq, self.model.nv, len(self.model.capsules)
        self._offsets = output_layout(nq, nv, c)
        self._state_f = np.zeros(nq + 2 * nv + 6)
        self._command_f = np.zeros(16)
        self._command_i = np.zeros(4, dtype=np.int64)
        self._settings_f = self.settings.vector()
        self._out_f = np.zeros(int(self._offsets[-1]))
        self._out_i = np.zeros(OUT_I_HEADER + 1024, dtype=np.int64)
        self.state = RobotState(self.model)
        self._set_q(self.model.home_q)
        self.R_world_ee_ref = self.state.R_world_ee.copy()
        self.reach = reach_limits(self.state) if reach else None
        self.table = TablePlane(0.0) if table else None
        self.zones = zones if zones is not None else default_zones(self.state.p_world_ee)
        self._pack_key: tuple | None = None
        self._pack = None
        self._names: dict = {}
        self._human = HumanCapsules.absent()
        self._human_f = np.zeros(0)
        self._human_given_s = -math.inf
        self._human_age_s = 0.0
        self.clock_s = 0.0
        """Time stepped since the start [s] (the watchdog's and the yield's clock)."""
        self.reset()

    # ---- state ------------------------------------------------------------------------------
    def _set_q(self, q: np.ndarray) -> None:
        """Put the arm at ``q`` at rest and compute its kinematics (one zero-velocity step)."""
        nq = self.model.nq
        self._state_f[:] = 0.0
        self._state_f[:nq] = q
        self._command_f[:] = 0.0
        self._command_f[3] = 1e-3
        self._command_f[4:13] = np.eye(3).ravel()
        self._command_i[:] = (3, 0, 0, 1)  # off, no orientation, no SSM, forced stop: stays put
        empty_i = np.zeros((0, 2), dtype=np.int64)
        arm_step(self._state_f, self._command_f, self._command_i, self.model.robot_i, self.model.robot_f, empty_i,
                 np.zeros((0, 12)), np.zeros(0), self._settings_f, self._out_f, self._out_i)
        self._state_f[:nq] = q
        self._state_f[nq:] = 0.0
        self.state.refresh(self._out_f.copy(), self._offsets)

    def set_configuration(self, q: np.ndarray) -> None:
        """Put the arm at rest at ``q`` (shape (nq,)), e.g. a test's random state; the hold point,
        the yield and the counters are kept."""
        q = np.array(q, dtype=float).reshape(-1)
        if q.shape != (self.model.nq,) or not np.all(np.isfinite(q)):
            raise ValueError(f"q must be {self.model.nq} finite numbers, got {q}")
        self._set_q(q)

    def reset(self) -> None:
        """Home pose at rest; hold, yield and the episode's counters cleared."""
        self._set_q(self.model.home_q)
        self.p_hold_m: np.ndarray | None = None
        self.yield_until_s = -math.inf
        self.contradictions = 0
        self.smoothness_steps = 0
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

    def _scene(self):
        key = (tuple(map(id, self.zones)), tuple(self.zones), self.reach, self.table, self.human)
        if key != self._pack_key:
            self._pack = pack_scene(self.limitations, self.model)
            self._pack_key = key
            self._scene_i = np.ascontiguousarray(np.stack([self._pack.kinds, self._pack.skips], axis=1))
            self._scene_f = np.ascontiguousarray(self._pack.reals)
            self._names = {}
        return self._pack

    # ---- the human ---------------------------------------------------------------------------
    def set_human(self, human: HumanCapsules | None) -> None:
        """The human now (robot base frame), from the human source; ``None`` clears it (no
        human expected: the watchdog rests). Velocities come with the capsules (the person
        tracker's estimate); without them the human counts as still."""
        self._human_given_s = self.clock_s if human is not None else -math.inf
        human = human if human is not None else HumanCapsules.absent()
        self._human = human
        self._human_age_s = max([0.0, *(a for a in human.ages_s.values() if math.isfinite(a))]) if human.present else 0.0
        if human.present:
            v0 = human.v0_b_m_s if human.v0_b_m_s is not None else np.zeros_like(human.p0_b_m)
            v1 = human.v1_b_m_s if human.v1_b_m_s is not None else np.zeros_like(human.p1_b_m)
            self._human_f = human_buffer(human.p0_b_m, human.p1_b_m, human.radius_m, v0, v1)
        else:
            self._human_f = np.zeros(0)

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
    def step(self, v_desired_m_s, dt_s: float, method: str = "anticipative") -> StepReport:
        """Filter ``v_desired_m_s`` (shape (3,)) [m/s] with ``method``, integrate over ``dt_s``
        [s], report. See the module docstring for bad input."""
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        v = np.asarray(v_desired_m_s, dtype=float).reshape(-1)
        if v.shape != (3,):
            raise ValueError(f"v_desired_m_s must have shape (3,), got {np.shape(v_desired_m_s)}")
        reason = ""
        if not (isinstance(dt_s, (int, float)) and math.isfinite(dt_s) and dt_s > 0.0):
            logger.warning("step period %r is not a finite positive number: holding", dt_s)
            return self._hold_report(v, f"period {dt_s!r} s refused: holding")
        if not all(math.isfinite(x) for x in v.tolist()):
            logger.warning("desired velocity %s is not finite: commanding zero", v)
            v, reason = np.zeros(3), "desired velocity not finite: commanding zero"
        if dt_s > MAX_PERIOD_S:
            raise StepError(f"a step of {dt_s} s is longer than {MAX_PERIOD_S} s: refused (the arm would be "
                            "integrated over a jump)")
        pieces = max(1, math.ceil(dt_s / MAX_STEP_S - 1e-9))
        report = None
        for _ in range(pieces):
            report = self._step_once(v, dt_s / pieces, method, reason)
        return report

    def _hold_report(self, v: np.ndarray, reason: str) -> StepReport:
        p = self.state.p_world_ee.copy()
        return StepReport(v_desired_m_s=v if np.all(np.isfinite(v)) else np.zeros(3), v_commanded_m_s=np.zeros(3),
                          v_executed_m_s=np.zeros(3), p_base_ee_m=p, stopped=True, reason=reason,
                          contradictions=self.contradictions,
                          safety_over_smoothness_steps=self.smoothness_steps)

    def _command(self, v: np.ndarray, method: str) -> np.ndarray:
        """The user's command, or (released: zero, and not ``off``) the attraction back to the
        held point."""
        if method == "off" or any(x != 0.0 for x in v.tolist()):
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
        if not self._human.present:
            age = self.human_age_s()
            if math.isfinite(self._human_given_s) and age > self.watchdog.stop_after_s and self._human.stale:
                return self._human_f, f"human sensors silent for {age:.2f} s: stopped", True
            return self._human_f, "", False
        age = self.human_age_s()
        excess = age - self.watchdog.grow_after_s
        if excess <= 0.0:
            return self._human_f, "", False
        grown = self._human_f.copy()
        h = grown.shape[0] // 13
        grown[6 * h:7 * h] += self.watchdog.growth_speed_m_s * excess
        if age > self.watchdog.stop_after_s:
            return grown, f"human model {age:.2f} s old: stopped", True
        return grown, f"human model {age:.2f} s old: grown by {self.watchdog.growth_speed_m_s * excess:.2f} m", False

    def _step_once(self, v_user: np.ndarray, dt_s: float, method: str, reason: str) -> StepReport:
        pack = self._scene()
        v = self._command(v_user, method)
        yielding = method == "anticipative" and self.clock_s < self.yield_until_s
        human_f, human_status, watchdog_stop = self._human_now()
        command_f = self._command_f
        command_f[0:3] = 0.0 if yielding else v
        command_f[3] = dt_s
        command_f[4:13] = self.R_world_ee_ref.ravel()
        command_f[13] = max(0.0, self.clock_s - self._human_given_s) if self._human.present else 0.0
        command_f[14] = self.settings.max_speed_m_s
        self._command_i[:] = (STRATEGIES.index(method), 1, int(self.ssm), int(watchdog_stop))
        out_f, out_i = np.empty_like(self._out_f), self._out_i
        before = self.state.p_world_ee
        status = arm_step(self._state_f, command_f, self._command_i, self.model.robot_i, self.model.robot_f,
                          self._scene_i, self._scene_f, human_f, self._settings_f, out_f, out_i)
        if status != STATUS_DONE:
            raise CobotSafetyError(f"the compiled step refused the scene (status {status})")
        self.clock_s += dt_s
        self.state.refresh(out_f, self._offsets)
        o = self._offsets
        n_binding, n_motion = int(out_i[I_BINDING]), int(out_i[I_MOTION_COUNT])
        codes = out_i[OUT_I_HEADER:OUT_I_HEADER + n_binding + n_motion].tolist()
        binding = tuple(dict.fromkeys(self._name(code) for code in codes[:n_binding]))
        motion_limited = tuple(dict.fromkeys(self._name(code) for code in codes[n_binding:]))
        stopped = bool(out_i[I_STOPPED])
        level = int(out_i[I_LEVEL])
        relaxed = level in (2, 3) and out_i[I_RELAXED] > 0
        if level:
            worst = int(out_i[I_WORST])
            detail = f" ({int(out_i[I_RELAXED])} row(s), at most {out_f[o[13]]:.3g} m/s: {self._name(worst)})" \
                if worst >= 0 else ""
            reason = reason or _LEVEL_REASONS[level] + detail
        if out_i[I_PROTECTIVE]:
            reason = reason or "SSM protective stop: the human is within the protective separation distance"
        if watchdog_stop:
            reason = reason or human_status
        if relaxed:
            self.contradictions += 1
            if self.contradictions == 1:  # once per episode; the count is in every StepReport
                logger.warning("%s (further contradictions this episode are counted, not logged)", reason)
        smoothness = bool(out_i[I_SMOOTHNESS])
        self.smoothness_steps += smoothness
        v_commanded = out_f[o[7]:o[8]]
        if method == "anticipative":
            blocked = relaxed and math.sqrt(float(v_commanded @ v_commanded)) < 1e-3
            if blocked:
                self.yield_until_s = self.clock_s + YIELD_DWELL_S
            if blocked or yielding:
                stopped, reason = True, "yielding: " + (reason or "the retreats contradicted each other")
        if stopped and not reason and binding:
            reason = "blocked by " + ", ".join(binding)
        if self.p_hold_m is not None:  # released: the return is ours, not a command refused
            stopped = False
        distance = float(out_f[o[9]])
        report = StepReport(
            v_desired_m_s=v_user, v_commanded_m_s=v_commanded, v_executed_m_s=out_f[o[8]:o[9]],
            p_base_ee_m=self.state.p_world_ee, binding=binding, stopped=stopped,
            min_distance_m=distance if math.isfinite(distance) else None,
            extras={"net_scale": float(out_f[o[12]]), "qdot": out_f[o[1]:o[2]], "level": level,
                    "p_before_m": before, "brake_factor": float(out_f[o[15]])},
            reason=reason, contradictions=self.contradictions,
            p_robot_closest_m=out_f[o[10]:o[11]] if math.isfinite(distance) else None,
            p_human_closest_m=out_f[o[11]:o[12]] if math.isfinite(distance) else None,
            motion_limited=motion_limited, safety_over_smoothness=smoothness,
            safety_over_smoothness_steps=self.smoothness_steps, human_status=human_status)
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
