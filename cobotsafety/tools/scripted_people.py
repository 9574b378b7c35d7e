"""Scripted humans for ``generate_recording``: where the torso walks, where it faces, what the arms do.

Robot base frame ``b``: origin at the robot base, z = 0 the table top, the table in front of the
robot (+x), the human coming from +x. Each scenario gives, for times ``t`` (n,) [s]:

* ``torso_path(t)`` -> torso xy (n, 2) [m], heading (n,) [rad] (direction faced), speed (n,) [m/s];
* ``reaches(t, fwd, left, up)`` -> ``{side: (weight (n,), upper (n, 3), fore (n, 3))}``: the
  upper arm and forearm of ``side`` ("left"/"right") point along ``upper``/``fore`` with weight
  1 (blended with the walking swing by ``weight``).

Three scenarios (``SCENARIOS``):

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

from dataclasses import dataclass, field
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

SCENARIOS = {"reach-over": ReachOver(), "exp1": EXP1, "exp2": EXP2}
