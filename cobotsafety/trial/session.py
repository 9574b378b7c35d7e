"""Run one trial on a ``Teleoperated`` robot: course, optional colour task, scoring.

Completion time runs from the first motion to the last target; touching an obstacle scores
-3 and is logged with time and place (once per contact). The colour task runs from the start
to the end of the trial (``TrialRun.tick_colour``); which stimuli count is
``cobotsafety.trial.scoring``'s rule, applied in ``record`` (and again by the analysis).
Headless here (the simulated participant); the browser trial drives the same ``TrialRun``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from cobotsafety.trial.colour_task import COLOURS, ColourTask
from cobotsafety.trial.course import Course
from cobotsafety.trial.scoring import ANSWER_WINDOW_S, error_score, stimulus_scored

OBSTACLE_POINTS = -3


@dataclass
class TrialRun:
    course: Course
    divided: bool
    seed: int
    next_target: int = 0
    started_s: float | None = None
    finished_s: float | None = None
    errors: list = field(default_factory=list)
    trajectory: list = field(default_factory=list)
    _touching: int | None = None

    def __post_init__(self):
        self.colour = ColourTask(self.seed) if self.divided else None

    @property
    def finished(self) -> bool:
        return self.finished_s is not None

    def target(self) -> np.ndarray:
        return np.array(self.course.targets_m[min(self.next_target, len(self.course.targets_m) - 1)])

    def update(self, t_s: float, p_m: np.ndarray, moving: bool) -> None:
        """Advance the trial with the end-effector at ``p_m`` at time ``t_s`` (nothing once finished)."""
        if self.finished:
            return
        if self.started_s is None:
            if not moving:
                return
            self.started_s = t_s
        self.trajectory.append((t_s, *np.asarray(p_m, dtype=float)[:3]))
        touched = self.course.touched(p_m)
        if touched is not None and touched != self._touching:
            self.errors.append({"kind": "obstacle", "t_s": round(t_s - self.started_s, 3),
                                "obstacle": touched, "p_m": [round(float(x), 4) for x in p_m[:2]],
                                "points": OBSTACLE_POINTS})
        self._touching = touched
        if self.course.reached(self.next_target, p_m):
            self.next_target += 1
            if self.next_target == len(self.course.targets_m):
                self.finished_s = t_s

    def tick_colour(self, t_s: float):
        """Run the colour task between the start and the end of the trial; the new stimulus or None."""
        if self.colour is None or self.started_s is None or self.finished:
            return None
        return self.colour.tick(t_s)

    def record(self, participant: str, condition: str, order: int, seed: int, skip_reason: str | None = None) -> dict:
        """The log record; colour errors only for stimuli that count (``scoring``). With
        ``skip_reason`` the trial is logged as skipped (not finished: no completion time, the
        targets reached so far, the reason), and the analysis leaves it out of every test."""
        completion = None if self.finished_s is None else round(self.finished_s - self.started_s, 3)
        colour_errors, response_times, stimuli = [], [], []
        start = self.started_s if self.started_s is not None else 0.0
        for s in (self.colour.stimuli if self.colour is not None else []):
            shown = round(s.shown_s - start, 3)
            scored = stimulus_scored(shown, completion)
            stimuli.append({"shown_s": shown, "word": s.word, "ink": s.ink, "answer": s.answer,
                            "answered_s": None if s.answered_s is None else round(s.answered_s - start, 3),
                            "judged_by": s.judged_by, "scored": scored})
            if not scored:
                continue
            if s.answer is None:
                colour_errors.append({"kind": "missed", "t_s": shown, "points": -2})
            else:
                response_times.append(round(s.answered_s - s.shown_s, 3))
                if not s.correct:
                    colour_errors.append({"kind": "wrong", "t_s": shown, "points": -1})
        record = {
            "participant": participant, "condition": condition,
            "attention": "divided" if self.divided else "full", "order": order, "seed": seed,
            "completion_time_s": completion, "errors": self.errors + colour_errors,
            "response_times_s": response_times, "course": self.course.name,
            "answer_window_s": ANSWER_WINDOW_S, "stimuli": stimuli,
        }
        record["error_score"] = error_score(record)
        if skip_reason is not None:
            record.update({"skipped": True, "skip_reason": skip_reason, "targets_reached": self.next_target,
                           "completion_time_s": None})
        return record


def simulate_trial(robot, course: Course, participant, condition: str, divided: bool, seed: int,
                   dt_s: float = 0.01, timeout_s: float = 120.0) -> tuple[TrialRun, np.ndarray]:
    """Run a whole trial with a ``SimulatedParticipant`` driving ``robot`` under ``condition``."""
    robot.reset()
    run = TrialRun(course, divided, seed)
    t = 0.0
    while t < timeout_s and not run.finished:
        p = robot.p_base_ee_m
        target = run.target()
        if course.height_m is not None:
            goal = np.array([target[0], target[1], course.height_m])
        else:
            goal = target
        v = participant.command(t, p[:robot.dim], goal[:robot.dim], divided, route=run.next_target)
        report = robot.step(v, dt_s, condition)
        t += dt_s
        moving = bool(np.linalg.norm(report.v_executed_m_s) > 1e-3)
        participant.observe(t, moving, slid=moving and bool(report.binding))
        run.update(t, report.p_base_ee_m, moving=moving)
        shown = run.tick_colour(t)
        if shown is not None:
            participant.colour_shown(t, shown.ink, COLOURS)
        if run.colour is not None:
            answer = participant.colour_response(t)
            if answer is not None:
                run.colour.answer(t, answer)
    participant.finish_trial()
    return run, np.array(run.trajectory).reshape(-1, 4)
