"""How fast a limitation may be approached: the speed from which the arm can still stop before it.

A limitation at gap ``g`` (its distance minus the filter's buffer) [m or rad] may be approached
at speed ``v`` only if braking stops within ``g``. Braking is modelled as a real arm's
controller does it, under an acceleration limit ``a`` and a jerk limit ``j`` along the
limitation's normal, in discrete time steps ``dt``: in the worst case the arm is accelerating
toward the limitation at ``+a`` when it decides to brake, ramps its acceleration down to ``-a``
at the jerk limit (``2 a / j``; its speed rises by ``a^2 / 2j`` and falls back), then brakes at
``-a``. The distance covered is at most::

    D(v) = v^2 / 2a + v (2a / j + dt / 2) + (2/3) a^3 / j^2 + a dt^2

(the ramp's travel, the braking's ``v^2 / 2a``, and the discrete steps' excess: each step holds
its velocity for ``dt``). ``braking_speed`` is the largest ``v`` with ``D(v) <= g``, and at most
``g / dt`` (one step closes at most the gap). This is the viability bound of Del Prete ("Joint
position and velocity bounds in discrete-time acceleration/torque control of robot
manipulators", RA-L 2018), ``qdot >= -sqrt(2 a (q - q_min))`` in its discrete-time form,
extended by the jerk ramp; ``tests/test_arm_braking.py`` simulates the braking from random
states and checks it stops before the limitation.

The same bound serves every limitation: for a joint ``a`` and ``j`` are its own limits times the
braking share; for a Cartesian limitation (zones, table, reach, the human) they are what the
joints can give along its normal ``n`` (``share * sum_i |n_i| a_i``), at most the
end-effector's own limits; for a human the approach speed is the robot's plus the human's.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def braking_distance(speed, decel, jerk, dt_s):  # pragma: no cover - compiled
    """``D(v)`` above [m or rad]: the longest braking from ``speed`` >= 0."""
    tau = 2.0 * decel / jerk + 0.5 * dt_s
    return speed * speed / (2.0 * decel) + speed * tau + (2.0 / 3.0) * decel ** 3 / (jerk * jerk) + decel * dt_s * dt_s


@numba.njit(cache=True)
def braking_speed(gap, decel, jerk, dt_s):  # pragma: no cover - compiled
    """The fastest approach [m/s or rad/s] at ``gap`` [m or rad] from which braking at ``decel``
    with jerk ``jerk`` stops before the limitation (``D(v) <= gap``, and ``v <= gap / dt``);
    0 when even that is impossible. ``decel``, ``jerk`` > 0."""
    if gap <= 0.0:
        return 0.0
    tau = 2.0 * decel / jerk + 0.5 * dt_s
    room = gap - (2.0 / 3.0) * decel ** 3 / (jerk * jerk) - decel * dt_s * dt_s
    if room <= 0.0:
        return 0.0
    at = decel * tau
    speed = -at + np.sqrt(at * at + 2.0 * decel * room)
    return min(speed, gap / dt_s)
