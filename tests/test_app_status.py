"""The status block: what is happening in words, always the same number of lines, escaped."""

import re
from types import SimpleNamespace

import numpy as np
import pytest

from cobotsafety.app.limit_words import RobotVocabulary
from cobotsafety.app.status import STATUS_LINES, StatusFacts, situation, status_html, status_lines

PANDA = RobotVocabulary(tuple(f"panda_joint{k}" for k in range(1, 8)), "panda_joint2", "panda_joint4", "panda_joint6")
ZERO = (0.0, 0.0, 0.0)


def report(binding=(), v_desired=ZERO, v_executed=ZERO, stopped=False, reason="", contradictions=0, evading=False,
           smoothness=False):
    return SimpleNamespace(binding=binding, v_desired_m_s=np.array(v_desired), v_commanded_m_s=np.array(v_executed),
                           v_executed_m_s=np.array(v_executed), stopped=stopped, reason=reason,
                           contradictions=contradictions, evading=evading, safety_over_smoothness=smoothness)


def facts(rep, **kw):
    base = dict(method="anticipative", rate_hz=998.4, report=rep, p_base_ee_m=np.array([0.4831, -0.0004, 0.4132]),
                vocabulary=PANDA, dim=3, ssm=False)
    return StatusFacts(**{**base, **kw})


@pytest.mark.parametrize("rep, kw, sentence", [
    (None, {}, "Holding its pose: drag the arrow handle, or press Play under Replay to bring a person in."),
    (report(), {"replay_playing": True}, "Nobody in view of the scanner: the arm holds its pose."),
    (report(), {"human_present": True, "distance_m": 0.8}, "A person is in view; the arm holds its pose."),
    (report(("human forearm_right (panda_joint4)",), v_executed=(0.0, -0.1, 0.0)), {"human_present": True},
     "Giving way: the person's right forearm near the elbow."),
    (report(("human forearm_right (panda_joint4)",)), {"human_present": True},  # held away, not moving
     "Giving way: the person's right forearm near the elbow."),
    (report(v_executed=(0.0, -0.1, 0.0), evading=True), {"human_present": True, "distance_m": 0.45},
     "Moving out of the person's way."),
    (report(("human torso (panda_joint4)",), evading=True), {"human_present": True},  # a row binds too: named
     "Giving way: the person's torso near the elbow."),
    (report(("panda_joint4 upper", "velocity 9", "table (panda_joint7)"), v_desired=(0.1, 0.0, 0.0),
            v_executed=(0.0, 0.05, 0.0)), {},
     "Sliding along joint 4 at its upper end; joint 3 at its speed limit (+1 more)."),
    (report(("B joint 2 upper", "F triangle"), v_desired=(0.1, 0.0)), {"vocabulary": RobotVocabulary(planar=True)},
     "Held at B: joint 2 at its upper end; F: the triangle: as close to your drag as it allows."),  # Fig. 9 a, in the V
    (report(("E extended reach",)), {"dim": 2, "vocabulary": RobotVocabulary(planar=True)},  # released on E
     "Waiting: drag the arrow handle to move the arm."),
    (report(("B joint 2 lower",), v_desired=(0.1, 0.0), stopped=True), {"vocabulary": RobotVocabulary(planar=True)},
     "Stopped: B: joint 2 at its lower end."),
    (report(v_desired=(0.1, 0.0, 0.0)), {}, "Following your drag: nothing in the way."),
    (report(v_executed=(0.05, 0.0, 0.0)), {}, "Going back to where you left it."),
    (report(reason="retreats contradict", contradictions=23771), {},
     "Limits conflict: the arm yields to each as little as it can."),
    (report(("human torso (panda_joint4)",), v_executed=(0.0, -0.1, 0.0), smoothness=True,
            reason="safety over smoothness: the joints' motion limits gave way"), {"human_present": True},
     "Safety over smoothness: the joints' motion limits gave way."),  # not "limits conflict": the motion's
    (report(("velocity 9",), v_desired=(0.1, 0.0, 0.0)), {"method": "off"},
     "Filter off: the arm follows the drag; only its joints' ends hold it."),
    (report(), {"replay_state": "exp1: reading it"}, "The arm holds its pose (exp1: reading it)."),
])
def test_situation_says_what_happens_in_words(rep, kw, sentence):
    assert situation(facts(rep, **kw)) == sentence


def test_lines_name_limits_distance_mode_and_position_without_internal_names():
    lines = status_lines(facts(report(("human forearm_right (panda_joint2)", "velocity 9"), v_desired=(0.1, 0, 0),
                                      reason="", contradictions=23771),
                               human_present=True, distance_m=0.2234, critical_m=0.25, ssm=True))
    assert len(lines) == STATUS_LINES
    text = " ".join(lines)
    assert "Limits met: <b>the person&#x27;s right forearm near the shoulder; joint 3 at its speed limit</b>" in text
    assert "Person: <b>223 mm</b> from the arm (aim: &ge; 250 mm)" in text
    assert "Mode <b>anticipative</b> · SSM <b>on</b> · loop <b>1000 Hz</b>" in text  # 998.4 to the 10 Hz step
    assert "EE x=483.1 y=-0.4 z=413.2 mm" in text
    for internal in ("velocity 9", "forearm_right", "panda_joint", "23771", "contradicting"):
        assert internal not in text


def test_planar_and_stale_lines():
    planar = status_lines(facts(None, dim=2, ssm=None, vocabulary=RobotVocabulary(planar=True)))
    assert len(planar) == STATUS_LINES and planar[2] == "" and "SSM" not in planar[3]
    stale = status_lines(facts(report(), stale_reason="laser 0.4 s old <b>", human_present=True))
    assert stale[2] == "Person: <b>sensor stale</b>, laser 0.4 s old &lt;b&gt;"


def test_the_watchdogs_word_and_the_acceleration_limit_are_shown():
    """The controller being careful with an old human model, a step whose motion the
    acceleration or jerk limits shaped (issue 20 item 7: whose, in a reader's words), and one
    whose hand went over its own limits, each say so on their line; a fresh step says none."""
    careful = status_lines(facts(report(), human_present=True, distance_m=0.5,
                                 careful="human model 0.12 s old: grown by 0.14 m <b>"))
    assert careful[2] == "Person: <b>human model 0.12 s old: grown by 0.14 m &lt;b&gt;</b>"
    limited = status_lines(facts(report(v_desired=(0.1, 0.0, 0.0)),
                                 motion_limited=("panda_joint2 acceleration", "end-effector acceleration")))
    assert limited[4] == "Motion: <b>acceleration-limited</b> by joint 2; the hand"
    assert limited[3] == "Mode <b>anticipative</b> · SSM <b>off</b> · loop <b>1000 Hz</b>"  # the mode line alone
    many = status_lines(facts(report(), motion_limited=tuple(f"panda_joint{k} acceleration" for k in (1, 3, 6, 7))))
    assert many[4] == "Motion: <b>acceleration-limited</b> by joint 1; joint 3 (+2 more)"
    fresh = status_lines(facts(report(v_desired=(0.1, 0.0, 0.0)), human_present=True, distance_m=0.5))
    assert fresh[4] == "Motion: within the robot's limits" and fresh[2] == "Person: <b>500 mm</b> from the arm"
    assert "hand over its limit" not in "".join(fresh) and "hand over its limit" not in "".join(limited)
    over = status_lines(facts(report(v_desired=(0.1, 0.0, 0.0)), motion_limited=("panda_joint4 acceleration",),
                              hand_over_limit=True))
    assert over[4] == "Motion: <b>acceleration-limited</b> by joint 4 · <b>hand over its limit</b>"
    alone = status_lines(facts(report(), hand_over_limit=True))
    assert alone[4] == "Motion: <b>hand over its limit</b>"  # never "within the robot's limits" beside it
    assert over[5] == alone[5] == "EE x=483.1 y=-0.4 z=413.2 mm"  # the hand's position line as before


def test_html_block_has_fixed_height_and_fixed_rows_whatever_the_text():
    short = status_html(("one",))
    long = status_html(tuple(f"line {i} " + "word " * 60 for i in range(9)))
    for block in (short, long):
        assert block.count('class="cobotsafety-status-line"') == STATUS_LINES
        assert re.search(r'class="cobotsafety-status" style="height:[0-9.]+em;overflow:hidden', block)
        rows = re.findall(r'class="cobotsafety-status-line"[^>]*style="([^"]*)"', block)
        assert "-webkit-line-clamp:2" in rows[0] and "height:3.1em" in rows[0]  # the sentence: two rows at most
        assert all("white-space:nowrap" in row and "height:1.55em" in row for row in rows[1:])
    assert re.search(r"height:([0-9.]+)em", short).group(1) == re.search(r"height:([0-9.]+)em", long).group(1)
    assert 'title="Giving way: the person&#x27;s arm"' in status_html(("<b>Giving way: the person&#x27;s arm</b>",))
