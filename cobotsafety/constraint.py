"""The constraint interface shared by every limitation (planar, 3D arm, human).

A constraint is a tiny object with one job: given the robot state, the desired command and the
control period, return its half-spaces ``normals @ v >= bounds`` on the Cartesian command, or
``None`` when it is inactive. The filter (``cobotsafety.filter``) stacks them and projects; it
knows nothing about what produced them.

Sign convention: a limitation has a signed distance ``d`` [m] (or [rad] for joints) that is
positive on the allowed side, and ``normal`` is the gradient of ``d`` with respect to the
commanded Cartesian position, so ``normal @ v`` is the rate at which ``d`` changes [m/s].
"""

from __future__ import annotations

import abc
from typing import Any, NamedTuple, Sequence

import numpy as np


class HalfSpaces(NamedTuple):
    """Linear constraints ``normals @ v >= bounds`` on a velocity command."""

    normals: np.ndarray
    """Shape (m, n). Row i points into the allowed side of constraint i."""
    bounds: np.ndarray
    """Shape (m,). Same unit as ``normals @ v`` (usually [m/s])."""
    names: tuple[str, ...]
    """One name per row, shown to users ("joint 2 lower", "zone F1", ...)."""

    @property
    def inactive(self) -> bool:
        return self.bounds.shape[0] == 0

    @staticmethod
    def empty(n: int) -> "HalfSpaces":
        return HalfSpaces(np.zeros((0, n)), np.zeros(0), ())

    @staticmethod
    def single(normal: np.ndarray, bound: float, name: str) -> "HalfSpaces":
        return HalfSpaces(np.asarray(normal, dtype=float)[None, :], np.array([float(bound)]), (name,))

    @staticmethod
    def stack(parts: Sequence["HalfSpaces | None"], n: int) -> "HalfSpaces":
        """Concatenate the active parts (``None`` entries are skipped)."""
        active = [p for p in parts if p is not None and not p.inactive]
        if not active:
            return HalfSpaces.empty(n)
        return HalfSpaces(
            np.vstack([p.normals for p in active]),
            np.concatenate([p.bounds for p in active]),
            tuple(name for p in active for name in p.names),
        )


class Constraint(abc.ABC):
    """One limitation. Subclasses are small frozen dataclasses with named, unit-carrying fields."""

    name: str

    @abc.abstractmethod
    def halfspaces(self, state: Any, v_desired: np.ndarray, dt_s: float) -> HalfSpaces | None:
        """Return this limitation's half-spaces on the Cartesian command, or None if inactive.

        Args:
            state: the robot state (kinematics already updated for this step).
            v_desired: Shape (n,), the user's desired command [m/s] (used by the damped zone).
            dt_s: control period [s] (used so one integration step cannot cross the limit).
        """

    def distance(self, state: Any) -> float | np.ndarray:
        """Signed distance(s) to the limitation, positive where allowed [m or rad].

        Used by tests (finite differences of the normal) and by the integrator's final check.
        """
        raise NotImplementedError


def approach_bound(distance: float, dt_s: float, v_normal_desired: float = 0.0,
                   damping_width: float = 0.0) -> float:
    """Lower bound on ``normal @ v`` for a limitation at signed ``distance``.

    Combines three rules:

    * Discrete-time guarantee: with ``d >= 0``, one step of ``dt_s`` may close at most the
      remaining gap, ``normal @ v >= -d / dt_s`` (mink's collision damper with gain 1).
    * Recovery: with ``d < 0`` (already inside the limitation) only motions that do not deepen
      the violation are allowed, ``normal @ v >= 0``.
    * Damped zone of paper 1, III.C.1: within ``damping_width`` of the limit the allowed approach
      speed shrinks in proportion to the distance, from the desired normal speed at the zone's
      outer edge to zero at the limit. ``damping_width = 0`` is the hard limitation.

    Args:
        distance: signed distance to the limit [m] (or [rad]), positive on the allowed side.
        dt_s: control period [s], > 0.
        v_normal_desired: ``normal @ v_desired`` [m/s]; only its approaching part (< 0) matters.
        damping_width: width of the damped zone, same unit as ``distance``.
    """
    if distance <= 0.0:
        return 0.0
    bound = -distance / dt_s
    if damping_width > 0.0 and distance < damping_width and v_normal_desired < 0.0:
        bound = max(bound, (distance / damping_width) * v_normal_desired)
    return bound
