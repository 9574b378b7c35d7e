"""Session plans: every participant does every condition; orders counterbalanced.

Conditions are the methods under test (``anticipative`` = sliding, ``stop`` = the standard
implementation; optionally ``reactive``). Orders cycle through all permutations (a balanced
Latin square for two conditions: AB, BA, AB, ...), shuffled in blocks with a recorded seed so
the assignment is random but balanced. Full attention comes first, then divided, as in the
paper.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

ATTENTION_MODES = ("full", "divided")


@dataclass(frozen=True)
class PlannedTrial:
    participant: str
    attention: str
    condition: str
    order: int
    """1-based position of the trial in the participant's session."""


def condition_orders(participants: list[str], conditions: tuple[str, ...], seed: int) -> dict[str, tuple[str, ...]]:
    """Counterbalanced condition order per participant (each permutation equally often)."""
    permutations = list(itertools.permutations(conditions))
    rng = np.random.default_rng(seed)
    orders: dict[str, tuple[str, ...]] = {}
    for block_start in range(0, len(participants), len(permutations)):
        block = participants[block_start:block_start + len(permutations)]
        shuffled = [permutations[i] for i in rng.permutation(len(permutations))]
        for participant, order in zip(block, shuffled):
            orders[participant] = order
    return orders


def session_plan(participants: list[str], conditions: tuple[str, ...] = ("anticipative", "stop"),
                 seed: int = 0) -> list[PlannedTrial]:
    if len(set(participants)) != len(participants):
        raise ValueError("participant ids must be unique")
    orders = condition_orders(participants, conditions, seed)
    plan = []
    for participant in participants:
        k = 0
        for attention in ATTENTION_MODES:
            for condition in orders[participant]:
                k += 1
                plan.append(PlannedTrial(participant, attention, condition, k))
    return plan
