"""One 3D arm control step: map, filter, integrate, check.

The command is the end-effector's translational velocity ``v`` [m/s] (3D; 2D for the planar
arm). Joint rates are ``qdot = M v + c``:

* ``M = J^+``, the damped pseudo-inverse of the translation Jacobian (paper 2, eq. 16), its
  damping growing smoothly as the manipulability ``w = sqrt(det(J J^T))`` falls below
  ``w_threshold`` — near a singularity the command shrinks smoothly instead of blowing up, and
  motion away from it stays available (the singularity safeguard);
* ``c = (I - J^+ J) qdot_secondary``: a secondary task in the translation's null space holds
  the home orientation and, on redundant arms, pulls joints toward the middle of their range.
  Orientation is a secondary task (not a 6D twist) because the user's gizmo commands a point:
  keeping the command 3D keeps every constraint a half-space on what the user drags.

Each limitation's measure ``(d, a)`` (``d_dot = a @ qdot``) becomes the half-space
``(M^T a) . v >= approach_bound(d, dt, ...) - a . c`` on the command; joint velocity limits
``|qdot_i| <= qdot_max_i`` become ``+-(M^T e_i) . v >= -qdot_max_i -+ c_i``. The command is
projected (``cobotsafety.slide``), integrated with ``pin.integrate``, and the new state is
checked: a step that crossed a limitation (first-order bounds on curved limits) is scaled down
by bisection; zero motion is always admissible.

Smoothness (``max_accel_m_s2 = a``):

* a limitation in metres may be approached no faster than the arm can still brake before it,
  ``d_dot >= -min(d / dt, sqrt(2 a d))``, so a limitation never asks for a jump;
* the command changes by at most ``a dt`` per axis and step from the previous one
  (``v_previous``), a soft row: when it conflicts with a limitation, the limitation wins and
  the change is the least that satisfies it (``cobotsafety.projection.relax``);
* when the required retreats (rows with a bound > 0: a human closing in, a limit already
  inside its buffer) contradict each other, they are relaxed by least squares, each down to
  "approach nothing" at most, while every other row stays hard, so the arm still moves away
  as far as it can (``ArmStepInfo.relaxed``) instead of stopping.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from cobotsafety.arm.constraints import ArmConstraint, Measures
from cobotsafety.arm.mapping_kernel import mapping_kernel
from cobotsafety.arm.robot_state import RobotState
from cobotsafety.constraint import HalfSpaces
from cobotsafety.errors import InfeasibleConstraintsError
from cobotsafety.filter import BINDING_TOLERANCE
from cobotsafety.projection import relax, slide

logger = logging.getLogger(__name__)

CROSSING_TOLERANCE_M = 1e-9
#: ``secondary_scale`` counts a row as approached by the null-space term when ``a . c`` is
#: below ``-SECONDARY_RELATIVE_TOLERANCE * |a| |c|`` (rounding of an orthogonal ``a . c`` is not
#: an approach).
SECONDARY_RELATIVE_TOLERANCE = 1e-9
#: A half-space normal shorter than this [m/s per m/s of command] is rounding noise: zeroed.
NEGLIGIBLE_NORMAL = 1e-10


@dataclass(frozen=True)
class ArmParams:
    """Filter and mapping settings (units in the names)."""

    max_speed_m_s: float = 0.5
    damping_width_m: float = 0.02
    damping_width_rad: float = 0.1
    activation_m: float = 0.15
    w_threshold: float = 0.01
    """Manipulability below which the pseudo-inverse is damped."""
    damping_max: float = 0.05
    """Damping lambda [m] at zero manipulability."""
    orientation_gain_per_s: float = 2.0
    centering_gain_per_s: float = 0.2
    velocity_limit_scale: float = 1.0
    buffer_m: float = 1e-3
    """The filter keeps this much clearance [m] (``buffer_rad`` for joints), so second-order
    motion while sliding (curved limits, rotating links) never reaches the limit itself."""
    buffer_rad: float = 1e-3
    recovery_gain_per_s: float = 1.0
    """Inside the buffer, the command drifts back out at this rate (times the intrusion)."""
    reactive_stiffness_per_s: float = 30.0
    reactive_zone_m: float = 0.05
    max_accel_m_s2: float = 3.0
    """The anticipative command changes by at most this [m/s^2] per axis (unless a limitation
    needs more), and limitations in metres are approached no faster than this braking allows;
    ``inf`` turns both off."""


@dataclass
class ArmStepInfo:
    v_desired: np.ndarray
    v_commanded: np.ndarray
    qdot: np.ndarray
    binding: tuple[str, ...]
    stopped: bool
    net_scale: float
    halfspaces: HalfSpaces = field(repr=False, default=None)
    relaxed: bool = False
    """The required retreats contradicted each other and were relaxed by least squares."""
    reason: str = ""
    """Why the command was stopped or relaxed ("" when neither)."""


def task_axes(state: RobotState) -> np.ndarray:
    """Translation axes the arm can command: x, y for the planar arm, x, y, z otherwise."""
    return np.array([0, 1]) if state.name == "planar" else np.array([0, 1, 2])


def mapping(state: RobotState, params: ArmParams, R_world_ee_ref: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """``(M (nv, k), c (nv,))`` with ``qdot = M v + c`` (arithmetic in ``mapping_kernel``)."""
    J = np.ascontiguousarray(state.J_ee[task_axes(state)])
    with_orientation = R_world_ee_ref is not None and state.name != "planar"
    # World-frame rotation error of the end-effector; the orientation task's damped least
    # squares gives way smoothly near a singularity.
    error = pin.log3(R_world_ee_ref @ state.R_world_ee.T) if with_orientation else np.zeros(3)
    centering = np.zeros(state.nv)
    if state.limited_v.size and params.centering_gain_per_s > 0:
        iq, iv = state.limited_v[:, 0], state.limited_v[:, 1]
        middle = 0.5 * (state.lower[iq] + state.upper[iq])
        span = state.upper[iq] - state.lower[iq]
        centering[iv] = -params.centering_gain_per_s * (state.q[iq] - middle) / np.maximum(span, 1e-6)
    # The secondary task never takes more than half of any joint's speed limit.
    return mapping_kernel(J, np.ascontiguousarray(state.J_ee_angular), np.asarray(error, dtype=float), centering,
                          params.damping_max, params.w_threshold, params.orientation_gain_per_s,
                          0.5 * state.model.velocityLimit, with_orientation)


def all_measures(state: RobotState, constraints: list[ArmConstraint], activation_m: float) -> Measures:
    return Measures.stack([c.measures(state, activation_m) for c in constraints], state.nv)


def measures_and_distances(state: RobotState, constraints: list[ArmConstraint],
                           activation_m: float) -> tuple[Measures, list[np.ndarray]]:
    """The active measures, and each constraint's distances (for the safety net), in one pass."""
    pairs = [c.measures_and_distances(state, activation_m) for c in constraints]
    return Measures.stack([m for m, _ in pairs], state.nv), [d for _, d in pairs]


def approach_limit(d: np.ndarray, angular: np.ndarray, dt_s: float, max_accel_m_s2: float) -> np.ndarray:
    """The fastest allowed approach rate (<= 0) at gaps ``d`` (m,) >= 0 [m or rad]:
    ``-min(d / dt, sqrt(2 a d))`` for metres (close at most the gap in one step, and no faster
    than braking at ``a`` still stops before it), ``-d / dt`` for angles."""
    d = np.maximum(d, 0.0)
    brake = np.where(angular, np.inf, np.sqrt(2.0 * max_accel_m_s2 * d) if np.isfinite(max_accel_m_s2) else np.inf)
    return -np.minimum(d / dt_s, brake)


def build_halfspaces(state: RobotState, measures: Measures, M: np.ndarray, c: np.ndarray,
                     v_desired: np.ndarray, dt_s: float, params: ArmParams, hard: bool = False) -> HalfSpaces:
    """Half-spaces on the command from the measures and the joint velocity limits."""
    normals = measures.A @ M
    # A limitation the command cannot move (a joint that does not move the hand, as the panda's
    # last one) has a normal of rounding noise, which the projection would normalise into a
    # random direction: it is no half-space on the command (a zero normal).
    normals[np.linalg.norm(normals, axis=1) < NEGLIGIBLE_NORMAL] = 0.0
    secondary = measures.A @ c
    # Limits that move by themselves (a human): only their approach counts. A receding human
    # earns the arm no approach, which the safety net (human held still over the step) would
    # refuse, and a noisy rate estimate cannot pull the arm in.
    human = np.minimum(measures.rate, 0.0) if measures.rate is not None else 0.0
    offset = secondary + human
    rate_desired = normals @ v_desired + offset
    width = np.where(measures.angular, params.damping_width_rad, params.damping_width_m) * (not hard)
    buffer = np.where(measures.angular, params.buffer_rad, params.buffer_m)
    d = measures.distance - buffer
    # Outside the buffer: approach at most the remaining gap in one step, and (anticipative)
    # no faster than the arm can brake before the limit; inside it: drift out gently (never
    # deeper), which also holds the recovery rule for a violated limit.
    braking = np.inf if hard else params.max_accel_m_s2
    bound = np.where(d <= 0.0, -params.recovery_gain_per_s * d, approach_limit(d, measures.angular, dt_s, braking))
    damped = (width > 0) & (d > 0) & (d < width) & (rate_desired < 0)
    bound = np.where(damped, np.maximum(bound, d / np.where(width > 0, width, 1.0) * rate_desired), bound)
    # Never demand of the arm a separation rate above the maximum speed [m/s] (a human closing
    # faster than the arm can retreat must not make a single limit infeasible on its own). The
    # cap is on the arm's own rate, before the null-space term is taken out: capping after it
    # let a secondary task that drives a joint into its limit through (z1, wrist joint).
    bound = np.minimum(bound - human, params.max_speed_m_s) - secondary
    # Joint velocity limits.
    vmax = state.model.velocityLimit * params.velocity_limit_scale
    # And the end-effector's own speed, per axis: a retreat the limitations ask for (a human
    # closing in on a capsule near the base) may not make the hand flee faster than the user
    # may drive it; if that leaves the retreat infeasible, the step approaches nothing instead.
    k = M.shape[1]
    axes = "xyz"[:k]
    vel_normals = np.vstack([M, -M, np.eye(k), -np.eye(k)])
    vel_bounds = np.concatenate([-vmax - c, -vmax + c, np.full(2 * k, -params.max_speed_m_s)])
    vel_names = (tuple(f"velocity {i}" for i in range(2 * state.nv)) + tuple(f"speed +{a}" for a in axes)
                 + tuple(f"speed -{a}" for a in axes))
    all_normals = np.vstack([normals, vel_normals])
    all_bounds = np.concatenate([bound, vel_bounds])
    names = measures.names + vel_names
    # Keep the rows that can bind at twice the maximum speed, and every joint velocity limit.
    scale = np.linalg.norm(all_normals, axis=1)
    keep = all_bounds > -2.0 * params.max_speed_m_s * scale - 1e-12
    keep[normals.shape[0]:] = True
    return HalfSpaces(all_normals[keep], all_bounds[keep], tuple(n for n, k in zip(names, keep) if k))


def reactive_command(measures: Measures, M: np.ndarray, v: np.ndarray, params: ArmParams) -> tuple[np.ndarray, tuple[str, ...]]:
    """The ``reactive`` baseline: ``v`` plus a virtual spring pushing away from every limitation
    closer than ``reactive_zone_m`` (stiffness ``reactive_stiffness_per_s``), along the
    direction of the command that increases its distance fastest; and the names of those pushing."""
    command, binding = np.array(v, dtype=float), ()
    for a_row, d, name in zip(measures.A, measures.distance, measures.names):
        if d < params.reactive_zone_m:
            n = a_row @ M
            norm2 = float(n @ n)
            if norm2 > 1e-12:
                command = command + params.reactive_stiffness_per_s * (params.reactive_zone_m - d) * n / norm2
                binding += (name,)
    return command, binding


def secondary_scale(measures: Measures, c: np.ndarray, dt_s: float, params: ArmParams) -> float:
    """The share in [0, 1] of the null-space term ``c`` to keep: by itself it may approach no
    limitation faster than the step allows (``-d / dt`` outside the buffer; inside it, nothing).

    The secondary task (orientation hold, joint centring) is a convenience: near a limitation
    it gives way instead of asking the user's command to make up for it.
    """
    if not measures.distance.size:
        return 1.0
    ac = measures.A @ c
    toward = ac < -SECONDARY_RELATIVE_TOLERANCE * np.linalg.norm(measures.A, axis=1) * np.linalg.norm(c)
    if not np.any(toward):
        return 1.0
    buffer = np.where(measures.angular, params.buffer_rad, params.buffer_m)
    d = measures.distance - buffer
    allowed = np.where(d > 0.0, approach_limit(d, measures.angular, dt_s, params.max_accel_m_s2), 0.0)
    if measures.rate is not None:
        allowed = allowed - np.minimum(measures.rate, 0.0)  # as in build_halfspaces
    allowed = np.minimum(allowed, 0.0)[toward]
    return float(np.clip(np.min(allowed / ac[toward]), 0.0, 1.0))


def filter_command(vk: np.ndarray, hs: HalfSpaces, v_previous: np.ndarray | None, dt_s: float,
                   params: ArmParams) -> tuple[np.ndarray, np.ndarray]:
    """The anticipative command (k,) and each row's relaxation (m,) [m/s] (zeros unless the
    retreats contradicted each other). ``v_previous`` (k,) or None: no acceleration bound.

    Priorities: every row at least "approach nothing" (hard; ``v = 0`` satisfies it); then the
    limitations' full bounds (hard while they agree); then the acceleration bound (soft). When
    the retreats (bounds > 0) contradict each other they become soft too, down to "approach
    nothing", and their violations and the acceleration's are minimised together.
    """
    normals, bounds = hs.normals, hs.bounds
    m = bounds.shape[0]
    accel_soft = np.zeros(0, dtype=bool)
    if v_previous is not None and np.isfinite(params.max_accel_m_s2):
        k = vk.shape[0]
        change = params.max_accel_m_s2 * dt_s
        normals = np.vstack([normals, np.eye(k), -np.eye(k)])
        bounds = np.concatenate([bounds, v_previous - change, -v_previous - change])
        accel_soft = np.ones(2 * k, dtype=bool)
    try:
        command, _ = relax(vk, normals, bounds, np.concatenate([np.zeros(m, dtype=bool), accel_soft]))
        return command, np.zeros(m)
    except InfeasibleConstraintsError:
        pass  # the limitations contradict each other: their retreats give way too
    retreat = hs.bounds > 0.0
    floor = np.concatenate([np.zeros(m), np.full(accel_soft.size, -np.inf)])
    command, violation = relax(vk, normals, bounds, np.concatenate([retreat, accel_soft]), floor)
    return command, violation[:m]


def anticipative_command(vk: np.ndarray, hs: HalfSpaces, v_previous: np.ndarray | None, dt_s: float,
                         params: ArmParams) -> tuple[np.ndarray, np.ndarray, str]:
    """``filter_command``, and when the relaxation itself fails (degenerate rows): approach
    nothing, else stop. Returns the command (k,), each row's relaxation (m,) and, in that
    case, the reason ("" otherwise)."""
    try:
        command, violation = filter_command(vk, hs, v_previous, dt_s, params)
        return command, violation, ""
    except InfeasibleConstraintsError as error:
        violation = np.maximum(hs.bounds, 0.0)
        reason = f"limits contradict ({error}): approaching nothing"
        try:
            command = slide(vk, hs.normals, hs.bounds - violation)
        except (InfeasibleConstraintsError, ValueError):
            command, reason = np.zeros_like(vk), f"limits contradict ({error}): stopped"
        return command, violation, reason


def _admissible(before: np.ndarray, after: np.ndarray) -> bool:
    return bool(np.all(after >= np.minimum(before, 0.0) - CROSSING_TOLERANCE_M))


def integrate_with_safety_net(state: RobotState, qdot: np.ndarray, dt_s: float, constraints: list[ArmConstraint],
                              before: list[np.ndarray]) -> float:
    """Integrate ``qdot`` over ``dt_s`` (``state`` in place), scaled down by bisection if the
    full step would cross a limitation that ``before`` (each constraint's distances now) shows
    clear, or deepen one already violated. Returns the scale applied (1 = the full step).

    A limitation farther than the step can move any point (``state.lever_m`` times the summed
    joint travel; the largest joint travel for joint limits) cannot be crossed and is not
    re-evaluated.
    """
    q_before = state.q
    travel = np.abs(qdot) * dt_s
    reach = {False: state.lever_m * float(travel.sum()) + CROSSING_TOLERANCE_M,
             True: float(travel.max(initial=0.0)) + CROSSING_TOLERANCE_M}
    checked = [(con, part) for con, part in zip(constraints, before)
               if part.size and float(part.min()) <= reach[bool(con.angular)]]

    def admissible() -> bool:
        return all(_admissible(part, con.distances(state)) for con, part in checked)

    state.q = state.integrate(qdot, dt_s)
    state.update()
    if admissible():
        return 1.0
    low, high = 0.0, 1.0
    for _ in range(25):
        mid = 0.5 * (low + high)
        state.q = pin.integrate(state.model, q_before, qdot * mid * dt_s)
        state.update()
        if admissible():
            low = mid
        else:
            high = mid
    state.q = pin.integrate(state.model, q_before, qdot * low * dt_s)
    state.update()
    return low


def step(state: RobotState, v_desired: np.ndarray, dt_s: float, constraints: list[ArmConstraint],
         params: ArmParams, method: str = "anticipative", R_world_ee_ref: np.ndarray | None = None,
         last_qdot: np.ndarray | None = None, v_previous: np.ndarray | None = None) -> ArmStepInfo:
    """Advance ``state`` (in place) by one period; ``state.update()`` must be current.

    ``v_previous``: shape (3,), the previous step's ``v_commanded`` [m/s], from which the
    anticipative command may change by ``params.max_accel_m_s2 * dt_s`` per axis (None: no
    acceleration bound). ``last_qdot`` is unused.
    """
    axes = task_axes(state)
    v = np.asarray(v_desired, dtype=float).reshape(-1)
    if v.shape != (3,):
        raise ValueError(f"v_desired must have shape (3,), got {np.shape(v_desired)}")
    if not dt_s > 0:
        raise ValueError(f"dt_s must be positive, got {dt_s}")
    if not np.all(np.isfinite(v)):
        logger.warning("desired velocity %s is not finite; commanding zero", v)
        v = np.zeros(3)
    speed = np.linalg.norm(v)
    if speed > params.max_speed_m_s:
        v = v * params.max_speed_m_s / speed
    vk = v[axes]
    M, c = mapping(state, params, R_world_ee_ref)
    measures, before = measures_and_distances(state, constraints, params.activation_m)
    c = c * secondary_scale(measures, c, dt_s, params)
    binding: tuple[str, ...] = ()
    stopped, relaxed, reason = False, False, ""
    if method == "anticipative":
        hs = build_halfspaces(state, measures, M, c, vk, dt_s, params)
        previous = None
        if v_previous is not None:
            previous = np.asarray(v_previous, dtype=float).reshape(-1)[axes]
            previous = previous if np.all(np.isfinite(previous)) else np.zeros_like(vk)
        command, violation, reason = anticipative_command(vk, hs, previous, dt_s, params)
        slack = hs.normals @ command - (hs.bounds - violation)
        binding = tuple(name for name, gap in zip(hs.names, slack) if gap <= BINDING_TOLERANCE)
        relaxed = bool(np.any(violation > 0.0))
        if relaxed and not reason:
            worst = int(np.argmax(violation))
            reason = (f"retreats contradict: relaxed {int(np.sum(violation > 0))} row(s), "
                      f"at most {violation[worst]:.3g} m/s ({hs.names[worst]})")
        stopped = bool(np.any(vk != 0.0) and np.all(np.abs(command) <= 1e-12))
        if stopped and not reason:
            reason = "blocked by " + ", ".join(binding) if binding else "blocked"
        qdot = M @ command + (0.0 if stopped else c)
    elif method == "stop":
        hs = build_halfspaces(state, measures, M, c, vk, dt_s, params, hard=True)
        violated = hs.normals @ vk < hs.bounds - 1e-12
        binding = tuple(n for n, bad in zip(hs.names, violated) if bad)
        stopped = bool(binding)
        command = np.zeros_like(vk) if stopped else vk
        qdot = np.zeros(state.nv) if stopped else M @ vk + c
    elif method in ("reactive", "off"):
        hs = build_halfspaces(state, measures, M, c, vk, dt_s, params, hard=True)
        command = vk.copy()
        if method == "reactive":
            command, binding = reactive_command(measures, M, vk, params)
        qdot = M @ command + c
        vmax = state.model.velocityLimit
        ratio = float(np.max(np.abs(qdot) / vmax))
        if ratio > 1.0:
            qdot = qdot / ratio
    else:
        raise ValueError(f"method must be one of anticipative, stop, reactive, off; got {method!r}")

    if method != "off":
        net_scale = integrate_with_safety_net(state, qdot, dt_s, constraints, before)
    else:
        net_scale = 1.0
        state.q = state.integrate(qdot, dt_s)
        state.update()
    command_full = np.zeros(3)
    command_full[axes] = command * net_scale
    return ArmStepInfo(v, command_full, qdot * net_scale, binding, stopped, net_scale, hs, relaxed, reason)
