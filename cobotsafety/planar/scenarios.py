"""Planar scenes: the demo scene with every limitation A-G, and Fig. 9's scenarios a and b.

Positions in metres in the base frame; the base is at the origin.
"""

from __future__ import annotations

from cobotsafety.planar.arm import PlanarArm
from cobotsafety.planar.limitations import (
    CircleKeepIn,
    CircleKeepOut,
    Conditioning,
    Damping,
    JointLimit,
    LinkCircleZone,
    PlanarLimitation,
    PolygonZone,
    RectangleZone,
)
from cobotsafety.planar.step import PlanarScene

#: Fig. 9's start position [m].
FIG9_START_M = (-0.2, 0.03)
#: Fig. 9's target, above the wall of zones [m].
FIG9_TARGET_M = (-0.27, 0.30)
BASE_RADIUS_M = 0.12
INNER_REACH_RADIUS_M = 0.05
EXTENDED_REACH_RADIUS_M = 0.57


def arm_limitations(arm: PlanarArm) -> list[PlanarLimitation]:
    """A, B, C, D, E and the conditioning safeguard (the arm's own limitations)."""
    return [
        CircleKeepOut("A base", BASE_RADIUS_M),
        JointLimit("B joint 2", 2, arm.theta_2_min_rad, arm.theta_2_max_rad),
        CircleKeepOut("C inner reach", INNER_REACH_RADIUS_M),
        JointLimit("D joint 1", 1, arm.theta_1_min_rad, arm.theta_1_max_rad),
        CircleKeepIn("E extended reach", EXTENDED_REACH_RADIUS_M),
        Conditioning(),
    ]


def demo_scene(arm: PlanarArm | None = None) -> PlanarScene:
    """Every limitation of section II: A-E, end-effector zones F (circle and rectangle) and a
    link zone G, with a thin damped zone."""
    arm = arm or PlanarArm()
    zones: list[PlanarLimitation] = [
        CircleKeepOut("F circle zone", 0.05, (0.25, 0.30)),
        RectangleZone("F rectangle zone", (-0.38, 0.25), (0.05, 0.04)),
        LinkCircleZone("G link zone", (0.16, -0.16), 0.04),
    ]
    return PlanarScene(arm, arm_limitations(arm) + zones, Damping(width_m=0.01, width_rad=0.05))


def fig9_triangle() -> PolygonZone:
    return PolygonZone("F triangle", ((-0.24, 0.12), (-0.10, 0.12), (-0.17, 0.22)))


def fig9_scene(scenario: str, arm: PlanarArm | None = None) -> PlanarScene:
    """Scenario ``a``: a bar joined to the triangle (no way through); ``b``: a 6 cm gap between
    the bar and the triangle, through which the target can be reached."""
    arm = arm or PlanarArm()
    if scenario == "a":
        bar = RectangleZone("F bar", (-0.35, 0.145), (0.15, 0.025))
    elif scenario == "b":
        bar = RectangleZone("F bar", (-0.40, 0.145), (0.10, 0.025))
    else:
        raise ValueError(f"scenario must be 'a' or 'b', got {scenario!r}")
    return PlanarScene(arm, arm_limitations(arm) + [bar, fig9_triangle()])
