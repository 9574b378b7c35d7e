"""Planar scenes: the demo scene with every limitation A-G, the user trial's scene, Fig. 9's
scenarios a and b, and a scene in which the Jacobian-conditioning safeguard of III.C.2 acts.

Positions in metres in the base frame; the base is at the origin.
"""

from __future__ import annotations

import math

from cobotsafety.planar.rr_arm import PlanarArm
from cobotsafety.planar.baselines import ReactiveParams
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
from cobotsafety.planar.planar_step import PlanarScene

#: Fig. 9's start position [m].
FIG9_START_M = (-0.2, 0.03)
#: Fig. 9's target [m]: beyond the base, so the straight drive meets joint 2's circle B first
#: and slides along it toward the wall of zones standing on top of it.
FIG9_TARGET_M = (0.22, 0.18)
#: Fig. 9 (b)'s gap between circle B and the tip of the triangle [m].
FIG9_GAP_M = 0.06
BASE_RADIUS_M = 0.12
INNER_REACH_RADIUS_M = 0.05
EXTENDED_REACH_RADIUS_M = 0.57


#: The demo's and the trial's damped zone (III.C.1): 1 cm before metric limits, 0.05 rad before joint limits.
DEMO_DAMPING = Damping(width_m=0.01, width_rad=0.05)


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
    return PlanarScene(arm, arm_limitations(arm) + zones, DEMO_DAMPING)


def trial_scene(arm: PlanarArm | None = None) -> PlanarScene:
    """The scene of the user trials (paper 1, IV.A-B), the one people drive in the browser and
    the simulated participant drives headless: the arm's own limitations A-E and the
    conditioning safeguard, with the demo's damped zone. No protection zones (F, G): the
    course's triangles are the only obstacles, and they are scored, not enforced."""
    arm = arm or PlanarArm()
    return PlanarScene(arm, arm_limitations(arm), DEMO_DAMPING)


def joint_2_circle_radius_m(arm: PlanarArm) -> float:
    """Radius of circle B [m]: the end-effector's distance from the base at joint 2's upper limit."""
    l1, l2, c = arm.link_1_m, arm.link_2_m, math.cos(arm.theta_2_max_rad)
    return math.sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * c)


def fig9_wall(scenario: str, arm: PlanarArm | None = None) -> list[PlanarLimitation]:
    """A triangle standing point-down on top of circle B, and a bar above it (a wall across the
    way to the target). ``a``: the triangle's tip touches B, so its left edge and B meet at an
    angle (a V) and the robot sliding along B into it ends with two binding limitations, the
    zero output of section III.A. ``b``: the tip is ``FIG9_GAP_M`` above B, a gap to slide through."""
    arm = arm or PlanarArm()
    radius = joint_2_circle_radius_m(arm)
    if scenario == "a":
        tip_y = radius - 0.01  # overlapping B by 1 cm: connected
    elif scenario == "b":
        tip_y = radius + FIG9_GAP_M
    else:
        raise ValueError(f"scenario must be 'a' or 'b', got {scenario!r}")
    top_y = tip_y + 0.15
    triangle = PolygonZone("F triangle", ((-0.03, top_y), (0.0, tip_y), (0.03, top_y)))
    bar = RectangleZone("F bar", (0.0, top_y + 0.07), (0.03, 0.07))
    return [triangle, bar]


def fig9_scene(scenario: str, arm: PlanarArm | None = None, reactive: ReactiveParams | None = None) -> PlanarScene:
    """Scenario ``a``: the wall of zones joined to circle B (no way through); ``b``: a 6 cm gap
    between B and the triangle, through which the target can be reached."""
    arm = arm or PlanarArm()
    return PlanarScene(arm, arm_limitations(arm) + fig9_wall(scenario, arm), reactive=reactive or ReactiveParams())


#: The conditioning scene's arm: joint 2 may almost stretch and fold (sin(theta_2) down to 0.02).
CONDITIONING_ARM = PlanarArm(theta_2_min_rad=0.02, theta_2_max_rad=3.12)


def conditioning_scene(min_sin: float = 0.15) -> PlanarScene:
    """Joint limits and the III.C.2 safeguard only (no reach circles A, C, E): with joint 2's
    range [0.02, 3.12] rad, only ``Conditioning`` keeps sin(theta_2) >= ``min_sin``, i.e. the
    end-effector inside r = 2 L cos(asin(min_sin) / 2) (0.598 m) and outside the folded circle."""
    arm = CONDITIONING_ARM
    return PlanarScene(arm, [
        JointLimit("B joint 2", 2, arm.theta_2_min_rad, arm.theta_2_max_rad),
        JointLimit("D joint 1", 1, arm.theta_1_min_rad, arm.theta_1_max_rad),
        Conditioning(min_sin=min_sin),
    ])
