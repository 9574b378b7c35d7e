"""Human capsules as moving protection zones for the anticipative filter (beyond both papers).

For every (robot capsule, human capsule) pair closer than ``activation_m`` the separation
``d`` (capsule distance) must stay above ``critical_m``. Its rate is
``d_dot = u . J_c qdot - u . v_h``: ``u`` the unit vector from the human's closest point to the
robot's, ``J_c`` the Jacobian of the robot capsule's closest point (paper 1 II.G, ``J_c J^+`` on
the command), ``v_h`` the human's velocity at its closest point (``HumanVelocityEstimator``).
The human's part enters as the measure's ``rate``, so the robot gives way ahead of an
approaching human, and slides around them; it stops only when every motion would close in.
Defaults: ``critical_m`` = 0.25 m (paper 2's d_cr is not given numerically: a quarter metre
between capsule surfaces) and ``activation_m`` = 0.60 m (d_cr + d_o with d_o = 0.35 m).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from cobotsafety.arm.constraints import ArmConstraint, Measures
from cobotsafety.arm.robot_state import RobotState
from cobotsafety.arm.packed_measures import human_minimum, human_pairs
from cobotsafety.human.body import HumanCapsules

DEFAULT_CRITICAL_M = 0.25
DEFAULT_ACTIVATION_M = 0.60


@dataclass
class HumanCapsulesConstraint(ArmConstraint):
    """Keeps every robot capsule ``critical_m`` away from every human capsule.

    Give it the human (``HumanCapsules``, with end-point velocities or without: zeros) before
    each step (``set_human``).
    """

    critical_m: float = DEFAULT_CRITICAL_M
    activation_m: float = DEFAULT_ACTIVATION_M
    skip_capsules: int = 1
    name: str = "human"
    p0: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    p1: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    radius: np.ndarray = field(default_factory=lambda: np.zeros(0))
    v0: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    v1: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    human_names: tuple[str, ...] = ()

    def set_human(self, human: HumanCapsules | None) -> None:
        """The human now (robot base frame); None or an absent human clears it."""
        if human is None:
            human = HumanCapsules.absent()
        self.p0, self.p1, self.radius = human.p0_b_m, human.p1_b_m, human.radius_m
        self.v0 = np.zeros_like(self.p0) if human.v0_b_m_s is None else human.v0_b_m_s
        self.v1 = np.zeros_like(self.p1) if human.v1_b_m_s is None else human.v1_b_m_s
        self.human_names = human.names

    def pairs(self, state: RobotState):
        """Distances (c, k) [m], robot points (c, k, 3), human points (c, k, 3)."""
        args = self._kernel_arguments(state)
        c, k = len(state.capsule_radius) - args[3], len(self.radius)
        # ``capsule_distance`` on the (c, 1) x (1, k) broadcast, without its broadcasting cost.
        d, p_robot, p_human = human_pairs(*args)
        return d.reshape(c, k), p_robot.reshape(c, k, 3), p_human.reshape(c, k, 3)

    def _kernel_arguments(self, state: RobotState) -> tuple:
        """The robot's and the human's capsules as ``human_pairs`` and ``human_minimum`` take them."""
        robot = [np.ascontiguousarray(a, dtype=float) for a in (state.capsule_p0, state.capsule_p1, state.capsule_radius)]
        human = [np.ascontiguousarray(a, dtype=float) for a in (self.p0, self.p1, self.radius)]
        return (*robot, min(self.skip_capsules, len(state.capsule_radius)), *human)

    def minimum(self, state: RobotState) -> tuple[float, np.ndarray, np.ndarray]:
        """Minimum human-robot distance [m] and its closest points (robot, human)."""
        if self.radius.size == 0 or len(state.capsules) <= self.skip_capsules:
            return np.inf, np.full(3, np.nan), np.full(3, np.nan)
        # The first smallest of ``pairs``' distances, in one compiled call.
        return human_minimum(*self._kernel_arguments(state))

    def distances(self, state: RobotState) -> np.ndarray:
        if self.radius.size == 0:
            return np.zeros(0)
        return (self.pairs(state)[0] - self.critical_m).ravel()

    def measures(self, state: RobotState, activation_m: float = np.inf) -> Measures:
        return self.measures_and_distances(state, activation_m)[0]

    def measures_and_distances(self, state: RobotState, activation_m: float) -> tuple[Measures, np.ndarray]:
        if self.radius.size == 0:
            return Measures.empty(state.nv), np.zeros(0)
        d, pr, ph = self.pairs(state)
        return self._measures(state, d, pr, ph), (d - self.critical_m).ravel()

    def _measures(self, state: RobotState, d: np.ndarray, pr: np.ndarray, ph: np.ndarray) -> Measures:
        ci, hi = np.nonzero(d < self.activation_m)
        if ci.size == 0:
            return Measures.empty(state.nv)
        gap = pr[ci, hi] - ph[ci, hi]
        norm = np.linalg.norm(gap, axis=1, keepdims=True)
        u = np.where(norm > 1e-9, gap / np.where(norm > 1e-9, norm, 1.0), np.array([0.0, 0.0, 1.0]))
        # Human velocity at its closest point: interpolate the end points' velocities.
        seg = self.p1[hi] - self.p0[hi]
        length2 = np.einsum("ij,ij->i", seg, seg)
        t = np.where(length2 > 0, np.einsum("ij,ij->i", ph[ci, hi] - self.p0[hi], seg) / np.where(length2 > 0, length2, 1.0), 0.0)
        v_h = self.v0[hi] + np.clip(t, 0, 1)[:, None] * (self.v1[hi] - self.v0[hi])
        A = np.array([u[n] @ state.point_jacobian(self.skip_capsules + c, pr[c, h]) for n, (c, h) in enumerate(zip(ci, hi))])
        names = tuple(f"human {self.human_names[h]} ({state.capsules[self.skip_capsules + c].name})" for c, h in zip(ci, hi))
        return Measures(d[ci, hi] - self.critical_m, A, names, np.zeros(ci.size, dtype=bool),
                        -np.einsum("ij,ij->i", u, v_h))
