"""A joint approaching its limit vanishingly slowly while another joint moves: the step must
stay finite (it raised ZeroDivisionError before ``limitation_bounds.AT_REST``)."""

from __future__ import annotations

import numpy as np
import pytest

from cobotsafety.arm.controller import ArmController

DT_S = 1.0 / 275.0
#: A state an iiwa hand drag reached (drag-turns, seed 563, 275 Hz, with a braking variant of the
#: filter): joint a1 creeping toward its upper limit at 5.4e-312 rad/s, joint a6 moving at
#: -2.7e-4 rad/s, the arm otherwise at rest. Layout of ``ArmController._state_f``: q (7), qdot
#: (7), qddot (7), the hand's previous velocity (3) and acceleration (3).
Q = [0.66571908169063476, 1.0259750871999724, -0.26844875870872004, -1.1409916868175967, -1.7231816906070963,
     2.0931778584765910, 0.89250982238266752]
QDDOT = [9.6423584449005340e-08, 9.6423580089261697e-08, -1.1343950995127614e-07, -8.5079654042829421e-08,
         -1.4747143433056538e-07, -7.5547308272871760e-02, -1.5314332528359282e-07]
HAND = [3.2906606528548821e-05, -3.9141972621448140e-06, -9.9998032007664328e-06, 9.0492855955859319e-03,
        -1.0763721321541131e-03, -2.7499946865169878e-03]
V = [0.03519439154564835, 0.1591163746344487, -0.1895872731143137]


@pytest.mark.parametrize("speed", [5e-324, 5.4e-312, 5.4e-250, 5.4e-200, 5.4e-150, 5.4e-104, 5.4e-100, 5.4e-60,
                                   5.4e-20])
def test_a_joint_creeping_toward_its_limit_keeps_the_step_finite(speed):
    c = ArmController("iiwa")
    qdot = np.zeros(7)
    qdot[0] = speed  # [rad/s], toward joint a1's upper limit
    qdot[5] = -2.7471804151348039e-04
    c._state_f[:] = np.concatenate([Q, qdot, QDDOT, HAND])
    c.step(np.array(V), DT_S, "anticipative")
    assert np.all(np.isfinite(c.state.q)) and np.all(np.isfinite(c._state_f))
