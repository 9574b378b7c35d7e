"""``ArmStepReport``: what one arm step did, read from that step's output buffers when asked.

It carries the ``StepReport`` fields (``cobotsafety.teleoperated``) under the same names, but a
1 kHz loop reads few of them: each is made from the step's buffers (``step_kernel.output_layout``,
the row codes) the first time it is read, so a step costs no more than what its caller reads.
Every step writes new buffers: a report never changes once made.
"""

from __future__ import annotations

import math

import numpy as np

from cobotsafety.arm.step_kernel import (I_BINDING, I_EVADING, I_HAND_OVER, I_MOTION_COUNT, I_PROTECTIVE, OUT_I_HEADER,
                                         decode_row)


class ArmStepReport:
    """A ``StepReport`` of one ``ArmController`` step (read-only attributes)."""

    __slots__ = ("_out_f", "_out_i", "_o", "_name", "_binding", "_motion", "v_desired_m_s", "stopped", "reason",
                 "contradictions", "safety_over_smoothness", "safety_over_smoothness_steps", "human_status",
                 "_previous_f")

    @property
    def protective_stop(self) -> bool:
        """ISO/TS 15066's protective stop held (braked) the arm this step."""
        return bool(self._out_i[I_PROTECTIVE])

    @property
    def evading(self) -> bool:
        """The anticipative command carried paper 2's repulsion from a person this step
        (``FilterSettings.evasion_gain``): the arm was moving out of their way."""
        return bool(self._out_i[I_EVADING])

    @property
    def hand_over_limit(self) -> bool:
        """The end-effector's executed path (its positions' backward differences, as
        ``experiments.motion_ratios`` measures a run) went over the robot's end-effector
        acceleration or jerk limit this step: the filter bounds ``J qddot``, and the path's
        curvature (a body turning fast in the hand's null space) took more than the tenth of the
        limit left for it. Reported, not prevented (``hand_limit_ratios``)."""
        return bool(self._out_i[I_HAND_OVER])

    @property
    def hand_limit_ratios(self) -> tuple[float, float]:
        """The end-effector's executed acceleration and jerk this step, each norm over the
        robot's end-effector limit (1 = the limit)."""
        o = self._o[19]
        return float(self._out_f[o]), float(self._out_f[o + 1])

    def __init__(self, out_f, out_i, offsets, name, v_desired_m_s, stopped, reason, contradictions, smoothness,
                 smoothness_steps, human_status, previous_f):
        self._out_f, self._out_i, self._o, self._name = out_f, out_i, offsets, name
        self._binding = self._motion = None
        self.v_desired_m_s = v_desired_m_s
        """Shape (3,), the user's command as received [m/s]."""
        self.stopped = stopped
        self.reason = reason
        self.contradictions = contradictions
        self.safety_over_smoothness = smoothness
        self.safety_over_smoothness_steps = smoothness_steps
        self.human_status = human_status
        self._previous_f = previous_f  # the previous step's out_f (the hand before the step)

    def _part(self, i: int) -> np.ndarray:
        return self._out_f[self._o[i]:self._o[i + 1]]

    @property
    def v_commanded_m_s(self) -> np.ndarray:
        """Shape (3,): the end-effector velocity the filter commanded (``J qdot``) [m/s]."""
        return self._part(7)

    @property
    def v_executed_m_s(self) -> np.ndarray:
        """Shape (3,): the end-effector's displacement over the step divided by the period [m/s]."""
        return self._part(8)

    @property
    def p_base_ee_m(self) -> np.ndarray:
        return self._part(2)

    def _codes(self) -> list[int]:
        n_binding, n_motion = int(self._out_i[I_BINDING]), int(self._out_i[I_MOTION_COUNT])
        return self._out_i[OUT_I_HEADER:OUT_I_HEADER + n_binding + n_motion].tolist(), n_binding

    @property
    def binding(self) -> tuple[str, ...]:
        """The limitations the command slides on (or that stopped it)."""
        if self._binding is None:
            codes, n_binding = self._codes()
            self._binding = tuple(dict.fromkeys(self._name(code) for code in codes[:n_binding]))
        return self._binding

    @property
    def binding_owners(self) -> frozenset[int]:
        """Who owns ``binding``'s rows: each limitation's index in ``ArmController.limitations``
        (0 the joint limits, the last the human), or a negative ``step_kernel.OWNER_*`` (the
        robot's speed cap and joint speed limits)."""
        codes, n_binding = self._codes()
        return frozenset(decode_row(code)[0] for code in codes[:n_binding])

    @property
    def motion_limited(self) -> tuple[str, ...]:
        """The joints or the end-effector whose acceleration or jerk limit shaped the command."""
        if self._motion is None:
            codes, n_binding = self._codes()
            self._motion = tuple(dict.fromkeys(self._name(code) for code in codes[n_binding:]))
        return self._motion

    @property
    def min_distance_m(self) -> float | None:
        """The minimum robot-human capsule distance after the step [m] (None without a human)."""
        d = float(self._out_f[self._o[9]])
        return d if math.isfinite(d) else None

    @property
    def p_robot_closest_m(self) -> np.ndarray | None:
        return self._part(10) if self.min_distance_m is not None else None

    @property
    def p_human_closest_m(self) -> np.ndarray | None:
        return self._part(11) if self.min_distance_m is not None else None

    @property
    def extras(self) -> dict:
        """Diagnostics: the safety net's scale, the joint velocity commanded, the filter's level,
        the factor by which a safety bound exceeded the motion limits, the hand before the step."""
        o = self._out_f
        return {"net_scale": float(o[self._o[12]]), "qdot": self._part(1), "level": int(self._out_i[1]),
                "brake_factor": float(o[self._o[15]]), "p_before_m": self._previous_f[self._o[2]:self._o[3]]}

    @property
    def joint_acceleration_ratio(self) -> float:
        """This step's largest joint acceleration over that joint's limit (1 = the limit)."""
        return float(self._out_f[self._o[16]])

    def __repr__(self) -> str:
        return (f"ArmStepReport(p_base_ee_m={self.p_base_ee_m}, v_commanded_m_s={self.v_commanded_m_s}, "
                f"binding={self.binding}, stopped={self.stopped}, reason={self.reason!r})")
