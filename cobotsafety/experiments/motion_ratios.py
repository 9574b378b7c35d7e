"""How close a run's commanded motion came to the robot's motion limits.

A ratio is ``|value| / limit``: 1.0 means the command used exactly the limit at its worst step
and joint, above 1.0 a real robot would refuse the command (libfranka stops the Panda with a
reflex such as ``joint_motion_generator_acceleration_discontinuity``) or could not follow it.

Derivatives are **backward differences of the commanded positions at the run's period**, the
way the robot's interface sees a stream of position (or velocity) commands (libfranka's rate
limiter differences ``q_c`` against the last command, step by step)::

    v_k = difference(q_{k-1}, q_k) / dt        (the velocity commanded over step k)
    a_k = (v_k - v_{k-1}) / dt
    j_k = (a_k - a_{k-1}) / dt                  for steps k = 1 .. T-1

``difference`` returns the tangent-space difference (``pin.difference``), so continuous joints
stored as (cos, sin) and angles that wrap are differenced correctly. **First step:** by default
(``from_rest=True``) the arm is taken at rest at ``q_path[0]`` before the run (``v_0 = a_0 = 0``),
as a robot is when a motion starts (the FCI requires ``q_dot = q_ddot = 0`` at a motion's start):
a run that jumps to speed in its first step is charged for that jump. With ``from_rest=False``
only differences inside the run count (velocities from step 1, accelerations from step 2, jerks
from step 3), for a window cut out of a longer run. The end-effector's speed, acceleration and
jerk are the norms of the same differences of ``p_ee_path`` (libfranka limits the norm of the
translational part), and their ratios are those norms over the robot's end-effector limits
(``MotionLimits.ee_*``): a hand that breaks its own limits is reported as a joint that does.

For a path sampled from a cubic ``q(t) = c0 + c1 t + c2 t² + c3 t³`` these differences are
exact polynomials: ``v_k = c1 + c2 (2 t_k - dt) + c3 (3 t_k² - 3 t_k dt + dt²)``,
``a_k = 2 c2 + 6 c3 (t_k - dt)`` (the acceleration at ``t_{k-1}``), ``j_k = 6 c3``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cobotsafety.arm.motion_limits import OVER_LIMIT_RATIO as OVER_LIMIT_RATIO  # (re-exported: runs' judge)
from cobotsafety.arm.motion_limits import MotionLimits


@dataclass(frozen=True, eq=False)
class Derivatives:
    """Backward differences of one path; row ``i`` is step ``first_step + i``.

    ``velocity`` (n, d) from step ``velocity_first_step`` on, likewise acceleration and jerk;
    units: the path's per second, per second², per second³ (rad or m).
    """

    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    velocity_first_step: int
    acceleration_first_step: int
    jerk_first_step: int


def backward_differences(velocity_steps: np.ndarray, dt_s: float, from_rest: bool) -> Derivatives:
    """Velocity, acceleration and jerk from per-step velocities (T-1, d) [unit/s] of a path."""
    v = velocity_steps
    if from_rest:
        rest = np.zeros((1, v.shape[1]))
        a = np.diff(v, axis=0, prepend=rest) / dt_s
        j = np.diff(a, axis=0, prepend=rest) / dt_s
        return Derivatives(v, a, j, 1, 1, 1)
    a = np.diff(v, axis=0) / dt_s
    j = np.diff(a, axis=0) / dt_s
    return Derivatives(v, a, j, 1, 2, 3)


def joint_derivatives(q_path, dt_s: float, difference: Callable[[np.ndarray, np.ndarray], np.ndarray],
                      from_rest: bool = True) -> Derivatives:
    """Joint velocity [rad/s], acceleration [rad/s²], jerk [rad/s³] of ``q_path`` (T, nq)."""
    q = _path(q_path, "q_path", dt_s, from_rest)
    v = np.array([np.asarray(difference(q[k - 1], q[k]), dtype=float).reshape(-1) for k in range(1, len(q))]) / dt_s
    if not np.all(np.isfinite(v)):
        step = int(np.argwhere(~np.isfinite(v))[0, 0]) + 1
        raise ValueError(f"difference(q_path[{step - 1}], q_path[{step}]) is not finite")
    return backward_differences(v, dt_s, from_rest)


def ee_derivatives(p_ee_path, dt_s: float, from_rest: bool = True) -> Derivatives:
    """End-effector velocity [m/s], acceleration [m/s²], jerk [m/s³] (3-vectors) of ``p_ee_path`` (T, 3)."""
    p = _path(p_ee_path, "p_ee_path", dt_s, from_rest)
    if p.shape[1] != 3:
        raise ValueError(f"p_ee_path must have shape (T, 3), got {p.shape}")
    return backward_differences(np.diff(p, axis=0) / dt_s, dt_s, from_rest)


def _path(path, name: str, dt_s: float, from_rest: bool) -> np.ndarray:
    if isinstance(dt_s, bool) or not isinstance(dt_s, (int, float, np.integer, np.floating)) \
            or not (np.isfinite(dt_s) and dt_s > 0):
        raise ValueError(f"dt_s must be a finite positive period [s], got {dt_s!r}")
    x = np.asarray(path, dtype=float)
    least = 2 if from_rest else 4
    if x.ndim != 2 or x.shape[0] < least:
        raise ValueError(f"{name} must have shape (T, n) with T >= {least}, got {x.shape}")
    bad = ~np.all(np.isfinite(x), axis=1)
    if bad.any():
        raise ValueError(f"{name}[{int(np.argmax(bad))}] is not finite")
    return x


@dataclass(frozen=True)
class MotionRatios:
    """Worst use of the motion limits over one run.

    Ratios are ``max over steps and joints of |value| / limit``; each ``*_at`` is the
    ``(step, joint)`` of that worst value, step ``k`` being the one from sample ``k-1`` to ``k``.
    ``steps_over_acceleration_limit`` counts steps with any joint's acceleration ratio above
    ``OVER_LIMIT_RATIO``. End-effector values (norms, and the ``max_ee_*_ratio`` of each over the
    robot's end-effector limit) are ``None`` without ``p_ee_path``.
    """

    max_joint_velocity_ratio: float
    max_joint_acceleration_ratio: float
    max_joint_jerk_ratio: float
    max_joint_velocity_at: tuple[int, int]
    max_joint_acceleration_at: tuple[int, int]
    max_joint_jerk_at: tuple[int, int]
    steps_over_acceleration_limit: int
    max_ee_speed_m_s: float | None = None
    max_ee_acceleration_m_s2: float | None = None
    max_ee_jerk_m_s3: float | None = None
    max_ee_speed_ratio: float | None = None
    max_ee_acceleration_ratio: float | None = None
    max_ee_jerk_ratio: float | None = None

    def as_json(self) -> dict:
        """The keys a run's JSON object carries, ``JSON_KEYS`` (``None`` -> null)."""
        return {key: getattr(self, key) for key in JSON_KEYS}


#: The ``MotionRatios`` fields a run's JSON object carries, in its order.
JSON_KEYS = ("max_joint_velocity_ratio", "max_joint_acceleration_ratio", "max_joint_jerk_ratio", "max_ee_jerk_m_s3",
             "max_ee_speed_ratio", "max_ee_acceleration_ratio", "max_ee_jerk_ratio")


def _worst(values: np.ndarray, limit: np.ndarray, first_step: int) -> tuple[float, tuple[int, int], np.ndarray]:
    ratio = np.abs(values) / limit
    step, joint = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    return float(ratio[step, joint]), (int(step) + first_step, int(joint)), ratio


def motion_ratios(q_path, dt_s: float, limits: MotionLimits,
                  difference: Callable[[np.ndarray, np.ndarray], np.ndarray], p_ee_path=None,
                  *, from_rest: bool = True) -> MotionRatios:
    """Ratios of a run's commanded joint path ``q_path`` (T, nq) at period ``dt_s`` [s] to ``limits``.

    ``difference(q0, q1)`` -> tangent-space difference (nv,), e.g.
    ``RobotModel.difference``; ``p_ee_path`` (T, 3) [m] adds the end-effector's
    worst speed, acceleration and jerk. See the module docstring for the formulas.
    """
    d = joint_derivatives(q_path, dt_s, difference, from_rest)
    nv = len(limits.velocity_rad_s)
    if d.velocity.shape[1] != nv:
        raise ValueError(f"difference gives {d.velocity.shape[1]} velocities but {limits.robot!r} "
                         f"has limits for {nv} joints {limits.joint_names}")
    v_ratio, v_at, _ = _worst(d.velocity, limits.velocity_rad_s, d.velocity_first_step)
    a_ratio, a_at, a_all = _worst(d.acceleration, limits.acceleration_rad_s2, d.acceleration_first_step)
    j_ratio, j_at, _ = _worst(d.jerk, limits.jerk_rad_s3, d.jerk_first_step)
    over = int(np.count_nonzero(np.any(a_all > OVER_LIMIT_RATIO, axis=1)))
    ee = ee_ratios = (None, None, None)
    if p_ee_path is not None:
        e = ee_derivatives(p_ee_path, dt_s, from_rest)
        if len(e.velocity) != len(d.velocity):
            raise ValueError(f"p_ee_path has {len(e.velocity) + 1} samples, q_path {len(d.velocity) + 1}")
        ee = tuple(float(np.linalg.norm(x, axis=1).max()) for x in (e.velocity, e.acceleration, e.jerk))
        ee_ratios = tuple(value / limit for value, limit in
                          zip(ee, (limits.ee_speed_m_s, limits.ee_acceleration_m_s2, limits.ee_jerk_m_s3)))
    return MotionRatios(v_ratio, a_ratio, j_ratio, v_at, a_at, j_at, over, *ee, *ee_ratios)
