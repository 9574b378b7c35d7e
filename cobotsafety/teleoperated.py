"""The teleoperation interface shared by the planar and the 3D scenes.

The app, the trial tool and the experiments drive a robot through this protocol only, so the
planar RR arm (``cobotsafety.planar``) and the pinocchio arms (``cobotsafety.arm``) are
interchangeable behind it. Methods are the paper's comparison set:

* ``anticipative``: the sliding filter (paper 1).
* ``stop``: the "standard implementation": zero velocity when a limitation is reached.
* ``reactive``: virtual spring-damper repulsion from each limitation.
* ``off``: no filtering at all (joint limits still clamp the integrator).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, Protocol, runtime_checkable

import numpy as np

Method = Literal["anticipative", "stop", "reactive", "off"]
METHODS: tuple[str, ...] = ("anticipative", "stop", "reactive", "off")


@dataclass(frozen=True)
class StepReport:
    """What one control step did. Vectors are in the robot base frame."""

    v_desired_m_s: np.ndarray
    """Shape (dim,), the user's command as received (after clamping) [m/s]."""
    v_commanded_m_s: np.ndarray
    """Shape (dim,), the command after the method (filter, stop or reactive) [m/s]."""
    v_executed_m_s: np.ndarray
    """Shape (dim,), the end-effector's actual velocity over the step [m/s]."""
    p_base_ee_m: np.ndarray
    """Shape (3,), end-effector position after the step [m] (planar: z = 0)."""
    binding: tuple[str, ...] = ()
    """Names of the limitations the command slides on (or that stopped it)."""
    stopped: bool = False
    """True when the method stopped the robot although the user asked for motion."""
    min_distance_m: float | None = None
    """Minimum human-robot capsule distance, when a human is modelled [m]."""
    extras: dict = field(default_factory=dict)
    """Free-form diagnostics (e.g. per-constraint distances) for plots."""
    reason: str = ""
    """Why the command was stopped or its retreats relaxed ("" when neither)."""
    contradictions: int = 0
    """Steps of this episode (since ``reset``) whose limitations contradicted each other (the
    arm then violated the required retreats as little as it could); logged once per episode."""
    p_robot_closest_m: np.ndarray | None = None
    """Shape (3,): the robot's point of the minimum human distance, on its capsule's surface [m]
    (None without a human)."""
    p_human_closest_m: np.ndarray | None = None
    """Shape (3,): the human's point of the minimum distance, on its capsule's surface [m]."""
    motion_limited: tuple[str, ...] = ()
    """The joints (``"<joint> acceleration"``) or the end-effector (``"end-effector
    acceleration"``) whose acceleration or jerk limit shaped the command this step."""
    safety_over_smoothness: bool = False
    """This step exceeded an acceleration or jerk limit because a limitation needed it."""
    safety_over_smoothness_steps: int = 0
    """Such steps in this episode (since ``reset``)."""
    human_status: str = ""
    """What the controller knows of the human: "" (fresh or none), or why it is being careful
    ("human model 0.12 s old: grown by 0.14 m", "human model 0.6 s old: stopped")."""
    evading: bool = False
    """The command carried a repulsion from a person this step (the arm moving out of their way)."""


@runtime_checkable
class Teleoperated(Protocol):
    """A kinematic robot driven by a Cartesian velocity command."""

    dim: int
    """2 for the planar scene, 3 for the 3D arms."""

    def reset(self) -> None:
        """Return to the home configuration."""

    def step(self, v_desired_m_s: np.ndarray, dt_s: float, method: str = "anticipative") -> StepReport:
        """Filter ``v_desired_m_s`` with ``method``, integrate over ``dt_s``, report."""

    @property
    def p_base_ee_m(self) -> np.ndarray:
        """Shape (3,), the end-effector position now [m]."""
