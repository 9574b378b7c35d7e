"""The simulated participant's parameters: name, default, per-person range, unit and source.

Every number of the model (``simulated_participant``) is one entry of ``PARAMETERS``, with where
it comes from, so a reader sees which effects come from paper 1 and which from assumptions:

* ``paper``: read off paper 1 (IV.A-B) directly;
* ``calibrated``: chosen so the model reproduces one of the paper's figures (the derivation is
  in ``source``): the model cannot be evidence for that figure;
* ``assumption``: not in the paper; a plausible value, to be varied
  (``cobotsafety trial --simulate N --repeat K --vary NAME=LO:HI``).

Each simulated person draws every parameter once, uniformly in ``[low, high]`` (their four
trials share it); ``low == high`` fixes it. ``population(overrides)`` applies ``--vary``.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Paper 1's divided-attention figures (IV.B) the calibrations use.
PAPER_SLIDING_DIVIDED_TIME_S = 43.2
PAPER_SLIDING_FULL_TIME_S = 31.9
PAPER_SLIDING_DIVIDED_SCORE = -0.9
PAPER_STOP_DIVIDED_TIME_S = 63.4
PAPER_STOP_DIVIDED_SCORE = -4.7
COLOUR_PERIOD_S = 2.0


@dataclass(frozen=True)
class Parameter:
    name: str
    low: float
    high: float
    unit: str
    source: str
    """``paper``, ``calibrated`` or ``assumption``."""
    why: str

    @property
    def default(self) -> float:
        """The middle of the range (what a single ``SimulatedParticipant()`` uses)."""
        return 0.5 * (self.low + self.high)


def _points_per_word(score: float, time_s: float) -> float:
    return -score / (time_s / COLOUR_PERIOD_S)


#: Points lost per colour word with sliding in divided attention (paper: 0.9 points in 43.2 s).
SLIDING_POINTS_PER_WORD = _points_per_word(PAPER_SLIDING_DIVIDED_SCORE, PAPER_SLIDING_DIVIDED_TIME_S)

PARAMETERS: dict[str, Parameter] = {p.name: p for p in (
    # ---- the drag ---------------------------------------------------------------------------
    Parameter("max_speed_m_s", 0.20, 0.30, "m/s", "assumption",
              "drag speed in full attention; the paper's course and speeds are not given"),
    Parameter("gain_per_s", 2.5, 2.5, "1/s", "assumption", "drag speed per metre of remaining offset"),
    Parameter("reaction_delay_s", 0.15, 0.35, "s", "assumption",
              "the drag follows what was seen this long ago (visuomotor delay)"),
    Parameter("noise_m_s", 0.02, 0.02, "m/s", "assumption", "SD of the drag's noise per axis"),
    Parameter("divided_speed_factor", 0.64, 0.84, "-", "calibrated",
              f"drag speed in divided attention, both conditions: the paper's sliding times "
              f"{PAPER_SLIDING_FULL_TIME_S} s (full) and {PAPER_SLIDING_DIVIDED_TIME_S} s (divided) give "
              f"{PAPER_SLIDING_FULL_TIME_S / PAPER_SLIDING_DIVIDED_TIME_S:.2f} (sliding has no stops to handle), +-0.1 "
              "between people"),
    Parameter("practice_exponent", 0.0, 0.2, "-", "assumption",
              "general motor learning: drag speed x (trials done + 1) ** exponent (power law of practice)"),
    # ---- a stopped robot ----------------------------------------------------------------------
    Parameter("notice_stop_s", 0.2, 0.5, "s", "assumption",
              "watching a robot that does not follow the drag this long: it is seen to be stopped"),
    Parameter("look_back_s", 0.25, 0.55, "s", "assumption",
              "after the eyes come back from a colour word, time to re-read the scene"),
    Parameter("replan_s", 0.3, 0.8, "s", "assumption", "first time at a limit: time to choose a way around"),
    Parameter("detour_angle_deg", 70.0, 70.0, "deg", "assumption",
              "first time at a limit: the drag is turned this much to one side (side drawn at random)"),
    Parameter("detour_s", 0.5, 0.5, "s", "assumption", "first time at a limit: how long the turned drag is held"),
    Parameter("limit_learning_exponent", 0.3, 0.7, "-", "assumption",
              "replanning and detours at a known limit shrink as (encounters + 1) ** -exponent "
              "(power law of practice)"),
    Parameter("memory_noise_m", 0.02, 0.04, "m", "assumption",
              "each trial the remembered way points are recalled this far off (SD per axis)"),
    Parameter("via_tighten", 0.3, 0.5, "-", "assumption",
              "a way point passed without a stop moves this fraction closer to the limit next time"),
    # ---- the colour task ----------------------------------------------------------------------
    Parameter("colour_response_s", 0.6, 1.0, "s", "assumption",
              "mean time to answer a word (each drawn in [0.7, 1.4] x this); the paper gives none"),
    Parameter("colour_error_rate", 0.021, 0.021, "-", "calibrated",
              f"wrong answers per word: half of the paper's sliding divided score, "
              f"{SLIDING_POINTS_PER_WORD:.3f} points per word, at 1 point each"),
    Parameter("colour_miss_rate", 0.0105, 0.0105, "-", "calibrated",
              "missed words: the other half of the paper's sliding points per word, at 2 points each"),
    Parameter("load_miss_rate", 0.43, 0.43, "-", "calibrated",
              "probability to miss a word shown while loaded (handling a stopped robot, or steering "
              "round a remembered limit): set so that, in divided attention, stop loses "
              f"{-(PAPER_STOP_DIVIDED_SCORE / (PAPER_STOP_DIVIDED_TIME_S / COLOUR_PERIOD_S)) - SLIDING_POINTS_PER_WORD:.3f} "
              "more points per colour word than sliding, as in the paper (interpolated between 20-person "
              "simulations at 0.3 and 0.6: docs/study_model.md)"),
    Parameter("load_rt_slowdown", 0.25, 0.25, "-", "assumption",
              "answers to words shown while loaded take this fraction longer (the paper gives no response times)"),
)}

SOURCES = ("paper", "calibrated", "assumption")


def population(overrides: dict[str, tuple[float, float]] | None = None) -> dict[str, tuple[float, float]]:
    """``{name: (low, high)}`` of every parameter, with ``overrides`` (``--vary``) applied."""
    ranges = {name: (p.low, p.high) for name, p in PARAMETERS.items()}
    for name, (low, high) in (overrides or {}).items():
        if name not in PARAMETERS:
            raise ValueError(f"unknown participant parameter {name!r}; known: {', '.join(PARAMETERS)}")
        if not low <= high:
            raise ValueError(f"{name}: low {low} must not exceed high {high}")
        ranges[name] = (float(low), float(high))
    return ranges


def parse_vary(text: str) -> tuple[str, float, float]:
    """``"NAME=LO:HI"`` -> ``(name, lo, hi)``; one clear error line otherwise."""
    name, sep, span = text.partition("=")
    low, colon, high = span.partition(":")
    try:
        if not (sep and colon):
            raise ValueError
        lo, hi = float(low), float(high)
    except ValueError:
        raise ValueError(f"--vary {text!r}: expected NAME=LO:HI, e.g. load_miss_rate=0:0.6") from None
    name = name.strip()
    if name not in PARAMETERS:
        raise ValueError(f"--vary {text!r}: unknown parameter {name!r}; known: {', '.join(PARAMETERS)}")
    if not (lo <= hi) or lo != lo or hi != hi:
        raise ValueError(f"--vary {text!r}: LO must not exceed HI")
    return name, lo, hi


def table_markdown() -> str:
    """The parameter table of the report and the docs."""
    lines = ["| parameter | per-person range | unit | source | meaning |", "|---|---|---|---|---|"]
    for p in PARAMETERS.values():
        span = f"{p.low:g}" if p.low == p.high else f"{p.low:g}-{p.high:g}"
        lines.append(f"| `{p.name}` | {span} | {p.unit} | {p.source} | {p.why} |")
    return "\n".join(lines)
