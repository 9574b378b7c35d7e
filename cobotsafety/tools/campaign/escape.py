"""Did an escape exist? An offline joint-space optimisation over the same (true) human.

For a breach (the true separation fell below the critical distance at ``t_closest``), take the
robot's logged joint state at ``t0 = t_closest - LOOKBACK_S`` and ask scipy (SLSQP) for a joint
trajectory over ``[t0, t_closest + LOOKAHEAD_S]`` that keeps the true separation above the
critical distance, knowing the human's whole future (the ground truth): joint velocities
piecewise constant over ``KNOTS`` segments, each within the robot's velocity limits, positions
within its joint limits, maximising the smallest separation ``s`` at ``SAMPLES`` times
(epigraph form: maximise ``s`` subject to ``d_j(qdot) >= s``). An escape existed when the
optimum (or a candidate tried first: hold still, or retreat along the logged motion) reaches
the critical distance. The window is a stated choice: the controller could have started
earlier, so "no escape in the window" does not prove none existed before it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from cobotsafety.experiments.approach_truth import TruthHuman, min_capsule_distance_m

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
    """The robot's capsules (minus the base one) at any q, for the optimisation."""

    def __init__(self, robot: str, capsules: str = "paper", skip_capsules: int = 1):
        from cobotsafety.arm.robot_state import RobotState

        self.state = RobotState(robot, capsules=capsules)
        self.skip = skip_capsules
        model = self.state.model
        self.v_max = np.asarray(model.velocityLimit, dtype=float)
        self.lower, self.upper = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()

    def capsules(self, q: np.ndarray):
        s = self.state
        s.q = q
        s.update()
        return s.capsule_p0[self.skip:], s.capsule_p1[self.skip:], s.capsule_radius[self.skip:]


def _rollout(q0: np.ndarray, qdot_knots: np.ndarray, window_s: float) -> np.ndarray:
    """Joint positions (SAMPLES, n) at the sample times for piecewise-constant joint rates."""
    times = np.linspace(window_s / SAMPLES, window_s, SAMPLES)
    segment = window_s / KNOTS
    cumulative = np.vstack([np.zeros(len(q0)), np.cumsum(qdot_knots * segment, axis=0)])
    k = np.minimum((times // segment).astype(int), KNOTS - 1)
    return q0 + cumulative[k] + qdot_knots[k] * (times - k * segment)[:, None]


def escape_exists(robot: str, q_log: np.ndarray, t_log: np.ndarray, t_closest_s: float, truth: TruthHuman,
                  truth_offset_s: float, critical_m: float, capsules: str = "paper", maxiter: int = 25,
                  kinematics: _Kinematics | None = None) -> Escape:
    """Search the window around ``t_closest_s`` (run clock) for a motion keeping the true
    separation >= ``critical_m``; ``q_log`` (n, nq) at ``t_log`` (n,) is the run's trajectory."""
    kin = kinematics or _Kinematics(robot, capsules)
    t0 = max(float(t_log[0]), t_closest_s - LOOKBACK_S)
    t1 = min(float(t_log[-1]) + LOOKAHEAD_S, t_closest_s + LOOKAHEAD_S)
    window = max(t1 - t0, 1e-3)
    i0 = int(np.clip(np.searchsorted(t_log, t0), 0, len(t_log) - 1))
    q0 = np.asarray(q_log[i0], dtype=float)
    times = t0 + np.linspace(window / SAMPLES, window, SAMPLES)
    humans = [truth.capsules_at(truth_offset_s + t) for t in times]
    n = len(q0)

    def distances(x: np.ndarray) -> np.ndarray:
        q = np.clip(_rollout(q0, x[: KNOTS * n].reshape(KNOTS, n), window), kin.lower, kin.upper)
        out = np.empty(SAMPLES)
        for j in range(SAMPLES):
            p0, p1, r = kin.capsules(q[j])
            hp0, hp1 = humans[j]
            out[j] = min_capsule_distance_m(p0, p1, r, hp0, hp1, truth.radius_m)
        return out

    def joint_margin(x: np.ndarray) -> np.ndarray:
        q = _rollout(q0, x[: KNOTS * n].reshape(KNOTS, n), window)
        return np.concatenate([(q - kin.lower).ravel(), (kin.upper - q).ravel()])

    # Candidates first: hold still, and the logged motion reversed (a retreat along it).
    i1 = int(np.clip(np.searchsorted(t_log, t1), 0, len(t_log) - 1))
    logged = (np.asarray(q_log[i1]) - q0) / window
    candidates = [np.zeros(KNOTS * n), np.tile(np.clip(-logged, -kin.v_max, kin.v_max), KNOTS)]
    best = -np.inf
    for x in candidates:
        best = max(best, float(distances(x).min()))
        if best >= critical_m:
            return Escape(True, best, (t0, t1))
    x0 = np.concatenate([candidates[0], [best]])
    bounds = [(-v, v) for v in np.tile(kin.v_max, KNOTS)] + [(None, None)]
    result = minimize(lambda x: -x[-1], x0, jac=lambda x: np.r_[np.zeros(KNOTS * n), -1.0], method="SLSQP",
                      bounds=bounds, options={"maxiter": maxiter, "ftol": 1e-4},
                      constraints=[{"type": "ineq", "fun": lambda x: distances(x) - x[-1]},
                                   {"type": "ineq", "fun": joint_margin}])
    x = np.clip(result.x[:-1], -np.tile(kin.v_max, KNOTS), np.tile(kin.v_max, KNOTS))
    best = max(best, float(distances(x).min()) if np.all(joint_margin(x) >= -1e-6) else -np.inf)
    return Escape(bool(best >= critical_m), best, (t0, t1))
