"""Robot capsules: one per moving link, fitted to the link's collision meshes.

The tables live in ``assets/capsules/<robot>.json`` (made by ``python -m
cobotsafety.arm.fit_capsules``); each capsule is a segment fixed in a joint's frame and a radius.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources

import numpy as np


@dataclass(frozen=True)
class RobotCapsule:
    """A capsule fixed to ``joint``'s frame: segment ``p0_joint``-``p1_joint`` [m], ``radius_m``."""

    name: str
    joint: str
    p0_joint: tuple[float, float, float]
    p1_joint: tuple[float, float, float]
    radius_m: float


def load_capsules(robot: str) -> list[RobotCapsule]:
    """The capsule table of ``robot`` from the bundled assets."""
    text = resources.files("cobotsafety.assets").joinpath("capsules", f"{robot}.json").read_text()
    return [RobotCapsule(c["name"], c["joint"], tuple(c["p0"]), tuple(c["p1"]), c["radius_m"])
            for c in json.loads(text)["capsules"]]
