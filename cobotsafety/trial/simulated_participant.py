"""A scripted participant for planning trials (how many people a study needs), not evidence.

Every number is a named parameter of ``participant_parameters.PARAMETERS`` with its source
(paper, calibrated to the paper, or assumption); ``cobotsafety trial --vary`` measures how the
study's outcome depends on each. The model:

* **Drag.** A saturated proportional drag toward the point aimed at (the next way point of the
  route, else the target), following what was seen ``reaction_delay_s`` ago, with noise. In
  divided attention the drag is ``divided_speed_factor`` slower in both conditions (calibrated
  on the paper's sliding times, where no stop has to be handled). General practice speeds the
  drag up as ``(trials done + 1) ** practice_exponent``.
* **Eyes.** While answering a colour word the eyes are on the word: the hand drags on toward
  where the robot is believed to be going (dead reckoning) and what the robot does is unseen.
* **A stopped robot.** A robot that does not follow the drag is noticed after
  ``notice_stop_s`` of watching it (after ``look_back_s`` to re-read the scene when the eyes
  come back from a word). Then the participant replans (``replan_s``) and drives round: the
  drag turned by ``detour_angle_deg`` for ``detour_s``, to a side drawn at random the first
  time (the other side, turned ``RETRY_TURN_DEG`` further, if that failed).
* **Learning the limits.** Where the robot stopped, the participant remembers the place and the
  point the detour reached (a way point of that route), for all their later trials: a known
  limit is met with the side known and the replanning and detour shortened as
  ``(encounters + 1) ** -limit_learning_exponent``, and the route is driven through its way
  points. A way point passed without a stop moves ``via_tighten`` of the way back toward the
  limit next time: detours shrink with practice (under sliding, where the robot never stops,
  they fade away). The participant does not know the condition, so what was learned under stop
  carries over to sliding (a real carry-over the order check is there to see).
* **Load.** Paper 1's hypothesis (IV.B) is that without sliding the user must attend to the
  robot's configuration. Here the participant is loaded while handling a stopped robot (from
  noticing it until the way round is driven) and while steering round a remembered limit
  (within ``VIGILANCE_M`` of it, its way point still ahead, until the robot is seen sliding along
  a limit in this trial: then the participant knows this robot does not stop there): a colour word shown then is missed with ``load_miss_rate``
  instead of ``colour_miss_rate``, and its answer takes ``load_rt_slowdown`` longer.

Times in seconds, speeds in m/s, positions in metres (the robot's base frame).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from cobotsafety.trial.participant_parameters import PARAMETERS, population

#: A stop within this distance of a remembered one is the same limit [m].
SAME_PLACE_M = 0.06
#: A way point counts as passed within this distance [m].
VIA_REACHED_M = 0.03
#: A detour that moved the robot less than this did not free it [m].
FREED_M = 0.01
#: Each failed detour in a row turns the next one this much further [deg], up to ``MAX_TURN_DEG``.
RETRY_TURN_DEG = 30.0
MAX_TURN_DEG = 160.0
#: A way point the robot has come no closer to for this long is given up for this trial [s].
GIVE_UP_S = 1.5
#: Steering round a remembered limit loads the participant within this distance of it [m].
VIGILANCE_M = 0.10
#: The robot counts as following the drag above this speed [m/s] (the session's "moving").
MOVING_M_S = 1e-3


@dataclass
class Via:
    """A remembered limit on one route: where the robot stopped and a point reached round it."""

    stuck_m: np.ndarray
    """Shape (dim,), where the robot stopped [m]."""
    via_m: np.ndarray
    """Shape (dim,), the way point aimed at next time [m]."""
    encounters: int = 1
    """Stops met at this place so far."""


@dataclass
class Experience:
    """What one person learned, kept across their trials (``simulate`` passes it on)."""

    routes: dict[int, list[Via]] = field(default_factory=dict)
    trials_done: int = 0

    def nearest(self, route: int, p_m: np.ndarray) -> Via | None:
        """The remembered limit of ``route`` within ``SAME_PLACE_M`` of ``p_m``, if any."""
        best, best_d = None, SAME_PLACE_M
        for via in self.routes.get(route, []):
            d = float(np.linalg.norm(via.stuck_m - p_m))
            if d <= best_d:
                best, best_d = via, d
        return best


@dataclass
class TrialDiagnostics:
    """What the model did in one trial (logged with simulated records as ``model``)."""

    stops_noticed: int = 0
    known_stops: int = 0
    """Stops at a limit met before (in this or an earlier trial)."""
    still_s: float = 0.0
    """Time the robot did not follow a non-zero drag [s]."""
    detour_s: float = 0.0
    """Time spent replanning and driving round [s]."""
    loaded_words: int = 0
    """Colour words shown while handling a stopped robot or steering round a remembered limit."""

    def as_json(self) -> dict:
        return {k: (round(v, 3) if isinstance(v, float) else v) for k, v in self.__dict__.items()}


def _p(name: str) -> float:
    return PARAMETERS[name].default


@dataclass
class SimulatedParticipant:
    seed: int
    experience: Experience = field(default_factory=Experience)
    max_speed_m_s: float = _p("max_speed_m_s")
    gain_per_s: float = _p("gain_per_s")
    reaction_delay_s: float = _p("reaction_delay_s")
    noise_m_s: float = _p("noise_m_s")
    divided_speed_factor: float = _p("divided_speed_factor")
    practice_exponent: float = _p("practice_exponent")
    notice_stop_s: float = _p("notice_stop_s")
    look_back_s: float = _p("look_back_s")
    replan_s: float = _p("replan_s")
    detour_angle_deg: float = _p("detour_angle_deg")
    detour_s: float = _p("detour_s")
    limit_learning_exponent: float = _p("limit_learning_exponent")
    memory_noise_m: float = _p("memory_noise_m")
    via_tighten: float = _p("via_tighten")
    colour_response_s: float = _p("colour_response_s")
    colour_error_rate: float = _p("colour_error_rate")
    colour_miss_rate: float = _p("colour_miss_rate")
    load_miss_rate: float = _p("load_miss_rate")
    load_rt_slowdown: float = _p("load_rt_slowdown")
    diagnostics: TrialDiagnostics = field(default_factory=TrialDiagnostics)

    def __post_init__(self):
        self.rng = np.random.default_rng(self.seed)
        self._seen: deque = deque()
        self._still_watched_s = 0.0
        self._still_s = 0.0
        self._replan_until = -1.0
        self._detour_until = -1.0
        self._detour_sign = 1.0
        self._stuck_at: np.ndarray | None = None
        self._stuck_via: Via | None = None
        self._failed_sign: dict[int, float] = {}
        self._eyes_back_s = -1.0
        self._pending: tuple | None = None
        self._last_t_s = 0.0
        self._believed_p_m: np.ndarray | None = None
        self._believed_aim_m: np.ndarray | None = None
        self._last_command_t_s = 0.0
        self._last_v_m_s: np.ndarray | None = None
        self._p_m: np.ndarray | None = None
        self._route: int | None = None
        self._passed: list[Via] = []
        self._stopped_on_leg = False
        self._recall: dict[int, np.ndarray] = {}
        self._seen_sliding = False
        self._failures = 0
        self._aim_via: Via | None = None
        self._aim_best_m = math.inf
        self._aim_best_t_s = 0.0

    @classmethod
    def from_population(cls, person_seed: int, trial_seed: int, experience: Experience | None = None,
                        overrides: dict[str, tuple[float, float]] | None = None) -> "SimulatedParticipant":
        """One person (every parameter drawn uniformly in its range with ``person_seed``; ranges
        from ``PARAMETERS`` with ``overrides`` applied) in one trial (drag noise and colour answers
        drawn with ``trial_seed``), carrying ``experience`` from their earlier trials."""
        rng = np.random.default_rng(person_seed)
        drawn = {name: float(rng.uniform(low, high)) for name, (low, high) in population(overrides).items()}
        return cls(seed=trial_seed, experience=experience or Experience(), **drawn)

    def finish_trial(self) -> None:
        """The trial is over: it counts as practice for the next one."""
        self.experience.trials_done += 1

    # ---- what the participant sees -------------------------------------------------------
    def eyes_on_robot(self, t_s: float) -> bool:
        return t_s >= self._eyes_back_s

    def dealing_with_stop(self, t_s: float) -> bool:
        """Noticed the robot stopped and choosing or driving a way round it."""
        return t_s < self._detour_until

    def steering_round_a_limit(self) -> bool:
        """Within ``VIGILANCE_M`` of a remembered limit whose way point is still ahead."""
        if self._route is None or self._p_m is None or self._seen_sliding:
            return False
        return any(not any(via is done for done in self._passed)
                   and float(np.linalg.norm(self._p_m - via.stuck_m)) <= VIGILANCE_M
                   for via in self.experience.routes.get(self._route, []))

    def loaded(self, t_s: float) -> bool:
        """Attending to the robot's limits (the load of paper 1's hypothesis)."""
        return self.dealing_with_stop(t_s) or self.steering_round_a_limit()

    def _practice(self, encounters: int) -> float:
        return (encounters + 1.0) ** -self.limit_learning_exponent

    def observe(self, t_s: float, moving: bool, slid: bool = False) -> None:
        """The robot moved (or not) during the step ending at ``t_s``; ``slid``: it moved along
        a limitation instead of where it was dragged (seen only with the eyes on the robot)."""
        dt_s = max(t_s - self._last_t_s, 0.0)
        if slid and self.eyes_on_robot(t_s):
            self._seen_sliding = True
        self._last_t_s = t_s
        commanded = self._last_v_m_s is not None and float(np.linalg.norm(self._last_v_m_s)) > MOVING_M_S
        if not moving and commanded:
            self.diagnostics.still_s += dt_s
        if self._detour_until > 0.0 and t_s >= self._detour_until:
            self._end_detour()
        if moving:
            self._still_watched_s = 0.0
            return
        if t_s < self._eyes_back_s + self.look_back_s or self.dealing_with_stop(t_s) or not commanded:
            return
        self._still_watched_s += dt_s
        if self._still_watched_s >= self.notice_stop_s:
            self._notice_stop(t_s)

    def _notice_stop(self, t_s: float) -> None:
        self._still_watched_s = 0.0
        self._stopped_on_leg = True
        p = self._p_m.copy()
        route = self._route if self._route is not None else -1
        via = self.experience.nearest(route, p)
        encounters = via.encounters if via is not None else 0
        practice = self._practice(encounters)
        self._replan_until = t_s + self.replan_s * practice
        self._detour_until = self._replan_until + self.detour_s * practice
        if via is not None and route not in self._failed_sign:
            self._detour_sign = self._side(via)
        elif route in self._failed_sign:
            self._detour_sign = -self._failed_sign.pop(route)
        else:
            self._detour_sign = float(self.rng.choice([-1.0, 1.0]))
        self._stuck_at, self._stuck_via = p, via
        self.diagnostics.stops_noticed += 1
        self.diagnostics.known_stops += via is not None
        self.diagnostics.detour_s += self._detour_until - t_s

    def _side(self, via: Via) -> float:
        """The side (+1: counter-clockwise of the way to the target) on which the way round was found."""
        heading = self._target_m[:2] - via.stuck_m[:2]
        out = via.via_m[:2] - via.stuck_m[:2]
        cross = heading[0] * out[1] - heading[1] * out[0]
        return 1.0 if cross >= 0.0 else -1.0

    def _end_detour(self) -> None:
        self._detour_until = -1.0
        if self._stuck_at is None or self._p_m is None:
            return
        route = self._route if self._route is not None else -1
        if float(np.linalg.norm(self._p_m - self._stuck_at)) < FREED_M:
            self._failed_sign[route] = self._detour_sign  # try the other side next time
            self._failures += 1  # and turn further
            return
        self._failures = 0
        if self._stuck_via is not None:
            self._stuck_via.via_m = self._p_m.copy()
            self._stuck_via.encounters += 1
        else:  # a new limit on the way to the point aimed at: a way point before it
            vias = self.experience.routes.setdefault(route, [])
            ahead = [i for i, via in enumerate(vias) if not any(via is done for done in self._passed)]
            vias.insert(ahead[0] if ahead else len(vias), Via(self._stuck_at.copy(), self._p_m.copy()))
        self._stuck_at, self._stuck_via = None, None

    # ---- the route -----------------------------------------------------------------------
    def _start_route(self, route: int) -> None:
        self._route = route
        self._passed = []
        self._stopped_on_leg = False

    def _aim_point(self) -> np.ndarray:
        """The next way point of the route not yet passed, else the target."""
        for via in self.experience.routes.get(self._route, []):
            if not any(via is done for done in self._passed):
                return self._recalled(via)
        return self._target_m

    def _recalled(self, via: Via) -> np.ndarray:
        """Where this trial's participant remembers ``via`` (off by ``memory_noise_m`` per axis,
        drawn once per trial and way point)."""
        if id(via) not in self._recall:
            offset = np.zeros_like(via.via_m)
            offset[:2] = self.memory_noise_m * self.rng.normal(size=2)
            self._recall[id(via)] = offset
        return via.via_m + self._recall[id(via)]

    def _update_route(self, t_s: float, p_m: np.ndarray) -> None:
        for via in self.experience.routes.get(self._route, []):
            if any(via is done for done in self._passed):
                continue
            distance = float(np.linalg.norm(p_m - self._recalled(via)))
            if via is not self._aim_via:
                self._aim_via, self._aim_best_m, self._aim_best_t_s = via, distance, t_s
            elif distance < self._aim_best_m - FREED_M:
                self._aim_best_m, self._aim_best_t_s = distance, t_s
            if distance <= VIA_REACHED_M:
                self._passed.append(via)
                if not self._stopped_on_leg:  # passed cleanly: cut closer next time
                    via.via_m = via.stuck_m + (via.via_m - via.stuck_m) * (1.0 - self.via_tighten)
                self._stopped_on_leg = False
            elif t_s - self._aim_best_t_s > GIVE_UP_S and not self.dealing_with_stop(t_s):
                self._passed.append(via)  # cannot get there (e.g. recalled out of reach): drop it this time
            break

    # ---- the drag ------------------------------------------------------------------------
    def command(self, t_s: float, p_m: np.ndarray, target_m: np.ndarray, divided: bool,
                route: int | None = None) -> np.ndarray:
        """The drag velocity [m/s] (dim of ``p_m``) at time ``t_s`` toward ``target_m`` on
        ``route`` (the index of the target; None: no route memory)."""
        p_m, target_m = np.asarray(p_m, dtype=float), np.asarray(target_m, dtype=float)
        self._p_m = p_m
        self._target_m = target_m
        if route != self._route:
            self._start_route(route)
        if route is not None:
            self._update_route(t_s, p_m)
        aim = self._aim_point() if route is not None else target_m
        dt_s = max(t_s - self._last_command_t_s, 0.0)
        self._last_command_t_s = t_s
        if self.eyes_on_robot(t_s):
            self._seen.append((t_s, aim - p_m))
            self._believed_p_m = None
            while len(self._seen) > 1 and self._seen[1][0] <= t_s - self.reaction_delay_s:
                self._seen.popleft()
            offset = self._seen[0][1]
        else:  # eyes on the word: the robot is believed to follow the drag
            if self._believed_p_m is None:
                self._believed_p_m, self._believed_aim_m = p_m.copy(), aim.copy()
            elif self._last_v_m_s is not None:
                self._believed_p_m = self._believed_p_m + self._last_v_m_s * dt_s
            offset = self._believed_aim_m - self._believed_p_m
        v = self.gain_per_s * offset
        speed = float(np.linalg.norm(v))
        limit = self.max_speed_m_s * (self.divided_speed_factor if divided else 1.0)
        limit *= (self.experience.trials_done + 1.0) ** self.practice_exponent
        if speed > limit:
            v = v * (limit / speed)
        if self._replan_until <= t_s < self._detour_until:
            turn_deg = min(self.detour_angle_deg + RETRY_TURN_DEG * self._failures, MAX_TURN_DEG)
            angle = self._detour_sign * np.radians(turn_deg)
            c, s = np.cos(angle), np.sin(angle)
            v = v.copy()
            v[0], v[1] = c * v[0] - s * v[1], s * v[0] + c * v[1]
        self._last_v_m_s = v
        return v + self.noise_m_s * self.rng.normal(size=v.shape)

    # ---- the colour task -----------------------------------------------------------------
    def colour_shown(self, t_s: float, ink: str, colours: tuple[str, ...]) -> None:
        """A word appears: decide to answer (eyes leave the robot until then) or to miss it."""
        loaded = self.loaded(t_s)
        self.diagnostics.loaded_words += loaded
        if self.rng.uniform() < (self.load_miss_rate if loaded else self.colour_miss_rate):
            self._pending = None
            return
        delay = self.colour_response_s * self.rng.uniform(0.7, 1.4) * (1.0 + self.load_rt_slowdown * loaded)
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
