"""``experiment limits``: a scripted hand drag keeps every joint ratio within the robot's limits,
the JSON objects carry the issue's keys, and the command prints them."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cobotsafety.arm.controller import ArmController
from cobotsafety.arm.filter_settings import FilterSettings
from cobotsafety.experiments import limit_runs
from cobotsafety.experiments.limit_runs import KEYS, _measure, drag_release, drag_turns
from cobotsafety.experiments.motion_ratios import motion_ratios


@pytest.mark.parametrize("robot,dt_s", [("panda", 0.001), ("iiwa", 1 / 275)])
def test_a_scripted_drag_stays_within_the_robots_limits(robot, dt_s):
    c = ArmController(robot)
    run = _measure("drag-turns", c, drag_turns(c, dt_s, duration_s=3.0), dt_s)
    r = run.ratios
    assert r.max_joint_velocity_ratio <= 1.0 + 1e-9
    assert r.max_joint_acceleration_ratio <= 1.0 + 1e-9
    assert r.max_joint_jerk_ratio <= 1.0 + 1e-9
    assert r.max_ee_jerk_m_s3 <= c.model.limits.ee_jerk_m_s3 * (1 + 1e-9)
    assert run.safety_over_smoothness_steps == 0
    assert r.max_joint_acceleration_ratio > 0.1  # the drag does use the arm


def test_a_drag_sliding_along_the_extended_reach_keeps_the_iiwas_limits_at_1_khz():
    """From 1.8 s on the hand slides along the extended reach with joint a6 near its upper
    limit. The sphere bends the hand's straight motion outward (``|v_t|^2 / r``); before the
    braking model counted that pull, 36 steps gave way to it. Near the stretched arm the
    solver's tolerance (in the task's coordinates) is ~2e-8 rad/s of a5's velocity, 1.2e-4 of
    its jerk step at 1 kHz: the step holds the joints' boxes exactly after the solve."""
    c = ArmController("iiwa")
    run = _measure("drag-turns", c, drag_turns(c, 0.001, duration_s=3.0), 0.001)
    assert run.safety_over_smoothness_steps == 0
    assert run.ratios.max_joint_acceleration_ratio <= 1.0 + 1e-9
    assert run.ratios.max_joint_jerk_ratio <= 1.0 + 1e-9


@pytest.mark.parametrize("robot,pulls", [("panda", 2), ("iiwa", 6)])
def test_releases_hold_within_the_limits(robot, pulls):
    """Released while it slides on the iiwa's extended reach (the fourth pull, at 2.69 s),
    the hand brakes with joints a5 and a6 already at their acceleration limits: the reach's
    braking bound counted their jerk as if they could still give more (23 steps gave up
    smoothness, jerk 1.29 times the limit) until ``row_capacity`` took them out."""
    c = ArmController(robot)
    run = _measure("drag-release", c, drag_release(c, 0.001, pulls=pulls), 0.001)
    assert run.ratios.max_joint_acceleration_ratio <= 1.0 + 1e-9 and run.ratios.max_joint_jerk_ratio <= 1.0 + 1e-9
    assert run.safety_over_smoothness_steps == 0


def test_a_drag_whose_box_contradicts_a_zone_keeps_the_limits_within_the_hands_ball():
    """The iiwa's drag-turns, seed 6, at 1 kHz: from 2.0 s joint a7's capsule slides on the sphere
    zone while the joints brake toward their limits, and for 36 steps the zone's safety bound,
    the joints' boxes and a face of the hand's per-axis box contradict. The hand's limits are
    norms: the box is the ball inscribed, and the rest of the ball holds those steps. Every
    step's hand acceleration and jerk (the joints' part: ``J dqdot / dt`` and its change from
    ``J qddot``) stay within ``EE_MOTION_SHARE`` of their norms; some step leaves the box. (It
    was the panda's drag-turns seed 9 until the zone's rows at each capsule end, with which no
    panda drag of seeds 0-39 leaves the box.)"""
    from cobotsafety.arm.motion_box import EE_AXIS_SHARE, EE_MOTION_SHARE, MOTION_MARGIN

    c = ArmController("iiwa")
    limits, dt = c.model.limits, 0.001
    box_acc = MOTION_MARGIN * EE_AXIS_SHARE * limits.ee_acceleration_m_s2
    box_jerk = MOTION_MARGIN * EE_AXIS_SHARE * limits.ee_jerk_m_s3
    hand_acc, hand_jerk, beyond_box = [], [], 0
    qs = [c.state.q.copy()]
    for v in drag_turns(c, dt, seed=6):
        J, qdot_prev, qddot_prev = c.state.J_ee.copy(), c.joint_velocity_rad_s, c.joint_acceleration_rad_s2
        c.step(v, dt)
        a = J @ (c.joint_velocity_rad_s - qdot_prev) / dt
        jerk = (a - J @ qddot_prev) / dt
        hand_acc.append(np.linalg.norm(a))
        hand_jerk.append(np.linalg.norm(jerk))
        beyond_box += np.max(np.abs(a)) > box_acc * (1 + 1e-9) or np.max(np.abs(jerk)) > box_jerk * (1 + 1e-9)
        qs.append(c.state.q.copy())
    ratios = motion_ratios(np.array(qs), dt, limits, c.model.difference)
    assert c.smoothness_steps == 0
    assert ratios.max_joint_acceleration_ratio <= 1.0 + 1e-9 and ratios.max_joint_jerk_ratio <= 1.0 + 1e-9
    assert max(hand_acc) <= EE_MOTION_SHARE * limits.ee_acceleration_m_s2 * (1 + 1e-9)
    assert max(hand_jerk) <= EE_MOTION_SHARE * limits.ee_jerk_m_s3 * (1 + 1e-9)
    assert beyond_box >= 10


def _drive_to_lower_limit(robot: str, joint: str):
    """``experiment limits``' run ``joint-<joint>-lower`` at 1 kHz."""
    model = ArmController(robot).model
    (iq, iv), = [pair for pair, name in zip(model.limited, model.limited_names) if name == joint]
    c = limit_runs._start_near(lambda: ArmController(robot), model, iq, False, 0.001)
    return _measure(f"joint-{joint}-lower", c, limit_runs.toward_joint_limit(c, 0.001, iq, iv, False), 0.001)


def test_a_drive_into_a_joint_limit_holds_the_iiwas_limits_at_1_khz():
    """The iiwa's hand dragged so that joint a2 runs into its lower limit, at 1 kHz: met within
    the robot's limits. A joint limit keeps its hard recovery (``RECOVERY`` rows are a standing
    person's): eased before smoothness like a person's, the joint's drift out of its buffer gave
    up smoothness on 49 steps (jerk 7.8 times the limit)."""
    run = _drive_to_lower_limit("iiwa", "joint_a2")
    assert run.safety_over_smoothness_steps == 0
    assert run.ratios.max_joint_jerk_ratio <= 1.0 + 1e-9
    assert run.ratios.max_joint_velocity_ratio > 0.5  # the drive does reach the limit at speed


def test_a_drive_along_the_wall_into_joint_6s_limit_holds_the_pandas_limits():
    """The panda's hand dragged so that joint 2 leans back: link 6 meets the demo cell's wall
    while joint 6 sits at its lower limit, and slides along it with joints 4 and 5 near their
    speed limits. Turning, the link carries the capsule's end toward the wall at 2.7 m/s^2 with
    no joint acceleration at all; before the safety bound counted that drift, 4 steps gave up
    smoothness (joint 2 at 15 times its acceleration limit)."""
    run = _drive_to_lower_limit("panda", "panda_joint2")
    assert run.safety_over_smoothness_steps == 0
    assert run.ratios.max_joint_acceleration_ratio <= 1.0 + 1e-9
    assert run.ratios.max_joint_jerk_ratio <= 1.0 + 1e-9


@pytest.mark.parametrize("robot", ["panda", "iiwa"])
def test_a_drive_at_the_box_zone_holds_the_limits_as_its_capsule_tilts_along_a_face(robot):
    """The hand driven at the demo cell's box: the last link slides along a face nearly
    parallel to it, and as it tilts the capsule's closest point jumps from the end held at the
    buffer to the other end, arriving at 0.1 m/s. With a row at each end the arriving end has
    braked by its own row; with the closest point's row alone 3 (panda) and 2 (iiwa) steps gave
    up smoothness (15 and 34 times the acceleration and jerk limits)."""
    c = ArmController(robot)
    box = next(z for z in c.zones if type(z).__name__ == "BoxZone")
    to_box = np.asarray(box.center, dtype=float) - c.state.p_world_ee
    run = _measure("zone", c, limit_runs.constant(0.4 * to_box / np.linalg.norm(to_box), 3.0, 0.001), 0.001)
    assert run.safety_over_smoothness_steps == 0
    assert run.ratios.max_joint_acceleration_ratio <= 1.0 + 1e-9
    assert run.ratios.max_joint_jerk_ratio <= 1.0 + 1e-9


OFF_PERIOD = ("1 % off the measured 1 ms the iiwa's drag-turns gives up smoothness (0.99 ms: 52 steps, "
              "jerk 33 times its limit, joint a6's upper limit and the extended reach binding at once; drag-release "
              "at 1.01 ms gave up 70 the same way until the zones' rows at each capsule end): each row's bound is "
              "viable alone, but the joints that would "
              "hold the hand off the reach while the wrist brakes are committed the other way, and their jerk "
              "limits take 30-50 ms to turn them (docs/motion_limits.md, 'Two limitations at once')")


@pytest.mark.parametrize("robot, run, dt_s", [
    ("panda", "drag-turns", 0.00099), ("panda", "drag-release", 0.00101),
    pytest.param("iiwa", "drag-turns", 0.00099, marks=pytest.mark.xfail(strict=True, reason=OFF_PERIOD)),
    ("iiwa", "drag-release", 0.00101)])  # (an xfail like the one above until the rows at each capsule end)
def test_the_hand_drags_hold_the_limits_one_percent_off_the_period(robot, run, dt_s):
    """``experiment limits``' drags at a period 1 % off 1 ms: a real controller's period jitters,
    and issue 20 asks for no step giving up smoothness in the hand drags."""
    c = ArmController(robot)
    commands = drag_turns(c, dt_s) if run == "drag-turns" else drag_release(c, dt_s)
    measured = _measure(run, c, commands, dt_s)
    assert measured.ratios.max_joint_acceleration_ratio <= 1.0 + 1e-9
    assert measured.ratios.max_joint_jerk_ratio <= 1.0 + 1e-9
    assert measured.safety_over_smoothness_steps == 0


OVER_SEEDS = ("the two shipped hand drags hold the limits; other seeds of the same drags do not on the iiwa at 1 kHz "
              "(`experiment limits --drag-seeds 40`, 2026-12-06, with the hand's ball: runs giving up smoothness of "
              "80, iiwa 12 at 1 kHz (up to 4.5 times the acceleration and 216 times the jerk limit: joint a6's "
              "upper limit with the extended reach, the wrist's capsule on the sphere zone, joint a4's lower "
              "limit), 1 at 275 Hz (drag-release seed 11, jerk 1.027 times); panda 0 at both rates): rows binding "
              "together, each viable alone (docs/motion_limits.md, 'Forty seeds of each hand drag', 'The hand's "
              "ball')")


@pytest.mark.parametrize("robot, dt_s", [
    pytest.param("panda", 0.001, id="panda-1kHz"), pytest.param("panda", 1 / 275, id="panda-275Hz"),
    pytest.param("iiwa", 1 / 275, id="iiwa-275Hz"),
    pytest.param("iiwa", 0.001, id="iiwa-1kHz", marks=pytest.mark.xfail(strict=True, reason=OVER_SEEDS))])
def test_the_hand_drags_hold_the_limits_over_ten_seeds(robot, dt_s):
    """Each hand drag with ten seeds (its default one first): a user's hand is not one script,
    and issue 20 asks for no step giving up smoothness in the hand drags. (Before the hand's
    ball, ``motion_box.within_hand_ball``, the panda at 1 kHz and the iiwa at 275 Hz gave up
    smoothness in one drag each over these seeds, for one to four steps at 1.002 times a limit
    or less; the iiwa at 1 kHz fails by up to twice the acceleration limit in three of its
    twenty.)"""
    for run in limit_runs.drag_runs(robot, dt_s, 10):
        assert run.ratios.max_joint_acceleration_ratio <= 1.0 + 1e-9, run.run
        assert run.ratios.max_joint_jerk_ratio <= 1.0 + 1e-9, run.run
        assert run.safety_over_smoothness_steps == 0, run.run


def _fast_table_cases():
    for dt in (0.001, 1 / 275):
        for speed in (0.5, 0.9):
            for robot in ("panda", "iiwa"):
                yield pytest.param(robot, speed, dt, id=f"{robot}-{speed}-{1 / dt:.0f}Hz")


@pytest.mark.parametrize("robot, speed, dt", list(_fast_table_cases()))
def test_a_fast_drive_down_brakes_for_the_table_within_the_limits(robot, speed, dt):
    """The hand driven straight down at the filter's default cap (0.5 m/s) and at a flee's
    0.9 m/s (``EE_MOTION_SHARE`` of the iiwa's own 1 m/s), no zones: it stops above the table
    within the joints' limits, no step giving up smoothness. The iiwa's hand brakes at 0.52 m/s^2
    per axis in the plan (half of 2 m/s^2 x 0.9 / sqrt 3): 0.25 m from 0.5 m/s, 0.80 m from
    0.9 m/s with the jerk ramp, farther than ``FilterSettings.activation_m`` (0.15 m): the
    table's rows enter from the plan's braking distance of the arm's fastest point (fails with
    ``activation_m`` alone on the iiwa at three of the four)."""
    c = ArmController(robot, zones=[], settings=FilterSettings(max_speed_m_s=speed))
    run = _measure("table", c, limit_runs.constant(np.array([0.0, 0.0, -speed]), 2.5, dt), dt)
    assert c.state.p_world_ee[2] > 0.0  # it stopped above the table, and stood there
    assert run.ratios.max_joint_acceleration_ratio <= 1.0 + 1e-9
    assert run.ratios.max_joint_jerk_ratio <= 1.0 + 1e-9
    assert run.safety_over_smoothness_steps == 0


def test_the_command_prints_one_object_per_run_with_the_issue_keys(monkeypatch, capsys, tmp_path):
    from cobotsafety.cli import main

    def short(robot, dt_s, drag_seeds=1):
        c = ArmController(robot)
        return [_measure("drag-turns", c, drag_turns(c, dt_s, duration_s=0.5), dt_s)]

    monkeypatch.setattr(limit_runs, "scripted_runs", short)
    # With --out the plot's path goes to stderr: stdout stays one JSON document.
    assert main(["experiment", "limits", "--robot", "panda", "--no-recordings", "--json", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr()
    (row,) = json.loads(printed.out)
    assert str(tmp_path) in printed.err and list(tmp_path.glob("*.png"))
    assert set(row) == {"run", "robot", "dt_s", *KEYS}
    assert (row["run"], row["robot"], row["dt_s"]) == ("drag-turns", "panda", 0.001)
    assert isinstance(row["safety_over_smoothness_steps"], int)


def test_the_periods_spread_evenly_around_the_period_with_it_in_the_middle():
    assert limit_runs.periods(1 / 275, 1, 0.05) == [1 / 275]
    spread = limit_runs.periods(1 / 275, 5, 0.01)
    assert spread[2] == 1 / 275  # bit for bit: the period itself is one of them
    assert np.allclose(spread, np.array([0.99, 0.995, 1.0, 1.005, 1.01]) / 275, rtol=1e-14, atol=0)
    assert limit_runs.periods(0.001, 2, 0.01) == pytest.approx([0.00099, 0.00101], rel=1e-14)


def test_several_periods_run_every_run_at_each_and_name_those_that_gave_up_smoothness(monkeypatch, capsys):
    """``--periods 3``: each run at 0.99, 1 and 1.01 ms; the table says which periods counted
    steps giving up smoothness (here made up: the first two), the JSON one object per run and
    period."""
    from cobotsafety.cli import main
    from cobotsafety.experiments.motion_ratios import MotionRatios

    seen = []

    def fake(robot, dt_s, drag_seeds=1):
        seen.append(dt_s)
        ratios = MotionRatios(0.5, 0.5, 0.5, None, None, None, 0, None, None, 1.0)
        counted = {0: 4, 1: 1}.get(len(seen) - 1, 0)
        return [limit_runs.LimitRun(name, robot, dt_s, ratios, counted if name == "drag-turns" else 0, np.zeros((1, 7)))
                for name in ("drag-turns", "drag-release")]

    monkeypatch.setattr(limit_runs, "scripted_runs", fake)
    assert main(["experiment", "limits", "--robot", "panda", "--no-recordings", "--periods", "3"]) == 0
    printed = capsys.readouterr().out
    assert seen == pytest.approx([0.00099, 0.001, 0.00101], rel=1e-14) and seen[1] == 0.001
    assert printed.splitlines()[-1] == ("periods giving up smoothness: 2 of 3; outside reach-over: 2 of 3 (0.99 ms: "
                                        "4, 1 ms: 1)")
    assert len([line for line in printed.splitlines() if line.startswith("drag-")]) == 6
    # the stress case counts in the first figure only
    stress = [{"run": "reach-over", "dt_s": dt, "safety_over_smoothness_steps": 9} for dt in seen]
    drag = [{"run": "drag-turns", "dt_s": seen[1], "safety_over_smoothness_steps": 2}]
    assert limit_runs.period_summary(stress + drag) == ("periods giving up smoothness: 3 of 3; outside reach-over: "
                                                        "1 of 3 (1 ms: 2)")
    seen.clear()
    assert main(["experiment", "limits", "--robot", "panda", "--no-recordings", "--periods", "2", "--spread",
                 "0.05", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [(r["run"], r["dt_s"]) for r in rows] == [("drag-turns", seen[0]), ("drag-release", seen[0]),
                                                    ("drag-turns", seen[1]), ("drag-release", seen[1])]
    assert seen == pytest.approx([0.00095, 0.00105], rel=1e-14)


def test_several_drag_seeds_run_each_drag_from_its_default_seed_and_count_those_that_gave_up(monkeypatch, capsys):
    """``--drag-seeds 3``: each hand drag with three seeds, its default one first, named by
    seed; the table ends with how many drags gave up smoothness (here made up: one)."""
    from cobotsafety.cli import main
    from cobotsafety.experiments.motion_ratios import MotionRatios

    seeds = []

    def script(name):
        def commands(controller, dt_s, seed):
            seeds.append((name, seed))
            return iter([np.zeros(3)] * 3)
        return commands

    monkeypatch.setattr(limit_runs, "DRAGS", tuple((name, script(name), first)
                                                   for name, _, first in limit_runs.DRAGS))
    runs = limit_runs.drag_runs("panda", 0.001, 3)
    assert seeds == [("drag-turns", 0), ("drag-turns", 1), ("drag-turns", 2),
                     ("drag-release", 1), ("drag-release", 2), ("drag-release", 3)]
    assert [r.run for r in runs] == ["drag-turns-seed0", "drag-turns-seed1", "drag-turns-seed2",
                                     "drag-release-seed1", "drag-release-seed2", "drag-release-seed3"]
    assert [r.run for r in limit_runs.drag_runs("panda", 0.001)] == ["drag-turns", "drag-release"]

    def fake(robot, dt_s, drag_seeds=1):
        assert drag_seeds == 3
        return [limit_runs.LimitRun(r.run, robot, dt_s, MotionRatios(0.5, 0.5 + i, 0.5 + 2 * i, None, None, None, 0,
                                                                      None, None, 1.0),
                                    5 if i == 1 else 0, np.zeros((1, 7))) for i, r in enumerate(runs)]

    monkeypatch.setattr(limit_runs, "scripted_runs", fake)
    assert main(["experiment", "limits", "--robot", "panda", "--no-recordings", "--drag-seeds", "3"]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == (
        "hand drags giving up smoothness: 1 of 6 (5 steps); worst joint acceleration 5.5, jerk 10.5 times the limits")


def test_runs_over_a_limit_without_a_counted_step_are_named(monkeypatch, capsys):
    """The table's last word on silence: a run whose ratio (joint or hand, before the JSON's
    rounding) is above 1 while the controller counted no step is named; a run at its limit, or
    one that counted its steps, is not."""
    from cobotsafety.cli import main
    from cobotsafety.experiments.motion_ratios import MotionRatios

    def ratios(joint_jerk=0.5, ee=(None, None, None), velocity=0.5):
        return MotionRatios(velocity, 0.5, joint_jerk, None, None, None, 0, None, None, None, *ee)

    runs = [limit_runs.LimitRun("counted", "panda", 0.001, ratios(joint_jerk=3.0), 2, np.zeros((1, 7))),
            limit_runs.LimitRun("hand", "panda", 0.001, ratios(ee=(0.5, 0.9, 1.00004)), 0, np.zeros((1, 7))),
            limit_runs.LimitRun("at-limit", "panda", 0.001, ratios(ee=(1.0, 1.0, 1.0), velocity=1.0 + 5e-10), 0,
                                np.zeros((1, 7))),
            limit_runs.LimitRun("joint", "panda", 0.001, ratios(joint_jerk=1.2), 0, np.zeros((1, 7)))]
    assert limit_runs.over_summary(runs) == ("runs over a limit without a counted or reported step: 2 of 4 (worst: "
                                             "joint_jerk 1.2 times the limit in joint); over the hand's limits, "
                                             "reported: 0")
    assert runs[1].as_json()["max_ee_jerk_ratio"] == 1.0  # rounded in the JSON, over the limit all the same
    assert limit_runs.over_summary(runs[1:2]) == ("runs over a limit without a counted or reported step: 1 of 1 "
                                                  "(worst: ee_jerk 1 times the limit in hand); over the hand's "
                                                  "limits, reported: 0")
    assert limit_runs.over_summary(runs[:1] + runs[2:3]) == ("runs over a limit without a counted or reported step: "
                                                             "0 of 2; over the hand's limits, reported: 0")
    # The hand's excess reported by the step is not silent; a joint's excess beside it still is.
    reported = limit_runs.LimitRun("hand", "panda", 0.001, ratios(ee=(0.5, 0.9, 1.00004)), 0, np.zeros((1, 7)), 3)
    assert reported.as_json()["hand_over_limit_steps"] == 3
    assert limit_runs.over_summary([reported]) == ("runs over a limit without a counted or reported step: 0 of 1; "
                                                   "over the hand's limits, reported: 1")
    both = limit_runs.LimitRun("both", "panda", 0.001, ratios(joint_jerk=1.3, ee=(0.5, 1.2, 0.5)), 0,
                               np.zeros((1, 7)), 2)
    assert limit_runs.over_summary([both]) == ("runs over a limit without a counted or reported step: 1 of 1 "
                                               "(worst: joint_jerk 1.3 times the limit in both); over the hand's "
                                               "limits, reported: 1")
    slower = limit_runs.LimitRun("joint", "panda", 0.002, ratios(joint_jerk=1.1), 0, np.zeros((1, 7)))
    assert "1.2 times the limit in joint at 1 ms);" in limit_runs.over_summary(runs + [slower])

    monkeypatch.setattr(limit_runs, "scripted_runs", lambda robot, dt_s, drag_seeds=1: runs)
    assert main(["experiment", "limits", "--robot", "panda", "--no-recordings"]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == limit_runs.over_summary(runs)
    assert main(["experiment", "limits", "--robot", "panda", "--no-recordings", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [row["max_ee_acceleration_ratio"] for row in rows] == [None, 0.9, 1.0, None]


def test_a_runs_hand_ratios_are_its_norms_over_the_robots_hand_limits():
    """The hand's ratios of a real drag: the commanded hand path's speed, acceleration and jerk
    norms over the robot's end-effector limits (the iiwa's 40 m/s^3 is not the panda's 6500)."""
    for robot in ("panda", "iiwa"):
        c = ArmController(robot)
        run = _measure("drag-turns", c, drag_turns(c, 0.001, duration_s=1.0), 0.001)
        r, limits = run.ratios, c.model.limits
        assert r.max_ee_speed_ratio == pytest.approx(r.max_ee_speed_m_s / limits.ee_speed_m_s, rel=1e-12)
        assert r.max_ee_acceleration_ratio == pytest.approx(r.max_ee_acceleration_m_s2 / limits.ee_acceleration_m_s2,
                                                            rel=1e-12)
        assert r.max_ee_jerk_ratio == pytest.approx(r.max_ee_jerk_m_s3 / limits.ee_jerk_m_s3, rel=1e-12)
        assert 0.05 < r.max_ee_speed_ratio <= 1.0 and r.max_ee_acceleration_ratio > 1e-3
        row = run.as_json()
        assert {"max_ee_speed_ratio", "max_ee_acceleration_ratio", "max_ee_jerk_ratio"} <= set(row)
        assert row["max_ee_jerk_ratio"] == round(r.max_ee_jerk_ratio, 4)


@pytest.mark.xfail(strict=True, reason="the hand's acceleration is bounded on J qddot (the box, 0.9 of the norm); "
                                       "the curvature's share (dJ/dt qdot) is not: the iiwa's default drag-release "
                                       "at 1 kHz reaches 1.04 times its 2 m/s^2 without a counted step "
                                       "(each such step reported: the test below; docs/motion_limits.md)")
def test_the_iiwas_default_release_keeps_its_hands_acceleration_limit():
    c = ArmController("iiwa")
    run = _measure("drag-release", c, drag_release(c, 0.001), 0.001)
    assert run.safety_over_smoothness_steps == 0  # the joints keep their limits: no step was counted
    assert run.ratios.max_joint_acceleration_ratio <= 1.0 + 1e-9 and run.ratios.max_joint_jerk_ratio <= 1.0 + 1e-9
    assert run.ratios.max_ee_acceleration_ratio <= 1.0 + 1e-9


@pytest.mark.parametrize("robot, dt_s, run", [("iiwa", 0.001, "drag-release"), ("iiwa", 1 / 275, "drag-release"),
                                              ("panda", 0.001, "drag-release"), ("iiwa", 0.001, "drag-turns"),
                                              ("iiwa", 0.001, "invariant")])
def test_the_step_reports_each_step_its_hand_goes_over_its_limits(robot, dt_s, run):
    """Never silent: the hand's executed path (its positions' backward differences, from rest)
    over the robot's end-effector acceleration or jerk limit at exactly the steps the step's
    report says so (``hand_over_limit``), with the same ratios; the controller's count is those
    steps, and the run's ``hand_over_limit_steps`` too. The iiwa's default drag-release at 1 kHz
    goes over its acceleration limit (the strict xfail above: the path's curvature), and its
    drag-turns with seed 1 over its jerk limit alone, so both checks are exercised. (That was the
    iiwa's random teleoperation until the zones' rows at each capsule end: it now stays within
    the hand's limits.)"""
    from cobotsafety.experiments.motion_ratios import OVER_LIMIT_RATIO, ee_derivatives

    def commands(c):
        if run == "drag-release":
            return drag_release(c, dt_s)
        return drag_turns(c, dt_s, seed=1) if run == "drag-turns" else limit_runs.invariant_commands(dt_s)

    c = ArmController(robot)
    limits = c.model.limits
    hands, reports = [c.state.p_world_ee.copy()], []
    for v in commands(c):
        reports.append(c.step(v, dt_s, "anticipative"))
        hands.append(c.state.p_world_ee.copy())
    d = ee_derivatives(np.array(hands), dt_s)
    acceleration = np.linalg.norm(d.acceleration, axis=1) / limits.ee_acceleration_m_s2
    jerk = np.linalg.norm(d.jerk, axis=1) / limits.ee_jerk_m_s3
    ratios = np.array([r.hand_limit_ratios for r in reports])
    np.testing.assert_allclose(ratios[:, 0], acceleration, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(ratios[:, 1], jerk, rtol=1e-12, atol=1e-12)
    over = (acceleration > OVER_LIMIT_RATIO) | (jerk > OVER_LIMIT_RATIO)
    said = np.array([r.hand_over_limit for r in reports])
    assert np.array_equal(said, over)
    assert c.hand_over_limit_steps == int(over.sum())
    if robot == "iiwa" and dt_s == 0.001 and run != "invariant":
        exercised = acceleration > OVER_LIMIT_RATIO if run == "drag-release" else (
            (jerk > OVER_LIMIT_RATIO) & (acceleration <= OVER_LIMIT_RATIO))
        assert exercised.sum() > 0
    c.reset()
    measured = _measure(run, c, commands(c), dt_s)
    assert measured.hand_over_limit_steps == int(over.sum())
    assert measured.as_json()["hand_over_limit_steps"] == over.sum()


def test_a_recordings_run_is_measured_by_the_same_ratios_as_its_metrics(monkeypatch):
    """``recording_runs`` measures paper 2's recordings on the commanded path their metrics
    measured: every ratio the run reports equals the approach's own (``RunMetrics``), and the
    run carries the whole ``MotionRatios`` (where the worst step was, how many steps were over),
    not a copy of the metrics' few numbers."""
    from cobotsafety.experiments.human_approach import load_scenario, run_approach

    dt_s = 1 / 275
    monkeypatch.setattr(limit_runs, "RECORDINGS", ("exp2",))
    (run,) = limit_runs.recording_runs("panda", dt_s)
    approach = run_approach("anticipative", scenario="exp2", robot="panda", dt_s=dt_s, loaded=load_scenario("exp2"))
    metrics = approach.metrics
    for key in (*limit_runs.RATIO_KEYS, "max_ee_jerk_m_s3"):
        assert getattr(run.ratios, key) == getattr(metrics, key), key
    assert run.safety_over_smoothness_steps == metrics.safety_over_smoothness_steps
    assert run.hand_over_limit_steps == metrics.hand_over_limit_steps
    r = run.ratios
    assert r.max_joint_acceleration_at is not None and r.max_ee_acceleration_m_s2 is not None
    assert r.max_joint_acceleration_ratio > 0.5  # the arm moved
    assert np.array_equal(run.q_path, approach.log.commanded_path()[0])


def test_where_the_limitations_leave_no_room_the_hands_limits_give_way_before_the_joints():
    """The iiwa's drag-release with seed 4 at 1 kHz meets limitations that leave the motion
    limits no room (counted steps). The hand's box gives way first: every joint keeps its
    acceleration and jerk limits, the ones a robot's controller enforces on a joint command, and
    only the hand's limits (the iiwa's are our 0.2 g principle) are exceeded, counted. (This was
    seed 6 until the zones' rows at each capsule end; there, with the joints' and the hand's
    boxes giving way together, a joint reached 1.61 times its acceleration and 42 times its jerk
    limit.)"""
    c = ArmController("iiwa")
    reasons = []

    def commands():
        for v in drag_release(c, 0.001, seed=4):
            yield v
            if c.last_report.safety_over_smoothness:
                reasons.append(c.last_report.reason)

    run = _measure("drag-release", c, commands(), 0.001)
    assert run.safety_over_smoothness_steps > 0  # the limitations did leave no room
    assert reasons == ["safety over smoothness: the hand's motion limits gave way (the joints' kept)"] * len(reasons)
    assert len(reasons) == run.safety_over_smoothness_steps
    assert run.ratios.max_joint_acceleration_ratio <= 1.0 + 1e-9
    assert run.ratios.max_joint_jerk_ratio <= 1.0 + 1e-9
    assert run.ratios.max_ee_acceleration_ratio > 1.0 + 1e-9  # the hand's limit gave way instead
