"""Motion limits of one robot, read from the bundled table ``assets/limits/robot_limits.toml``.

A robot's section gives, per joint (keyed by the pinocchio model's joint name), the largest
velocity [rad/s], acceleration [rad/s²] and jerk [rad/s³] a command may have, and for the
end-effector its translational speed [m/s], acceleration [m/s²] and jerk [m/s³] (norms of the
3-vector). Each value group names its source in the file (``*_source`` strings).

``load_motion_limits(robot, joint_names)`` returns them in the order of ``joint_names`` (the
reduced model's velocity order, one name per velocity coordinate): a robot missing from the
table, a joint of ``joint_names`` missing from it, a joint in it missing from ``joint_names``,
a missing source, or a value that is not a finite positive number raises ``MotionLimitsError``
naming the robot and the joint. This module imports nothing of the arm core, so the core may
import it.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from types import MappingProxyType

import numpy as np

from cobotsafety.errors import MotionLimitsError

TABLE_FORMAT = "cobotsafety-motion-limits"
TABLE_VERSION = 1
JOINT_FIELDS = ("velocity_rad_s", "acceleration_rad_s2", "jerk_rad_s3")
EE_FIELDS = ("ee_speed_m_s", "ee_acceleration_m_s2", "ee_jerk_m_s3")
#: A ratio of a value to its limit above this counts as over the limit (the step's report of the
#: hand's executed path, ``experiments.motion_ratios`` over a run): position rounding (float64,
#: |q| < 10 rad) differenced twice at dt >= 1e-4 s stays orders of magnitude below 1e-9 of any
#: limit here.
OVER_LIMIT_RATIO = 1.0 + 1e-9
#: Source keys of a robot section: the section's own, then one per value group.
SOURCE_KEYS = ("source", "velocity_source", "acceleration_source", "jerk_source",
               "ee_speed_source", "ee_acceleration_source", "ee_jerk_source")


@dataclass(frozen=True, eq=False)
class MotionLimits:
    """One robot's motion limits; arrays are read-only, shape (nv,), in ``joint_names`` order."""

    robot: str
    joint_names: tuple[str, ...]
    velocity_rad_s: np.ndarray
    acceleration_rad_s2: np.ndarray
    jerk_rad_s3: np.ndarray
    ee_speed_m_s: float
    ee_acceleration_m_s2: float
    ee_jerk_m_s3: float
    sources: Mapping[str, str]
    """``SOURCE_KEYS`` -> the text the table gives for it."""


@lru_cache(maxsize=1)
def bundled_table() -> Mapping:
    """The parsed bundled table (read once; treat as read-only)."""
    path = resources.files("cobotsafety.assets").joinpath("limits/robot_limits.toml")
    with path.open("rb") as f:
        return tomllib.load(f)


def table_robots(table: Mapping | None = None) -> tuple[str, ...]:
    """Names of the robots the table (default: the bundled one) has limits for."""
    return tuple((bundled_table() if table is None else table).get("robots", {}))


def _positive(robot: str, where: str, field: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise MotionLimitsError(f"motion limits of {robot!r}: {where} {field} must be a number, got {value!r}")
    if not math.isfinite(value) or value <= 0.0:
        raise MotionLimitsError(f"motion limits of {robot!r}: {where} {field} must be finite and > 0, got {value!r}")
    return float(value)


def load_motion_limits(robot: str, joint_names: Sequence[str], *, table: Mapping | None = None) -> MotionLimits:
    """Motion limits of ``robot`` for ``joint_names`` (the model's joints, velocity order).

    ``table`` is a parsed table of the bundled file's layout (default: the bundled one).
    Raises ``MotionLimitsError`` naming robot and joint on any missing, extra or invalid entry.
    """
    table = bundled_table() if table is None else table
    if table.get("format") != TABLE_FORMAT or table.get("version") != TABLE_VERSION:
        raise MotionLimitsError(f"motion limits of {robot!r}: table is not {TABLE_FORMAT!r} version {TABLE_VERSION}")
    robots = table.get("robots", {})
    if robot not in robots:
        raise MotionLimitsError(f"no motion limits for robot {robot!r}; the table has {', '.join(robots) or 'none'}")
    section = robots[robot]
    names = tuple(joint_names)
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise MotionLimitsError(f"motion limits of {robot!r}: joint {repeated[0]!r} is named twice in joint_names")
    joints = section.get("joints", {})
    for name in names:
        if name not in joints:
            raise MotionLimitsError(f"motion limits of {robot!r}: no entry for joint {name!r}")
    for name in joints:
        if name not in names:
            raise MotionLimitsError(f"motion limits of {robot!r}: joint {name!r} is in the table but not in the model")
    sources = {}
    for key in SOURCE_KEYS:
        text = section.get(key)
        if not isinstance(text, str) or not text.strip():
            raise MotionLimitsError(f"motion limits of {robot!r}: {key} is missing (every value names its source)")
        sources[key] = text
    columns = {field: np.empty(len(names)) for field in JOINT_FIELDS}
    for i, name in enumerate(names):
        entry = joints[name]
        for field in JOINT_FIELDS:
            if field not in entry:
                raise MotionLimitsError(f"motion limits of {robot!r}: joint {name!r} has no {field}")
            columns[field][i] = _positive(robot, f"joint {name!r}", field, entry[field])
    for column in columns.values():
        column.setflags(write=False)
    ee = {}
    for field in EE_FIELDS:
        if field not in section:
            raise MotionLimitsError(f"motion limits of {robot!r}: end-effector {field} is missing")
        ee[field] = _positive(robot, "end-effector", field, section[field])
    return MotionLimits(robot, names, columns["velocity_rad_s"], columns["acceleration_rad_s2"],
                        columns["jerk_rad_s3"], ee["ee_speed_m_s"], ee["ee_acceleration_m_s2"],
                        ee["ee_jerk_m_s3"], MappingProxyType(sources))
