"""The packed fast path of the 3D arm step: flat arrays once, one compiled call per step.

``cobotsafety.arm.step.step`` (with the constraint classes and ``slide``) is the readable spec;
``PackedArm.step`` computes the same step: the robot (joint placements, axes, limits, capsule
attachments) is packed when the ``PackedArm`` is made, the constraints when their list changes
(``pack``; the caller's cache key decides), the human's capsules are read from the
``HumanCapsulesConstraint`` every step (``set_human`` replaces its arrays). One numba call
(``packed_kernel.packed_step``) then does the kinematics, the mapping, every measure row, the
half-spaces, the projection, the integration and the safety net's re-check. Names are made for
the binding rows only (the step info's half-space names are built when read).

What it does not handle goes to the reference ``step``, counted in ``fallbacks``: a box zone
touched or penetrated, a step the safety net would bisect, the ``reactive`` and ``off``
methods, and constraint types it does not know. ``tests/test_arm_packed.py`` holds the two
equal on random states of every robot.
"""

from __future__ import annotations

import logging
import math
import operator
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from cobotsafety.arm.constraints import ArmConstraint, JointPositionLimits, ReachLimits, TablePlane, ZoneConstraint
from cobotsafety.arm.packed_kernel import (METHOD_ANTICIPATIVE, METHOD_STOP, STATUS_BOX_TOUCHED, STATUS_CONTRADICTION,
                                           STATUS_DONE, packed_step, tag_of)
from cobotsafety.arm.packed_kinematics import JOINT_CODES, joint_axis_local
from cobotsafety.arm.packed_projection import RELAX_HARD_CONTRADICT, RELAX_STAGE_INFEASIBLE
from cobotsafety.arm.packed_measures import BOX, CAPSULE, HALFSPACE, HUMAN, JOINT, REACH, TABLE
from cobotsafety.arm.robot_state import RobotState
from cobotsafety.arm.step import ArmParams, ArmStepInfo, step, task_axes
from cobotsafety.arm.zones import BoxZone, CapsuleZone, HalfSpaceZone
from cobotsafety.constraint import HalfSpaces
from cobotsafety.control.human_constraint import HumanCapsulesConstraint

logger = logging.getLogger(__name__)

STATUS_SINGULAR = -1
_REASONS = {STATUS_BOX_TOUCHED: "box zone touched", STATUS_CONTRADICTION: "limits contradict",
            STATUS_SINGULAR: "singular active set"}
_EMPTY, _EYE3 = np.zeros(0), np.eye(3)
_METHODS = {"anticipative": METHOD_ANTICIPATIVE, "stop": METHOD_STOP}
_HUMAN_ARRAYS = ("p0", "p1", "radius", "v0", "v1")
_FLOAT = np.dtype(float)


def _is_vector3(a) -> bool:
    """``a`` is already what ``np.asarray(a, dtype=float).reshape(-1)`` makes of a 3-vector."""
    return type(a) is np.ndarray and a.shape == (3,) and a.dtype == _FLOAT


def _contradiction_reason(detail: np.ndarray) -> str:
    """``step.step``'s reason when the relaxation itself failed, from the kernel's ``detail``
    (the message of the ``InfeasibleConstraintsError`` that ``projection.relax`` raises)."""
    status, rows, advance, stopped = detail.tolist()
    if status == RELAX_HARD_CONTRADICT:
        error = f"the {int(rows)} hard half-spaces contradict each other"
    elif status == RELAX_STAGE_INFEASIBLE:
        error = (f"no velocity satisfies the {int(rows)} half-spaces at once "
                 f"(largest required advance {advance:.3g}); the bounds contradict each other")
    else:
        error = "the relaxation did not meet its hard rows (ill-conditioned rows)"
    return f"limits contradict ({error}): " + ("stopped" if stopped else "approaching nothing")


def params_vector(params: ArmParams) -> np.ndarray:
    """The ``ArmParams`` fields the kernel reads, in its order."""
    return np.array([params.max_speed_m_s, params.damping_width_m, params.damping_width_rad, params.activation_m,
                     params.w_threshold, params.damping_max, params.orientation_gain_per_s,
                     params.centering_gain_per_s, params.velocity_limit_scale, params.buffer_m, params.buffer_rad,
                     params.recovery_gain_per_s, params.max_accel_m_s2], dtype=float)


@dataclass(frozen=True)
class ConstraintPack:
    """The constraints as flat arrays (``packed_measures`` says what each kind holds)."""

    constraints_list: list
    constraints: tuple
    kinds: np.ndarray
    reals: np.ndarray
    ints: np.ndarray
    before_start: np.ndarray
    max_rows: int
    humans: tuple


class _RowNames(Sequence):
    """The names of packed half-space rows, each made when read."""

    def __init__(self, namer, tags: np.ndarray):
        self._namer, self._tags = namer, tags

    def __len__(self) -> int:
        return len(self._tags)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return tuple(self[j] for j in range(*i.indices(len(self))))
        return self._namer(self._tags[i])

    def __eq__(self, other) -> bool:
        return tuple(self) == tuple(other)

    def __repr__(self) -> str:
        return repr(tuple(self))


class PackedArm:
    """The robot of ``state`` packed once; ``step`` is ``arm.step.step`` on the fast path."""

    def __init__(self, state: RobotState):
        model = state.model
        nj = model.njoints
        self.supported = all(model.joints[j].shortname() in JOINT_CODES for j in range(1, nj))
        self.fallbacks: Counter = Counter()
        """Steps handed to the reference ``step``, by reason (rare geometry, unknown
        constraints, other methods)."""
        self.steps = 0
        if not self.supported:
            return
        self.jtype = np.array([0] + [JOINT_CODES[model.joints[j].shortname()] for j in range(1, nj)], dtype=np.int64)
        self.axes = np.array([(0.0, 0.0, 1.0)] + [joint_axis_local(model.joints[j]) for j in range(1, nj)])
        self.parent = np.array([model.parents[j] for j in range(nj)], dtype=np.int64)
        self.idx_q = np.array([model.joints[j].idx_q if j else 0 for j in range(nj)], dtype=np.int64)
        self.idx_v = np.array([model.joints[j].idx_v if j else 0 for j in range(nj)], dtype=np.int64)
        self.placement_R = np.array([model.jointPlacements[j].rotation for j in range(nj)])
        self.placement_t = np.array([model.jointPlacements[j].translation for j in range(nj)])
        self.support = np.zeros((nj, nj), dtype=np.bool_)
        for k in range(1, nj):
            i = k
            while i > 0:
                self.support[k, i] = True
                i = model.parents[i]
        frame = model.frames[state.ee_frame_id]
        self.robot_int = np.array([model.nv, frame.parentJoint], dtype=np.int64)
        self.ee_R = np.ascontiguousarray(frame.placement.rotation)
        self.ee_t = np.ascontiguousarray(frame.placement.translation)
        self.lower, self.upper = state.lower.copy(), state.upper.copy()
        self.limited = np.ascontiguousarray(state.limited_v, dtype=np.int64)
        self.vlim = np.ascontiguousarray(model.velocityLimit, dtype=float)
        self.k = len(task_axes(state))
        self._state = state
        self._pack: ConstraintPack | None = None
        self._params: tuple | None = None
        self._human: tuple | None = None
        self._names: tuple | None = None
        self._no_previous = np.zeros(self.k)
        self._pack_capsules()

    def _pack_capsules(self) -> None:
        """The robot's capsule attachments (again after ``RobotState.use_capsules``)."""
        state = self._state
        self._capsules = state.capsules
        self.cap_joint = np.array(state.capsule_joint_ids, dtype=np.int64)
        self.cap_p0l = np.ascontiguousarray(state.capsule_p0_local, dtype=float)
        self.cap_p1l = np.ascontiguousarray(state.capsule_p1_local, dtype=float)
        self.radius = np.ascontiguousarray(state.capsule_radius, dtype=float)
        self._robot_i, self._robot_f = self.robot_buffers()
        self._pack = None

    def robot_buffers(self) -> tuple[np.ndarray, np.ndarray]:
        """The robot's arrays in two flat buffers, int64 and float64 (``packed_kernel.unpack_robot``
        reads them): a header (joints, nq, nv, end-effector joint, capsules, limited joints),
        then every array in a fixed order."""
        nj = len(self.jtype)
        header = [nj, len(self.lower), int(self.robot_int[0]), int(self.robot_int[1]), len(self.cap_joint),
                  len(self.limited)]
        robot_i = np.concatenate([np.array(header, dtype=np.int64), self.jtype, self.parent, self.idx_q, self.idx_v,
                                  self.support.astype(np.int64).ravel(), self.cap_joint,
                                  self.limited.astype(np.int64).ravel()]).astype(np.int64)
        floats = (self.axes, self.placement_R, self.placement_t, self.ee_R, self.ee_t, self.cap_p0l, self.cap_p1l,
                  self.radius, self.lower, self.upper, self.vlim)
        robot_f = np.concatenate([a.ravel() for a in floats]).astype(float)
        return np.ascontiguousarray(robot_i), np.ascontiguousarray(robot_f)

    def packed(self, constraints: list[ArmConstraint]) -> ConstraintPack | None:
        """``pack(constraints)``, made again only when the list object or the capsules change."""
        if self._state.capsules is not self._capsules:
            self._pack_capsules()
        if self._pack is None or self._pack.constraints_list is not constraints:
            self._pack = self.pack(constraints)
        return self._pack

    # ---- packing ------------------------------------------------------------------------------
    def pack(self, constraints: list[ArmConstraint]) -> ConstraintPack | None:
        """Flat arrays of ``constraints`` (None if one of them is of a kind the kernel lacks)."""
        state = self._state
        n_caps = len(state.capsules)
        kinds, reals, ints, sizes, rows, humans = [], [], [], [], 0, []
        for con in constraints:
            real = np.zeros(12)
            skip = 0
            if type(con) is JointPositionLimits:
                kind, size = JOINT, 2 * len(self.limited)
            elif type(con) is ReachLimits:
                kind, size = REACH, 2
                real[0:3], real[3], real[4] = con.shoulder, con.inner_m, con.outer_m
            elif type(con) is TablePlane:
                kind, skip = TABLE, con.skip_capsules
                real[0] = con.height_m
                size = n_caps - skip
            elif type(con) is ZoneConstraint:
                zone, skip = con.zone, con.skip_capsules
                size = n_caps - skip
                if type(zone) is BoxZone:
                    kind = BOX
                    centre, sphere_r = zone.bounding_sphere()
                    real[0:3], real[3:6], real[6] = centre, zone.half_size, sphere_r
                elif isinstance(zone, CapsuleZone) and hasattr(zone, "p0") and type(zone).capsule_distances is CapsuleZone.capsule_distances:
                    kind = CAPSULE
                    real[0:3], real[3:6], real[6] = zone.p0, zone.p1, zone.radius_m
                elif type(zone) is HalfSpaceZone:
                    kind = HALFSPACE
                    n = np.asarray(zone.normal, dtype=float)
                    real[0:3], real[3:6] = zone.point, n / np.linalg.norm(n)
                else:
                    return None
            elif type(con) is HumanCapsulesConstraint:
                kind, skip = HUMAN, con.skip_capsules
                real[0], real[1] = con.critical_m, con.activation_m
                humans.append(con)
                size = 0  # sized per step (the human's capsule count changes)
            else:
                return None
            if skip > n_caps:
                return None
            kinds.append(kind)
            reals.append(real)
            ints.append([skip, 0, 0])
            sizes.append(size)
        return ConstraintPack(constraints, tuple(constraints), np.array(kinds, dtype=np.int64), np.array(reals).reshape(-1, 12),
                              np.array(ints, dtype=np.int64).reshape(-1, 3), np.array(sizes, dtype=np.int64),
                              0, tuple(humans))

    def _human_arrays(self, pack: ConstraintPack):
        """The human capsules of every human constraint, concatenated, and the layout: ints
        (per-constraint human ranges), before_start (offsets of each constraint's distances),
        the row bound. Remade only when a human constraint's arrays are replaced (``set_human``)."""
        arrays = [getattr(con, a) for con in pack.humans for a in _HUMAN_ARRAYS]
        cached = self._human
        if cached is not None and cached[0] is pack and all(map(operator.is_, arrays, cached[1])):
            return cached[2]
        counts = tuple(len(con.radius) for con in pack.humans)
        ints, sizes = pack.ints.copy(), pack.before_start.copy()
        first, h = 0, 0
        n_caps = len(self._state.capsules)
        for i, kind in enumerate(pack.kinds):
            if kind == HUMAN:
                ints[i, 1], ints[i, 2] = first, counts[h]
                sizes[i] = (n_caps - ints[i, 0]) * counts[h]
                first += counts[h]
                h += 1
        before_start = np.zeros(len(sizes) + 1, dtype=np.int64)
        np.cumsum(sizes, out=before_start[1:])
        max_rows = int(before_start[-1]) + 2 * len(self.limited) + 2
        # One flat buffer (``packed_kernel.unpack_human``): p0, p1, radius, v0, v1 of every capsule.
        human = np.concatenate([np.asarray(getattr(con, a), dtype=float).ravel() for a in _HUMAN_ARRAYS
                                for con in pack.humans] or [_EMPTY])
        layout = (ints, before_start, int(before_start[-1]), max_rows, np.ascontiguousarray(human))
        self._human = (pack, arrays, layout)
        return layout

    # ---- names ----------------------------------------------------------------------------------
    def _namer(self, pack: ConstraintPack):
        """The row-name function of ``pack`` (made once per pack) and its memo of names by tag code."""
        if self._names is not None and self._names[0] is pack:
            return self._names[1], self._names[2]
        name = self._make_namer(pack)
        self._names = (pack, name, {})
        return name, self._names[2]

    def _make_namer(self, pack: ConstraintPack):
        state = self._state
        nv, k = state.nv, self.k
        axes = "xyz"[:k]
        vel_names = (tuple(f"velocity {i}" for i in range(2 * nv)) + tuple(f"speed +{a}" for a in axes)
                     + tuple(f"speed -{a}" for a in axes))

        def name(tag) -> str:
            con_index, a, b = int(tag[0]), int(tag[1]), int(tag[2])
            if con_index < 0:
                return vel_names[a]
            con, kind = pack.constraints[con_index], pack.kinds[con_index]
            if kind == JOINT:
                return f"{state.limited_names[b]} {('lower', 'upper')[a]}"
            if kind == REACH:
                return f"{con.name} {('inner', 'extended')[a]}"
            if kind == HUMAN:
                return f"human {con.human_names[b]} ({state.capsules[a].name})"
            return f"{con.name} ({state.capsules[a].name})"
        return name

    def _binding_names(self, pack: ConstraintPack, codes: np.ndarray) -> tuple[str, ...]:
        """The names of the binding rows (their tag codes), memoised per pack (a human's names
        are read from the constraint: its memo is cleared when the human's arrays change)."""
        namer, memo = self._namer(pack)
        if pack.humans and memo.get("human") is not self._human:
            memo.clear()
            memo["human"] = self._human
        names = []
        for code in codes.tolist():
            name = memo.get(code)
            if name is None:
                name = memo[code] = namer(tag_of(code))
            names.append(name)
        return tuple(names)

    # ---- the step -----------------------------------------------------------------------------
    def step(self, state: RobotState, v_desired: np.ndarray, dt_s: float, constraints: list[ArmConstraint],
             params: ArmParams, method: str = "anticipative", R_world_ee_ref: np.ndarray | None = None,
             last_qdot: np.ndarray | None = None, v_previous: np.ndarray | None = None) -> ArmStepInfo:
        """``arm.step.step`` on the fast path (same arguments, same result; ``state`` in place).

        The constraints are packed again when ``constraints`` is another list object (keep one
        list while the constraints stay the same, as ``ArmTeleop.constraints`` does).
        """
        self.steps += 1
        pack = self.packed(constraints) if self.supported else None
        if pack is None or method not in _METHODS or state is not self._state:
            reason = ("joint type" if not self.supported else "constraint type" if pack is None
                      else "method" if method not in _METHODS else "another state")
            return self._reference(reason, state, v_desired, dt_s, constraints, params, method, R_world_ee_ref,
                                   last_qdot, v_previous)
        v = v_desired if _is_vector3(v_desired) else np.asarray(v_desired, dtype=float).reshape(-1)
        if v.shape != (3,):
            raise ValueError(f"v_desired must have shape (3,), got {np.shape(v_desired)}")
        if not dt_s > 0:
            raise ValueError(f"dt_s must be positive, got {dt_s}")
        vx, vy, vz = v.tolist()
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        if not math.isfinite(speed):
            return self._reference("non-finite command", state, v_desired, dt_s, constraints, params, method,
                                   R_world_ee_ref, last_qdot, v_previous)
        if speed > params.max_speed_m_s:
            v = v * params.max_speed_m_s / speed  # the reference's rounding
        k = self.k
        vk = v if k == 3 else np.ascontiguousarray(v[:k])
        previous = self._no_previous
        if v_previous is not None:
            given = (v_previous if k == 3 and _is_vector3(v_previous)
                     else np.asarray(v_previous, dtype=float).reshape(-1)[:k])
            if math.isfinite(sum(given.tolist())):
                previous = np.ascontiguousarray(given)
        if self._params is None or self._params[0] is not params:
            self._params = (params, params_vector(params))
        ints, before_start, n_before, max_rows, human_f = self._human_arrays(pack)
        with_orientation = R_world_ee_ref is not None and state.name != "planar"
        R_ref = np.ascontiguousarray(R_world_ee_ref, dtype=float) if with_orientation else _EYE3
        try:
            (status, q_next, qdot, command, stopped, normals, bounds, tags, codes, relaxed_rows, worst_row,
             worst_violation, net_scale, p_ee, R_ee, J6, p0, p1, origins, detail) = packed_step(
                np.ascontiguousarray(state.q, dtype=float), vk, previous, v_previous is not None, float(dt_s),
                _METHODS[method], R_ref, with_orientation, self._robot_i, self._robot_f, float(state.lever_m),
                pack.kinds, pack.reals, ints, before_start, n_before, max_rows, human_f, self._params[1])
        except np.linalg.LinAlgError:  # an active set on dependent rows: the reference says why
            status = STATUS_SINGULAR
        if status != STATUS_DONE:
            return self._reference(_REASONS[status], state, v_desired, dt_s, constraints, params, method,
                                   R_world_ee_ref, last_qdot, v_previous)
        state.set_kinematics(q_next, p_ee, R_ee, J6, p0, p1, origins)
        names = self._binding_names(pack, codes)
        if k == 3:
            command_full = command
        else:
            command_full = np.zeros(3)
            command_full[:k] = command
        reason = ""
        if detail[0]:
            reason = _contradiction_reason(detail)
        elif relaxed_rows:
            reason = (f"retreats contradict: relaxed {relaxed_rows} row(s), "
                      f"at most {worst_violation:.3g} m/s ({self._namer(pack)[0](tags[worst_row])})")
        elif stopped and method == "anticipative":
            reason = "blocked by " + ", ".join(names) if names else "blocked"
        return ArmStepInfo(v, command_full, qdot, names, stopped, net_scale,
                           HalfSpaces(normals, bounds, _RowNames(self._namer(pack)[0], tags)), relaxed_rows > 0, reason)

    def _reference(self, reason: str, *args) -> ArmStepInfo:
        self.fallbacks[reason] += 1
        args[0].update()
        return step(*args)
