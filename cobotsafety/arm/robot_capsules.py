"""Robot capsules: one per moving link fitted to its meshes, or paper 2's three.

The tables live in ``assets/capsules/<robot>.json`` (``model="fitted"``) and
``assets/capsules/<robot>-paper.json`` (``model="paper"``), both made by ``python -m
cobotsafety.tools.fit_capsules``; each capsule is a segment fixed in a joint's frame and a radius.

Paper 2's model (section 5, Fig. 9): two identical capsules of 400 mm by 230 mm diameter on the
upper arm and the forearm, one of 250 mm by 115 mm on the tool. "Height" is read as the axis
segment between the joint centres (a 400 mm segment spans the iiwa R800's 400 mm links; the
caps then cover the joint housings). The paper's table has a first entry, the fitted base-link
capsule: it is never checked against zones or the human (``skip_capsules``) and only anchors
the reach limit, as in the fitted tables.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources

from cobotsafety.errors import UnknownRobotError

CAPSULE_MODELS = ("fitted", "paper")
#: Paper 2's capsules: (name, segment length [m], radius [m]).
PAPER_CAPSULES = (("upper arm", 0.400, 0.115), ("forearm", 0.400, 0.115), ("tool", 0.250, 0.0575))


@dataclass(frozen=True)
class RobotCapsule:
    """A capsule fixed to ``joint``'s frame: segment ``p0_joint``-``p1_joint`` [m], ``radius_m``."""

    name: str
    joint: str
    p0_joint: tuple[float, float, float]
    p1_joint: tuple[float, float, float]
    radius_m: float


def capsule_file(robot: str, model: str = "fitted") -> str:
    """The asset file name of ``robot``'s ``model`` table."""
    if model not in CAPSULE_MODELS:
        raise UnknownRobotError(f"unknown capsule model {model!r}; known: {', '.join(CAPSULE_MODELS)}")
    return f"{robot}.json" if model == "fitted" else f"{robot}-{model}.json"


def load_capsules(robot: str, model: str = "fitted") -> list[RobotCapsule]:
    """The capsule table of ``robot`` from the bundled assets (``model``: "fitted" or "paper")."""
    path = resources.files("cobotsafety.assets").joinpath("capsules", capsule_file(robot, model))
    if not path.is_file():
        raise UnknownRobotError(f"robot {robot!r} has no {model!r} capsule table ({path.name})")
    return [RobotCapsule(c["name"], c["joint"], tuple(c["p0"]), tuple(c["p1"]), c["radius_m"])
            for c in json.loads(path.read_text())["capsules"]]
