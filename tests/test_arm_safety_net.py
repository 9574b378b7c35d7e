"""The arm's safety net (``step_kernel.safety_net``) called directly: the filter keeps the limits
itself, so in the suite's runs the net never acts; here steps are made that would cross a
limitation or go deeper into one, and the net must scale them to the largest share that does
not (its bisection's resolution), re-checked with the limitations' own distances."""

from __future__ import annotations

import numpy as np
import pytest

from cobotsafety.arm.controller import ArmController
from cobotsafety.arm.limitations import JointPositionLimits
from cobotsafety.arm.limitations.human import unpack_human
from cobotsafety.arm.step_kernel import ANTICIPATIVE, CROSSING_TOLERANCE_M, safety_net
from compiled_arm import compiled_distances, compiled_kinematics

#: The net's bisection halves its bracket 25 times: the share it returns is within this of the
#: largest admissible one.
RESOLUTION = 2.0 ** -24


def _distance_parts(controller: ArmController, q: np.ndarray) -> list[np.ndarray]:
    """Each limitation's distances at ``q``, as the net re-checks them."""
    hum = unpack_human(controller._human_f, 0.0)
    return compiled_distances(controller._scene(), controller.model, compiled_kinematics(controller.model, q)[0], hum)


def _distances(controller: ArmController, q: np.ndarray) -> np.ndarray:
    return np.concatenate(_distance_parts(controller, q))


def _net(controller: ArmController, q: np.ndarray, qdot: np.ndarray, dt_s: float):
    """``(q_next, share executed, distances before)`` of ``safety_net`` for the step ``qdot dt_s``."""
    model, hum = controller.model, unpack_human(controller._human_f, 0.0)
    parts = _distance_parts(controller, q)
    before_start = np.concatenate([[0], np.cumsum([len(p) for p in parts])]).astype(np.int64)
    before = np.concatenate(parts)
    out = safety_net(np.ascontiguousarray(q), np.ascontiguousarray(qdot), dt_s, ANTICIPATIVE, model.robot_i,
                     model.robot_f, controller._scene_i, controller._scene_f, hum, before, before_start, np.zeros(model.nv))
    return out[0], out[-1], before


def _integrated(controller: ArmController, q: np.ndarray, qdot: np.ndarray, dt_s: float) -> np.ndarray:
    return np.asarray(controller.model.integrate(q, qdot * dt_s), dtype=float)


def _admissible(after: np.ndarray, before: np.ndarray) -> bool:
    return bool(np.all(after >= np.minimum(before, 0.0) - CROSSING_TOLERANCE_M))


@pytest.mark.parametrize("robot", ["panda", "iiwa"])
def test_a_step_through_the_table_is_cut_where_the_arm_meets_it(robot):
    """One long step of the hand straight down through the table: the net executes the largest
    share that keeps every limitation, no more and (to its resolution) no less."""
    c = ArmController(robot)
    q = c.state.q.copy()
    J = c.state.J_ee
    qdot = np.linalg.pinv(J) @ np.array([0.0, 0.0, -1.0])  # the hand down at 1 m/s
    dt_s = 2.0 * c.state.p_world_ee[2]  # twice as long as the hand needs to reach the floor
    before = _distances(c, q)
    assert np.all(before >= 0.0)
    assert not _admissible(_distances(c, _integrated(c, q, qdot, dt_s)), before)  # the whole step crosses
    q_next, scale, _ = _net(c, q, qdot, dt_s)
    assert 0.0 < scale < 1.0
    np.testing.assert_allclose(q_next, _integrated(c, q, qdot, scale * dt_s), atol=1e-12)
    assert _admissible(_distances(c, q_next), before)
    assert not _admissible(_distances(c, _integrated(c, q, qdot, (scale + 2 * RESOLUTION) * dt_s)), before)


@pytest.mark.parametrize("robot", ["panda", "iiwa"])
def test_a_step_deeper_into_a_limit_already_crossed_is_not_taken_one_back_out_is(robot):
    """A joint already past its upper limit (a start inside a limitation): a step further in is
    cut to nothing (the net's crossing tolerance), a step back out is taken whole."""
    c = ArmController(robot)
    assert any(isinstance(lim, JointPositionLimits) for lim in c.limitations)
    model = c.model
    (iq, iv) = model.limited[-1]  # the last joint: the wrist, nothing else in its way
    q = c.state.q.copy()
    q[iq] = model.upper[iq] + 0.01
    qdot = np.zeros(model.nv)
    qdot[iv] = 1.0
    q_next, scale, before = _net(c, q, qdot, 0.01)
    assert np.min(before) < 0.0
    assert scale < 1e-6 and q_next[iq] - q[iq] <= CROSSING_TOLERANCE_M  # (deeper by the net's tolerance at most)
    assert _admissible(_distances(c, q_next), before)
    q_back, scale_back, _ = _net(c, q, -qdot, 0.01)
    assert scale_back == 1.0 and q_back[iq] == pytest.approx(q[iq] - 0.01)
