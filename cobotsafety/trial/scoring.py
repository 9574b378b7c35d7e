"""The error score of one trial (paper 1, IV.B), with the rule for which stimuli count.

Paper 1 scores a missed colour -2, a wrong colour -1 and a touched triangle -3. The colour task
runs from the start of the trial (the first motion, t = 0) to its end (the last target reached,
t = completion time). A stimulus counts only if the participant could answer it inside the
trial: shown at ``0 <= t_s`` and at least ``answer_window_s`` before the end. Stimuli shown
before the start (the browser shows words from the operator's start, logged at negative times)
or in the last answer window are not scored, answered or not. Touched triangles always count.

The rule is applied here, to the logged records, so it scores the simulated sessions and the
browser server's logs alike, old logs included (their colour errors carry ``t_s`` relative to
the start).
"""

from __future__ import annotations

#: A stimulus can be answered until the next one replaces it: the task's period [s].
ANSWER_WINDOW_S = 2.0
COLOUR_KINDS = ("missed", "wrong")


def stimulus_scored(shown_s: float, completion_time_s: float | None,
                    answer_window_s: float = ANSWER_WINDOW_S) -> bool:
    """Whether a stimulus shown at ``shown_s`` [s from the start] counts in the score.

    An unfinished trial (``completion_time_s`` None) scores every stimulus after the start.
    """
    if shown_s < 0.0:
        return False
    return completion_time_s is None or shown_s + answer_window_s <= completion_time_s


def scored_errors(record: dict) -> list[dict]:
    """The record's errors that count: obstacles, and colour errors of scored stimuli."""
    window = float(record.get("answer_window_s", ANSWER_WINDOW_S))
    end = record.get("completion_time_s")
    return [e for e in record.get("errors", [])
            if e.get("kind") not in COLOUR_KINDS or stimulus_scored(float(e["t_s"]), end, window)]


def error_score(record: dict) -> int:
    """Sum of the points of the errors that count (0 or negative)."""
    return int(sum(e["points"] for e in scored_errors(record)))
