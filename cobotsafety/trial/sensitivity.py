"""Sensitivity of the simulated study to the participant model's parameters (``--vary``).

``sensitivity(N, K, vary)`` runs, for the default population and then for each
``(name, low, high)`` of ``vary`` at ``levels`` values from low to high (every simulated person
given that value, the other parameters drawn as usual), K simulated studies of N participants,
with the same seeds at every level (common random numbers: differences between levels come
from the parameter, not from the draw). Each level reports the power of the declared tests
(Holm-adjusted decisions, ``power.power``), the time saving of sliding in both attention modes
(against paper 1's 20 % and 32 %), the mean error scores in divided attention (paper: -0.9
sliding, -4.7 stop) and the share of stop trials the robot stood still.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cobotsafety.trial.power import PowerRow, power, simulated_studies
from cobotsafety.trial.statistics import LOG_INTERACTION, SCORE, SLIDING, STOP, TIME, WILCOXON

#: The power columns of the table: (header, comparison, test).
COLUMNS = (
    ("full time (W)", f"full attention: {TIME}", WILCOXON),
    ("divided time (W)", f"divided attention: {TIME}", WILCOXON),
    ("divided score (W)", f"divided attention: {SCORE}", WILCOXON),
    ("log interaction (W)", LOG_INTERACTION, WILCOXON),
    ("mixed model", "attention interaction (mixed model)", ""),
)


@dataclass(frozen=True)
class Level:
    parameter: str
    """``"(defaults)"`` for the default population."""
    value: float | None
    power: dict[str, float]
    """Header of ``COLUMNS`` -> share of studies significant."""
    saving_full: float
    saving_divided: float
    score_sliding: float
    score_stop: float
    still_share_stop: float

    def as_json(self) -> dict:
        return {k: (round(v, 4) if isinstance(v, float) else v) for k, v in self.__dict__.items()}


def _level(parameter: str, value, studies: list[list[dict]], alpha: float) -> Level:
    rows: list[PowerRow] = power(iter(studies), alpha)
    share = {}
    for header, comparison, test in COLUMNS:
        row = next((r for r in rows if r.comparison.startswith(comparison) and (not test or r.test == test)), None)
        share[header] = row.power if row is not None else float("nan")
    records = [r for study in studies for r in study if r.get("completion_time_s")]

    def mean(attention, condition, key):
        values = [r[key] if key != "score" else r["error_score"] for r in records
                  if r["attention"] == attention and r["condition"] == condition]
        return float(np.mean(values)) if values else float("nan")

    stops = [r for r in records if r["condition"] == STOP and "model" in r]
    return Level(parameter, value, share,
                 1 - mean("full", SLIDING, "completion_time_s") / mean("full", STOP, "completion_time_s"),
                 1 - mean("divided", SLIDING, "completion_time_s") / mean("divided", STOP, "completion_time_s"),
                 mean("divided", SLIDING, "score"), mean("divided", STOP, "score"),
                 float(np.mean([r["model"]["still_s"] / r["completion_time_s"] for r in stops])) if stops else float("nan"))


def sensitivity(participants: int, repeat: int, vary: list[tuple[str, float, float]], seed: int = 0,
                levels: int = 3, scene: str = "planar", alpha: float = 0.05, baseline: bool = True) -> list[Level]:
    """The default population (if ``baseline``), then each varied parameter at ``levels`` values."""
    out = []
    if baseline:
        out.append(_level("(defaults)", None, list(simulated_studies(participants, repeat, seed, scene)), alpha))
    for name, low, high in vary:
        for value in np.linspace(low, high, levels if high > low else 1):
            studies = list(simulated_studies(participants, repeat, seed, scene, {name: (float(value), float(value))}))
            out.append(_level(name, float(value), studies, alpha))
    return out


def table(levels: list[Level], participants: int, repeat: int) -> str:
    head = [f"Sensitivity: {repeat} simulated studies of {participants} participants per row (same seeds in every "
            "row); power = share of studies significant after Holm; saving = 1 - sliding / stop mean time "
            "(paper 1: 20 % full, 32 % divided); scores in divided attention (paper 1: -0.9 sliding, -4.7 stop).",
            "", "| parameter | value | " + " | ".join(h for h, _, _ in COLUMNS)
            + " | saving full | saving divided | score sliding / stop | stop: robot still |",
            "|---|---|" + "---|" * (len(COLUMNS) + 4)]
    for level in levels:
        value = "-" if level.value is None else f"{level.value:g}"
        cells = " | ".join(f"{100 * level.power[h]:.0f} %" for h, _, _ in COLUMNS)
        head.append(f"| {level.parameter} | {value} | {cells} | {100 * level.saving_full:.0f} % | "
                    f"{100 * level.saving_divided:.0f} % | {level.score_sliding:.1f} / {level.score_stop:.1f} | "
                    f"{100 * level.still_share_stop:.0f} % |")
    return "\n".join(head)
