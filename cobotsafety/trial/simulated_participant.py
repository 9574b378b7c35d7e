"""A scripted participant for planning trials (how many people a study needs), not evidence.

It drags toward the next target (saturated proportional command, reaction delay, noise) and
answers the colour task. Divided attention is modelled the way paper 1 explains its effect
(IV.B): the cost of the standard ("stop") implementation is that the user must watch the robot.

* **Eyes.** While answering a colour word (from the word's appearance until the answer) the
  participant's eyes are on the word, not on the robot: the hand keeps dragging toward the
  target as if the robot followed the drag (dead reckoning from where the robot was last
  seen), and what the robot really does meanwhile goes unseen.
* **Noticing a stop.** A robot that stays still while being dragged is noticed after
  ``notice_stop_s`` of *watching* it; a stop that happens while the eyes are on a word is only
  noticed once they are back and have re-read the scene (``look_back_s``). Then ``replan_s`` passes before a detour (the drag turned by
  ``detour_angle_deg`` for ``detour_s``) is tried. Under sliding the robot rarely stops, so
  this cost falls mostly on ``stop``, and more in divided attention.
* **Stuck robot, missed words.** A word shown, or still unanswered, while the participant is
  dealing with a stuck robot (noticed and re-planning) is dropped with probability
  ``colour_miss_rate_stuck`` instead of ``colour_miss_rate``.
* **Dual-task cost.** Divided attention scales the drag speed by ``divided_speed_factor``
  in both conditions.

Times in seconds, speeds in m/s; every parameter is a named field. ``from_population`` draws
one person's parameters (the same in their four trials) from ``POPULATION``'s ranges, so
simulated studies have between-participant spread; the ranges are assumptions, not data.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np


@dataclass
class SimulatedParticipant:
    seed: int
    gain_per_s: float = 2.5
    """Drag speed per metre of remaining offset [1/s]."""
    max_speed_m_s: float = 0.25
    reaction_delay_s: float = 0.25
    """The command follows what the participant saw this long ago."""
    noise_m_s: float = 0.02
    """Standard deviation of the drag's noise, per axis [m/s]."""
    divided_speed_factor: float = 0.9
    """Drag speed factor in divided attention (both conditions)."""
    notice_stop_s: float = 0.3
    """Watching a robot that does not move for this long: the participant sees it is stopped."""
    look_back_s: float = 0.4
    """After the eyes come back from a word, time to re-read the scene before a stop is seen."""
    replan_s: float = 0.5
    """Time to choose a way around once a stop is noticed."""
    detour_angle_deg: float = 70.0
    detour_s: float = 0.5
    colour_response_s: float = 0.8
    """Mean answer time (each drawn uniformly in [0.7, 1.4] x this) [s]."""
    colour_error_rate: float = 0.08
    colour_miss_rate: float = 0.03
    colour_miss_rate_stuck: float = 0.4
    """Probability to drop a word shown or pending while dealing with a stuck robot."""
    _seen: deque = field(default_factory=deque, repr=False)
    _still_watched_s: float = 0.0
    _replan_until: float = -1.0
    _detour_until: float = -1.0
    _detour_sign: float = 1.0
    _eyes_back_s: float = -1.0
    _pending: tuple | None = None
    _last_t_s: float = 0.0
    _believed_p_m: np.ndarray | None = None
    _believed_target_m: np.ndarray | None = None
    _last_command_t_s: float = 0.0
    _last_v_m_s: np.ndarray | None = None

    def __post_init__(self):
        self.rng = np.random.default_rng(self.seed)

    @classmethod
    def from_population(cls, person_seed: int, trial_seed: int) -> "SimulatedParticipant":
        """One person (parameters drawn from ``POPULATION`` with ``person_seed``) in one trial
        (drag noise and colour answers drawn with ``trial_seed``)."""
        rng = np.random.default_rng(person_seed)
        drawn = {name: float(rng.uniform(low, high)) for name, (low, high) in POPULATION.items()}
        return cls(seed=trial_seed, **drawn)

    # ---- what the participant sees -------------------------------------------------------
    def eyes_on_robot(self, t_s: float) -> bool:
        return t_s >= self._eyes_back_s

    def dealing_with_stop(self, t_s: float) -> bool:
        """Noticed the robot stopped and choosing a way around it."""
        return t_s < self._replan_until

    def observe(self, t_s: float, moving: bool) -> None:
        """The robot moved (or not) during the step ending at ``t_s``."""
        dt_s = max(t_s - self._last_t_s, 0.0)
        self._last_t_s = t_s
        if moving:
            self._still_watched_s = 0.0
            return
        if t_s < self._eyes_back_s + self.look_back_s or self.dealing_with_stop(t_s) or t_s < self._detour_until:
            return
        self._still_watched_s += dt_s
        if self._still_watched_s >= self.notice_stop_s:
            self._still_watched_s = 0.0
            self._replan_until = t_s + self.replan_s
            self._detour_until = self._replan_until + self.detour_s
            self._detour_sign = float(self.rng.choice([-1.0, 1.0]))
            if self._pending is not None and self.rng.uniform() < self.colour_miss_rate_stuck:
                self._pending = None  # the pending word is dropped
                self._eyes_back_s = t_s

    # ---- the drag ------------------------------------------------------------------------
    def command(self, t_s: float, p_m: np.ndarray, target_m: np.ndarray, divided: bool) -> np.ndarray:
        """The drag velocity [m/s] (dim of ``p_m``) at time ``t_s``."""
        p_m, target_m = np.asarray(p_m, dtype=float), np.asarray(target_m, dtype=float)
        dt_s = max(t_s - self._last_command_t_s, 0.0)
        self._last_command_t_s = t_s
        if self.eyes_on_robot(t_s):
            self._seen.append((t_s, target_m - p_m))
            self._believed_p_m = None
            while len(self._seen) > 1 and self._seen[1][0] <= t_s - self.reaction_delay_s:
                self._seen.popleft()
            offset = self._seen[0][1]
        else:  # eyes on the word: the robot is believed to follow the drag
            if self._believed_p_m is None:
                self._believed_p_m, self._believed_target_m = p_m.copy(), target_m.copy()
            elif self._last_v_m_s is not None:
                self._believed_p_m = self._believed_p_m + self._last_v_m_s * dt_s
            offset = self._believed_target_m - self._believed_p_m
        v = self.gain_per_s * offset
        speed = float(np.linalg.norm(v))
        limit = self.max_speed_m_s * (self.divided_speed_factor if divided else 1.0)
        if speed > limit:
            v = v * limit / speed
        if self.dealing_with_stop(t_s):
            v = v.copy()  # still pushing the same way while deciding
        elif t_s < self._detour_until:
            angle = self._detour_sign * np.radians(self.detour_angle_deg)
            c, s = np.cos(angle), np.sin(angle)
            v = v.copy()
            v[0], v[1] = c * v[0] - s * v[1], s * v[0] + c * v[1]
        self._last_v_m_s = v
        return v + self.noise_m_s * self.rng.normal(size=v.shape)

    # ---- the colour task -----------------------------------------------------------------
    def colour_shown(self, t_s: float, ink: str, colours: tuple[str, ...]) -> None:
        """A word appears: decide to answer (eyes leave the robot until then) or to miss it."""
        miss = self.colour_miss_rate_stuck if self.dealing_with_stop(t_s) else self.colour_miss_rate
        if self.rng.uniform() < miss:
            self._pending = None
            return
        delay = self.colour_response_s * self.rng.uniform(0.7, 1.4)
        answer = ink
        if self.rng.uniform() < self.colour_error_rate:
            answer = str(self.rng.choice([c for c in colours if c != ink]))
        self._pending = (t_s + delay, answer)
        self._eyes_back_s = t_s + delay

    def colour_response(self, t_s: float) -> str | None:
        """The answer given at ``t_s`` (at most once per word), or None."""
        if self._pending is not None and t_s >= self._pending[0]:
            answer, self._pending = self._pending[1], None
            return answer
        return None


#: Uniform ranges of the per-person parameters for ``SimulatedParticipant.from_population``.
POPULATION: dict[str, tuple[float, float]] = {
    "max_speed_m_s": (0.20, 0.30),
    "reaction_delay_s": (0.15, 0.35),
    "notice_stop_s": (0.2, 0.5),
    "look_back_s": (0.25, 0.55),
    "replan_s": (0.3, 0.8),
    "colour_response_s": (0.6, 1.0),
    "divided_speed_factor": (0.8, 1.0),
}
