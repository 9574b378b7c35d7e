"""``ArmController`` with a human: the strategies against a static and a moving human, the
human's velocity, ISO/TS 15066 SSM, the human watchdog, dropouts, contradictions and the yield,
paper 2's field, and a person walking at the held arm.

Separations come from the oracle (``oracles.geometry.capsule_pair`` on pinocchio's capsules),
never from the compiled step."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from cobotsafety.arm.controller import YIELD_DWELL_S, ArmController, HumanWatchdog
from cobotsafety.arm.filter_settings import FilterSettings
from cobotsafety.arm.limitations import BoxZone, HumanLimitation
from cobotsafety.arm.ssm import SsmParams
from cobotsafety.arm.motion_box import EE_MOTION_SHARE
from cobotsafety.human.body import HumanCapsules
from oracles import limitations as oracle
from oracles.geometry import capsule_pair
from oracles.kinematics import Kinematics

DT = 0.004
#: The rows alone, without the evasion the anticipative command gets next to a person
#: (``FilterSettings.evasion_gain``): the tests of how each row bounds the motion.
SLIDING = FilterSettings(evasion_gain=0.0)


def torso(p, radius: float = 0.12, v=None, height=(-0.3, 0.4), ages_s=None) -> HumanCapsules:
    """One upright capsule around ``p`` [m]; ``v`` (3,) its velocity [m/s] (None: unknown, still)."""
    p = np.asarray(p, dtype=float)
    velocity = None if v is None else np.tile(np.asarray(v, dtype=float), (1, 1))
    return HumanCapsules([p + [0, 0, height[0]]], [p + [0, 0, height[1]]], [radius], ("torso",),
                         v0_b_m_s=velocity, v1_b_m_s=velocity, ages_s=ages_s or {})


def separation(controller: ArmController, human: HumanCapsules, skip: int = 1) -> float:
    """Oracle: the smallest distance [m] between the robot's capsules (from ``skip`` on) and the
    human's, from pinocchio's kinematics."""
    kin = Kinematics(controller.model, controller.state.q)
    return min(capsule_pair(kin.p0[c], kin.p1[c], kin.radius[c], human.p0_b_m[h], human.p1_b_m[h],
                            human.radius_m[h])[0]
               for c in range(skip, len(kin.radius)) for h in range(len(human.names)))


def drive(controller, human, v, method, steps, ssm=None):
    """``steps`` steps of ``v`` with ``human`` given before each; the oracle's separations and
    the reports."""
    distances, reports = [], []
    for _ in range(steps):
        controller.set_human(human)
        reports.append(controller.step(np.asarray(v, dtype=float), DT, method))
        distances.append(separation(controller, human))
    return np.array(distances), reports


def beside(controller, offset=(0.0, 0.55, 0.0), **kwargs) -> HumanCapsules:
    return torso(controller.p_base_ee_m + np.asarray(offset), **kwargs)


def test_the_report_gives_the_human_distance_and_clearing_removes_it():
    controller = ArmController("panda")
    human = beside(controller)
    controller.set_human(human)
    report = controller.step(np.zeros(3), DT)
    assert report.min_distance_m == pytest.approx(separation(controller, human), abs=1e-9)
    controller.clear_human()
    assert controller.step(np.zeros(3), DT).min_distance_m is None


def test_anticipative_slides_past_the_human_and_off_runs_into_them():
    v = np.array([0.08, 0.2, 0.0])  # mostly at the human, a little along them
    controller = ArmController("panda", settings=SLIDING)
    critical = controller.human.critical_m
    human = beside(controller)
    start = controller.p_base_ee_m
    distances, reports = drive(controller, human, v, "anticipative", 500)
    assert distances.min() >= critical - 1e-9
    assert any(name.startswith("human") for r in reports for name in r.binding)
    assert controller.p_base_ee_m[0] - start[0] > 0.05  # it kept moving along the human: sliding

    blind = ArmController("panda", settings=SLIDING)
    distances_off, _ = drive(blind, human, v, "off", 500)
    assert distances_off.min() < critical - 0.05  # the same command without the filter closes in


@pytest.mark.parametrize("method", ["stop", "reactive"])
def test_stop_and_reactive_never_cross_the_critical_distance_of_a_static_human(method):
    controller = ArmController("panda")
    human = beside(controller)
    distances, reports = drive(controller, human, [0.0, 0.2, 0.0], method, 500)
    critical = controller.human.critical_m if method == "stop" else controller.settings.field_critical_m
    assert distances.min() >= critical - 1e-9
    assert distances.min() < critical + 0.1  # it did come close
    if method == "reactive":  # the field held it, not its stop at d_cr
        assert not any(r.stopped for r in reports)
    else:
        assert reports[-1].stopped


def walking_at_the_hand(method: str, with_velocity: bool, steps: int = 900):
    """A torso walks at the hand at 0.3 m/s for 1.5 s, then stands; the arm is asked to hold."""
    controller = ArmController("panda")
    start = controller.p_base_ee_m + np.array([0.0, 0.75, 0.0])
    v = np.array([0.0, -0.3, 0.0])
    distances, reports = [], []
    for i in range(steps):
        walking = i * DT < 1.5
        human = torso(start + v * min(i * DT, 1.5), v=(v if walking else np.zeros(3)) if with_velocity else None)
        controller.set_human(human)
        reports.append(controller.step(np.zeros(3), DT, method))
        distances.append(separation(controller, human))
    return controller, np.array(distances), reports


def test_a_moving_human_anticipative_keeps_the_distance_and_stop_halts():
    controller, distances, _ = walking_at_the_hand("anticipative", with_velocity=True)
    assert distances.min() >= controller.human.critical_m - 1e-9  # gives way every step
    stopper, d_stop, reports = walking_at_the_hand("stop", with_velocity=True)
    assert max(np.linalg.norm(r.v_executed_m_s) for r in reports) < 1e-4  # holds still ...
    assert d_stop.min() < stopper.human.critical_m - 0.05  # ... and the human closes in on it


def test_the_human_velocity_enters_as_the_rate_of_the_distance():
    """A human 2 cm beyond the critical distance: standing, the held arm stays put; walking at
    it (the same position, a velocity), the arm gives way at once; walking away, it stays."""
    moved = {}
    for name, v in (("still", None), ("toward", (0.0, -0.5, 0.0)), ("away", (0.0, 0.5, 0.0))):
        controller = ArmController("panda", settings=SLIDING)
        start = controller.p_base_ee_m
        probe = beside(controller, offset=(0.0, 0.6, 0.0))
        d = separation(controller, probe)
        human = beside(controller, offset=(0.0, 0.6 - (d - controller.human.critical_m - 0.02), 0.0), v=v)
        assert separation(controller, human) == pytest.approx(controller.human.critical_m + 0.02, abs=0.005)
        for _ in range(20):  # 80 ms
            controller.set_human(human)  # the frame is fresh: extrapolated by 0 s
            controller.step(np.zeros(3), DT)
        moved[name] = controller.p_base_ee_m - start
    assert np.linalg.norm(moved["still"]) < 1e-6
    assert np.linalg.norm(moved["away"]) < 1e-6
    assert moved["toward"][1] < -3e-4  # away from the human (-y), though no distance changed


def test_ssm_slows_the_approach_but_not_the_retreat():
    """With speed scaling the arm's approach to the human (the oracle's separation, differenced)
    is at most ISO/TS 15066's speed for the separation; without it the same command approaches
    faster. Commanded away, the two runs are the same."""
    from cobotsafety.arm.ssm import max_approach_speed_m_s

    runs = {}
    for ssm in ("off", "scaling"):
        for v in ((0.0, 0.3, 0.0), (0.0, -0.3, 0.0)):
            controller = ArmController("panda", settings=SLIDING, zones=[], ssm=ssm,
                                       human=HumanLimitation(critical_m=0.05, activation_m=2.0))
            human = beside(controller, offset=(0.0, 0.45, 0.0), radius=0.05, height=(0.0, 0.0))
            runs[ssm, v[1] > 0] = drive(controller, human, v, "anticipative", 60)
    excess = {}
    for ssm in ("off", "scaling"):
        d = runs[ssm, True][0]
        approach = -np.diff(d) / DT
        allowed = np.array([float(max_approach_speed_m_s(x, SsmParams())) for x in d[:-1]])
        excess[ssm] = float(np.max(approach - allowed))
    assert excess["scaling"] <= 1e-3  # first-order rows: the approach within the scaled speed
    assert excess["off"] > 0.05  # without scaling the same command approaches faster
    away_off, away_scaling = runs["off", False][1], runs["scaling", False][1]
    for a, b in zip(away_off, away_scaling):
        np.testing.assert_allclose(b.v_executed_m_s, a.v_executed_m_s, atol=1e-12)  # not slowed
    assert away_off[-1].v_executed_m_s[1] == pytest.approx(-0.3, abs=0.01)


def test_the_ssm_protective_stop_keeps_the_protective_distance_at_rest():
    """ISO/TS 15066's protective stop: the arm brakes while the separation is below S at its
    approach speed; it never gets closer than S at rest (the human's reaction-time travel and
    the uncertainties, 0.22 m here), where the filter alone would go on to d_cr (0.05 m)."""
    from cobotsafety.arm.ssm import protective_separation_m

    s_at_rest = float(protective_separation_m(0.0, SsmParams()))
    closest = {}
    for ssm in ("off", "stop"):
        controller = ArmController("panda", settings=SLIDING, zones=[], ssm=ssm, human=HumanLimitation(critical_m=0.05, activation_m=2.0))
        human = beside(controller, offset=(0.0, 0.6, 0.0), radius=0.05, height=(0.0, 0.0))
        distances, reports = drive(controller, human, [0.0, 0.3, 0.0], "anticipative", 400)
        closest[ssm] = distances.min()
        stops = [r for r in reports if "protective stop" in r.reason]
        assert bool(stops) == (ssm == "stop") and all(r.stopped for r in stops)
    assert closest["stop"] >= s_at_rest - 1e-3
    assert closest["off"] < s_at_rest - 0.1


def test_the_protective_stop_holds_until_the_arm_could_go_at_its_full_speed():
    """A stopped arm's S is the smallest (it approaches at 0): a stop released there lets the arm
    go, reach S at its new speed and stop again, every few steps while the separation hovers at
    S (224 stop/go transitions in paper 2's exp1). The stop holds until the separation is S at
    the speed cap: one stop while the person stays, still held a little inside S at the cap
    (well beyond S at rest), and the arm goes again beyond it. Fails with the stop released at
    S for the arm's speed now (several stops; going again inside S at the cap)."""
    from cobotsafety.arm.ssm import protective_separation_m

    controller = ArmController("panda", settings=SLIDING, zones=[], ssm="stop",
                               human=HumanLimitation(critical_m=0.05, activation_m=2.0))
    cap = min(controller.settings.max_speed_m_s, controller.model.limits.ee_speed_m_s)
    s_rest, s_cap = (float(protective_separation_m(v, SsmParams())) for v in (0.0, cap))
    human = beside(controller, offset=(0.0, 0.6, 0.0), radius=0.05, height=(0.0, 0.0))
    _, reports = drive(controller, human, [0.0, 0.3, 0.0], "anticipative", 400)
    held = [r.protective_stop for r in reports]
    assert sum(b and not a for a, b in zip([False, *held], held)) == 1 and held[-1]

    def moved_to(target):  # the person steps back along y until the separation is ``target``
        return beside(controller, offset=(0.0, 0.6 + target - first_stop, 0.0), radius=0.05, height=(0.0, 0.0))

    first_stop = separation(controller, human)
    human = moved_to(s_cap - 0.03)
    assert separation(controller, human) == pytest.approx(s_cap - 0.03, abs=0.005) and s_cap - 0.03 > s_rest + 0.1
    distances, reports = drive(controller, human, [0.0, 0.3, 0.0], "anticipative", 100)
    assert all(r.protective_stop and r.stopped for r in reports)
    assert np.ptp(distances) < 1e-6  # standing still
    human = moved_to(s_cap + 0.03)
    _, reports = drive(controller, human, [0.0, 0.3, 0.0], "anticipative", 20)
    assert not reports[0].protective_stop and reports[-1].v_executed_m_s[1] > 0.01


def test_a_larger_stale_human_never_lets_the_robot_approach_faster():
    speeds = []
    for radius in (0.05, 0.15, 0.3):  # the degraded model grows while the sensors are silent
        controller = ArmController("panda", settings=SLIDING)
        human = beside(controller, offset=(0.0, 0.7, 0.0), radius=radius)
        _, reports = drive(controller, human, [0.0, 0.4, 0.0], "anticipative", 80)
        speeds.append([r.v_executed_m_s[1] for r in reports])
    speeds = np.array(speeds)
    assert np.all(speeds[0] >= speeds[1] - 1e-9) and np.all(speeds[1] >= speeds[2] - 1e-9)
    assert speeds[0, -1] > speeds[2, -1] + 0.01  # and the radius did matter


def old_human_run(steps: int):
    """A human 1.2 m from the hand, given once (its laser data 10 ms old then), never refreshed;
    the arm commanded at 0.1 m/s. Per step: the model's age when read, the report, the oracle's
    separation to the human as given."""
    watchdog = HumanWatchdog(grow_after_s=0.05, stop_after_s=0.5, growth_speed_m_s=2.0)
    controller = ArmController("panda", settings=SLIDING, watchdog=watchdog, zones=[])
    human = beside(controller, offset=(0.0, 1.5, 0.0), ages_s={"laser": 0.01})
    controller.set_human(human)
    log = []
    for i in range(steps):
        age = i * DT + 0.01  # the model's age when the step reads it
        report = controller.step(np.array([0.1, 0.0, 0.0]), DT)
        log.append((age, report, separation(controller, human)))
    return controller, watchdog, human, log


def test_the_watchdog_grows_an_old_human_then_stops_the_arm():
    controller, watchdog, human, log = old_human_run(140)
    for age, report, exact in log:
        grown = watchdog.growth_speed_m_s * max(age - watchdog.grow_after_s, 0.0)
        assert report.min_distance_m == pytest.approx(exact - grown, abs=1e-9)  # grown by 2 m/s x excess age
        if age <= watchdog.grow_after_s - 1e-9:
            assert report.human_status == "" and not report.stopped
        elif age <= watchdog.stop_after_s - 1e-9:
            assert "grown" in report.human_status and not report.stopped
            assert np.linalg.norm(report.v_executed_m_s) == pytest.approx(0.1, abs=1e-3)  # still going
        elif age > watchdog.stop_after_s + 1e-9:
            assert "stopped" in report.human_status and report.stopped
    assert np.linalg.norm(log[-1][1].v_executed_m_s) < 0.02  # braking
    controller.set_human(human)  # a fresh frame: the arm goes again
    report = controller.step(np.array([0.1, 0.0, 0.0]), DT)
    assert report.human_status == "" and not report.stopped


def test_the_watchdog_stop_holds_the_arm_at_rest():
    _, watchdog, _, log = old_human_run(200)
    late = [report for age, report, _ in log if age > watchdog.stop_after_s + 0.1]
    assert all(report.stopped for report in late)
    assert max(np.linalg.norm(report.v_executed_m_s) for report in late) < 1e-3


@pytest.mark.parametrize("stale", [True, False])
def test_an_absence_the_sensors_cannot_vouch_for_stops_the_arm_a_fresh_nobody_does_not(stale):
    """Nobody in the model: flagged stale (the laser silent, so nobody is *known* to be there),
    the watchdog stops the arm once it is older than ``stop_after_s``, as for a person; a fresh
    "nobody in range" lets it go on."""
    watchdog = HumanWatchdog(grow_after_s=0.05, stop_after_s=0.5, growth_speed_m_s=2.0)
    controller = ArmController("panda", watchdog=watchdog, zones=[])
    reason = "laser silent: human position unknown" if stale else "nobody in range"
    controller.set_human(HumanCapsules.absent(0.0, reason, stale=stale))
    reports = [controller.step(np.array([0.05, 0.0, 0.0]), DT) for _ in range(int(0.7 / DT))]
    early = [r for k, r in enumerate(reports) if (k + 1) * DT < watchdog.stop_after_s - 1e-9]
    late = [r for k, r in enumerate(reports) if k * DT > watchdog.stop_after_s + 1e-9]
    assert early and late and not any(r.stopped for r in early)
    if stale:
        assert all(r.stopped and "silent" in r.human_status for r in late)
    else:
        assert not any(r.stopped for r in late) and all(r.human_status == "" for r in late)


def test_a_dropout_keeps_the_last_human_and_clear_human_forgets_it():
    controller = ArmController("panda")
    human = beside(controller)
    controller.set_human(human)
    for _ in range(5):  # no new frame (within grow_after_s): the last human, as it was
        report = controller.step(np.zeros(3), DT)
        assert report.min_distance_m == pytest.approx(separation(controller, human), abs=1e-9)
    controller.clear_human()
    for _ in range(200):  # cleared: no human, and the watchdog rests (0.8 s > stop_after_s)
        report = controller.step(np.array([0.05, 0.0, 0.0]), DT)
        assert report.min_distance_m is None and report.human_status == "" and not report.stopped
    assert controller.human_age_s() == 0.0


def test_reactive_respects_the_protection_zones_it_does_not_know():
    controller = ArmController("panda", zones=[])
    p = controller.p_base_ee_m
    box = BoxZone("box", (p[0], p[1] + 0.3, p[2]), (0.1, 0.05, 0.08))
    controller.zones = [box]
    human = beside(controller, offset=(0.0, 1.5, 0.0))  # far: only the zone matters

    def clearance() -> float:
        kin = Kinematics(controller.model, controller.state.q)
        return float(oracle.exact_distances(box, kin, oracle.Human.none()).min())

    assert clearance() > 0.05  # clear at the start
    worst, pushed = np.inf, False
    for _ in range(400):
        controller.set_human(human)
        report = controller.step(np.array([0.0, 0.2, 0.0]), DT, "reactive")
        pushed |= any(name.startswith("box") for name in report.binding)
        worst = min(worst, clearance())
    assert worst >= -1e-9
    assert worst < 0.01  # it came up to the box ...
    assert pushed  # ... and slid on it (not only the safety net)


def test_a_fast_human_never_makes_the_hand_flee_faster_than_the_robots_own_limit():
    """Retreat rows of capsules near the base once asked the hand for ~2 m/s. The command's cap
    (0.5 m/s) is planned and gives way to a retreat from a person walking at the arm at 1.5 m/s;
    the robot's own end-effector speed limit (panda 1.7 m/s, libfranka) never does."""
    controller = ArmController("panda")
    cap = controller.settings.max_speed_m_s
    start = controller.state.capsule_p1[2] - np.array([0.0, 0.9, 0.0])  # beside the upper arm
    fastest = 0.0
    for i in range(300):
        p = start + np.array([0.0, 1.5, 0.0]) * min(i * DT, 0.5)  # 1.5 m/s at the arm
        walking = i * DT < 0.5
        controller.set_human(HumanCapsules([p + [0, 0, -0.4]], [p + [0, 0, 0.4]], [0.15], ("torso",),
                                           v0_b_m_s=[[0.0, 1.5 if walking else 0.0, 0.0]],
                                           v1_b_m_s=[[0.0, 1.5 if walking else 0.0, 0.0]]))
        report = controller.step(np.zeros(3), DT, "anticipative")
        fastest = max(fastest, float(np.linalg.norm(report.v_executed_m_s)))
    assert cap < fastest <= controller.model.limits.ee_speed_m_s * 1.05  # a few % of curvature over a step


def test_the_anticipative_arm_flees_a_walking_person_faster_than_the_commands_cap():
    """A person walking at the panda's hand at 1.6 m/s (ISO 13855's walking speed) who stops at
    it, the user commanding nothing: the hand retreats faster than the command's cap (0.5 m/s:
    held there, the arm breached people it could have escaped, issue 24) and no faster than the
    filter's planning share of the robot's own end-effector speed (``EE_MOTION_SHARE`` x 1.66
    m/s, a planned cap: met to a few %; the rest is the reserve the hard limit keeps: at the
    full speed a hand fleeing at the limit gave up smoothness the step the person stopped)."""
    controller = ArmController("panda", zones=[], settings=SLIDING)
    hand = controller.p_base_ee_m.copy()
    fastest = 0.0
    for i in range(int(1.5 / DT)):
        gap = max(1.6 - 1.6 * i * DT, 0.05)
        human = torso(hand + [0.0, gap + 0.12, 0.0], v=(0.0, -1.6 if gap > 0.05 else 0.0, 0.0))
        controller.set_human(human)
        report = controller.step(np.zeros(3), DT)
        fastest = max(fastest, float(np.linalg.norm(report.v_commanded_m_s)))
    flee_cap = EE_MOTION_SHARE * controller.model.limits.ee_speed_m_s
    assert SLIDING.max_speed_m_s * 2.0 < fastest <= flee_cap * 1.05, (fastest, flee_cap)
    assert fastest < controller.model.limits.ee_speed_m_s


def test_a_fleeing_hand_slows_to_the_commands_cap_once_the_person_stops():
    """The person of the test above walks 1.0 s at the panda's hand and stands there; the user
    pulls the hand away at the command's cap, the evasion pushing with it. While they close,
    the hand flees faster than the cap; once they stand, it slows down to the cap within 0.15
    s (at the plan's share of its deceleration) and stays there (held at the flee cap, it went
    on at 0.83 m/s beside a person who had stopped: 0.73-0.83 m/s in this window)."""
    controller = ArmController("panda", zones=[])
    hand = controller.p_base_ee_m.copy()
    y = hand[1] + 1.6 + 0.12
    fastest_walking, after_stop = 0.0, []
    for i in range(int(2.0 / DT)):
        walking = i * DT < 1.0
        if walking:
            y -= 1.6 * DT
        controller.set_human(torso([hand[0], y, hand[2]], v=(0.0, -1.6 if walking else 0.0, 0.0)))
        report = controller.step(np.array([0.0, -0.5, 0.0]), DT)
        speed = float(np.linalg.norm(report.v_commanded_m_s))
        if walking:
            fastest_walking = max(fastest_walking, speed)
        elif i * DT >= 1.15:
            after_stop.append(speed)
    cap = controller.settings.max_speed_m_s
    assert fastest_walking > 1.2 * cap
    assert max(after_stop) <= 1.01 * cap, max(after_stop)


# ---- contradictions and the yield ----------------------------------------------------------------
def pinch(controller: ArmController, rng: np.random.Generator) -> HumanCapsules:
    """Two or three capsules closing on the hand from random sides."""
    k = int(rng.integers(2, 4))
    directions = rng.normal(size=(k, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    p0 = controller.p_base_ee_m + rng.uniform(0.25, 0.45) * directions
    v = -rng.uniform(0.0, 1.0) * directions
    return HumanCapsules(p0, p0 + rng.normal(size=(k, 3)) * 0.2, np.full(k, 0.06), tuple(f"h{i}" for i in range(k)),
                         v0_b_m_s=v, v1_b_m_s=v)


def test_the_contradiction_warning_comes_once_per_episode_with_a_count(caplog):
    controller = ArmController("panda", zones=[])
    p = controller.p_base_ee_m
    sides = np.array([[0.0, 0.3, 0.0], [0.0, -0.3, 0.0]])
    # Standing inside the critical distance on both sides: each asks the arm to drift out (a
    # person walking at it asks only that it can stop, which never contradicts).
    human = HumanCapsules(p + sides, p + sides + [0, 0, 0.3], [0.05, 0.05], ("left", "right"))
    with caplog.at_level(logging.WARNING, logger="cobotsafety.arm.controller"):
        controller.set_human(human)
        reports = [controller.step(np.array([0.0, 0.3, 0.0]), DT) for _ in range(10)]
        assert [r.contradictions for r in reports] == list(range(1, 11))
        assert all("contradict" in r.reason for r in reports)
        assert len([r for r in caplog.records if "contradict" in r.getMessage()]) == 1
        controller.reset()  # a new episode counts afresh and warns again
        controller.set_human(human)
        assert controller.step(np.array([0.0, 0.3, 0.0]), DT).contradictions == 1
        assert len([r for r in caplog.records if "contradict" in r.getMessage()]) == 2


def test_the_anticipative_arm_yields_for_a_dwell_instead_of_stopping_and_going(caplog):
    caplog.set_level(logging.ERROR, logger="cobotsafety.arm.controller")
    rng = np.random.default_rng(0)
    controller = ArmController("panda", zones=[])
    v = np.array([0.0, 0.3, 0.0])
    for _ in range(300):  # a pinch whose retreats leave the arm no motion
        controller.reset()
        controller.set_human(pinch(controller, rng))
        first = controller.step(v, DT)
        if first.reason.startswith("yielding"):
            break
    assert first.stopped and first.reason.startswith("yielding")
    controller.clear_human()  # the contradiction is gone at once ...
    steps = int(round(YIELD_DWELL_S / DT))
    reports = [controller.step(v, DT) for _ in range(steps + 5)]
    assert all(r.stopped and r.reason.startswith("yielding") for r in reports[:steps - 1])  # ... it still yields
    assert not reports[-1].stopped and reports[-1].v_commanded_m_s[1] > 0.0  # then goes, once
    assert all(not r.stopped for r in reports[steps + 1:])


# ---- paper 2's field -----------------------------------------------------------------------------
def test_the_repulsion_is_paper_2_eq_18_along_the_separation():
    """``field_velocity`` with no attraction: the robot's closest point moves at
    ``f = k_rep (d_o / (d - d_cr) - 1)`` (eq. 18), at most ``f_max``, away from the human; zero
    beyond ``d_cr + d_o``; a stop at ``d_cr``. The point's Jacobian: pinocchio's."""
    from compiled_arm import compiled_kinematics, robot
    from cobotsafety.arm.potential_field import field_velocity
    from cobotsafety.arm.step_kernel import unpack_robot

    model = robot("panda")
    unpacked = unpack_robot(model.robot_i, model.robot_f)
    cap_joint, axes, idx_v, support = unpacked[8], unpacked[10], unpacked[6], unpacked[7]
    _, _, _, J6, oR, op, p0, p1 = compiled_kinematics(model, model.home_q)
    kin = Kinematics(model, model.home_q)
    capsule = len(model.capsules) - 2
    p_robot = 0.5 * (p0[capsule] + p1[capsule])
    J_cp = kin.point_jacobian(kin.capsule_joint[capsule], p_robot)
    s = np.array([0.0, 0.6, 0.8])  # from the human to the robot
    critical, influence, k_rep, f_max = 0.2, 0.3, 0.1, 0.5
    J = np.ascontiguousarray(J6[:3])
    for d in (0.21, 0.25, 0.35, 0.45, 0.49, 0.51, 0.8):
        qdot, stopped = field_velocity(J, np.zeros(3), d, capsule, p_robot, p_robot - 0.3 * s, cap_joint, oR, op,
                                       axes, idx_v, support, critical, influence, k_rep, f_max, 1e-9)
        expected = min(k_rep * (influence / (d - critical) - 1.0), f_max) if d < critical + influence else 0.0
        assert not stopped
        np.testing.assert_allclose(J_cp @ qdot, expected * s, atol=1e-6)
    qdot, stopped = field_velocity(J, np.array([0.1, 0.0, 0.0]), critical, capsule, p_robot, p_robot - 0.3 * s,
                                   cap_joint, oR, op, axes, idx_v, support, critical, influence, k_rep, f_max, 1e-9)
    assert stopped and not qdot.any()
    qdot, _ = field_velocity(J, np.zeros(3), 0.35, capsule, p_robot, p_robot - 0.3 * s, cap_joint, oR, op, axes,
                             idx_v, support, critical, influence, k_rep, f_max, 1e-9)
    np.testing.assert_allclose(J_cp @ qdot, [0.0, 0.06, 0.08], atol=1e-6)  # by hand: 0.1 (0.3 / 0.15 - 1) s


# ---- a person walking at the held arm ------------------------------------------------------------
LASER_PERIOD_S = 0.02
TORSO_RADIUS_M = 0.18


def walk_at_the_arm(stop_gap_m: float = 0.35, speed_m_s: float = 1.5, hold_s: float = 1.5, seed: int = 0):
    """The torso walks along -x at the hand from 1.6 m, seen by a 50 Hz laser (1 cm noise, its
    velocity as the person tracker estimates it), stops ``stop_gap_m`` (torso surface to the
    hand's held point), stands ``hold_s``, walks back out and is gone. The gizmo is released
    throughout. Returns per-step logs, the robot and its home."""
    rng = np.random.default_rng(seed)
    controller = ArmController("panda", zones=[])
    home = controller.p_base_ee_m.copy()
    direction = np.array([-1.0, 0.0, 0.0])
    axis_start = home - direction * (1.6 + TORSO_RADIUS_M)
    walk_s = (1.6 - stop_gap_m) / speed_m_s
    total_s = 2 * walk_s + hold_s + 2.5
    frame_t, centre = None, None
    log = {"distance": [], "stopped": [], "executed": []}
    noise, jumps = np.zeros(3), [0.0]
    for i in range(int(total_s / DT)):
        t = i * DT
        t_frame = np.floor(t / LASER_PERIOD_S) * LASER_PERIOD_S
        if t_frame != frame_t:  # a new laser frame: the torso with 1 cm of noise
            travelled = speed_m_s * min(t_frame, walk_s) - speed_m_s * max(t_frame - walk_s - hold_s, 0.0)
            velocity = direction * speed_m_s * (1.0 if t_frame < walk_s else -1.0 if t_frame > walk_s + hold_s else 0.0)
            new_noise = rng.normal(scale=0.01, size=3) * [1, 1, 0]
            jumps.append(float(np.linalg.norm(new_noise - noise)))  # how far the model teleports
            noise = new_noise
            centre = axis_start + direction * travelled + noise
            frame_t = t_frame
        gone = t_frame > 2 * walk_s + hold_s + 0.3
        if gone:
            controller.clear_human()
        else:
            human = HumanCapsules([centre + [0, 0, -0.6]], [centre + [0, 0, 0.5]], [TORSO_RADIUS_M], ("torso",),
                                  t_s=t, ages_s={"laser": t - t_frame}, v0_b_m_s=[velocity], v1_b_m_s=[velocity])
            controller.set_human(human)
        report = controller.step(np.zeros(3), DT)
        log["distance"].append(np.inf if gone else separation(controller, human))
        log["stopped"].append(report.stopped)
        log["executed"].append(report.v_executed_m_s.copy())
    log["largest_jump"] = max(jumps)
    return {k: np.array(v) for k, v in log.items()}, controller, home


@pytest.fixture(scope="module")
def walk():
    logger = logging.getLogger("cobotsafety")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        return walk_at_the_arm()
    finally:
        logger.setLevel(level)


def test_the_walker_is_given_way_without_breaching_the_critical_distance(walk):
    log, controller, _ = walk
    # The laser's 1 cm noise moves the model by up to ``largest_jump`` in one step (a teleport no
    # motion limit can answer at once): at most that is lost, and only while it lasts.
    jump = float(log["largest_jump"])
    assert 0.0 < jump < 0.1
    assert log["distance"].min() >= controller.human.critical_m - jump
    # The person did push the arm: held still, it would have been well inside.
    assert np.linalg.norm(log["executed"], axis=1).max() > 0.2


def test_the_walker_causes_no_stop_go_chatter(walk):
    log, _, _ = walk
    # The arm starts moving once when the person comes and comes to rest once, home; on the
    # way it may pause while the person stands (at most one more start).
    moving = np.linalg.norm(log["executed"], axis=1) > 1e-3
    assert int(np.sum(moving[1:] != moving[:-1])) <= 4
    assert not log["stopped"].any()  # released: the hold is the arm's own motion, never a refusal
    jumps = np.linalg.norm(np.diff(log["executed"], axis=0), axis=1)
    assert jumps.max() < 0.3  # the executed velocity never jumps by 0.3 m/s


def test_the_arm_returns_to_the_held_pose_when_the_walker_has_gone(walk):
    from cobotsafety.arm.controller import HOLD_DEADBAND_M

    _, controller, home = walk
    assert np.linalg.norm(controller.p_base_ee_m - home) <= HOLD_DEADBAND_M + 1e-4


def test_next_to_a_person_the_anticipative_arm_moves_out_of_the_way():
    """A person standing within the field's reach of the arm (default ``field_*``: 0.25 + 0.35 m)
    while the user commands nothing: the anticipative command gets paper 2's repulsion at the
    arm's closest point (``evasion_gain``), so the arm moves away, at most at the field's speed,
    and never closer than the critical distance; with the rows alone (``evasion_gain`` 0) it
    holds still, which is what the first assertion catches."""
    runs = {}
    for name, settings in (("evading", FilterSettings()), ("sliding", SLIDING)):
        controller = ArmController("panda", settings=settings, zones=[])
        human = beside(controller, offset=(0.0, 0.7, 0.0))
        runs[name] = drive(controller, human, np.zeros(3), "anticipative", 250)
    evading, _ = runs["evading"]
    sliding, _ = runs["sliding"]
    assert evading[-1] > evading[0] + 0.02  # m in 1 s (the default field pushes at ~0.1 m/s here)
    assert np.all(np.diff(evading) > -1e-6)  # never toward the person
    assert np.all(np.diff(evading) < FilterSettings().field_max_repulsion_m_s * DT + 1e-6)
    assert np.ptp(sliding) < 0.005  # the rows alone: standing still (centering only)
    assert evading.min() > HumanLimitation().critical_m


def _walker_at_the_iiwa():
    """The iiwa (1 m/s and 2 m/s^2 at the hand), driven at a person walking at it at 1.6 m/s
    (ISO 13855's walking speed) who stops inside the critical distance: ``(controller, step
    reports, separations after each step, the arm's own closing over each step, the commanded
    joint path, the hand's path)``."""
    controller = ArmController("iiwa", zones=[], settings=SLIDING)
    hand = controller.p_base_ee_m.copy()
    toward = np.array([0.0, 0.3, 0.0])  # the user drives the hand at the person
    reports, distances, approach = [], [], []
    qs, ps = [controller.state.q.copy()], [controller.state.p_world_ee.copy()]
    for i in range(int(1.2 / DT)):
        gap = max(1.6 - 1.6 * i * DT, 0.05)
        walking = gap > 0.05
        human = torso(hand + [0.0, gap + 0.12, 0.0], v=(0.0, -1.6 if walking else 0.0, 0.0))
        before = separation(controller, human)
        controller.set_human(human)
        reports.append(controller.step(toward, DT))
        distances.append(separation(controller, human))
        approach.append(before - distances[-1])  # the arm's own closing over the step [m]
        qs.append(controller.state.q.copy())
        ps.append(controller.state.p_world_ee.copy())
    return controller, reports, distances, approach, np.array(qs), np.array(ps)


def test_a_person_faster_than_the_arm_meets_an_arm_at_rest_within_its_motion_limits():
    """ISO/TS 15066's separation: the robot must be able to stand still before the person,
    still walking at it, reaches the limitation; it need not outrun them. The walker of
    ``_walker_at_the_iiwa``: on no step does the arm exceed its joints' motion limits or count
    one, and it is no longer approaching when the separation reaches the critical distance.
    (The old row asked the arm to retreat as fast as the person came: hundreds of steps beyond
    the limits.) The hand's own limit: the strict xfail below."""
    from cobotsafety.experiments.motion_ratios import motion_ratios

    controller, reports, distances, approach, q_path, _ = _walker_at_the_iiwa()
    assert not any(r.safety_over_smoothness for r in reports)
    ratios = motion_ratios(q_path, DT, controller.model.limits, controller.model.difference)
    assert ratios.max_joint_acceleration_ratio <= 1.0 + 1e-9 and ratios.max_joint_jerk_ratio <= 1.0 + 1e-9
    first_inside = int(np.argmax(np.array(distances) < controller.human.critical_m))
    assert distances[first_inside] < controller.human.critical_m  # the person did get that close
    assert approach[first_inside] <= 1e-9  # and met an arm at rest (or leaving)
    assert max(approach) > 1e-4  # the arm did approach while that was safe


@pytest.mark.xfail(strict=True, reason=(
    "the hand's box bounds J qddot; fleeing the walker the iiwa swings about its base at ~0.8 m/s "
    "(joint a1 at its speed limit, the extended reach binding), a centripetal ~0.9 m/s^2 the box "
    "does not see: the executed hand acceleration reaches 1.96 times the 2 m/s^2 in 128 steps, none "
    "counted, each reported (the test below; docs/motion_limits.md, 'Where the hand's silent excess comes from')"))
def test_a_person_faster_than_the_arm_meets_an_arm_within_its_hands_limits():
    """The same walker: the executed hand path (its positions' differences, as ``experiment
    limits`` measures it) keeps the iiwa's end-effector acceleration limit, or the steps that
    do not are counted."""
    from cobotsafety.experiments.motion_ratios import motion_ratios

    controller, reports, _, _, q_path, p_path = _walker_at_the_iiwa()
    ratios = motion_ratios(q_path, DT, controller.model.limits, controller.model.difference, p_path)
    assert ratios.max_ee_acceleration_ratio <= 1.0 + 1e-9 or any(r.safety_over_smoothness for r in reports)


def test_the_walkers_hand_over_its_limits_is_reported_at_every_such_step():
    """Never silent (issue 20 item 4): where the fleeing iiwa's hand goes over its own limits
    (the strict xfail above), every such step says so (``hand_over_limit``), and no other."""
    from cobotsafety.experiments.motion_ratios import OVER_LIMIT_RATIO, ee_derivatives

    controller, reports, _, _, _, p_path = _walker_at_the_iiwa()
    limits = controller.model.limits
    d = ee_derivatives(p_path, DT)
    over = (np.linalg.norm(d.acceleration, axis=1) > limits.ee_acceleration_m_s2 * OVER_LIMIT_RATIO) | (
        np.linalg.norm(d.jerk, axis=1) > limits.ee_jerk_m_s3 * OVER_LIMIT_RATIO)
    assert over.sum() > 10  # the swing's curvature (docs/motion_limits.md)
    assert [r.hand_over_limit for r in reports] == over.tolist()
    assert controller.hand_over_limit_steps == over.sum()


JOINTS_GAVE_WAY = "safety over smoothness: the joints' motion limits gave way"
HAND_GAVE_WAY = "safety over smoothness: the hand's motion limits gave way (the joints' kept)"


def test_a_counted_step_says_whose_motion_limits_gave_way():
    """Issue 20 item 4 (never silent, with a reason): the iiwa's hand driven at 0.25 m/s, a
    person appearing 0.45 m ahead of it, walking at it at 1.5 m/s. The steps that keep the
    person's row give up smoothness, and each says whose limits gave way, as the joint path
    shows: "the joints'" where a joint's acceleration or jerk exceeds the box (the robot's
    limits less ``MOTION_MARGIN``), "the hand's" where every joint keeps its acceleration
    limit (and its jerk, unless the step before gave way: the box then starts from beyond it)."""
    from cobotsafety.arm.motion_box import MOTION_MARGIN

    controller = ArmController("iiwa", zones=[], settings=SLIDING)
    limits = controller.model.limits
    v = np.array([0.0, 0.25, 0.0])
    qs = [controller.state.q.copy()]
    for _ in range(100):
        controller.step(v, DT)
        qs.append(controller.state.q.copy())
    hand = controller.p_base_ee_m.copy()
    counted = {}  # step index in qs -> reason
    for _ in range(60):
        controller.set_human(torso(hand + [0.0, 0.45, 0.0], v=(0.0, -1.5, 0.0)))
        report = controller.step(v, DT)
        qs.append(controller.state.q.copy())
        if report.safety_over_smoothness:
            counted[len(qs) - 1] = report.reason
    q = np.array(qs)
    acceleration = np.max(np.abs(np.diff(q, 2, axis=0)) / DT ** 2 / limits.acceleration_rad_s2, axis=1)
    jerk = np.max(np.abs(np.diff(q, 3, axis=0)) / DT ** 3 / limits.jerk_rad_s3, axis=1)
    assert set(counted.values()) == {JOINTS_GAVE_WAY, HAND_GAVE_WAY}, counted  # both kinds happen here
    for k, reason in counted.items():  # step k's acceleration: acceleration[k - 2]; its jerk: jerk[k - 3]
        if reason == JOINTS_GAVE_WAY:
            assert max(acceleration[k - 2], jerk[k - 3]) > MOTION_MARGIN, k
        else:
            assert acceleration[k - 2] <= 1.0 + 1e-9, k
            assert k - 1 in counted or jerk[k - 3] <= 1.0 + 1e-9, k


def test_the_evasion_weighs_joints_near_their_limits_as_chan_and_dubey():
    """``field_push`` and ``weighted_least_norm`` with ``limit_scale``: the weighted least-norm solution
    ``W^-1 J^T (J W^-1 J^T + lambda I)^-1 f s`` of Chan and Dubey (1995), ``W = diag(1 +
    |dH/dq|)`` with the joint-limit measure ``H = sum (u - l)^2 / (4 (u - q)(q - l))``, here
    differentiated numerically; at mid-range every weight is 1 (paper 2's repulsion), and a
    joint near its limit moves less than in paper 2's (the others take over)."""
    from compiled_arm import compiled_kinematics, robot
    from cobotsafety.arm.potential_field import field_push, limit_scale, weighted_least_norm
    from cobotsafety.arm.step_kernel import unpack_robot

    model = robot("iiwa")
    unpacked = unpack_robot(model.robot_i, model.robot_f)
    cap_joint, axes, idx_v, support, limited = unpacked[8], unpacked[10], unpacked[6], unpacked[7], unpacked[9]
    lower, upper = model.lower, model.upper
    middle = 0.5 * (lower + upper)
    q = model.home_q.copy()
    q[3] = upper[3] - 0.03 * (upper[3] - lower[3])  # the elbow 3 % of its range from its limit
    _, _, _, J6, oR, op, p0, p1 = compiled_kinematics(model, q)
    kin = Kinematics(model, q)
    capsule = len(model.capsules) - 2
    p_robot = 0.5 * (p0[capsule] + p1[capsule])
    s = np.array([0.0, 0.6, 0.8])
    critical, influence, k_rep, f_max, damping = 0.2, 0.3, 0.1, 0.5, 1e-3
    d = 0.3
    f = min(k_rep * (influence / (d - critical) - 1.0), f_max)

    def H(x):
        return float(np.sum((upper - lower) ** 2 / (4.0 * (upper - x) * (x - lower))))

    h = 1e-7
    grad = np.array([(H(q + h * e) - H(q - h * e)) / (2 * h) for e in np.eye(len(q))])
    W_inv = np.diag(1.0 / (1.0 + np.abs(grad)))
    J_cp = kin.point_jacobian(kin.capsule_joint[capsule], p_robot)
    expected = W_inv @ J_cp.T @ np.linalg.solve(J_cp @ W_inv @ J_cp.T + damping * np.eye(3), f * s)
    scale = limit_scale(q, lower, upper, limited, len(q))
    J_push, push = field_push(d, capsule, p_robot, p_robot - 0.3 * s, len(q), cap_joint, oR, op, axes, idx_v,
                              support, critical, influence, k_rep, f_max)
    np.testing.assert_allclose(push, f * s, rtol=1e-12)
    qdot = weighted_least_norm(J_push, push, damping, scale)
    np.testing.assert_allclose(qdot, expected, rtol=1e-5, atol=1e-9)
    plain = weighted_least_norm(J_push, push, damping, np.ones(len(q)))
    assert abs(qdot[3]) < 0.7 * abs(plain[3])  # the elbow near its limit moves less (the others take over)
    np.testing.assert_allclose(limit_scale(middle, lower, upper, limited, len(q)), 1.0)


def test_the_closest_pair_from_the_rows_distances_is_the_closest_pair_measured_again():
    """``closest_of_rows`` (the evasion's and the field's closest pair, from the human rows'
    ``distance - critical``) against ``closest_axis_pair`` (every pair measured): the same
    distance, capsules and points bit for bit, on random arms and people (a generator of our
    own) and on people placed so that two pairs tie or round together after the subtraction."""
    from cobotsafety.arm.limitations.human import closest_axis_pair, closest_of_rows
    from cobotsafety.geometry.capsule import all_pairs

    rng = np.random.default_rng(41)
    ties = 0
    for trial in range(300):
        n, k, skip = int(rng.integers(2, 9)), int(rng.integers(1, 6)), int(rng.integers(0, 2))
        p0, p1 = rng.uniform(-0.5, 0.5, (n, 3)), rng.uniform(-0.5, 0.5, (n, 3))
        radius = rng.uniform(0.02, 0.1, n)
        hp0, hp1 = rng.uniform(-1.0, 1.0, (k, 3)), rng.uniform(-1.0, 1.0, (k, 3))
        hr = rng.uniform(0.03, 0.2, k)
        if trial % 3 == 0 and k > 1:  # a person's capsule repeated: an exact tie
            hp0[1], hp1[1], hr[1] = hp0[0], hp1[0], hr[0]
        critical = float(rng.choice([0.25, 0.307, 1e16]))  # 1e16 (ulp 2 m): the distances round together
        d, _, _ = all_pairs(p0, p1, radius, skip, hp0, hp1, hr)
        before = (d - critical).ravel()
        ties += int(np.sum(before == before.min()) > 1)
        found = closest_of_rows(before, skip, p0, p1, radius, hp0, hp1, hr)
        measured = closest_axis_pair(p0, p1, radius, skip, hp0, hp1, hr)
        assert found[:3] == measured[:3]
        assert found[3].tobytes() == measured[3].tobytes() and found[4].tobytes() == measured[4].tobytes()
    assert ties >= 30  # ties exercised (44 of the 300 draws)
