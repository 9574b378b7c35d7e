"""The status block: what is happening, in words, in a box whose height never changes.

``status_lines`` reads one control-loop report (and the human shown with it) and returns
``STATUS_LINES`` lines, always that many: a sentence saying what the arm is doing and why, the
limits it meets (``limit_words``), the person's distance, the mode and loop rate, the motion
against the robot's own limits (which joints' or the hand's acceleration shaped the step; the
hand over its limit), and the hand's position. ``status_html`` lays them out in a fixed-height
block, one line each (too long: cut with an ellipsis, the whole line in its tooltip), so the
buttons below never move while the replay plays. Every piece of text from outside (reasons,
names) is HTML-escaped.
"""

from __future__ import annotations

import html
from dataclasses import dataclass

import numpy as np

from cobotsafety.app.limit_words import (HAND_ACCELERATION, HUMAN, JOINT_ACCELERATION, RobotVocabulary, describe,
                                          in_play)

STATUS_LINES = 6
SENTENCE_ROWS = 2
"""The sentence may wrap once; every other line keeps to one row."""
LINE_HEIGHT_EM = 1.55
RATE_STEP_HZ = 10.0
"""The loop rate is shown to this step [Hz] (its last digits changed at every refresh)."""
SHOWN_LIMITS = 2
"""Limits named in the sentence and the "limits met" line; more are counted ("+2 more")."""


@dataclass(frozen=True)
class StatusFacts:
    """What one status refresh reads; the distance comes from the same report as the scene's."""

    method: str
    rate_hz: float
    report: object | None
    """The loop's last ``StepReport`` (None before the first step)."""
    p_base_ee_m: np.ndarray
    vocabulary: RobotVocabulary = RobotVocabulary()
    dim: int = 3
    ssm: bool | None = None
    """SSM on/off (3D); None hides it."""
    distance_m: float | None = None
    """The robot-human minimum distance shown everywhere [m]; None when nobody is modelled."""
    critical_m: float | None = None
    """The distance the controller keeps [m], when it says."""
    human_present: bool = False
    stale_reason: str = ""
    """Why the sensors are stale ("" when fresh)."""
    replay_playing: bool = False
    replay_state: str = ""
    """"" when the replay is ready, else why it is not (e.g. "loading exp1")."""
    careful: str = ""
    """The controller's word on old or missing human data ("" when fresh): slower, then stopped."""
    motion_limited: tuple[str, ...] = ()
    """Whose acceleration or jerk limit shaped this step's motion (``ArmStepReport.motion_limited``:
    ``"<joint> acceleration"``, ``"end-effector acceleration"``); () when none did."""
    hand_over_limit: bool = False
    """The hand's executed path went over the robot's end-effector acceleration or jerk limit
    (its curvature: ``ArmStepReport.hand_over_limit``) within the last second
    (``control_loop.HAND_OVER_SHOWN_S``)."""
    failure: str = ""
    """Why the control loop stopped ("" while it runs)."""


def _limits(facts: StatusFacts) -> list:
    return [describe(name, facts.vocabulary) for name in in_play(facts.report)]


def _listed(limits: list) -> str:
    return _counted([limit.words for limit in limits])


def _counted(words: list) -> str:
    """The first ``SHOWN_LIMITS`` words, the rest counted ("(+2 more)")."""
    more = len(words) - SHOWN_LIMITS
    return "; ".join(words[:SHOWN_LIMITS]) + (f" (+{more} more)" if more > 0 else "")


def situation(facts: StatusFacts) -> str:
    """One sentence: what the arm is doing now and why."""
    report = facts.report
    limits = _limits(facts)
    human = [limit for limit in limits if limit.kind == HUMAN]
    others = [limit for limit in limits if limit.kind != HUMAN]
    driven = report is not None and _speed(report.v_desired_m_s) > 1e-3
    moving = report is not None and _speed(report.v_executed_m_s) > 1e-3
    if facts.failure:
        return f"Control stopped: {facts.failure}."
    if facts.method == "off":
        return "Filter off: the arm follows the drag; only its joints' ends hold it."
    if report is not None and report.stopped:
        cause = _listed(limits) or (report.reason or "a limit in the way")
        return f"Stopped: {cause}."
    if report is not None and report.reason:
        if report.safety_over_smoothness:  # whose motion limits gave way, and why
            return f"{report.reason[:1].upper()}{report.reason[1:]}."
        return "Limits conflict: the arm yields to each as little as it can."
    if human:
        return f"Giving way: {human[0].words}."
    if report is not None and report.evading:
        return "Moving out of the person's way."
    if others and driven and not moving:
        return f"Held at {_listed(others)}: as close to your drag as it allows."
    if others and driven:
        return f"Sliding along {_listed(others)}."
    if driven:
        return "Following your drag: nothing in the way."
    if moving:
        return "Going back to where you left it."
    if facts.dim == 2:
        return "Waiting: drag the arrow handle to move the arm."
    if facts.human_present:
        return "A person is in view; the arm holds its pose."
    if facts.replay_state:
        return f"The arm holds its pose ({facts.replay_state})."
    if facts.replay_playing:
        return "Nobody in view of the scanner: the arm holds its pose."
    return "Holding its pose: drag the arrow handle, or press Play under Replay to bring a person in."


def status_lines(facts: StatusFacts) -> tuple[str, ...]:
    """``STATUS_LINES`` lines of HTML-safe text (``<b>`` marks the values)."""
    e = html.escape
    limits = _limits(facts)
    met = f"Limits met: <b>{e(_listed(limits))}</b>" if limits else "Limits met: none"
    if facts.dim != 3:
        person = ""
    elif facts.stale_reason:
        person = f"Person: <b>sensor stale</b>, {e(facts.stale_reason)}"
    elif facts.careful:
        person = f"Person: <b>{e(facts.careful)}</b>"
    elif facts.distance_m is None:
        person = "Person: not in view"
    else:
        kept = f" (aim: &ge; {facts.critical_m * 1e3:.0f} mm)" if facts.critical_m is not None else ""
        person = f"Person: <b>{facts.distance_m * 1e3:.0f} mm</b> from the arm{kept}"
    monitoring = "" if facts.ssm is None else f" · SSM <b>{'on' if facts.ssm else 'off'}</b>"
    rate = round(facts.rate_hz / RATE_STEP_HZ) * RATE_STEP_HZ  # the block is re-sent only when it changes
    mode = f"Mode <b>{e(facts.method)}</b>{monitoring} · loop <b>{rate:.0f} Hz</b>"
    x, y, z = (float(c) * 1e3 for c in facts.p_base_ee_m)
    where = f"EE x={x:.1f} y={y:.1f} z={z:.1f} mm"
    return (f"<b>{e(situation(facts))}</b>", met, person, mode, _motion(facts), where)


def _motion(facts: StatusFacts) -> str:
    """The motion against the robot's own limits: "within the robot's limits", or whose
    acceleration limit shaped the step ("acceleration-limited by joint 2; the hand"), and "hand
    over its limit" while the hand's executed path is over its own limits."""
    shaped = [_whose(describe(name, facts.vocabulary), facts.vocabulary) for name in facts.motion_limited]
    words = []
    if shaped:
        words.append(f"<b>acceleration-limited</b> by {html.escape(_counted(shaped))}")
    if facts.hand_over_limit:
        words.append("<b>hand over its limit</b>")
    return "Motion: " + (" · ".join(words) or "within the robot's limits")


def _whose(limit, vocabulary: RobotVocabulary) -> str:
    """Whose acceleration limit a motion row is: "joint 2", "the hand" (else its words)."""
    if limit.kind == JOINT_ACCELERATION:
        return vocabulary.joint_words(limit.joint)
    return "the hand" if limit.kind == HAND_ACCELERATION else limit.words


def status_html(lines: tuple[str, ...]) -> str:
    """The lines in a block of fixed height: the sentence on up to ``SENTENCE_ROWS`` rows, each
    other line on one row; longer text is cut with an ellipsis (the whole line in its tooltip)."""
    rows = []
    for index, line in enumerate((*lines, *("",) * STATUS_LINES)[:STATUS_LINES]):
        tip = html.escape(html.unescape(line.replace("<b>", "").replace("</b>", "")), quote=True)
        count = SENTENCE_ROWS if index == 0 else 1
        fit = ("white-space:nowrap;text-overflow:ellipsis" if count == 1 else
               f"display:-webkit-box;-webkit-box-orient:vertical;-webkit-line-clamp:{count}")
        rows.append(f'<div class="cobotsafety-status-line" title="{tip}" style="overflow:hidden;{fit};'
                    f'height:{count * LINE_HEIGHT_EM}em">{line or "&nbsp;"}</div>')
    height = (STATUS_LINES - 1 + SENTENCE_ROWS) * LINE_HEIGHT_EM
    return (f'<div class="cobotsafety-status" style="height:{height:.2f}em;overflow:hidden;'
            f'line-height:{LINE_HEIGHT_EM}em;font-size:0.875rem;padding:0 0.75em">{"".join(rows)}</div>')


def _speed(v) -> float:
    v = np.asarray(v, dtype=float)
    return float(np.linalg.norm(v)) if v.size and np.all(np.isfinite(v)) else 0.0
