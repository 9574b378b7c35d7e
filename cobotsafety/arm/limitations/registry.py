"""The table of limitation kinds: each data class, the module holding its rows, and the packing
of a scene (a list of limitations) into the flat arrays the compiled step reads.

Adding a kind: a module with ``KIND`` (a new code), ``ANGULAR``, ``pack``, ``row_name``,
``count``, ``distances`` and ``rows`` (see ``joint_range.py``), an entry here, and one branch in
``rows.py`` (``tests/test_arm_limitations.py`` checks that every registered kind dispatches).
A limitation of an unregistered type is refused when the scene is packed, never skipped.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType

import numpy as np

from cobotsafety.arm.limitations import (box_zone, capsule_zone, halfspace_zone, human, joint_range, reach,
                                         table)
from cobotsafety.errors import CobotSafetyError

#: Limitation type -> the module of its kind.
KINDS: dict[type, ModuleType] = {
    joint_range.JointPositionLimits: joint_range,
    reach.ReachLimits: reach,
    table.TablePlane: table,
    capsule_zone.CapsuleZone: capsule_zone,
    capsule_zone.SphereZone: capsule_zone,
    halfspace_zone.HalfSpaceZone: halfspace_zone,
    box_zone.BoxZone: box_zone,
    human.HumanLimitation: human,
}
ANGULAR_KINDS = tuple(sorted({m.KIND for m in KINDS.values() if m.ANGULAR}))
assert len({m.KIND for m in KINDS.values()}) == len(set(KINDS.values())), "two kinds share a code"


class UnsupportedLimitationError(CobotSafetyError, TypeError):
    """A limitation whose type is not in ``KINDS``."""


def kind_module(limitation) -> ModuleType:
    """The module of ``limitation``'s kind; raises ``UnsupportedLimitationError`` otherwise."""
    module = KINDS.get(type(limitation))
    if module is None:
        known = ", ".join(sorted(t.__name__ for t in KINDS))
        raise UnsupportedLimitationError(f"unsupported limitation {limitation!r} of type {type(limitation).__name__}; "
                                         f"known kinds: {known}")
    return module


@dataclass(frozen=True)
class ScenePack:
    """A scene's limitations as the compiled step reads them.

    ``kinds`` (n,) kind codes, ``reals`` (n, 12) each kind's numbers (its ``pack``), ``skips``
    (n,) the robot capsules each skips, ``human`` the index of the human limitation (-1: none).
    """

    limitations: tuple
    kinds: np.ndarray
    reals: np.ndarray
    skips: np.ndarray
    human: int

    def row_name(self, robot, con: int, a: int, b: int, human_names: tuple[str, ...] = ()) -> str:
        """The name a stakeholder reads for row ``(a, b)`` of limitation ``con``."""
        limitation = self.limitations[con]
        module = kind_module(limitation)
        if module is human:
            return human.row_name(limitation, robot, a, b, human_names)
        return module.row_name(limitation, robot, a, b)


def pack_scene(limitations, robot) -> ScenePack:
    """Pack ``limitations`` for ``robot`` (a ``RobotModel``); at most one human limitation.
    Raises ``UnsupportedLimitationError`` for an unknown type and ``ValueError`` for a skip
    beyond the robot's capsules or a second human."""
    limitations = tuple(limitations)
    kinds, reals, skips, human_index = [], [], [], -1
    for i, limitation in enumerate(limitations):
        module = kind_module(limitation)
        real, skip = module.pack(limitation, robot)
        if not 0 <= skip <= len(robot.capsules):
            raise ValueError(f"{limitation!r}: skips {skip} capsules, the robot has {len(robot.capsules)}")
        if not np.all(np.isfinite(real)):
            raise ValueError(f"{limitation!r}: non-finite geometry")
        if module is human:
            if human_index >= 0:
                raise ValueError("a scene holds at most one human limitation")
            human_index = i
        kinds.append(module.KIND)
        reals.append(real)
        skips.append(skip)
    return ScenePack(limitations, np.array(kinds, dtype=np.int64), np.array(reals, dtype=float).reshape(-1, 12),
                     np.array(skips, dtype=np.int64), human_index)
