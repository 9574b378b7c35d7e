"""A task's way out of a joint-limit deadlock: the posture move home.

A least-squares filter never moves the hand against its command. When the arm's posture has
wound joints into their limits so that the joints still free cannot move the hand toward the
task's target (docs/campaign.md: the panda's joints 1, 3 and 7 at their lower limits, the four
free joints' hand motion nearly orthogonal to the command), the closest feasible command is
zero and the task waits for good. Nothing local unwinds such a posture: it needs a move in
joint space.

``PostureRecovery`` watches the task each step. The hand is *stalled* when its target stands
(the path waits for the hand: it lags by more than ``near_m``), every step slides on a joint
limit and on no person's row (``ArmController.blocked_by_joint_limits``: a person in the way is
waited for, not driven around), and the hand has come no closer to the target than
``progress_m`` better than its best for ``stall_s`` (standing, or circling at the limits: an
iiwa's hand went round a 3 cm loop 5-8 cm from its target for 30 s; a hand that crawls toward
the target along a limit, or trails a moving target, is making its way). Then it commands a
joint-space move to the home posture (``ArmController.step_joints``: the same filter, every
limitation and motion limit kept; a person arriving meanwhile is kept as always) until every
joint is within ``home_rad`` of home; the task resumes from there (the path still waits where it
was). A move home that itself makes less than ``progress_rad`` of progress for ``stall_s`` is
given up (the task resumes).

Settings, from stated principles (fixed before any campaign figure):

* ``stall_s`` = 2 s: the task's slowest legitimate wait that is not a person in the way is the
  hand braking and turning at a corner of its path (0.12 m/s, a fraction of a second); a yield
  (0.3 s) is a person's and excluded anyway; twice a second to be sure;
* ``progress_m`` = 10 mm: 5 mm/s on average, 4 % of the task's speed (a first version, 1 s
  without coming 10 mm closer to a target that might be moving, also moved arms trailing the
  path at its lag along a joint limit: 9 of the iiwa's first 214 campaign people, ~6 s lost
  each; a second, the hand moving under 10 mm in 2 s, missed the circling hand above);
* ``gain_per_s`` = 1 /s toward home, each joint at most half its speed limit (the secondary
  task's share, ``task.task_mapping``);
* ``home_rad`` = 0.05 rad: home to within a few centimetres of the hand.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass
class PostureRecovery:
    """The posture move home of a task stalled at joint limits (module docstring).

    ``q_home_rad`` (nq,) the home posture; ``velocity_limit_rad_s`` (nv,) the joints' speed
    limits; ``difference(q0, q1)`` (nv,) the joint motion from ``q0`` to ``q1``
    (``pin.difference``), needed when nq != nv (continuous joints stored as cos / sin: the
    JACO2); None: ``q1 - q0`` (a revolute arm)."""

    q_home_rad: np.ndarray
    velocity_limit_rad_s: np.ndarray
    difference: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    near_m: float = 0.05
    stall_s: float = 2.0
    progress_m: float = 0.01
    progress_rad: float = 0.01
    gain_per_s: float = 1.0
    speed_share: float = 0.5
    home_rad: float = 0.05
    recovering: bool = False
    count: int = 0
    """Posture moves started."""
    _since_s: float = 0.0
    _best: float = np.inf
    _target: np.ndarray | None = None

    def __post_init__(self):
        self.q_home_rad = np.array(self.q_home_rad, dtype=float)
        self.velocity_limit_rad_s = np.array(self.velocity_limit_rad_s, dtype=float)
        motion = self._to_home(self.q_home_rad)
        if motion.shape != self.velocity_limit_rad_s.shape:
            raise ValueError(f"the motion home {motion.shape} and velocity_limit_rad_s "
                             f"{self.velocity_limit_rad_s.shape} differ in shape (nq != nv needs a difference)")

    def _to_home(self, q_rad: np.ndarray) -> np.ndarray:
        """The joint motion (nv,) from ``q_rad`` to home."""
        if self.difference is None:
            return self.q_home_rad - q_rad
        return np.asarray(self.difference(q_rad, self.q_home_rad), dtype=float)

    def _restart(self, t_s: float, measure: float, target: np.ndarray | None = None) -> None:
        self._since_s, self._best, self._target = t_s, measure, target

    def command(self, t_s: float, q_rad: np.ndarray, p_hand_m: np.ndarray, p_target_m: np.ndarray,
                blocked: bool) -> np.ndarray | None:
        """The joint velocity of the posture move [rad/s] (nv,), or None: follow the task.

        ``t_s`` the time [s]; ``q_rad`` the joints now; ``p_hand_m`` (3,) the hand and
        ``p_target_m`` (3,) the task's target now [m]; ``blocked`` the last step slid on a joint
        limit and on no person's row (``ArmController.blocked_by_joint_limits``)."""
        if self.recovering:
            offset = self._to_home(q_rad)
            remaining = float(np.max(np.abs(offset)))
            if remaining <= self.home_rad:
                self.recovering = False
                self._restart(t_s, np.inf)
                return None
            if remaining < self._best - self.progress_rad:
                self._restart(t_s, remaining)
            elif t_s - self._since_s >= self.stall_s:  # the move home is stuck too: back to the task
                self.recovering = False
                self._restart(t_s, np.inf)
                return None
            qdot = self.gain_per_s * offset
            ratio = float(np.max(np.abs(qdot) / (self.speed_share * self.velocity_limit_rad_s)))
            return qdot / ratio if ratio > 1.0 else qdot
        if not blocked:
            self._restart(t_s, np.inf)
            return None
        distance = float(np.linalg.norm(p_target_m - p_hand_m))
        if distance <= self.near_m:
            self._restart(t_s, np.inf)
            return None
        if self._target is None or float(np.linalg.norm(p_target_m - self._target)) > 1e-9 \
                or distance < self._best - self.progress_m:  # a target that moves, or progress
            self._restart(t_s, distance, np.array(p_target_m, dtype=float))
            return None
        if t_s - self._since_s < self.stall_s:
            return None
        self.recovering = True
        self.count += 1
        self._restart(t_s, np.inf)
        return self.command(t_s, q_rad, p_hand_m, p_target_m, blocked)
