"""One planar control step: filter the command, map it to joint rates, integrate, check.

``step(state, v_desired, dt_s, scene, method)`` is the whole pipeline of Fig. 3:

1. clamp the command to ``max_speed_m_s`` (NaN/inf -> zero with a warning);
2. apply the method: ``anticipative`` (project onto every limitation's half-space),
   ``stop`` (zero when the command would reach a limitation within the step), ``reactive``
   (spring-damper repulsion, ``cobotsafety.planar.baselines``) or ``off``;
3. joint rates ``theta_dot = K v`` (K = J^-1, damped near singularities) and Euler
   integration in joint space (exact for joint limits);
4. safety net: the half-spaces are exact for joint limits but only first-order for curved
   Cartesian limits, so the new state is checked against the limitations and, if one was
   crossed (or an already violated one got deeper), the step is scaled down by bisection;
   zero motion is always admissible. ``StepInfo.net_scale < 1`` says it acted. Only the
   limitations the step can reach are re-checked, and by their distances alone: every
   distance is 1-Lipschitz in the motion of the arm's points (lengths) or of the joints
   (angles; |d sin(theta_2)| <= |d theta_2|), and in one step no point of the arm moves more
   than ``(L1 + L2) |d theta_1| + L2 |d theta_2|``, no joint more than ``max |d theta_i|``, so a
   limitation farther than that cannot be crossed (as the 3D arm's safety net, ``arm.step_kernel``).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

from cobotsafety.planar.rr_arm import Kinematics, PlanarArm
from cobotsafety.planar.baselines import ReactiveParams, reactive_command
from cobotsafety.planar.limitations import Damping, Measure, PlanarLimitation, rows_from_measures
import numpy as np

from cobotsafety.least_distance import SOLVED, slide_kernel

logger = logging.getLogger(__name__)

#: A limitation counts as crossed when its distance goes below this [m or rad].
CROSSING_TOLERANCE = 1e-12


@dataclass(frozen=True)
class PlanarState:
    """Joint angles [rad] and the joint rates of the last step [rad/s]."""

    theta_1: float
    theta_2: float
    theta_dot_1: float = 0.0
    theta_dot_2: float = 0.0


@dataclass
class PlanarScene:
    """The arm, its limitations and the filter's settings."""

    arm: PlanarArm
    limitations: list[PlanarLimitation]
    damping: Damping = field(default_factory=Damping)
    max_speed_m_s: float = 0.5
    reactive: ReactiveParams = field(default_factory=ReactiveParams)


@dataclass(frozen=True)
class StepInfo:
    vx_desired: float
    vy_desired: float
    vx_commanded: float
    vy_commanded: float
    binding: tuple[str, ...]
    stopped: bool
    net_scale: float


def _clamp(vx: float, vy: float, max_speed: float) -> tuple[float, float]:
    if not (math.isfinite(vx) and math.isfinite(vy)):
        logger.warning("desired velocity (%s, %s) is not finite; commanding zero", vx, vy)
        return 0.0, 0.0
    speed = math.hypot(vx, vy)
    if speed > max_speed:
        return vx * max_speed / speed, vy * max_speed / speed
    return vx, vy


def project(vx: float, vy: float, rows: list) -> tuple[float, float, bool]:
    """The command closest to ``(vx, vy)`` [m/s] on the rows ``(nx, ny, bound, name)``
    (``cobotsafety.least_distance``, the package's one projection); ``ok`` False (and zero) when
    the rows contradict each other."""
    if not rows:
        return vx, vy, True
    normals = np.array([(r[0], r[1]) for r in rows])
    bounds = np.array([r[2] for r in rows])
    x, status, _ = slide_kernel(np.array([vx, vy]), normals, bounds)
    if status != SOLVED:
        return 0.0, 0.0, False
    return float(x[0]), float(x[1]), True


def measures(scene: PlanarScene, kin: Kinematics) -> list[Measure]:
    """Every limitation's signed distances and gradients at ``kin``."""
    return [m for limitation in scene.limitations for m in limitation.measures(kin)]


def step(state: PlanarState, v_desired: tuple[float, float], dt_s: float, scene: PlanarScene,
         method: str = "anticipative", reachable_only: bool = True) -> tuple[PlanarState, StepInfo]:
    """Advance the arm by one control period ``dt_s`` [s] under ``method``.

    ``reachable_only=False`` makes the safety net re-evaluate every limitation's full measures
    (the reference the fast check is tested and benchmarked against)."""
    if len(v_desired) != 2:
        raise ValueError(f"v_desired must have 2 components, got {len(v_desired)}")
    if not dt_s > 0.0:
        raise ValueError(f"dt_s must be positive, got {dt_s}")
    arm = scene.arm
    kin = Kinematics(arm, state.theta_1, state.theta_2)
    vx_d, vy_d = _clamp(float(v_desired[0]), float(v_desired[1]), scene.max_speed_m_s)
    binding: tuple[str, ...] = ()
    stopped = False
    per_limitation = [limitation.measures(kin) for limitation in scene.limitations]
    now = [m for ms in per_limitation for m in ms]
    rows: list = []
    if method == "anticipative":
        rows_from_measures(now, vx_d, vy_d, dt_s, scene.damping, scene.max_speed_m_s, rows)
        vx, vy, ok = project(vx_d, vy_d, rows)
        binding = tuple(r[3] for r in rows if r[0] * vx + r[1] * vy <= r[2] + 1e-9)
        stopped = not ok
    elif method == "stop":
        rows_from_measures(now, vx_d, vy_d, dt_s, Damping(), scene.max_speed_m_s, rows)
        blocked = tuple(r[3] for r in rows if r[0] * vx_d + r[1] * vy_d < r[2] - 1e-12)
        vx, vy = (0.0, 0.0) if blocked else (vx_d, vy_d)
        binding, stopped = blocked, bool(blocked)
    elif method == "reactive":
        vx, vy, binding = reactive_command(scene.limitations, scene.reactive, scene.max_speed_m_s, kin, vx_d, vy_d,
                                           state.theta_dot_1, state.theta_dot_2)
    elif method == "off":
        vx, vy = vx_d, vy_d
    else:
        raise ValueError(f"method must be one of anticipative, stop, reactive, off; got {method!r}")

    rate_1 = kin.k11 * vx + kin.k12 * vy
    rate_2 = kin.k21 * vx + kin.k22 * vy
    if method == "off":
        new = _integrate(state, rate_1, rate_2, dt_s, 1.0, arm)
        return new, StepInfo(vx_d, vy_d, vx, vy, binding, stopped, 1.0)
    scale = integrate_with_safety_net(state, rate_1, rate_2, dt_s, scene, per_limitation, reachable_only)
    new = _integrate(state, rate_1, rate_2, dt_s, scale, arm)
    return new, StepInfo(vx_d, vy_d, vx * scale, vy * scale, binding, stopped, scale)


def integrate_with_safety_net(state: PlanarState, rate_1: float, rate_2: float, dt_s: float, scene: PlanarScene,
                              per_limitation: list[list[Measure]], reachable_only: bool = True) -> float:
    """The largest scale in [0, 1] of the joint rates [rad/s] (1, else found by bisection) whose
    step crosses no limitation that ``per_limitation`` (each limitation's measures now) shows
    clear and deepens none already violated. Re-checks only the reachable limitations, by their
    distances (``reachable_only=False``: all of them, by their full measures)."""
    arm = scene.arm
    if not reachable_only:
        before_all = [m[0] for ms in per_limitation for m in ms]

        def admissible(scale: float) -> bool:
            kin = Kinematics(arm, state.theta_1 + rate_1 * scale * dt_s, state.theta_2 + rate_2 * scale * dt_s)
            return _admissible(before_all, [m[0] for m in measures(scene, kin)])

        return _bisect(admissible)
    travel_1, travel_2 = abs(rate_1) * dt_s, abs(rate_2) * dt_s
    reach_m = (arm.link_1_m + arm.link_2_m) * travel_1 + arm.link_2_m * travel_2 + CROSSING_TOLERANCE
    reach_rad = max(travel_1, travel_2) + CROSSING_TOLERANCE
    checked = []
    for limitation, ms in zip(scene.limitations, per_limitation):
        if ms and min(m[0] for m in ms) <= (reach_rad if limitation.angular else reach_m):
            checked.append((limitation, [m[0] for m in ms]))
    if not checked:
        return 1.0

    def admissible(scale: float) -> bool:
        kin = Kinematics(arm, state.theta_1 + rate_1 * scale * dt_s, state.theta_2 + rate_2 * scale * dt_s,
                         jacobian=False)
        return all(_admissible(before, limitation.distances(kin)) for limitation, before in checked)

    return _bisect(admissible)


def _bisect(admissible) -> float:
    """1 if the full step is admissible, else the largest admissible scale found by bisection."""
    if admissible(1.0):
        return 1.0
    low, high = 0.0, 1.0
    for _ in range(30):
        mid = 0.5 * (low + high)
        if admissible(mid):
            low = mid
        else:
            high = mid
    return low


def _integrate(state: PlanarState, rate_1: float, rate_2: float, dt_s: float, scale: float,
               arm: PlanarArm) -> PlanarState:
    r1, r2 = rate_1 * scale, rate_2 * scale
    return PlanarState(state.theta_1 + r1 * dt_s, state.theta_2 + r2 * dt_s, r1, r2)


def _admissible(before: list[float], after: list[float]) -> bool:
    for d0, d1 in zip(before, after):
        if d1 < min(d0, 0.0) - CROSSING_TOLERANCE:
            return False
    return True
