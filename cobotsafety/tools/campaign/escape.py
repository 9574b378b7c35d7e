"""Did an escape exist? An offline joint-space optimisation over the same (true) human.

For a breach (the true separation fell below the critical distance at ``t_closest``), take the
robot's logged joint state (position and velocity) at ``t0 = t_closest - LOOKBACK_S`` and ask
scipy (SLSQP) for a joint trajectory over ``[t0, t_closest + LOOKAHEAD_S]`` that keeps the true
separation above the critical distance, knowing the human's whole future (the ground truth).
The trajectory is one a real arm could follow: the joint velocity is continuous, starts at the
logged one, and is linear between ``KNOTS`` evenly spaced knots (the decision variables), each
knot within the robot's velocity limits and within its acceleration limits of the previous one,
positions within its joint limits, the end-effector within its own speed and acceleration
limits at every quarter of a knot interval (``HAND_POINTS``; the acceleration over each): the
same ``MotionLimits`` the controllers must keep; and the cell's other limitations every
campaign controller keeps, the table and the reach (``_Kinematics.cell_margins``), at the same
samples as the separation. So an escape is one they were allowed to take (jerk is not modelled;
until 2026-12-07 the table and the reach were not either, and the escapes found for 17 of the
anticipative controller's 104 escapable breaches after detection went through the table or
beyond the reach; with both kept the search finds others for all but one, docs/campaign.md).
It maximises the smallest separation ``s`` at ``SAMPLES`` times (epigraph form: maximise ``s``
subject to ``d_j(x) >= s``). The separation's gradients are
exact: ``d d_j / d q = u^T J_c`` at the closest pair (``u`` from the human's closest point to
the robot's, ``J_c`` the robot point's Jacobian), times the integral of each knot's hat
function up to sample ``j``; the hand's rows differentiate its velocity ``J_ee(q) v`` exactly,
in ``q`` from ``J_ee``'s own columns (``hand_velocity_turn``; by forward differences of ``J_ee``
until 2026-12-07). An escape existed when the optimum (or
a candidate tried first: brake to a stop, reverse the logged motion, or the steepest retreat at
full or half speed, each reached at the acceleration limits or at a half or a quarter of them;
SLSQP starts from the best) reaches the critical distance. The
search is local: an escape found is certain (``Escape.witness_rad_s``, its knot velocities,
checked every ``VERIFY_S``; until 2026-12-07 the samples alone decided, and escapes that
dipped below the critical distance between them counted, docs/campaign.md),
"none" is the best SLSQP found, so ``breaches_with_escape`` is a lower bound. The window is a
stated choice: the controller could have started earlier, so "no escape in the window" does not
prove none existed before it. ``earliest_s`` starts the window later (never earlier): the
campaign asks again from the moment the controller first saw the person, for the breaches whose
escape needed the arm to move before anyone was seen (perception's share, not the controller's),
and from the moment the person's final approach began (``approach_onset_s``, from the truth), for
those whose escape needed the arm to move before anything in the person's motion announced it
(prediction's share: a controller reacting to the person, however well it sees them, could not).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.optimize import minimize

from cobotsafety.arm.robot_state import point_jacobian
from cobotsafety.experiments.approach_truth import TruthHuman
from cobotsafety.geometry.capsule import capsule_distance

LOOKBACK_S = 1.0
LOOKAHEAD_S = 0.5
KNOTS = 6
SAMPLES = 16
#: The end-effector's speed is checked at every quarter of a knot interval, its acceleration
#: over each quarter (from the logged start).
HAND_POINTS = 4 * KNOTS
#: A person's final approach (``approach_onset_s``) is the last unbroken stretch before the
#: closest moment in which they close on the arm faster than this [m/s]: below the campaign's
#: slowest walk (0.5 m/s), above a standing person's sway (chosen before any onset was measured).
ONSET_CLOSING_M_S = 0.3
#: How far [m] an optimiser's answer may be on the wrong side of the table or the reach and
#: still count (SLSQP meets its constraints to about this; the controllers keep a 1 mm buffer).
CELL_TOLERANCE_M = 1e-5
#: The spacing [s] at which a motion the search found is checked before it counts as an
#: escape (the separation, the joint limits, the cell); the search itself keeps them at
#: ``SAMPLES`` times, between which a motion it finds can dip below the critical distance by
#: millimetres (its optimum tends to touch it at many samples at once).
VERIFY_S = 0.005
#: How many times the search runs again with the times of such dips added to its samples.
REFINE_ROUNDS = 3
#: The spacing [s] of the true distances ``approach_onset_s`` differentiates.
ONSET_STEP_S = 0.01


@dataclass(frozen=True)
class Escape:
    exists: bool
    best_min_distance_m: float
    """The largest smallest true separation [m] found over the window (every ``VERIFY_S``)."""
    window_s: tuple[float, float]
    witness_rad_s: np.ndarray | None = None
    """The best trajectory's knot velocities (KNOTS, nv) [rad/s] (None when no candidate was
    feasible); the velocity at ``window_s[0]`` is the logged one."""


class _Kinematics:
    """The robot's capsules (minus the base one) at any q, the separation's gradient, and the
    robot's joint limits. The capsules and the hand's Jacobian are the compiled step's own
    kinematics (``step_kernel.kinematics``, what ``ArmController.set_configuration`` reads,
    without a step around them); the separation's gradient is pinocchio's."""

    def __init__(self, robot: str, capsules: str = "paper", skip_capsules: int = 1):
        from cobotsafety.arm.controller import ArmController
        from cobotsafety.arm.step_kernel import unpack_robot

        self.arm = ArmController(robot, zones=[], capsules=capsules)
        self.state = self.arm.state
        self.skip = skip_capsules
        model = self.state.model
        limits = self.arm.model.limits
        self.v_max = np.asarray(limits.velocity_rad_s, dtype=float)
        self.a_max = np.asarray(limits.acceleration_rad_s2, dtype=float)
        self.lower, self.upper = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()
        self.ee_speed, self.ee_acc = float(limits.ee_speed_m_s), float(limits.ee_acceleration_m_s2)
        (_, nv, ee_joint, jtype, parent, idx_q, idx_v, support, cap_joint, _, axes, placement_R, placement_t, ee_R,
         ee_t, cap_p0l, cap_p1l, *_) = unpack_robot(self.arm.model.robot_i, self.arm.model.robot_f)
        self._robot = (jtype, axes, parent, idx_q, idx_v, placement_R, placement_t, support, ee_joint, ee_R, ee_t,
                       cap_joint, cap_p0l, cap_p1l, nv)
        self._data = model.createData()
        self.table, self.reach = self.arm.table, self.arm.reach

    def _at(self, q: np.ndarray):
        """``(p_ee (3,), J6 (6, nv), p0 (c, 3), p1 (c, 3))`` at ``q`` (finite, else ``ValueError``)."""
        from cobotsafety.arm.step_kernel import kinematics

        q = np.array(q, dtype=float).reshape(-1)
        if q.shape != (self.state.model.nq,) or not np.all(np.isfinite(q)):
            raise ValueError(f"q must be {self.state.model.nq} finite numbers, got {q}")
        _, _, p_ee, _, J6, p0, p1 = kinematics(q, *self._robot)
        return p_ee, J6, p0, p1

    def capsules(self, q: np.ndarray):
        _, _, p0, p1 = self._at(q)
        return p0[self.skip:], p1[self.skip:], self.state.capsule_radius[self.skip:]

    def hand_jacobian(self, q: np.ndarray) -> np.ndarray:
        """The end-effector's translation Jacobian (3, nv) at ``q`` (world-aligned)."""
        return self._at(q)[1][:3]

    def frame_jacobian(self, q: np.ndarray) -> np.ndarray:
        """The end-effector's Jacobian (6, nv) at ``q``: translation, then the joints' world
        axes (LOCAL_WORLD_ALIGNED)."""
        return self._at(q)[1]

    def outside_joint_limits(self, q: np.ndarray) -> np.ndarray:
        """Per configuration (the last axis of ``q``): any joint not within its limits (1e-9 rad;
        a NaN is not within)."""
        return ~np.all((q >= self.lower - 1e-9) & (q <= self.upper + 1e-9), axis=-1)

    def cell_margins(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The cell's limitations every campaign controller keeps besides the person and the
        joint limits, at ``q``: ``(margins (m,) [m], their gradient d/dq (m, nv))``, kept where
        every margin is >= 0. The table (``TablePlane``: each capsule's two end points, from its
        ``skip_capsules`` on, above the plane by the capsule's radius) and the reach
        (``ReachLimits``: the hand between its inner and extended reach from the shoulder), the
        same objects an ``ArmController`` keeps by default (``approach_step.make_controller``)."""
        p_ee, J6, p0, p1 = self._at(q)
        model = self.state.model
        pin.computeJointJacobians(model, self._data, np.array(q, dtype=float).reshape(-1))
        gradients = [point_jacobian(model, self._data, int(self.state.capsule_joint_ids[c]), end)[2]
                     for c in range(self.table.skip_capsules, len(self.state.capsule_radius)) for end in (p0[c], p1[c])]
        offset = p_ee - np.asarray(self.reach.shoulder, dtype=float)
        radial = (offset / max(float(np.linalg.norm(offset)), 1e-12)) @ J6[:3]
        return self._cell_values(p_ee, p0, p1), np.array(gradients + [radial, -radial])

    def capsules_and_cell(self, q: np.ndarray):
        """``(capsules(q), cell_margins(q)'s margins)`` from one pass of the kinematics."""
        p_ee, _, p0, p1 = self._at(q)
        radius = self.state.capsule_radius
        return (p0[self.skip:], p1[self.skip:], radius[self.skip:]), self._cell_values(p_ee, p0, p1)

    def _cell_values(self, p_ee: np.ndarray, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
        """``cell_margins``' margins from the kinematics at ``q``: the table's rows (capsules
        from ``skip_capsules`` on, both ends), then the reach's inner and extended rows."""
        radius = self.state.capsule_radius
        margins = [end[2] - radius[c] - self.table.height_m
                   for c in range(self.table.skip_capsules, len(radius)) for end in (p0[c], p1[c])]
        r = float(np.linalg.norm(p_ee - np.asarray(self.reach.shoulder, dtype=float)))
        return np.array(margins + [r - self.reach.inner_m, self.reach.outer_m - r])

    def separation(self, q: np.ndarray, hp0, hp1, hr) -> tuple[float, np.ndarray]:
        """(separation [m], its gradient d/dq (n,)) against human capsules (k, 3), (k, 3), (k,)."""
        p0, p1, r = self.capsules(q)
        d, pa, pb = capsule_distance(p0[:, None], p1[:, None], r[:, None], hp0[None], hp1[None], hr[None])
        c, h = np.unravel_index(int(np.argmin(d)), d.shape)
        gap = pa[c, h] - pb[c, h]
        u = gap / max(float(np.linalg.norm(gap)), 1e-12)
        model = self.state.model
        pin.computeJointJacobians(model, self._data, np.array(q, dtype=float).reshape(-1))
        joint = int(self.state.capsule_joint_ids[self.skip + int(c)])
        return float(d[c, h]), u @ point_jacobian(model, self._data, joint, pa[c, h])


def _hat_integral(t: np.ndarray, centre: float, half_width: float) -> np.ndarray:
    """The integral from 0 to ``t`` of the hat function 1 - |s - centre| / half_width (0 beyond)."""

    def cumulative(x):
        rise = np.clip(x - (centre - half_width), 0.0, half_width)
        fall = np.clip(x - centre, 0.0, half_width)
        return rise ** 2 / (2 * half_width) + fall - fall ** 2 / (2 * half_width)

    return cumulative(np.asarray(t, dtype=float)) - cumulative(0.0)


def _weights(window_s: float, points: int = SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """``_weights_at`` ``points`` evenly spaced times (the last at the window's end)."""
    return _weights_at(np.linspace(window_s / points, window_s, points), window_s)


def _weights_at(times: np.ndarray, window_s: float) -> tuple[np.ndarray, np.ndarray]:
    """``(w0 (m,), W (m, KNOTS))`` [s]: the position change at ``times`` (m,) [s, from the
    window's start] per unit of the starting velocity and of each knot's velocity (velocity
    linear between knots)."""
    h = window_s / KNOTS
    w0 = _hat_integral(times, 0.0, h)
    W = np.stack([_hat_integral(times, (k + 1) * h, h) for k in range(KNOTS)], axis=1)
    return w0, W


def _velocity_weights(window_s: float, points: int) -> tuple[np.ndarray, np.ndarray]:
    """``(u0 (points,), U (points, KNOTS))``: the joint velocity at the times of ``_weights``
    per unit of the starting velocity and of each knot's (the hat functions' values)."""
    times = np.linspace(window_s / points, window_s, points)
    h = window_s / KNOTS
    hat = lambda centre: np.clip(1.0 - np.abs(times - centre) / h, 0.0, None)  # noqa: E731
    return hat(0.0), np.stack([hat((k + 1) * h) for k in range(KNOTS)], axis=1)


def hand_velocity_turn(J6: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``d(J_ee(q) v)/dq`` (3, n): how the hand's velocity at the joint velocity ``v`` turns with
    the pose, from its Jacobian ``J6`` (6, n; ``_Kinematics.frame_jacobian``) alone. For revolute
    joints in chain order, column ``i``'s translation ``j_i = z_i x (p - o_i)`` changes with
    ``q_k`` at ``z_min(i,k) x j_max(i,k)``, so column ``k`` of the result is
    ``w_k x j_k + z_k x t_k`` with ``w_k = sum_{i<k} v_i z_i`` and ``t_k = sum_{i>=k} v_i j_i``
    (``kinematics.drift_along`` is ``u . turn qdot`` at ``v = qdot``, for one row in the compiled
    step; the tests compare this with pinocchio's ``getFrameJacobianTimeVariation``)."""
    j, z = J6[:3], J6[3:]
    jv, zv = j * v, z * v
    t = np.cumsum(jv[:, ::-1], axis=1)[:, ::-1]
    w = np.cumsum(zv, axis=1) - zv
    return np.cross(w, j, axis=0) + np.cross(z, t, axis=0)


class _HandRows:
    """The hand's rows of the search over knot velocities ``x`` (KNOTS n, then ``s``), from
    ``q0``, ``v0`` over ``window_s``: at every quarter of a knot interval its velocity
    ``J_ee(q) v``, its speed and its acceleration over each quarter within the robot's
    end-effector limits, as margins ``1 - (value / limit)^2`` (``margins``, >= 0 when kept),
    and their Jacobian (``jacobian``: exact, ``hand_velocity_turn`` for the pose's part)."""

    def __init__(self, kin: _Kinematics, q0: np.ndarray, v0: np.ndarray, window_s: float):
        self.kin, self.n = kin, len(q0)
        hw0, self.HW = _weights(window_s, HAND_POINTS)
        hu0, self.HU = _velocity_weights(window_s, HAND_POINTS)
        self.q_start = q0 + np.outer(hw0, v0)
        self.v_start = np.outer(hu0, v0)
        self.u_start = kin.hand_jacobian(q0) @ v0
        self.quarter = window_s / HAND_POINTS
        self._cache: dict = {}

    def velocities(self, x: np.ndarray):
        """(hand velocities (HAND_POINTS, 3), their derivatives (HAND_POINTS, 3, KNOTS n))."""
        key = x.tobytes()
        if key not in self._cache:
            self._cache.clear()
            kin, n = self.kin, self.n
            X = x[: KNOTS * n].reshape(KNOTS, n)
            q, v = self.q_start + self.HW @ X, self.v_start + self.HU @ X
            frames = [kin.frame_jacobian(qk) for qk in q]
            jacobians = [J6[:3] for J6 in frames]
            u = np.array([J @ vk for J, vk in zip(jacobians, v)])
            turn = [hand_velocity_turn(J6, vk) for J6, vk in zip(frames, v)]
            du = np.array([np.kron(self.HU[g][None, :], jacobians[g]) + np.kron(self.HW[g][None, :], turn[g])
                           for g in range(HAND_POINTS)])
            self._cache[key] = (u, du)
        return self._cache[key]

    def margins(self, x: np.ndarray) -> np.ndarray:
        u, _ = self.velocities(x)
        a = np.diff(np.vstack([self.u_start, u]), axis=0) / self.quarter
        return np.concatenate([1.0 - (u ** 2).sum(axis=1) / self.kin.ee_speed ** 2,
                               1.0 - (a ** 2).sum(axis=1) / self.kin.ee_acc ** 2])

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        u, du = self.velocities(x)
        a = np.diff(np.vstack([self.u_start, u]), axis=0) / self.quarter
        da = np.diff(np.concatenate([np.zeros((1,) + du.shape[1:]), du]), axis=0) / self.quarter
        rows = np.vstack([-2.0 * np.einsum("gi,gik->gk", u, du) / self.kin.ee_speed ** 2,
                          -2.0 * np.einsum("gi,gik->gk", a, da) / self.kin.ee_acc ** 2])
        return np.hstack([rows, np.zeros((2 * HAND_POINTS, 1))])


def _reach(v_start: np.ndarray, target: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Knot velocities (KNOTS, n) going from ``v_start`` to ``target`` by at most ``step`` per knot."""
    knots, v = [], v_start.copy()
    for _ in range(KNOTS):
        v = v + np.clip(target - v, -step, step)
        knots.append(v)
    return np.array(knots)


def escape_exists(robot: str, q_log: np.ndarray, t_log: np.ndarray, t_closest_s: float, truth: TruthHuman,
                  truth_offset_s: float, critical_m: float, capsules: str = "paper", maxiter: int = 200,
                  kinematics: _Kinematics | None = None, earliest_s: float | None = None) -> Escape:
    """Search the window around ``t_closest_s`` (run clock) for a motion keeping the true
    separation >= ``critical_m``; ``q_log`` (n, nq) at ``t_log`` (n,) is the run's trajectory;
    the window starts ``LOOKBACK_S`` before ``t_closest_s``, or at ``earliest_s`` when later.
    The search keeps the separation, the joint limits and the cell at ``SAMPLES`` times; a motion
    it finds counts as an escape only when it keeps them at every ``VERIFY_S`` too (``_Verifier``);
    when it dips between the samples, the times of its dips join the samples and the search runs
    again, at most ``REFINE_ROUNDS`` times."""
    kin = kinematics or _Kinematics(robot, capsules)
    t0 = max(float(t_log[0]), t_closest_s - LOOKBACK_S, -np.inf if earliest_s is None else float(earliest_s))
    t1 = t_closest_s + LOOKAHEAD_S
    window = max(t1 - t0, 1e-3)
    i0 = int(np.clip(np.searchsorted(t_log, t0), 0, len(t_log) - 1))
    q0 = np.asarray(q_log[i0], dtype=float)
    if i0 + 1 < len(t_log):  # the logged velocity at t0 (within the robot's limits)
        v0 = (np.asarray(q_log[i0 + 1], dtype=float) - q0) / max(float(t_log[i0 + 1] - t_log[i0]), 1e-9)
    else:
        v0 = np.zeros_like(q0)
    v0 = np.clip(v0, -kin.v_max, kin.v_max)
    i1 = int(np.clip(np.searchsorted(t_log, min(t1, float(t_log[-1]))), 0, len(t_log) - 1))
    logged = (np.asarray(q_log[i1]) - q0) / window
    search = _Search(kin, q0, v0, window, logged, lambda t: truth.capsules_at(truth_offset_s + t0 + t),
                     truth.radius_m, maxiter)
    verifier = _Verifier(kin, q0, v0, window, lambda p0, p1, r, t: truth.distance_m(p0, p1, r, truth_offset_s + t0 + t))
    times = np.linspace(window / SAMPLES, window, SAMPLES)
    best, witness = -np.inf, None
    for _ in range(REFINE_ROUNDS + 1):
        found = search.run(times, critical_m, verifier)
        if found is None:  # no motion within the limits (at the samples)
            break
        x, at_samples, value, dips = found
        if value > best:
            best, witness = value, x
        if value >= critical_m or at_samples < critical_m or not dips.size:
            break  # an escape; or none even at the samples, which more samples cannot give
        times = np.union1d(times, dips)
    return Escape(bool(best >= critical_m), best, (t0, t1), None if witness is None else witness.reshape(KNOTS, -1))


class _Verifier:
    """A motion's true separation, joint limits and cell every ``VERIFY_S`` over the window:
    ``check(x) -> (smallest separation [m] where the limits and the cell hold, else -inf; the
    times of its dips below ``critical_m`` and of any limit or cell it breaks)``."""

    def __init__(self, kin: _Kinematics, q0: np.ndarray, v0: np.ndarray, window_s: float, distance):
        points = max(int(np.ceil(window_s / VERIFY_S)), SAMPLES)
        self.times = np.linspace(window_s / points, window_s, points)
        w0, self.W = _weights_at(self.times, window_s)
        self.start = q0 + np.outer(w0, v0)
        self.kin, self.distance = kin, distance

    def check(self, x: np.ndarray, critical_m: float) -> tuple[float, np.ndarray]:
        kin = self.kin
        q = self.start + self.W @ x[: KNOTS * len(self.start[0])].reshape(KNOTS, -1)
        samples = [kin.capsules_and_cell(qk) for qk in q]
        d = np.array([self.distance(*capsules, t) for (capsules, _), t in zip(samples, self.times)])
        broken = kin.outside_joint_limits(q) | np.array([np.any(cell < -CELL_TOLERANCE_M) for _, cell in samples])
        low = d < critical_m
        # The dips' deepest times (a local minimum of each stretch below the critical distance)
        # and every time a limit or the cell breaks.
        minima = low & np.r_[True, d[1:] <= d[:-1]] & np.r_[d[:-1] <= d[1:], True]
        dips = self.times[minima | broken]
        return (-np.inf if broken.any() else float(d.min())), dips


class _Search:
    """The search at given sample times: the candidate motions, then SLSQP from the best, each
    kept only when ``_Verifier`` finds it within every limit at every ``VERIFY_S``."""

    def __init__(self, kin: _Kinematics, q0: np.ndarray, v0: np.ndarray, window_s: float, logged: np.ndarray,
                 human_at, human_radius: np.ndarray, maxiter: int):
        self.kin, self.q0, self.v0, self.window = kin, q0, v0, window_s
        self.logged, self.human_at, self.radius, self.maxiter = logged, human_at, human_radius, maxiter
        self.hand = _HandRows(kin, q0, v0, window_s)
        self.step = kin.a_max * window_s / KNOTS  # the most a knot's velocity may differ from the previous one

    def run(self, times: np.ndarray, critical_m: float, verifier: _Verifier):
        """``(x, its smallest separation at the samples, at every VERIFY_S (-inf where it
        breaks a limit or the cell there), the times of its dips)`` of the best motion found at
        ``times`` (relative to the window's start), or None when none keeps the limits there."""
        kin, q0, v0, hand, step = self.kin, self.q0, self.v0, self.hand, self.step
        n, samples = len(q0), len(times)
        humans = [self.human_at(t) for t in times]
        w0, W = _weights_at(times, self.window)
        start_motion = q0 + np.outer(w0, v0)
        dq_dx = np.kron(W, np.eye(n))  # (samples n, KNOTS n): d q_j / d knot velocities

        def positions(x: np.ndarray) -> np.ndarray:
            return start_motion + W @ x[: KNOTS * n].reshape(KNOTS, n)  # (samples, n)

        cache: dict = {}

        def separations(x: np.ndarray):
            key = x.tobytes()
            if key not in cache:
                cache.clear()
                q = positions(x)
                pairs = [kin.separation(q[j], *humans[j], self.radius) for j in range(samples)]
                cache[key] = (np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs]))
            return cache[key]

        cell_cache: dict = {}

        def cell(x: np.ndarray):
            """The table's and the reach's margins at the samples (``_Kinematics.cell_margins``),
            and their Jacobian in the knot velocities."""
            key = x.tobytes()
            if key not in cell_cache:
                cell_cache.clear()
                q = positions(x)
                rows = [kin.cell_margins(q[j]) for j in range(samples)]
                jacobian = np.vstack([g @ dq_dx[j * n:(j + 1) * n] for j, (_, g) in enumerate(rows)])
                cell_cache[key] = (np.concatenate([m for m, _ in rows]), jacobian)
            return cell_cache[key]

        # Acceleration rows: step -+ (x_k - x_{k-1}) >= 0, x_0 = v0.
        difference = np.eye(KNOTS * n) - np.eye(KNOTS * n, k=-n)
        previous = np.concatenate([v0, np.zeros((KNOTS - 1) * n)])
        steps = np.tile(step, KNOTS)
        v_bound = np.tile(kin.v_max, KNOTS)  # each knot's velocity limit

        def accelerations(x: np.ndarray) -> np.ndarray:
            change = difference @ x[: KNOTS * n] - previous
            return np.concatenate([steps - change, steps + change])

        def feasible(x: np.ndarray) -> bool:
            q = positions(x)
            return bool(not kin.outside_joint_limits(q).any()
                        and np.all(accelerations(x) >= -1e-9 * steps.max())
                        and np.all(np.abs(x[: KNOTS * n]) <= v_bound + 1e-12)
                        and np.all(hand.margins(x) >= -1e-4)  # SLSQP's tolerance: 5e-5 of the hand's limits
                        and np.all(cell(x)[0] >= -CELL_TOLERANCE_M))

        def verified(x: np.ndarray, at_samples: float):
            value, dips = verifier.check(x, critical_m)
            return x, at_samples, value, dips

        # Candidates first, each reached at the acceleration limits or a half or a quarter of
        # them (the hand's own limits may allow no more): brake to a stop, the logged motion
        # reversed (a retreat along it), the steepest retreat at full or half speed. One that
        # keeps the critical distance at the samples and at every VERIFY_S is an escape.
        braking = _reach(v0, np.zeros(n), step).ravel()
        d_brake, grads_brake = separations(braking)
        worst = int(np.argmin(d_brake))
        steepest = kin.v_max * np.sign(grads_brake[worst])  # every joint growing the worst separation
        best, start = -np.inf, None
        for target, share in itertools.product((np.zeros(n), np.clip(-self.logged, -kin.v_max, kin.v_max),
                                                steepest, 0.5 * steepest), (1.0, 0.5, 0.25)):
            x = _reach(v0, target, share * step).ravel()
            if feasible(x):
                value = float(separations(x)[0].min())
                if value >= critical_m:
                    found = verified(x, value)
                    if found[2] >= critical_m:
                        return found
                if value > best:
                    best, start = value, x
        if start is None:
            start = braking
        # Epigraph: maximise s subject to d_j(x) >= s, joint and acceleration limits, velocity bounds.

        def gap_jacobian(x):
            _, grads = separations(x)
            rows = np.einsum("jn,jnk->jk", grads, dq_dx.reshape(samples, n, KNOTS * n))
            return np.hstack([rows, -np.ones((samples, 1))])

        acceleration_jacobian = np.hstack([np.vstack([-difference, difference]), np.zeros((2 * KNOTS * n, 1))])
        limits = [{"type": "ineq", "fun": lambda x: separations(x)[0] - x[-1], "jac": gap_jacobian},
                  {"type": "ineq", "fun": lambda x: (positions(x) - kin.lower).ravel(),
                   "jac": lambda x: np.hstack([dq_dx, np.zeros((samples * n, 1))])},
                  {"type": "ineq", "fun": lambda x: (kin.upper - positions(x)).ravel(),
                   "jac": lambda x: np.hstack([-dq_dx, np.zeros((samples * n, 1))])},
                  {"type": "ineq", "fun": accelerations, "jac": lambda x: acceleration_jacobian},
                  {"type": "ineq", "fun": hand.margins, "jac": hand.jacobian},
                  {"type": "ineq", "fun": lambda x: cell(x)[0],
                   "jac": lambda x: np.hstack([cell(x)[1], np.zeros((len(cell(x)[0]), 1))])}]
        x0 = np.concatenate([start, [float(separations(start)[0].min())]])  # from the best candidate
        bounds = [(-v, v) for v in v_bound] + [(None, None)]
        result = minimize(lambda x: -x[-1], x0, jac=lambda x: np.r_[np.zeros(KNOTS * n), -1.0], method="SLSQP",
                          bounds=bounds, constraints=limits, options={"maxiter": self.maxiter, "ftol": 1e-5})
        x = np.clip(result.x[:-1], -v_bound, v_bound)
        if feasible(x) and float(separations(x)[0].min()) > best:
            best, start = float(separations(x)[0].min()), x
        if best == -np.inf:
            return None
        return verified(start, best)


def approach_onset_s(kin: _Kinematics, q_closest: np.ndarray, truth: TruthHuman, truth_offset_s: float,
                     t_from_s: float, t_closest_s: float) -> float | None:
    """When the person's final approach began [s, run clock]: the start of the last unbroken
    stretch before ``t_closest_s`` in which the true human alone (the arm held at its pose at the
    closest moment, ``q_closest``) closed on the arm faster than ``ONSET_CLOSING_M_S``, or
    ``t_from_s`` when the stretch began before it; None when they never closed that fast from
    ``t_from_s`` on (the arm came to them)."""
    p0, p1, r = (np.array(a, dtype=float) for a in kin.capsules(np.asarray(q_closest, dtype=float)))
    t = np.arange(t_from_s, t_closest_s + 0.5 * ONSET_STEP_S, ONSET_STEP_S)
    if len(t) < 2:
        return None
    d = np.array([truth.distance_m(p0, p1, r, truth_offset_s + x) for x in t])
    closing = -np.diff(d) / np.diff(t)  # per interval [t_k, t_k+1]
    fast = np.flatnonzero(closing > ONSET_CLOSING_M_S)
    if not fast.size:
        return None
    slow = np.flatnonzero(closing[: fast[-1]] <= ONSET_CLOSING_M_S)
    return float(t[slow[-1] + 1]) if slow.size else float(t[0])
