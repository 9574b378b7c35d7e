"""Scripted humans for ``generate_recording``: where the torso walks, where it faces, what the arms do.

Robot base frame ``b``: origin at the robot base, z = 0 the table top, the table in front of the
robot (+x), the human coming from +x. Each scenario gives, for times ``t`` (n,) [s]:

* ``torso_path(t)`` -> torso xy (n, 2) [m], heading (n,) [rad] (direction faced), speed (n,) [m/s];
* ``reaches(t, fwd, left, up)`` -> ``{side: (weight (n,), upper (n, 3), fore (n, 3))}``: the
  upper arm and forearm of ``side`` ("left"/"right") point along ``upper``/``fore`` with weight
  1 (blended with the walking swing by ``weight``).

Paper 2's two experiments come twice: with the scanner at the table's corner (``exp1-corner``,
``exp2-corner``: paper 2's set-up, the same people and seed) and under its front edge (``exp1``,
``exp2``, the first versions). ``draw_person(rng)`` draws a random person for the validation
campaign (``cobotsafety.tools.campaign``); ``Group`` puts two people in one scene.

Scenarios (``SCENARIOS``):

* ``reach-over``: the stress case (the first bundled recording): the human walks to the table
  edge, torso ~0.6 m from the base, and reaches over the table into the robot's path.
* ``exp1``: paper 2's experiment 1 with the iiwa's pick-and-place (``pick_and_place_iiwa``):
  walks in at ~1 m/s to a torso ~1.05 m from the base, puts the box at the pick pose (hand
  ~0.65 m from the base) with the right arm, holds 1.5 s, leaves; later, while the robot carries
  the box, comes back to a torso ~1.1 m from the base, reaches for a tool on the table (hand
  ~0.7 m from the base) and leaves.
* ``exp2``: paper 2's experiment 2: the robot holds its home; the human walks past along -y at
  up to 1.35 m/s (0.9 m/s mean) with the torso 1.0 m in front of the base, arms swinging, no reach.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np


class Scenario(Protocol):
    name: str
    duration_s: float
    description: str
    scanner_xy_m: tuple[float, float]
    """The laser's position in the base frame [m]; it looks along ``scanner_yaw_rad`` [rad]."""
    scanner_yaw_rad: float

    def torso_path(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def reaches(self, t: np.ndarray, fwd: np.ndarray, left: np.ndarray, up: np.ndarray) -> dict: ...


def smoothstep(u):
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3 - 2 * u)


def blend(t, t0, t1, a, b):
    w = smoothstep((t - t0) / (t1 - t0))[..., None]
    return (1 - w) * np.asarray(a, float) + w * np.asarray(b, float)


class ReachOver:
    """The stress case: approach to the table edge, reach over the table, step back, leave."""

    name = "reach-over"
    duration_s = 32.0
    description = "scripted human approaches the table, reaches with the right arm, leaves"
    scanner_xy_m = (0.40, -0.40)  # the table corner
    scanner_yaw_rad = -np.pi / 4  # looks away from the table; the 90 deg blind sector faces it
    START_XY_M, TABLE_XY_M, BACK_XY_M, END_XY_M = (2.6, 0.0), (0.62, -0.15), (1.0, 0.0), (2.8, 1.0)
    #: Key times [s]: stand, walk in, stand, reach, hold, retract, step back, stand, walk away, stand.
    SCRIPT_S = (2.0, 5.5, 7.0, 9.0, 13.0, 15.0, 17.5, 20.0, 25.5)

    def torso_path(self, t: np.ndarray):
        s = self.SCRIPT_S
        start, table, back, end = self.START_XY_M, self.TABLE_XY_M, self.BACK_XY_M, self.END_XY_M
        xy = np.where((t < s[1])[:, None], blend(t, s[0], s[1], start, table),
             np.where((t < s[6])[:, None], table,
             np.where((t < s[7])[:, None], blend(t, s[6], s[7], table, back),
             np.where((t < s[8] - 3.5)[:, None], back, blend(t, s[8] - 3.5, s[8], back, end)))))
        away = np.arctan2(end[1] - back[1], end[0] - back[0])
        heading = np.pi + (away - np.pi) * smoothstep((t - (s[8] - 4.0)) / 1.0)  # face the robot, then turn
        speed = np.linalg.norm(np.gradient(xy, t, axis=0), axis=1)
        return xy, heading, speed

    def reaches(self, t, fwd, left, up) -> dict:
        s = self.SCRIPT_S
        reach = smoothstep((t - s[2]) / (s[3] - s[2])) * (1 - smoothstep((t - s[4]) / (s[5] - s[4])))
        wobble = np.deg2rad(5.0) * np.sin(2 * np.pi * 0.7 * t)[:, None]
        # Forward and a little down over the table.
        target = np.cos(np.deg2rad(-15) + wobble) * fwd + np.sin(np.deg2rad(-15) + wobble) * up - 0.1 * left
        return {"right": (reach, target, target + 0.1 * up)}


@dataclass(frozen=True)
class Reach:
    """One arm reaching: raised over ``t_s[0]..t_s[1]``, held, lowered over ``t_s[2]..t_s[3]``;
    the arm points ``elevation_deg`` above the horizontal (negative: down), turned
    ``inward`` (fraction of the body's width axis, toward the body's middle)."""

    side: str
    t_s: tuple[float, float, float, float]
    elevation_deg: float
    inward: float = 0.0


@dataclass(frozen=True)
class KeyframedHuman:
    """Torso through keyframes ``(t [s], x [m], y [m], heading [rad])``, smoothstep between
    consecutive ones (so the walking speed peaks at 1.5x the mean), plus ``Reach``es."""

    name: str
    duration_s: float
    description: str
    keyframes: tuple[tuple[float, float, float, float], ...]
    reach_list: tuple[Reach, ...] = field(default=())
    #: Under the table's front edge, looking at the co-worker's side (+x): a walker 1 m in
    #: front is seen from ~1.35 m to either side (the 1.4 m clip, paper 2.1.1).
    scanner_xy_m: tuple[float, float] = (0.60, 0.0)
    scanner_yaw_rad: float = 0.0

    def torso_path(self, t: np.ndarray):
        keys = np.array(self.keyframes, dtype=float)
        xy = np.tile(keys[0, 1:3], (t.size, 1))
        heading = np.full(t.size, keys[0, 3])
        for a, b in zip(keys[:-1], keys[1:]):
            w = smoothstep((t - a[0]) / (b[0] - a[0]))
            inside = t >= a[0]
            xy[inside] = ((1 - w[:, None]) * a[1:3] + w[:, None] * b[1:3])[inside]
            heading[inside] = ((1 - w) * a[3] + w * b[3])[inside]
        speed = np.linalg.norm(np.gradient(xy, t, axis=0), axis=1)
        return xy, heading, speed

    def reaches(self, t, fwd, left, up) -> dict:
        out = {}
        for reach in self.reach_list:
            t0, t1, t2, t3 = reach.t_s
            weight = smoothstep((t - t0) / (t1 - t0)) * (1 - smoothstep((t - t2) / (t3 - t2)))
            elevation = np.deg2rad(reach.elevation_deg)
            toward_middle = -left if reach.side == "left" else left
            target = np.cos(elevation) * fwd + np.sin(elevation) * up + reach.inward * toward_middle
            if reach.side in out:  # a second reach of the same arm: add its weight
                w0, u0, _ = out[reach.side]
                mix = weight[:, None]
                target = (1 - mix) * u0 + mix * target
                weight = np.maximum(w0, weight)
            out[reach.side] = (weight, target, target)
        return out


FACING_ROBOT_RAD = np.pi
#: Paper 2, experiment 1 (section 5): place the box, leave; come back for the tool, leave.
EXP1 = KeyframedHuman(
    "exp1", 32.0, "paper 2 experiment 1: places the box at the pick pose, leaves, fetches a tool, leaves",
    keyframes=(
        (0.0, 2.6, -0.50, FACING_ROBOT_RAD),
        (1.0, 2.6, -0.50, FACING_ROBOT_RAD),
        (3.4, 1.00, -0.40, FACING_ROBOT_RAD),  # 1.6 m in 2.4 s: 0.67 m/s mean, 1.0 m/s peak
        (7.8, 1.00, -0.40, FACING_ROBOT_RAD),
        (8.4, 1.05, -0.40, 0.0),  # turns away
        (10.6, 2.7, -0.20, 0.0),
        (16.2, 2.7, 0.10, 0.0),
        (17.0, 2.7, 0.10, FACING_ROBOT_RAD),  # turns back
        (19.6, 1.10, 0.10, FACING_ROBOT_RAD),
        (23.0, 1.10, 0.10, FACING_ROBOT_RAD),
        (23.6, 1.15, 0.10, 0.0),
        (25.8, 2.8, 0.40, 0.0),
    ),
    reach_list=(
        Reach("right", (3.6, 4.6, 6.1, 7.2), elevation_deg=-42.0, inward=0.15),  # box at the pick pose, held 1.5 s
        Reach("right", (19.8, 20.8, 21.8, 22.8), elevation_deg=-45.0, inward=0.35),  # the tool on the table
    ),
)
#: Paper 2, experiment 2: walks past the robot along -y, no reach.
EXP2 = KeyframedHuman(
    "exp2", 12.0, "paper 2 experiment 2: walks past the robot along -y at up to 1.35 m/s, 1.0 m in front",
    keyframes=((0.0, 1.0, 3.0, -np.pi / 2), (1.0, 1.0, 3.0, -np.pi / 2), (8.0, 1.0, -3.3, -np.pi / 2)),
)

#: Paper 2's scanner: at the table's corner (as ``reach-over``'s), looking away from the table.
PAPER_SCANNER_XY_M = ReachOver.scanner_xy_m
PAPER_SCANNER_YAW_RAD = ReachOver.scanner_yaw_rad
EXP1_CORNER = replace(EXP1, name="exp1-corner", scanner_xy_m=PAPER_SCANNER_XY_M, scanner_yaw_rad=PAPER_SCANNER_YAW_RAD,
                      description=EXP1.description + "; scanner at the table corner")
EXP2_CORNER = replace(EXP2, name="exp2-corner", scanner_xy_m=PAPER_SCANNER_XY_M, scanner_yaw_rad=PAPER_SCANNER_YAW_RAD,
                      description=EXP2.description + "; scanner at the table corner")

SCENARIOS = {"reach-over": ReachOver(), "exp1": EXP1, "exp2": EXP2, "exp1-corner": EXP1_CORNER,
             "exp2-corner": EXP2_CORNER}


@dataclass(frozen=True)
class Group:
    """Several people in one scene: the first wears the IMUs (its ``torso_path`` and ``reaches``
    are the group's), the ``others`` are seen by the laser and are in the ground truth."""

    name: str
    duration_s: float
    description: str
    first: KeyframedHuman
    others: tuple[KeyframedHuman, ...] = ()
    scanner_xy_m: tuple[float, float] = PAPER_SCANNER_XY_M
    scanner_yaw_rad: float = PAPER_SCANNER_YAW_RAD

    def torso_path(self, t):
        return self.first.torso_path(t)

    def reaches(self, t, fwd, left, up) -> dict:
        return self.first.reaches(t, fwd, left, up)


#: The campaign's people (``draw_person``): where they come from, how fast, what they do.
ENTRY_SIDES = {"front": (-35.0, 35.0), "left": (55.0, 110.0), "right": (-110.0, -55.0)}
"""Entry directions [deg] from the robot base (x forward over the table, y left)."""
START_DISTANCE_M = 2.6
"""People start this far from the base, outside the scanner's 1.4 m clip."""
PEAK_SPEED_M_S = (0.5, 2.1)
"""Peak walking speed [m/s] (slow walk to a brisk one; ISO 13855 takes 1.6 m/s)."""
STOP_DISTANCE_M = (0.55, 1.15)
"""Where an approaching person stops: torso distance from the base [m] (inside the workspace)."""
CROSS_DISTANCE_M = (0.6, 1.4)
"""Closest torso distance from the base of a person walking past [m]."""
PAUSE_S = (0.0, 3.0)
REACH_TARGETS_M = {"arm": (0.40, 0.0, 0.55), "path": (0.50, -0.10, 0.20)}
"""What a reaching person reaches for: the arm at its home (hand toward the elbow and wrist) or
a point of its task path between the pick and the place poses (base frame [m])."""
FACING_RAD_OFFSET = 0.0


def _segment_s(a, b, peak_speed_m_s: float) -> float:
    """Duration [s] of a smoothstep walk from a to b peaking at ``peak_speed_m_s`` (1.5 x the mean)."""
    return max(1.5 * float(np.hypot(b[0] - a[0], b[1] - a[1])) / peak_speed_m_s, 0.3)


def _reach_elevation_deg(torso_xy, target_m, body_chest_height_m: float = 0.6) -> float:
    horizontal = float(np.hypot(target_m[0] - torso_xy[0], target_m[1] - torso_xy[1]))
    return float(np.degrees(np.arctan2(target_m[2] - body_chest_height_m, horizontal)))


def draw_walker(rng: np.random.Generator, name: str, delay_s: float = 0.0) -> tuple[KeyframedHuman, dict]:
    """One random person and what was drawn (a dict of plain numbers and names)."""
    side = str(rng.choice(list(ENTRY_SIDES)))
    angle = np.radians(rng.uniform(*ENTRY_SIDES[side]))
    start = START_DISTANCE_M * np.array([np.cos(angle), np.sin(angle)])
    speed = float(rng.uniform(*PEAK_SPEED_M_S))
    kind = "cross" if rng.random() < 0.35 else "approach"
    t = delay_s
    reaches: list[Reach] = []
    drawn = {"side": side, "peak_speed_m_s": round(speed, 3), "kind": kind, "delay_s": round(delay_s, 3)}
    if kind == "cross":
        # Walk past the base at a drawn closest distance, leaving on the far side.
        distance = float(rng.uniform(*CROSS_DISTANCE_M))
        normal = np.array([np.cos(angle), np.sin(angle)])
        tangent = np.array([-normal[1], normal[0]]) * rng.choice([-1.0, 1.0])
        closest = distance * normal
        end = closest + 2.4 * tangent
        first = closest - 2.4 * tangent
        heading = float(np.arctan2(tangent[1], tangent[0]))
        keys = [(0.0, *first, heading)] + ([(t, *first, heading)] if t > 0 else [])
        t += _segment_s(first, end, speed)
        keys.append((t, *end, heading))
        drawn.update(closest_torso_m=round(distance, 3))
    else:
        stop_distance = float(rng.uniform(*STOP_DISTANCE_M))
        stop_angle = angle + rng.uniform(-0.5, 0.5)
        stop = stop_distance * np.array([np.cos(stop_angle), np.sin(stop_angle)])
        facing = float(np.arctan2(-stop[1], -stop[0]))  # faces the robot base
        keys = [(0.0, *start, facing)] + ([(t, *start, facing)] if t > 0 else [])
        t += _segment_s(start, stop, speed)
        keys.append((t, *stop, facing))
        pause = float(rng.uniform(*PAUSE_S))
        reach = str(rng.choice(["none", "arm", "path"], p=[0.3, 0.35, 0.35]))
        hold = float(rng.uniform(0.5, 2.0)) if reach != "none" else 0.0
        if reach != "none":
            target = REACH_TARGETS_M[reach]
            arm_side = "right" if rng.random() < 0.5 else "left"
            reaches.append(Reach(arm_side, (t, t + 0.8, t + 0.8 + hold, t + 1.6 + hold),
                                 elevation_deg=_reach_elevation_deg(stop, target),
                                 inward=float(rng.uniform(0.0, 0.3))))
        t += pause + (1.6 + hold if reach != "none" else 0.0)
        keys.append((t, *stop, facing))
        exit_angle = angle + rng.uniform(-0.8, 0.8)
        exit_point = START_DISTANCE_M * np.array([np.cos(exit_angle), np.sin(exit_angle)])
        away = float(np.arctan2(exit_point[1] - stop[1], exit_point[0] - stop[0]))
        keys.append((t + 0.6, *stop, away))  # turns to leave
        t += 0.6 + _segment_s(stop, exit_point, speed)
        keys.append((t, *exit_point, away))
        drawn.update(stop_torso_m=round(stop_distance, 3), pause_s=round(pause, 3), reach=reach,
                     reach_hold_s=round(hold, 3))
    duration = t + 0.5
    person = KeyframedHuman(name, duration, f"campaign person {name}", tuple(keys), tuple(reaches),
                            scanner_xy_m=PAPER_SCANNER_XY_M, scanner_yaw_rad=PAPER_SCANNER_YAW_RAD)
    return person, drawn


def draw_person(rng: np.random.Generator, name: str, two_people_probability: float = 0.2) -> tuple[Group, dict]:
    """A campaign scene: one random person, or two at once (``two_people_probability``), each
    with its own entry side, speed, path, pause and reach (``draw_walker``)."""
    first, drawn = draw_walker(rng, name)
    others = ()
    if rng.random() < two_people_probability:
        second, drawn_second = draw_walker(rng, name + "-b", delay_s=float(rng.uniform(0.0, 3.0)))
        others = (second,)
        drawn = {**drawn, "second": drawn_second}
    duration = max([first.duration_s] + [o.duration_s for o in others])
    return Group(name, duration, f"campaign scene {name}", first, others), drawn
