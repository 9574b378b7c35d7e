"""The comparison methods of paper 1's experiments.

* ``stop`` (the "standard implementation", section IV) lives in ``step.step``: zero velocity
  whenever the command would reach a limitation within the step.
* ``reactive``: a virtual spring-damper per limitation (section I, refs [12], [15]): inside a
  repulsion zone of width ``zone_width_m`` the command gets ``(k * penetration - c * d_dot) n``
  added, ``penetration = zone_width - d``. Stiff springs keep the zone thin but, as the paper
  says, they fight each other where limitations meet.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from cobotsafety.planar.rr_arm import Kinematics
from cobotsafety.planar.limitations import PlanarLimitation


@dataclass(frozen=True)
class ReactiveParams:
    """Spring-damper repulsion: stiffness [1/s] (m/s per m of penetration), damping [-]."""

    stiffness_per_s: float = 60.0
    damping: float = 0.5
    zone_width_m: float = 0.04
    zone_width_rad: float = 0.15


def reactive_command(limitations: Sequence[PlanarLimitation], params: ReactiveParams, max_speed_m_s: float,
                     kin: Kinematics, vx: float, vy: float, theta_dot_1: float,
                     theta_dot_2: float) -> tuple[float, float, tuple[str, ...]]:
    """Desired command [m/s] plus the repulsion of every limitation whose zone it is in; the
    damper uses the joint rates of the last step [rad/s]. Output capped at 2 ``max_speed_m_s``."""
    # Velocity of the end-effector over the last step, for the damper.
    last_vx = kin.j11 * theta_dot_1 + kin.j12 * theta_dot_2
    last_vy = kin.j21 * theta_dot_1 + kin.j22 * theta_dot_2
    out_x, out_y = vx, vy
    pushing = []
    for limitation in limitations:
        for distance, gx, gy, name, angular in limitation.measures(kin):
            norm = math.hypot(gx, gy)
            if norm < 1e-12:
                continue
            width = params.zone_width_rad if angular else params.zone_width_m
            if distance >= width:
                continue
            nx, ny = gx / norm, gy / norm
            # Penetration of the repulsion zone, in metres along the normal.
            penetration = (width - distance) / norm
            rate = nx * last_vx + ny * last_vy
            push = params.stiffness_per_s * penetration - params.damping * rate
            if push > 0.0:
                out_x += push * nx
                out_y += push * ny
                pushing.append(name)
    speed = math.hypot(out_x, out_y)
    limit = 2.0 * max_speed_m_s
    if speed > limit:
        out_x, out_y = out_x * limit / speed, out_y * limit / speed
    return out_x, out_y, tuple(pushing)
