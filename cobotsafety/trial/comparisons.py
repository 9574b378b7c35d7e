"""Every comparison the plan declares (``plan.ANALYSIS``), in one list, Holm-adjusted within its
family: the rank tests of ``statistics`` and the mixed model of ``mixed_model``."""

from __future__ import annotations

from cobotsafety.trial.mixed_model import interaction_model
from cobotsafety.trial.statistics import (ABS_INTERACTION, LOG_INTERACTION, PER_WORD, RESPONSE, SCORE, TIME, Result,
                                          _both, _interaction, by_participant, completion, errors_per_word, holm,
                                          median_response, order_effect, score)


def compare_all(records: list[dict], with_ci: bool = True, order_power: bool = True) -> list[Result]:
    """Every declared comparison (``plan.ANALYSIS``), Holm-adjusted within its family."""
    t = by_participant(records)
    results: list[Result] = []
    for attention in ("full", "divided"):
        results += _both(f"{attention} attention: {TIME}", t, attention, completion, "less", with_ci, "primary")
    for attention in ("full", "divided"):
        results += _both(f"{attention} attention: {SCORE}", t, attention, score, "greater", with_ci, "secondary")
    results += _both(f"divided attention: {PER_WORD}", t, "divided", errors_per_word, "less", with_ci, "secondary")
    results += _interaction(LOG_INTERACTION, t, True, with_ci)
    results += _interaction(ABS_INTERACTION, t, False, with_ci)
    results += _both(f"divided attention: {RESPONSE}", t, "divided", median_response, "less", with_ci, "secondary")
    results.append(interaction_model(records))
    for attention in ("full", "divided"):
        results.append(order_effect(t, attention, with_ci, order_power))
    return holm(results)


