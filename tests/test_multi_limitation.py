"""Paper 1, experiment 3 (Fig. 9): the outcome the paper reports, through the CLI's JSON; the V
of two binding limitations in (a); the reactive sweep; the III.C.2 conditioning safeguard."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import cobotsafety
from cobotsafety.cli import main
from cobotsafety.experiments.multi_limitation import figure_reactive, run_scenario
from cobotsafety.planar.rr_arm import Kinematics
from cobotsafety.planar.limitations import Damping, rows_from_measures
from cobotsafety.planar.planar_scenes import FIG9_TARGET_M, conditioning_scene, fig9_scene
from cobotsafety.planar.planar_step import measures
from cobotsafety.planar.planar_teleop import PlanarTeleop


def test_fig9_outcome(tmp_path, capsys):
    assert main(["experiment", "multi-limitation", "--json", "--out", str(tmp_path)]) == 0
    rows = json.loads(capsys.readouterr().out)
    results = {(r["scenario"], r["method"], r.get("reactive")): r for r in rows}
    assert {(s, m) for s, m, _ in results} == {(s, m) for s in "ab" for m in ("anticipative", "reactive", "stop")}
    keys = {"scenario", "method", "reached", "time_s", "min_clearance_m", "max_binding", "net_steps"}
    assert all(set(r) - {"reactive"} == keys for r in rows)
    one = {(r["scenario"], r["method"]): r for r in rows if r["method"] != "reactive"}
    # a: the zones are joined to circle B, no method gets through; sliding ends in the V with two binding.
    for r in rows:
        if r["scenario"] == "a":
            assert r["reached"] is False and r["time_s"] is None
    assert one["a", "anticipative"]["max_binding"] == 2
    # b: sliding passes the gap; stop stops at circle B.
    assert one["b", "anticipative"]["reached"] is True
    assert 0 < one["b", "anticipative"]["time_s"] < 10
    assert one["b", "stop"]["reached"] is False and one["b", "stop"]["max_binding"] == 1
    # b: the figure shows a reactive setting that passes beside one that stalls.
    reactive_b = [r for r in rows if r["scenario"] == "b" and r["method"] == "reactive"]
    assert sorted(r["reached"] for r in reactive_b) == [False, True]
    assert all(r["min_clearance_m"] >= -1e-9 for r in rows)  # no method penetrates a zone (the safety net)
    for scenario in "ab":
        assert (tmp_path / f"fig9_{scenario}.png").stat().st_size > 10_000
        assert (tmp_path / f"fig9_{scenario}.svg").read_text().lstrip().startswith("<?xml")
        assert (tmp_path / f"fig9_{scenario}.pdf").read_bytes()[:4] == b"%PDF"
    from PIL import Image

    with Image.open(tmp_path / "fig9_b.png") as image:
        assert image.info["dpi"][0] == pytest.approx(300, abs=1)


def test_binding_is_one_geometric_definition_for_every_method():
    from cobotsafety.experiments.multi_limitation import BINDING_TOLERANCE_M, BINDING_TOLERANCE_RAD, binding_now

    scene = fig9_scene("a")
    result = run_scenario("a", "anticipative")
    theta_1, theta_2 = scene.arm.inverse_kinematics(*result.path_m[-1])
    kin = Kinematics(scene.arm, theta_1, theta_2)
    expected = sorted({name for lim in scene.limitations for d, _x, _y, name, angular in lim.measures(kin)
                       if d <= (BINDING_TOLERANCE_RAD if angular else BINDING_TOLERANCE_M)})
    assert list(binding_now(scene.limitations, kin)) == expected == ["B joint 2 upper", "F triangle"]
    # The reactive method keeps off every limitation: nothing binds by the same definition.
    assert run_scenario("a", "reactive").max_binding == 0


def test_the_sweep_varies_the_angular_zone_and_the_damping(capsys):
    assert main(["experiment", "multi-limitation", "--sweep", "--grid", "quick", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    from cobotsafety.experiments.multi_limitation import QUICK_GRID

    assert len(rows) == 2 * QUICK_GRID.size
    assert {(r["zone_width_m"], r["zone_width_rad"]) for r in rows} == {(w, a) for w in QUICK_GRID.widths_m
                                                                         for a in QUICK_GRID.widths_rad}
    assert all("damping" in r and "stiffness_per_s" in r for r in rows)
    b = {(r["zone_width_m"], r["zone_width_rad"]): r for r in rows if r["scenario"] == "b"}
    # With 4 cm linear zones, the 0.15 rad angular zone at joint 2 (~4.3 cm on circle B) stalls
    # the robot in the 6 cm gap; 0.05 rad lets it through.
    assert not b[0.04, 0.15]["reached"] and b[0.04, 0.05]["reached"]
    assert not any(r["reached"] for r in rows if r["scenario"] == "a")


def test_scenario_a_ends_in_the_v_where_two_limitations_give_zero_output():
    """Section III.A case 3, checked against the general projection ``cobotsafety.slide``."""
    result = run_scenario("a", "anticipative")
    assert set(result.final_binding) == {"B joint 2 upper", "F triangle"}
    scene = fig9_scene("a")
    theta_1, theta_2 = scene.arm.inverse_kinematics(*result.path_m[-1])
    kin = Kinematics(scene.arm, theta_1, theta_2)
    command = np.array(FIG9_TARGET_M) - result.path_m[-1]
    command *= 0.2 / np.linalg.norm(command)
    rows: list = []
    rows_from_measures(measures(scene, kin), command[0], command[1], 0.002, Damping(), scene.max_speed_m_s, rows)
    normals = np.array([r[:2] for r in rows])
    bounds = np.array([r[2] for r in rows])
    v = cobotsafety.slide(command, normals, bounds)
    assert np.linalg.norm(v) < 1e-3 * np.linalg.norm(command)
    active = {r[3] for r, n, b in zip(rows, normals, bounds) if n @ v <= b + 1e-9}
    assert {"B joint 2 upper", "F triangle"} <= active
    # Each of the two alone would let the robot slide: the zero comes from both together.
    for name in ("B joint 2 upper", "F triangle"):
        keep = np.array([r[3] != name for r in rows])
        assert np.linalg.norm(cobotsafety.slide(command, normals[keep], bounds[keep])) > 0.02


def test_the_reactive_outcome_in_b_depends_on_its_tuning():
    from cobotsafety.experiments.multi_limitation import stalling_reactive

    wide = run_scenario("b", "reactive", reactive=stalling_reactive())
    assert not wide.reached  # 4 cm / 0.15 rad repulsion zones do not fit the 6 cm gap (the paper's outcome)
    tuned = run_scenario("b", "reactive", reactive=figure_reactive())
    assert tuned.reached and tuned.min_clearance_m > 0


def _drive(robot, v, steps, method="anticipative"):
    reports = [robot.step(np.asarray(v, dtype=float), 0.002, method) for _ in range(steps)]
    return reports


def test_the_conditioning_safeguard_acts_and_slides_like_any_limitation():
    """III.C.2: stretching toward the singularity (sin(theta_2) = 0) stops at sin = 0.15 and the
    arm slides along that circle; without the safeguard joint 2 runs on to its limit."""
    scene = conditioning_scene()
    robot = PlanarTeleop(scene, home_m=(0.0, 0.45))
    reports = _drive(robot, (0.0, 0.3), 1500)  # straight out, 3 s
    sines = [math.sin(robot.state.theta_2)]
    assert "conditioning" in reports[-1].binding
    assert sines[-1] >= 0.15 - 1e-9 and sines[-1] < 0.151
    # Along the limit: a sideways push with an outward part still moves the end-effector.
    before = robot.p_base_ee_m.copy()
    reports = _drive(robot, (0.2, 0.1), 250)
    assert np.linalg.norm(robot.p_base_ee_m - before) > 0.02
    assert math.sin(robot.state.theta_2) >= 0.15 - 1e-9
    # Without the safeguard the same drive goes on toward the singularity.
    bare = conditioning_scene()
    bare.limitations = [lim for lim in bare.limitations if lim.name != "conditioning"]
    free = PlanarTeleop(bare, home_m=(0.0, 0.45))
    _drive(free, (0.0, 0.3), 1500)
    assert math.sin(free.state.theta_2) < 0.1


def test_the_conditioning_safeguard_stops_a_motion_that_infringes_further():
    """Started beyond the limit (sin(theta_2) = 0.1): motion deeper toward the singularity is
    stopped, motion back out is allowed (recovery)."""
    scene = conditioning_scene()
    robot = PlanarTeleop(scene, home_m=(0.0, 0.45))
    robot.state = type(robot.state)(robot.state.theta_1, math.asin(0.1))
    sines = [math.sin(robot.state.theta_2)]
    for _ in range(50):  # pushing outward, toward the stretched singularity
        kin = robot.kinematics
        radial = np.array([kin.x, kin.y]) / math.hypot(kin.x, kin.y)
        report = robot.step(0.3 * radial, 0.002, "anticipative")
        sines.append(math.sin(robot.state.theta_2))
        assert np.linalg.norm(report.v_commanded_m_s) < 1e-4  # stopped (0.3 m/s asked)
    assert min(np.diff(sines)) >= -1e-12  # never deeper
    robot.reset()
    robot.state = type(robot.state)(robot.state.theta_1, math.asin(0.1))
    _drive(robot, -0.3 * radial, 200)
    assert math.sin(robot.state.theta_2) > 0.15
