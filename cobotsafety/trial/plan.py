"""Session plans: every participant does every condition in both attention modes, with the
condition order and the attention order counterbalanced, and the analysis declared up front.

Conditions are the methods under test (``anticipative`` = sliding, ``stop`` = the standard
implementation; optionally ``reactive``). A participant does both conditions in one attention
mode, then both in the other, in the same condition order. Sequences (condition order x
attention order) are dealt in shuffled blocks (seeded): within each half-block every condition
order appears once and the attention order alternates, so any even number of participants is
balanced on both factors (the paper did full attention first for everyone; counterbalancing
separates the attention effect from practice).

``write_plan(directory, plan, seed)`` writes ``plan.json`` before the first trial: the trial
order and ``ANALYSIS``, the pre-declared primary outcome, secondaries and checks that
``comparisons.compare_all`` runs (the report quotes it, with the time it was written).
"""

from __future__ import annotations

import itertools
import json
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

ATTENTION_MODES = ("full", "divided")
PLAN_NAME = "plan.json"

#: The analysis declared before any data (written into ``plan.json``).
ANALYSIS = {
    "primary": {
        "outcome": "completion time [s], sliding (anticipative) vs stop, in each attention mode",
        "tests": ["wilcoxon signed-rank one-tailed (paired; the design is within-participant)",
                  "mann-whitney one-tailed (independent groups, as paper 1 reported it)"],
        "tail": "less (sliding - stop < 0: sliding faster)",
        "alpha": 0.05,
        "correction": "Holm over the two attention modes, per test",
    },
    "secondary": {
        "outcomes": ["error score [points] (paper's scoring), each attention mode",
                     "colour errors per scored word (missed + wrong), divided attention",
                     "attention interaction on log completion time: log(divided / full), sliding vs stop",
                     "divided - full completion time [s] (paper 1's IV.B comparison, absolute seconds)",
                     "median colour response time [s], divided attention"],
        "correction": "Holm over the secondary outcomes, per test",
        "supporting": "linear mixed model of log completion time: condition x attention x period fixed, "
                      "participant random intercept (statsmodels MixedLM, REML); the condition x attention "
                      "term is the interaction",
    },
    "checks": {
        "order": "sliding advantage (stop - sliding time) of sliding-first vs stop-first participants, "
                 "two-sided Mann-Whitney, per attention mode; reported with its power for a 10 % learning "
                 "effect (a participant's second trial of a mode 10 % faster); a p >= 0.05 is 'not detected'",
    },
    "p_values": "exact where scipy or a full permutation can give them (no ties: scipy's exact "
                "distribution; ties: every permutation), else the normal approximation, stated per p",
}


@dataclass(frozen=True)
class PlannedTrial:
    participant: str
    attention: str
    condition: str
    order: int
    """1-based position of the trial in the participant's session."""


def condition_orders(participants: list[str], conditions: tuple[str, ...], seed: int) -> dict[str, tuple[str, ...]]:
    """Counterbalanced condition order per participant (each permutation equally often)."""
    return {p: sequence[0] for p, sequence in sequences(participants, conditions, seed).items()}


def sequences(participants: list[str], conditions: tuple[str, ...], seed: int
              ) -> dict[str, tuple[tuple[str, ...], tuple[str, ...]]]:
    """``{participant: (condition order, attention order)}``, dealt in balanced shuffled blocks."""
    permutations = list(itertools.permutations(conditions))
    rng = np.random.default_rng(seed)
    dealt: list[tuple[tuple[str, ...], tuple[str, ...]]] = []
    while len(dealt) < len(participants):
        shuffled = [permutations[i] for i in rng.permutation(len(permutations))]
        first = ATTENTION_MODES if rng.uniform() < 0.5 else ATTENTION_MODES[::-1]
        other = first[::-1]
        for half in (0, 1):
            for i, order in enumerate(shuffled):
                dealt.append((order, first if (i + half) % 2 == 0 else other))
    return dict(zip(participants, dealt))


def session_plan(participants: list[str], conditions: tuple[str, ...] = ("anticipative", "stop"),
                 seed: int = 0) -> list[PlannedTrial]:
    if len(set(participants)) != len(participants):
        raise ValueError("participant ids must be unique")
    dealt = sequences(participants, conditions, seed)
    plan = []
    for participant in participants:
        condition_order, attention_order = dealt[participant]
        k = 0
        for attention in attention_order:
            for condition in condition_order:
                k += 1
                plan.append(PlannedTrial(participant, attention, condition, k))
    return plan


def write_plan(directory: Path, plan: list[PlannedTrial], seed: int, **extra) -> Path:
    """Write ``plan.json`` (atomically) unless it exists; return its path. An existing plan is
    kept (a resumed session keeps what was declared before its first trial)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / PLAN_NAME
    if path.exists():
        return path
    body = {"written_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "seed": seed,
            "analysis": ANALYSIS, "trials": [asdict(t) for t in plan], **extra}
    tmp = path.with_suffix(".json.tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(body, f, indent=1)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    return path


def read_plan(directory: Path) -> dict | None:
    """The ``plan.json`` of ``directory``, or None when there is none (older logs)."""
    path = Path(directory) / PLAN_NAME
    if not path.exists():
        return None
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return None
