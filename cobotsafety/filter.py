"""The sliding filter: stack the constraints' half-spaces, then project the command.

Building (``build``) and solving (``project``) are separate so each can be tested alone.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np

from cobotsafety.constraint import Constraint, HalfSpaces
from cobotsafety.errors import InfeasibleConstraintsError
from cobotsafety.projection import slide

logger = logging.getLogger(__name__)

#: A half-space counts as binding when the filtered command is within this of its bound [m/s].
BINDING_TOLERANCE = 1e-9


@dataclass(frozen=True)
class FilterResult:
    """What the filter did to one command."""

    v_filtered: np.ndarray
    """Shape (n,), the command sent on [m/s]; finite by construction."""
    halfspaces: HalfSpaces
    """All active half-spaces this step."""
    binding: tuple[str, ...]
    """Names of the half-spaces the command slides on (tight at ``v_filtered``)."""
    stopped: bool
    """True when no motion satisfied every limitation (or the command was invalid) and zero was sent."""


def build(constraints: Iterable[Constraint], state: Any, v_desired: np.ndarray, dt_s: float) -> HalfSpaces:
    """Stack every active constraint's half-spaces for this step."""
    n = v_desired.shape[0]
    return HalfSpaces.stack([c.halfspaces(state, v_desired, dt_s) for c in constraints], n)


def project(v_desired: np.ndarray, halfspaces: HalfSpaces) -> FilterResult:
    """Project ``v_desired`` onto the half-spaces; never returns NaN.

    A non-finite desired velocity, non-finite half-spaces or contradictory half-spaces give a
    zero command (``stopped=True``) and a logged warning.
    """
    n = v_desired.shape[0]
    zero = np.zeros(n)
    if not np.all(np.isfinite(v_desired)):
        logger.warning("desired velocity %s is not finite; commanding zero", v_desired)
        return FilterResult(zero, halfspaces, (), True)
    try:
        v = slide(v_desired, halfspaces.normals, halfspaces.bounds)
    except (InfeasibleConstraintsError, ValueError) as error:
        logger.warning("sliding filter stopped the robot: %s", error)
        return FilterResult(zero, halfspaces, halfspaces.names, True)
    slack = halfspaces.normals @ v - halfspaces.bounds
    binding = tuple(name for name, s in zip(halfspaces.names, slack) if s <= BINDING_TOLERANCE)
    stopped = bool(np.any(v_desired != 0.0) and np.all(np.abs(v) <= 1e-12))
    return FilterResult(v, halfspaces, binding, stopped)
