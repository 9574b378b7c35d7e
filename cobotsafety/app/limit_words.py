"""What a binding limitation's name means: the words a stakeholder reads and what the scene draws.

The controllers name the rows that bind (``StepReport.binding``). This module is the one place
that turns those names into a sentence ("right forearm near the elbow", "joint 3 at its speed
limit") and into a drawing target (a joint arc, a reach sphere, the table, a zone); the status
line and the scenes only call ``describe``. Both generations of names are understood:

=====================================  ==========================================  ===============
name                                   kind                                        drawn as
=====================================  ==========================================  ===============
``panda_joint6 upper`` / ``lower``     joint position (``JOINT_POSITION``)          arc at the joint
``panda_joint3 speed``, ``velocity 9``  joint speed (old: row ``i`` of ``2 nv``:     ring at the joint
                                       ``i < nv`` lower, else upper, joint ``i % nv``)
``panda_joint3 acceleration``          joint acceleration                          ring at the joint
``end-effector acceleration``          hand acceleration                           (words only)
``speed``, ``speed -z``                hand speed                                  (words only)
``reach inner`` / ``reach extended``   reach                                       reach sphere
``table (panda_joint6)``               table                                       the table top
``box zone (panda_joint5)``            zone                                        that zone
``human forearm_right (panda_joint2)``  human                                       the human (segment)
``B joint 2 lower``, ``E extended      planar (paper 1's letters A-G)              that outline
reach``, ``F circle zone``
=====================================  ==========================================  ===============

``in_play(report)`` says which binding rows the scene should highlight: a row that changes
nothing (the arm at rest against a limit with no command) is not shown.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

JOINT_POSITION = "joint position"
JOINT_SPEED = "joint speed"
JOINT_ACCELERATION = "joint acceleration"
HAND_SPEED = "hand speed"
HAND_ACCELERATION = "hand acceleration"
REACH = "reach"
TABLE = "table"
ZONE = "zone"
HUMAN = "human"
PLANAR = "planar"
OTHER = "other"

HUMAN_PART_WORDS = {
    "torso": "torso", "body": "body",
    "upper_arm_left": "left upper arm", "forearm_left": "left forearm",
    "upper_arm_right": "right upper arm", "forearm_right": "right forearm",
}
"""Human capsule names (``cobotsafety.human.body``) -> the words for that part of the body."""

MOVING_M_S = 1e-3
"""Speed [m/s] above which a command or a motion counts as one (``in_play``)."""


@dataclass(frozen=True)
class RobotVocabulary:
    """How to speak of one robot's joints and links.

    ``joints``: the joint names in velocity order (joint ``k`` is ``joints[k - 1]``);
    ``shoulder``, ``elbow``, ``wrist``: the joints where those sit (``RobotSpec.arm_joints``),
    "" when unknown. ``planar``: paper 1's RR arm, whose limitations carry their letters.
    """

    joints: tuple[str, ...] = ()
    shoulder: str = ""
    elbow: str = ""
    wrist: str = ""
    planar: bool = False

    def joint_words(self, joint: str) -> str:
        """``"joint 3"`` for the third joint; the joint's own name when it is not in the list."""
        if joint in self.joints:
            return f"joint {self.joints.index(joint) + 1}"
        return joint

    def part_words(self, capsule: str) -> str:
        """A robot capsule (named after the joint it hangs on, or a part name) -> "the elbow"."""
        capsule = capsule.split(" (")[0]
        if capsule not in self.joints:
            return f"the {capsule.replace('_', ' ')}" if capsule else "the arm"
        landmarks = [self.joints.index(j) if j in self.joints else None for j in (self.shoulder, self.elbow, self.wrist)]
        if None in landmarks:
            return f"the link of {self.joint_words(capsule)}"
        at = self.joints.index(capsule)
        shoulder, elbow, wrist = landmarks
        for limit, words in ((shoulder, "the base"), (shoulder + 1, "the shoulder"), (elbow, "the upper arm"),
                             (elbow + 1, "the elbow"), (wrist, "the forearm"), (wrist + 1, "the wrist")):
            if at < limit:
                return words
        return "the hand"


@dataclass(frozen=True)
class Limit:
    """One binding row, read.

    ``kind``: one of the module's kinds; ``words``: the phrase for the status; ``joint``: the
    joint name (joint kinds); ``side``: "lower"/"upper" (joint position, planar joint limits) or
    "inner"/"extended" (reach); ``target``: what the scene draws for it, the key its view
    looks up: a zone or planar limitation name, ``"table"``, the human capsule name, or "".
    """

    name: str
    kind: str
    words: str
    joint: str = ""
    side: str = ""
    target: str = ""


_ROBOT_PART = re.compile(r"^(?P<what>.+) \((?P<part>[^()]+)\)$")


def describe(name: str, vocabulary: RobotVocabulary = RobotVocabulary()) -> Limit:
    """Read one binding row's ``name`` (old or new naming, see the module docstring)."""
    if vocabulary.planar:
        return _planar(name)
    words = vocabulary.joint_words
    if name.startswith("velocity ") and name[9:].isdigit() and vocabulary.joints:
        row, count = int(name[9:]), len(vocabulary.joints)
        joint = vocabulary.joints[row % count] if row < 2 * count else ""
        side = "lower" if row < count else "upper"
        return Limit(name, JOINT_SPEED, f"{words(joint)} at its speed limit", joint, side, joint)
    if name == "speed" or re.fullmatch(r"speed [+-][xyz]", name):
        return Limit(name, HAND_SPEED, "the hand at its speed limit")
    if name == "end-effector acceleration":
        return Limit(name, HAND_ACCELERATION, "the hand at its acceleration limit")
    if name in ("reach inner", "reach extended"):
        side = name.split(" ")[1]
        text = "the arm at full stretch" if side == "extended" else "the hand folded in close to the shoulder"
        return Limit(name, REACH, text, side=side, target=name)
    part = _ROBOT_PART.match(name)
    if part is not None:
        what, where = part.group("what"), vocabulary.part_words(part.group("part"))
        if what == "table":
            return Limit(name, TABLE, f"the table under {where}", target="table")
        if what.startswith("human "):
            human = what[6:]
            return Limit(name, HUMAN, f"the person's {HUMAN_PART_WORDS.get(human, human.replace('_', ' '))} "
                                      f"near {where}", target=human)
        return Limit(name, ZONE, f"the {what} at {where}" if not what.lower().startswith("the ") else f"{what} at {where}",
                     target=what)
    joint, _, suffix = name.rpartition(" ")
    if joint and suffix in ("lower", "upper"):
        return Limit(name, JOINT_POSITION, f"{words(joint)} at its {suffix} end", joint, suffix, joint)
    if joint and suffix == "speed":
        return Limit(name, JOINT_SPEED, f"{words(joint)} at its speed limit", joint, target=joint)
    if joint and suffix == "acceleration":
        return Limit(name, JOINT_ACCELERATION, f"{words(joint)} at its acceleration limit", joint, target=joint)
    return Limit(name, OTHER, name.replace("_", " "))


def _planar(name: str) -> Limit:
    """Paper 1's limitations: "<letter> <what>" (joint limits add "lower"/"upper", link zones
    "link k"); the letter leads the words so they match the labels drawn in the plane."""
    letter, _, rest = name.partition(" ")
    if not (len(letter) == 1 and letter.isupper()):
        letter, rest = "", name
    target, side = name, ""
    joint = re.fullmatch(r"joint (\d) (lower|upper)", rest)
    link = re.fullmatch(r"(.+) link (\d)", rest)
    if joint is not None:
        side = joint.group(2)
        target = name[: -len(side) - 1]
        text = f"joint {joint.group(1)} at its {side} end"
    elif link is not None:
        target = name[: -len(" link 0")]
        text = f"link {link.group(2)} against the {link.group(1)}"
    elif rest == "extended reach":
        text = "the arm at full stretch"
    elif rest == "inner reach":
        text = "the hand too close to the base"
    elif rest == "base":
        text = "the hand against the base"
    elif rest == "conditioning":
        text = "the arm nearly straight (its elbow near singular)"
    else:
        text = f"the {rest}" if rest else name
    return Limit(name, PLANAR, f"{letter}: {text}" if letter else text, side=side, target=target)


def vocabulary_of(robot) -> RobotVocabulary:
    """The vocabulary of a ``Teleoperated`` robot: its pinocchio model's joints and the spec's
    (shoulder, elbow, wrist); a robot of dimension 2 is paper 1's planar arm."""
    if getattr(robot, "dim", 3) == 2:
        return RobotVocabulary(planar=True)
    state = getattr(robot, "state", None)
    model = getattr(state, "model", None)
    if model is None:
        return RobotVocabulary()
    joints = sorted((int(model.joints[j].idx_v), str(model.names[j])) for j in range(1, model.njoints)
                    if model.joints[j].nv == 1)
    arm = tuple(getattr(getattr(state, "spec", None), "arm_joints", ()) or ("", "", ""))
    return RobotVocabulary(tuple(name for _, name in joints), *arm)


def in_play(report) -> tuple[str, ...]:
    """The binding rows of ``report`` that change what the arm does now.

    All of them while the user commands motion, while the arm moves (pushed by the filter,
    returning) or when it was stopped; at rest with no command only the human rows (a person
    holding the arm away). A hand resting against a limit with nothing asked is not "meeting" it.
    """
    if report is None:
        return ()
    binding = tuple(dict.fromkeys(report.binding))
    moving = max(_norm(report.v_desired_m_s), _norm(report.v_commanded_m_s), _norm(report.v_executed_m_s))
    if moving > MOVING_M_S or report.stopped:
        return binding
    return tuple(name for name in binding if name.startswith("human "))


def _norm(v) -> float:
    v = np.asarray(v, dtype=float)
    return float(np.sqrt(np.sum(v * v))) if v.size and np.all(np.isfinite(v)) else 0.0
