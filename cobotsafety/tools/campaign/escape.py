"""Did an escape exist? An offline joint-space optimisation over the same (true) human.

For a breach (the true separation fell below the critical distance at ``t_closest``), take the
robot's logged joint state at ``t0 = t_closest - LOOKBACK_S`` and ask scipy (SLSQP) for a joint
trajectory over ``[t0, t_closest + LOOKAHEAD_S]`` that keeps the true separation above the
critical distance, knowing the human's whole future (the ground truth): joint velocities
piecewise constant over ``KNOTS`` segments, each within the robot's velocity limits (``MotionLimits``), positions
within its joint limits, maximising the smallest separation ``s`` at ``SAMPLES`` times
(epigraph form: maximise ``s`` subject to ``d_j(qdot) >= s``). The constraints' gradients are
exact: ``d d_j / d q = u^T J_c`` at the closest pair (``u`` from the human's closest point to
the robot's, ``J_c`` the robot point's Jacobian), times the time each knot acts before sample
``j``. An escape existed when the optimum (or a candidate tried first: hold still, reverse the
logged motion, or the steepest retreat at full or half speed; SLSQP starts from the best) reaches
the critical distance. The search is local: an escape found is certain (a witness trajectory),
"none" is the best SLSQP found, so ``breaches_with_escape`` is a lower bound. The window is a stated choice: the controller
could have started earlier, so "no escape in the window" does not prove none existed before it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from cobotsafety.experiments.approach_truth import TruthHuman
from cobotsafety.geometry.capsule import capsule_distance

LOOKBACK_S = 1.0
LOOKAHEAD_S = 0.5
KNOTS = 4
SAMPLES = 16


@dataclass(frozen=True)
class Escape:
    exists: bool
    best_min_distance_m: float
    """The largest smallest true separation [m] found over the window."""
    window_s: tuple[float, float]


class _Kinematics:
    """The robot's capsules (minus the base one) at any q, and the separation's gradient."""

    def __init__(self, robot: str, capsules: str = "paper", skip_capsules: int = 1):
        from cobotsafety.arm.controller import ArmController

        self.arm = ArmController(robot, zones=[], capsules=capsules)
        self.state = self.arm.state
        self.skip = skip_capsules
        model = self.state.model
        self.v_max = np.asarray(self.arm.model.limits.velocity_rad_s, dtype=float)
        self.lower, self.upper = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()

    def capsules(self, q: np.ndarray):
        self.arm.set_configuration(q)
        s = self.state
        return s.capsule_p0[self.skip:], s.capsule_p1[self.skip:], s.capsule_radius[self.skip:]

    def separation(self, q: np.ndarray, hp0, hp1, hr) -> tuple[float, np.ndarray]:
        """(separation [m], its gradient d/dq (n,)) against human capsules (k, 3), (k, 3), (k,)."""
        p0, p1, r = self.capsules(q)
        d, pa, pb = capsule_distance(p0[:, None], p1[:, None], r[:, None], hp0[None], hp1[None], hr[None])
        c, h = np.unravel_index(int(np.argmin(d)), d.shape)
        gap = pa[c, h] - pb[c, h]
        u = gap / max(float(np.linalg.norm(gap)), 1e-12)
        return float(d[c, h]), u @ self.state.point_jacobian(self.skip + int(c), pa[c, h])


def _weights(window_s: float) -> np.ndarray:
    """(SAMPLES, KNOTS): how long [s] each knot's rate has acted at each sample time."""
    times = np.linspace(window_s / SAMPLES, window_s, SAMPLES)
    starts = np.arange(KNOTS) * window_s / KNOTS
    return np.clip(times[:, None] - starts[None, :], 0.0, window_s / KNOTS)


def escape_exists(robot: str, q_log: np.ndarray, t_log: np.ndarray, t_closest_s: float, truth: TruthHuman,
                  truth_offset_s: float, critical_m: float, capsules: str = "paper", maxiter: int = 40,
                  kinematics: _Kinematics | None = None) -> Escape:
    """Search the window around ``t_closest_s`` (run clock) for a motion keeping the true
    separation >= ``critical_m``; ``q_log`` (n, nq) at ``t_log`` (n,) is the run's trajectory."""
    kin = kinematics or _Kinematics(robot, capsules)
    t0 = max(float(t_log[0]), t_closest_s - LOOKBACK_S)
    t1 = t_closest_s + LOOKAHEAD_S
    window = max(t1 - t0, 1e-3)
    q0 = np.asarray(q_log[int(np.clip(np.searchsorted(t_log, t0), 0, len(t_log) - 1))], dtype=float)
    times = t0 + np.linspace(window / SAMPLES, window, SAMPLES)
    humans = [truth.capsules_at(truth_offset_s + t) for t in times]
    n, W = len(q0), _weights(window)

    def positions(x: np.ndarray) -> np.ndarray:
        return q0 + W @ x[: KNOTS * n].reshape(KNOTS, n)  # (SAMPLES, n)

    cache: dict = {}

    def separations(x: np.ndarray):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            q = positions(x)
            pairs = [kin.separation(q[j], *humans[j], truth.radius_m) for j in range(SAMPLES)]
            cache[key] = (np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs]))
        return cache[key]

    def feasible(x: np.ndarray) -> bool:
        q = positions(x)
        return bool(np.all(q >= kin.lower - 1e-9) and np.all(q <= kin.upper + 1e-9))

    # Candidates first: hold still, and the logged motion reversed (a retreat along it).
    i1 = int(np.clip(np.searchsorted(t_log, min(t1, float(t_log[-1]))), 0, len(t_log) - 1))
    logged = (np.asarray(q_log[i1]) - q0) / window
    d_still, grads_still = separations(np.zeros(KNOTS * n))
    worst = int(np.argmin(d_still))
    # Steepest retreat: every joint at its limit in the direction that grows the worst separation.
    steepest = kin.v_max * np.sign(grads_still[worst])
    best, start = -np.inf, np.zeros(KNOTS * n)
    for rates in (np.zeros(n), np.clip(-logged, -kin.v_max, kin.v_max), steepest, 0.5 * steepest):
        x = np.tile(rates, KNOTS)
        if feasible(x):
            value = float(separations(x)[0].min())
            if value > best:
                best, start = value, x
            if best >= critical_m:
                return Escape(True, best, (t0, t1))
    # Epigraph: maximise s subject to d_j(x) >= s, joint limits, velocity bounds.
    dq_dx = np.kron(W, np.eye(n))  # (SAMPLES n, KNOTS n): d q_j / d knot rates

    def gap_jacobian(x):
        _, grads = separations(x)
        rows = np.einsum("jn,jnk->jk", grads, dq_dx.reshape(SAMPLES, n, KNOTS * n))
        return np.hstack([rows, -np.ones((SAMPLES, 1))])

    limits = [{"type": "ineq", "fun": lambda x: separations(x)[0] - x[-1], "jac": gap_jacobian},
              {"type": "ineq", "fun": lambda x: (positions(x) - kin.lower).ravel(),
               "jac": lambda x: np.hstack([dq_dx, np.zeros((SAMPLES * n, 1))])},
              {"type": "ineq", "fun": lambda x: (kin.upper - positions(x)).ravel(),
               "jac": lambda x: np.hstack([-dq_dx, np.zeros((SAMPLES * n, 1))])}]
    x0 = np.concatenate([start, [best]])  # from the best candidate
    bounds = [(-v, v) for v in np.tile(kin.v_max, KNOTS)] + [(None, None)]
    result = minimize(lambda x: -x[-1], x0, jac=lambda x: np.r_[np.zeros(KNOTS * n), -1.0], method="SLSQP",
                      bounds=bounds, constraints=limits, options={"maxiter": maxiter, "ftol": 1e-5})
    x = np.clip(result.x[:-1], -np.tile(kin.v_max, KNOTS), np.tile(kin.v_max, KNOTS))
    if feasible(x):
        best = max(best, float(separations(x)[0].min()))
    return Escape(bool(best >= critical_m), best, (t0, t1))
