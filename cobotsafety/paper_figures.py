"""The papers' own published figures, in one place for the experiments, plots and reports.

Paper 1 (Campeau-Lecours & Gosselin, IROS 2016) and paper 2 (Safeea & Neto, RCIM 2019);
``../shared/papers/README.md`` lists them with the errata.
"""

from __future__ import annotations

#: Paper 2, section 5: minimum human-robot distance kept [m] and peak end-effector speed
#: while evading [m/s], per experiment.
PAPER_RESULTS: dict[str, tuple[float, float]] = {"exp1": (0.431, 0.355), "exp2": (0.393, 0.548)}
