"""Binding names -> words and drawing targets, for today's names and the rebuilt core's."""

from types import SimpleNamespace

import numpy as np
import pytest

from cobotsafety.app import limit_words as lw

PANDA = lw.RobotVocabulary(tuple(f"panda_joint{k}" for k in range(1, 8)), "panda_joint2", "panda_joint4",
                           "panda_joint6")
IIWA = lw.RobotVocabulary(tuple(f"joint_a{k}" for k in range(1, 8)), "joint_a2", "joint_a4", "joint_a6")


@pytest.mark.parametrize("name, vocabulary, kind, words, joint, side, target", [
    # the examples (today's names)
    ("velocity 9", IIWA, lw.JOINT_SPEED, "joint 3 at its speed limit", "joint_a3", "upper", "joint_a3"),
    ("velocity 2", IIWA, lw.JOINT_SPEED, "joint 3 at its speed limit", "joint_a3", "lower", "joint_a3"),
    ("human forearm_right (panda_joint4)", PANDA, lw.HUMAN, "the person's right forearm near the elbow", "", "",
     "forearm_right"),
    ("human forearm_right (panda_joint2)", PANDA, lw.HUMAN, "the person's right forearm near the shoulder", "", "",
     "forearm_right"),
    ("speed -z", PANDA, lw.HAND_SPEED, "the hand at its speed limit", "", "", ""),
    ("joint_a6 upper", IIWA, lw.JOINT_POSITION, "joint 6 at its upper end", "joint_a6", "upper", "joint_a6"),
    ("reach extended", PANDA, lw.REACH, "the arm at full stretch", "", "extended", "reach extended"),
    ("table (panda_joint7)", PANDA, lw.TABLE, "the table under the hand", "", "", "table"),
    ("box zone (panda_joint5)", PANDA, lw.ZONE, "the box zone at the forearm", "", "", "box zone"),
    # the rebuilt core's names
    ("panda_joint3 speed", PANDA, lw.JOINT_SPEED, "joint 3 at its speed limit", "panda_joint3", "", "panda_joint3"),
    ("joint_a2 acceleration", IIWA, lw.JOINT_ACCELERATION, "joint 2 at its acceleration limit", "joint_a2", "",
     "joint_a2"),
    ("speed", PANDA, lw.HAND_SPEED, "the hand at its speed limit", "", "", ""),
    ("end-effector acceleration", PANDA, lw.HAND_ACCELERATION, "the hand at its acceleration limit", "", "", ""),
    ("reach inner", IIWA, lw.REACH, "the hand folded in close to the shoulder", "", "inner", "reach inner"),
    ("human torso (joint_a1)", IIWA, lw.HUMAN, "the person's torso near the base", "", "", "torso"),
    ("human upper_arm_left (joint_a3)", IIWA, lw.HUMAN, "the person's left upper arm near the upper arm", "", "",
     "upper_arm_left"),
    ("human body (joint_a6)", IIWA, lw.HUMAN, "the person's body near the wrist", "", "", "body"),
    ("Z1 sphere (joint_a5)", IIWA, lw.ZONE, "the Z1 sphere at the forearm", "", "", "Z1 sphere"),
    # paper 2's capsules carry part names, not joints
    ("human forearm_left (forearm)", IIWA, lw.HUMAN, "the person's left forearm near the forearm", "", "",
     "forearm_left"),
])
def test_describe(name, vocabulary, kind, words, joint, side, target):
    limit = lw.describe(name, vocabulary)
    assert (limit.kind, limit.words, limit.joint, limit.side, limit.target) == (kind, words, joint, side, target)
    assert limit.name == name


@pytest.mark.parametrize("name, words, target, side", [
    ("B joint 2 lower", "B: joint 2 at its lower end", "B joint 2", "lower"),
    ("D joint 1 upper", "D: joint 1 at its upper end", "D joint 1", "upper"),
    ("E extended reach", "E: the arm at full stretch", "E extended reach", ""),
    ("C inner reach", "C: the hand too close to the base", "C inner reach", ""),
    ("A base", "A: the hand against the base", "A base", ""),
    ("G link zone link 2", "G: link 2 against the link zone", "G link zone", ""),
    ("F circle zone", "F: the circle zone", "F circle zone", ""),
    ("Z3 box", "the Z3 box", "Z3 box", ""),
])
def test_describe_planar(name, words, target, side):
    limit = lw.describe(name, lw.RobotVocabulary(planar=True))
    assert (limit.kind, limit.words, limit.target, limit.side) == (lw.PLANAR, words, target, side)


@pytest.mark.parametrize("robot, joint_3, shoulder_capsule", [("panda", "panda_joint3", "panda_joint2"),
                                                               ("iiwa", "joint_a3", "joint_a2")])
def test_vocabulary_of_a_real_robot_reads_its_model(robot, joint_3, shoulder_capsule):
    """The vocabulary built from the robot's own pinocchio model: velocity rows index its joints."""
    from cobotsafety.arm.controller import ArmController

    state = ArmController(robot).state
    vocabulary = lw.vocabulary_of(SimpleNamespace(dim=3, state=state))
    assert len(vocabulary.joints) == state.nv
    assert lw.describe(f"velocity {state.nv + 2}", vocabulary).joint == joint_3
    assert lw.describe(f"{joint_3} speed", vocabulary).joint == joint_3  # the core's own row name
    assert lw.describe(f"human torso ({shoulder_capsule})", vocabulary).words == "the person's torso near the shoulder"
    assert lw.vocabulary_of(SimpleNamespace(dim=2)).planar


def _report(binding, v_desired=(0.0, 0.0, 0.0), v_commanded=(0.0, 0.0, 0.0), v_executed=(0.0, 0.0, 0.0),
            stopped=False):
    return SimpleNamespace(binding=binding, v_desired_m_s=np.array(v_desired), v_commanded_m_s=np.array(v_commanded),
                           v_executed_m_s=np.array(v_executed), stopped=stopped)


def test_in_play_drops_limits_a_resting_arm_only_touches():
    """Issue 25 item 11: released on E, the arm rests against it with nothing asked: no highlight."""
    resting = _report(("E extended reach", "human torso (panda_joint4)"))
    assert lw.in_play(resting) == ("human torso (panda_joint4)",)  # a person holding the arm away still shows
    assert lw.in_play(_report(("E extended reach",), v_desired=(0.1, 0.0, 0.0))) == ("E extended reach",)
    assert lw.in_play(_report(("E extended reach",), v_executed=(0.0, 0.01, 0.0))) == ("E extended reach",)
    assert lw.in_play(_report(("B joint 2 lower", "B joint 2 lower"), stopped=True)) == ("B joint 2 lower",)
    assert lw.in_play(_report(("E extended reach",), v_desired=(np.nan, 0.0, 0.0))) == ()
    assert lw.in_play(None) == ()
