"""The divided-attention task (paper 1, IV.B): every 2 s a colour word in a conflicting ink.

The participant answers the *ink* colour. Scores: missed -2, wrong -1 (a touched obstacle, -3,
is scored by the course). Response times are logged. Clock-driven and deterministic per seed.

Two ways to answer: on-screen buttons (``answer``: the colour clicked), or aloud as in paper 1,
judged by the operator with Right / Wrong / Missed keys (``judge``: the time of the key press is
logged as the answer time, so response times then include the operator's own reaction).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

COLOURS = ("red", "green", "blue", "yellow")
#: The answer logged for a word judged wrong by the operator (the colour said is not recorded).
OTHER = "other"
VERDICTS = ("right", "wrong", "missed")
MISSED_POINTS = -2
WRONG_POINTS = -1


@dataclass
class Stimulus:
    shown_s: float
    word: str
    ink: str
    answer: str | None = None
    answered_s: float | None = None
    judged_by: str | None = None
    """``"participant"`` (buttons), ``"operator"`` (aloud, judged), or None (no answer yet)."""
    judged_s: float | None = None
    """When the operator marked the word (Missed included) [s]."""

    @property
    def correct(self) -> bool | None:
        return None if self.answer is None else self.answer == self.ink


@dataclass
class ColourTask:
    seed: int
    period_s: float = 2.0
    stimuli: list[Stimulus] = field(default_factory=list)

    def __post_init__(self):
        self._rng = np.random.default_rng(self.seed)

    @property
    def current(self) -> Stimulus | None:
        return self.stimuli[-1] if self.stimuli else None

    def tick(self, t_s: float) -> Stimulus | None:
        """Show a new stimulus when the period has elapsed; return it (or None)."""
        if self.stimuli and t_s < self.stimuli[-1].shown_s + self.period_s:
            return None
        word = str(self._rng.choice(COLOURS))
        ink = str(self._rng.choice([c for c in COLOURS if c != word]))  # always conflicting
        stimulus = Stimulus(t_s, word, ink)
        self.stimuli.append(stimulus)
        return stimulus

    def answer(self, t_s: float, colour: str) -> bool:
        """Record an answer to the current stimulus (the first answer counts)."""
        if colour not in COLOURS:
            raise ValueError(f"colour must be one of {COLOURS}, got {colour!r}")
        s = self.current
        if s is None or s.answer is not None:
            return False
        s.answer, s.answered_s, s.judged_by = colour, t_s, "participant"
        return True

    def judge(self, t_s: float, verdict: str) -> bool:
        """The operator's judgement of the answer said aloud to the current word: ``right``
        (answer = the ink), ``wrong`` (answer = ``OTHER``) or ``missed``; the first one counts."""
        if verdict not in VERDICTS:
            raise ValueError(f"verdict must be one of {VERDICTS}, got {verdict!r}")
        s = self.current
        if s is None or s.judged_by is not None:
            return False
        s.judged_by, s.judged_s = "operator", t_s
        if verdict != "missed":
            s.answer, s.answered_s = (s.ink if verdict == "right" else OTHER), t_s
        return True

    def score(self) -> int:
        """Missed -2, wrong -1 over the stimuli shown so far."""
        return sum(MISSED_POINTS if s.answer is None else (0 if s.correct else WRONG_POINTS) for s in self.stimuli)

    def response_times_s(self) -> list[float]:
        return [s.answered_s - s.shown_s for s in self.stimuli if s.answered_s is not None]
