"""A scripted participant: drags toward the next target with human-like noise and reaction
delay, and answers the colour task with a set error rate and response time."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np


@dataclass
class SimulatedParticipant:
    seed: int
    gain_per_s: float = 2.5
    max_speed_m_s: float = 0.25
    reaction_delay_s: float = 0.25
    """The command follows what the participant saw this long ago."""
    noise_m_s: float = 0.02
    colour_error_rate: float = 0.1
    colour_miss_rate: float = 0.05
    colour_response_s: float = 0.8
    divided_slowdown: float = 0.7
    """Speed factor while attention is divided."""
    stuck_after_s: float = 0.6
    """When the robot has not moved for this long, try a detour (rotate the drag 70 degrees)."""
    detour_s: float = 0.5
    _seen: deque = field(default_factory=deque, repr=False)
    _still_since: float | None = None
    _detour_until: float = -1.0
    _detour_sign: float = 1.0

    def __post_init__(self):
        self.rng = np.random.default_rng(self.seed)

    def observe(self, t_s: float, moving: bool) -> None:
        """Tell the participant whether the robot moved; a robot that stays stopped while being
        dragged makes them try a detour, as people do with a robot that halts at a limit."""
        if moving:
            self._still_since = None
        elif self._still_since is None:
            self._still_since = t_s
        elif t_s - self._still_since > self.stuck_after_s and t_s > self._detour_until:
            self._detour_until = t_s + self.detour_s
            self._detour_sign = float(self.rng.choice([-1.0, 1.0]))
            self._still_since = None

    def command(self, t_s: float, p_m: np.ndarray, target_m: np.ndarray, divided: bool) -> np.ndarray:
        """The drag velocity [m/s] (dim of ``p_m``) at time ``t_s``."""
        self._seen.append((t_s, np.asarray(target_m) - np.asarray(p_m)))
        while len(self._seen) > 1 and self._seen[1][0] <= t_s - self.reaction_delay_s:
            self._seen.popleft()
        offset = self._seen[0][1]
        v = self.gain_per_s * offset
        speed = np.linalg.norm(v)
        limit = self.max_speed_m_s * (self.divided_slowdown if divided else 1.0)
        if speed > limit:
            v = v * limit / speed
        if t_s < self._detour_until:
            angle = self._detour_sign * np.radians(70.0)
            c, s = np.cos(angle), np.sin(angle)
            v = v.copy()
            v[0], v[1] = c * v[0] - s * v[1], s * v[0] + c * v[1]
        return v + self.noise_m_s * self.rng.normal(size=v.shape)

    def colour_answer(self, ink: str, colours: tuple[str, ...]) -> tuple[str | None, float]:
        """(answer or None when missed, response time [s])."""
        if self.rng.uniform() < self.colour_miss_rate:
            return None, 0.0
        delay = self.colour_response_s * self.rng.uniform(0.7, 1.4)
        if self.rng.uniform() < self.colour_error_rate:
            return str(self.rng.choice([c for c in colours if c != ink])), delay
        return ink, delay
