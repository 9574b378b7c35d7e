"""The validation campaign: the people drawn (deterministic per seed, within the stated ranges),
Clopper-Pearson against statsmodels and the closed form, the escape search, the rate-limited
plant, and a tiny campaign: the report's keys, resumption, determinism, and the same results on a
local Ray instance."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cobotsafety.tools.campaign.escape import escape_exists
from cobotsafety.tools.campaign.person_run import draw_scene
from cobotsafety.tools.campaign.report import REPORT_KEYS, clopper_pearson_upper
from cobotsafety.tools.campaign.runner import result_path, run_campaign


def test_clopper_pearson_against_statsmodels_and_the_zero_breach_closed_form():
    from statsmodels.stats.proportion import proportion_confint

    for k, n in ((0, 10), (3, 50), (17, 1000), (0, 1000), (999, 1000)):
        # One-sided 95 % = the upper end of the two-sided 90 % interval.
        _, upper = proportion_confint(k, n, alpha=0.10, method="beta")
        assert clopper_pearson_upper(k, n) == pytest.approx(upper, rel=1e-9)
    assert clopper_pearson_upper(0, 1000) == pytest.approx(1 - 0.05 ** (1 / 1000), rel=1e-9)
    assert clopper_pearson_upper(0, 1000) == pytest.approx(3 / 1000, rel=0.01)
    assert clopper_pearson_upper(5, 5) == 1.0


def test_people_are_drawn_deterministically_within_the_stated_ranges():
    scenes = [draw_scene(i, 11) for i in range(200)]
    again = draw_scene(7, 11)
    assert again[1] == scenes[7][1] and again[2] == scenes[7][2]
    assert scenes[8][1] != scenes[7][1] and draw_scene(7, 12)[1] != scenes[7][1]
    drawn = [d for _, d, _ in scenes]
    speeds = np.array([d["peak_speed_m_s"] for d in drawn])
    assert speeds.min() >= 0.5 and speeds.max() <= 2.1 and speeds.max() - speeds.min() > 1.3
    assert {d["side"] for d in drawn} == {"front", "left", "right"}
    assert {d["kind"] for d in drawn} == {"cross", "approach"}
    assert {d.get("reach") for d in drawn if d["kind"] == "approach"} == {"none", "arm", "path"}
    two = sum("second" in d for d in drawn)
    assert 20 <= two <= 60  # 0.2 of 200
    for scene, d, _ in scenes[:20]:  # the walked speeds follow the drawn peaks (smoothstep: 1.5 x mean)
        t = np.arange(0.0, scene.duration_s, 0.01)
        xy, _, speed = scene.first.torso_path(t)
        assert speed.max() == pytest.approx(d["peak_speed_m_s"], rel=0.05)


class _ApproachingHuman:
    """A torso closing in on a point from +y at ``speed`` [m/s], stopping ``stop_gap_m`` short of it."""

    def __init__(self, target, start_gap_m, stop_gap_m, speed_m_s, radius_m=0.15):
        self.t_s = np.arange(0.0, 4.0, 0.02)
        self.radius_m = np.array([radius_m])
        self._place(target, np.maximum(start_gap_m - speed_m_s * self.t_s, stop_gap_m))

    def _place(self, target, gap):
        """The torso (0.6 m tall) at ``gap`` [m] (per time) from ``target`` along +y."""
        centre = np.asarray(target) + np.outer(gap, [0.0, 1.0, 0.0])
        self.p0_b_m = (centre + [0, 0, -0.3])[:, None]
        self.p1_b_m = (centre + [0, 0, 0.3])[:, None]


def _truth(human):
    from cobotsafety.experiments.approach_truth import TruthHuman

    return TruthHuman(human.t_s, human.p0_b_m, human.p1_b_m, human.radius_m)


def test_the_separation_gradient_matches_finite_differences():
    from cobotsafety.tools.campaign.escape import _Kinematics

    kin = _Kinematics("iiwa")
    rng = np.random.default_rng(4)
    q = kin.state.q.copy() + rng.normal(scale=0.2, size=kin.state.nv)
    p = kin.capsules(q)[1][-1] + [0.1, 0.45, -0.05]
    human = (np.array([p + [0, 0, -0.3]]), np.array([p + [0, 0, 0.3]]), np.array([0.15]))
    d, grad = kin.separation(q, *human)
    h = 1e-6
    numeric = [(kin.separation(q + h * e, *human)[0] - kin.separation(q - h * e, *human)[0]) / (2 * h)
               for e in np.eye(len(q))]
    np.testing.assert_allclose(grad, numeric, atol=1e-5)


@pytest.mark.parametrize("robot", ["iiwa", "panda"])
def test_the_hands_velocity_turns_with_the_pose_as_pinocchios_jacobian_time_variation(robot):
    """``hand_velocity_turn(J6, v) @ d`` is ``d(J_ee v)/dq`` along ``d``: pinocchio's time
    variation of the hand's Jacobian at the joint velocity ``d`` (``dJ/dt = sum_k dJ/dq_k d_k``),
    applied to ``v``, at random poses and velocities."""
    import pinocchio as pin

    from cobotsafety.tools.campaign.escape import _Kinematics, hand_velocity_turn

    kin = _Kinematics(robot)
    model = kin.state.model
    data = model.createData()
    frame = model.getFrameId(kin.state.spec.ee_frame)
    rng = np.random.default_rng(11)
    for _ in range(20):
        q = pin.neutral(model) + rng.uniform(-1.0, 1.0, model.nq) * 0.5 * (model.upperPositionLimit
                                                                            - model.lowerPositionLimit)
        v, d = rng.uniform(-1.0, 1.0, model.nv), rng.uniform(-1.0, 1.0, model.nv)
        pin.computeJointJacobiansTimeVariation(model, data, q, d)
        pin.updateFramePlacements(model, data)
        dJ_dt = pin.getFrameJacobianTimeVariation(model, data, frame, pin.LOCAL_WORLD_ALIGNED)[:3]
        np.testing.assert_allclose(hand_velocity_turn(kin.frame_jacobian(q), v) @ d, dJ_dt @ v, atol=1e-12)


def test_the_hand_rows_match_the_hands_path_and_their_gradient_finite_differences():
    """The escape search's hand rows (``_HandRows``) at random knot velocities: the speed margins
    are those of the hand's velocity from finite differences of its position along the knots'
    path (integrated at 0.1 ms, pinocchio's forward kinematics), and the Jacobian of all the
    margins is their central finite difference."""
    from cobotsafety.tools.campaign.escape import HAND_POINTS, KNOTS, _HandRows, _Kinematics

    kin = _Kinematics("iiwa")
    rng = np.random.default_rng(8)
    n, window = kin.state.nv, 0.9
    q0 = kin.state.q.copy() + rng.normal(scale=0.2, size=n)
    v0 = rng.uniform(-0.3, 0.3, n)
    x = np.concatenate([rng.uniform(-0.5, 0.5, KNOTS * n), [0.0]])
    rows = _HandRows(kin, q0, v0, window)
    margins = rows.margins(x)
    knots_t = np.arange(KNOTS + 1) * window / KNOTS
    knots_v = np.vstack([v0, x[:-1].reshape(KNOTS, n)])
    fine = np.arange(0.0, window + 1e-9, 1e-4)
    v = np.stack([np.interp(fine, knots_t, knots_v[:, j]) for j in range(n)], axis=1)
    q = q0 + np.vstack([np.zeros(n), np.cumsum(0.5 * (v[1:] + v[:-1]) * 1e-4, axis=0)])
    checked = np.round(np.linspace(window / HAND_POINTS, window, HAND_POINTS) / 1e-4).astype(int)
    speeds = []
    for k in checked:
        ends = []
        for kk in (k - 1, k):
            kin.arm.set_configuration(q[kk])
            ends.append(kin.state.p_world_ee.copy())
        speeds.append(np.linalg.norm(ends[1] - ends[0]) / 1e-4)
    np.testing.assert_allclose(margins[:HAND_POINTS], 1.0 - (np.array(speeds) / kin.ee_speed) ** 2, atol=2e-3)
    h = 1e-6
    numeric = np.stack([(rows.margins(x + h * e) - rows.margins(x - h * e)) / (2 * h) for e in np.eye(len(x))],
                       axis=1)
    np.testing.assert_allclose(rows.jacobian(x), numeric, rtol=1e-4, atol=1e-4 * np.abs(numeric).max())


def test_the_escape_search_finds_a_retreat_the_held_arm_did_not_take():
    from cobotsafety.arm.controller import ArmController

    state = ArmController("iiwa", zones=[], capsules="paper").state
    q_home, p_ee = state.q.copy(), state.p_world_ee.copy()
    # The human walks at the hand and stops 0.1 m from its axis: inside the critical distance
    # of a robot that stays, avoidable by moving the hand away.
    truth = _truth(_ApproachingHuman(p_ee, 1.0, 0.1, 0.8))
    t = np.arange(0.0, 3.0, 0.01)
    held = np.tile(q_home, (len(t), 1))
    found = escape_exists("iiwa", held, t, 1.5, truth, 0.0, critical_m=0.1)
    assert found.exists and found.best_min_distance_m >= 0.1
    _assert_a_real_arm_could_follow(found, q_home, truth, critical_m=0.1)
    # A human standing on the robot's shoulder leaves no escape.
    shoulder = state.capsule_p0[1] + [0.0, 0.0, 0.1]
    trapped = _truth(_ApproachingHuman(shoulder, 0.2, 0.0, 0.5))
    assert not escape_exists("iiwa", held, t, 1.5, trapped, 0.0, critical_m=0.1).exists


def test_an_escape_that_needed_the_arm_to_move_before_the_person_was_seen_is_not_one_after_detection():
    """The person of the test above, seen only once they stand at the hand: from the window's
    start (1 s before) the arm had time to get away, from their detection it has none; and the
    detection time is the start of the unbroken stretch of sightings up to the closest moment."""
    from cobotsafety.arm.controller import ArmController
    from cobotsafety.tools.campaign.person_run import detection_time_s

    state = ArmController("iiwa", zones=[], capsules="paper").state
    q_home, p_ee = state.q.copy(), state.p_world_ee.copy()
    truth = _truth(_ApproachingHuman(p_ee, 1.0, 0.1, 0.8))  # standing at the hand from 1.125 s
    t = np.arange(0.01, 3.0, 0.01)
    held = np.tile(q_home, (len(t), 1))
    seen = np.where((t > 0.2) & (t < 0.3) | (t > 1.2), 0.5, np.inf)  # a glimpse, then from 1.2 s on
    detected = detection_time_s(t, seen, 1.5, 0.01)
    assert detected == pytest.approx(1.2, abs=1e-9)
    assert detection_time_s(t, np.where(t < 1.45, 0.5, np.inf), 1.5, 0.01) is None  # lost at the closest moment
    assert escape_exists("iiwa", held, t, 1.5, truth, 0.0, critical_m=0.1).exists
    late = escape_exists("iiwa", held, t, 1.5, truth, 0.0, critical_m=0.1, earliest_s=detected)
    assert late.window_s[0] == pytest.approx(detected) and not late.exists


class _LungingHuman(_ApproachingHuman):
    """A torso at ``gap(t)`` [m] from a point along +y: ``start_gap_m`` until ``onset_s``, then
    closing at ``speed_m_s`` to ``stop_gap_m`` short of it; with ``first`` = (gap, speed), an
    earlier approach from that gap down to ``start_gap_m``, from 0 s, paused until ``onset_s``."""

    def __init__(self, target, start_gap_m, stop_gap_m, speed_m_s, onset_s, first=None):
        super().__init__(target, start_gap_m, stop_gap_m, speed_m_s)
        gap = np.clip(start_gap_m - speed_m_s * (self.t_s - onset_s), stop_gap_m, start_gap_m)
        if first is not None:
            gap = np.where(self.t_s < onset_s, np.maximum(first[0] - first[1] * self.t_s, start_gap_m), gap)
        self._place(target, gap)


def test_an_escape_that_needed_the_arm_to_move_before_the_persons_approach_began_is_not_one_after_it():
    """A person standing 0.55 m from the resting iiwa's hand who lunges at it at 2 m/s from 1.2 s,
    stopping 0.1 m from its axis (at 1.425 s): their final approach begins at 1.2 s (the arm held
    where it is at the closest moment); an arm that moved off a second before the closest moment
    keeps the critical distance, one that starts when the lunge does cannot. A person who only
    stands has no approach (None), and one closing from the start began before the window."""
    from cobotsafety.tools.campaign.escape import ONSET_STEP_S, _Kinematics, approach_onset_s

    kin = _Kinematics("iiwa")
    q_home, p_ee = kin.state.q.copy(), kin.state.p_world_ee.copy()
    truth = _truth(_LungingHuman(p_ee, 0.55, 0.1, 2.0, 1.2))
    t = np.arange(0.01, 3.0, 0.01)
    held = np.tile(q_home, (len(t), 1))
    onset = approach_onset_s(kin, q_home, truth, 0.0, 0.3, 1.5)
    assert onset == pytest.approx(1.2, abs=ONSET_STEP_S + 1e-9)
    assert escape_exists("iiwa", held, t, 1.5, truth, 0.0, critical_m=0.1, kinematics=kin).exists
    assert not escape_exists("iiwa", held, t, 1.5, truth, 0.0, critical_m=0.1, kinematics=kin, earliest_s=onset).exists
    standing = _truth(_LungingHuman(p_ee, 0.55, 0.1, 2.0, 9.0))
    assert approach_onset_s(kin, q_home, standing, 0.0, 0.3, 1.5) is None
    walking = _truth(_ApproachingHuman(p_ee, 1.0, 0.1, 0.8))  # closing from 0 s to 1.125 s
    assert approach_onset_s(kin, q_home, walking, 0.0, 0.3, 1.0) == pytest.approx(0.3)
    # The last stretch counts: an earlier approach (0.9 -> 0.55 m at 0.8 m/s, to 0.44 s), then a pause.
    paused = _truth(_LungingHuman(p_ee, 0.55, 0.1, 2.0, 1.2, first=(0.9, 0.8)))
    assert approach_onset_s(kin, q_home, paused, 0.0, 0.0, 1.5) == pytest.approx(1.2, abs=ONSET_STEP_S + 1e-9)


def _path_at_1ms(found, q_start):
    """The witness's joint path every 1 ms from the logged state (at rest), by the rectangle rule."""
    from cobotsafety.tools.campaign.escape import KNOTS

    t0, t1 = found.window_s
    knots_t = t0 + np.arange(KNOTS + 1) * (t1 - t0) / KNOTS
    knots_v = np.vstack([np.zeros(len(q_start)), found.witness_rad_s])
    fine = np.arange(t0, t1, 0.001)
    v = np.stack([np.interp(fine, knots_t, knots_v[:, j]) for j in range(len(q_start))], axis=1)
    return q_start + np.cumsum(v * 0.001, axis=0)


def _separation_at_1ms(found, q, truth, kin) -> float:
    """The smallest true separation [m] along ``q``, the witness's path every 1 ms (``_path_at_1ms``)."""
    fine = found.window_s[0] + 0.001 * np.arange(len(q))
    return min(truth.distance_m(*kin.capsules(qk), tk) for qk, tk in zip(q, fine))


def _assert_a_real_arm_could_follow(found, q_start, truth, critical_m):
    """The witness, integrated at 1 ms from the logged state (at rest), stays within the iiwa's
    velocity and acceleration limits, its hand within the end-effector's speed and acceleration
    limits (finite differences of the hand's position; 1 % over at most, the search checks them
    every quarter of a knot interval), and keeps the true separation (the search checks it every
    ``VERIFY_S``; 1 mm for this integration's rectangle rule)."""
    from cobotsafety.tools.campaign.escape import KNOTS, _Kinematics

    kin = _Kinematics("iiwa")
    t0, t1 = found.window_s
    knots_t = t0 + np.arange(KNOTS + 1) * (t1 - t0) / KNOTS
    knots_v = np.vstack([np.zeros(len(q_start)), found.witness_rad_s])
    assert np.all(np.abs(np.diff(knots_v, axis=0)) / np.diff(knots_t)[:, None] <= kin.a_max * (1 + 1e-6))
    assert np.all(np.abs(knots_v) <= kin.v_max * (1 + 1e-9))
    q = _path_at_1ms(found, q_start)
    assert _separation_at_1ms(found, q, truth, kin) >= critical_m - 1e-3
    hand = []
    for qk in np.vstack([q_start, q])[::5]:
        kin.arm.set_configuration(qk)
        hand.append(kin.state.p_world_ee.copy())
    hand_v = np.diff(hand, axis=0) / 0.005
    hand_a = np.diff(hand_v, axis=0) / 0.005
    assert np.linalg.norm(hand_v, axis=1).max() <= kin.ee_speed * 1.01
    assert np.linalg.norm(hand_a, axis=1).max() <= kin.ee_acc * 1.01


def _resting_iiwa(start_gap_m: float, stop_gap_m: float, speed_m_s: float):
    """``(kinematics, q_home, truth, t, held)``: the iiwa's escape kinematics, its log at rest at
    home for 3 s, and a person closing on its hand from +y (``_ApproachingHuman``)."""
    from cobotsafety.tools.campaign.escape import _Kinematics

    kin = _Kinematics("iiwa")
    q_home, p_ee = kin.state.q.copy(), kin.state.p_world_ee.copy()
    truth = _truth(_ApproachingHuman(p_ee, start_gap_m, stop_gap_m, speed_m_s))
    t = np.arange(0.0, 3.0, 0.01)
    return kin, q_home, truth, t, np.tile(q_home, (len(t), 1))


def test_an_escape_needs_acceleration_the_arm_has():
    """A person closing 0.4 m on the resting iiwa's hand at 1 m/s, stopping 0.1 m from its
    axis: at once at full joint speed the hand could get clear (the search finds it with the
    acceleration limits lifted), but the iiwa needs 0.5 s to reach its joint speeds (its
    acceleration limits), and ramping up it covers well under half as far in those 0.4 s: no
    escape a real arm could take."""
    kin, q_home, truth, t, held = _resting_iiwa(0.5, 0.1, 1.0)
    limited = escape_exists("iiwa", held, t, 1.0, truth, 0.0, critical_m=0.08, kinematics=kin)
    kin.a_max, kin.ee_acc = kin.a_max * 1e3, kin.ee_acc * 1e3
    instant = escape_exists("iiwa", held, t, 1.0, truth, 0.0, critical_m=0.08, kinematics=kin)
    assert instant.exists and not limited.exists
    assert limited.best_min_distance_m < 0.08 <= instant.best_min_distance_m


def test_an_escape_keeps_the_hand_within_its_own_limits():
    """A person closing 0.7 m on the resting iiwa's hand at 1.5 m/s, stopping 0.1 m from its
    axis: the joints alone could take the hand clear (the search finds it with the hand's speed
    and acceleration limits lifted), but the iiwa's hand may not exceed 1 m/s and 2 m/s^2
    (``MotionLimits``, which the controllers keep): the escape the search allows is one within
    every limit a controller must keep."""
    kin, q_home, truth, t, held = _resting_iiwa(0.8, 0.1, 1.5)
    assert (kin.ee_speed, kin.ee_acc) == (1.0, 2.0)
    limited = escape_exists("iiwa", held, t, 0.67, truth, 0.0, critical_m=0.1, kinematics=kin)
    kin.ee_speed, kin.ee_acc = 1e3, 1e3
    free = escape_exists("iiwa", held, t, 0.67, truth, 0.0, critical_m=0.1, kinematics=kin)
    assert free.exists and not limited.exists
    assert limited.best_min_distance_m < 0.095


@pytest.mark.parametrize("lifted", ["acceleration", "hand"])
def test_an_optimisers_answer_beyond_the_arms_limits_is_never_counted_an_escape(lifted, monkeypatch):
    """The search checks every answer itself: SLSQP handed back the escape found with a limit
    lifted (the two scenes above) once that limit holds again, and it is refused, not counted."""
    from types import SimpleNamespace

    from cobotsafety.tools.campaign import escape
    from cobotsafety.tools.campaign.escape import _Kinematics

    kin = _Kinematics("iiwa")
    q_home, p_ee = kin.state.q.copy(), kin.state.p_world_ee.copy()
    t = np.arange(0.0, 3.0, 0.01)
    held = np.tile(q_home, (len(t), 1))
    if lifted == "acceleration":
        truth, t_closest, critical = _truth(_ApproachingHuman(p_ee, 0.5, 0.1, 1.0)), 1.0, 0.08
        a_max, ee_acc = kin.a_max, kin.ee_acc
        kin.a_max, kin.ee_acc = a_max * 1e3, ee_acc * 1e3
        beyond = escape_exists("iiwa", held, t, t_closest, truth, 0.0, critical_m=critical, kinematics=kin)
        kin.a_max = a_max  # (the hand's limit stays lifted: the joints' acceleration alone must refuse it)
    else:
        truth, t_closest, critical = _truth(_ApproachingHuman(p_ee, 0.8, 0.1, 1.5)), 0.67, 0.1
        ee_speed, ee_acc = kin.ee_speed, kin.ee_acc
        kin.ee_speed, kin.ee_acc = 1e3, 1e3
        beyond = escape_exists("iiwa", held, t, t_closest, truth, 0.0, critical_m=critical, kinematics=kin)
        kin.ee_speed, kin.ee_acc = ee_speed, ee_acc
    assert beyond.exists and beyond.witness_rad_s is not None
    answer = np.concatenate([beyond.witness_rad_s.ravel(), [beyond.best_min_distance_m]])
    monkeypatch.setattr(escape, "minimize", lambda *args, **kwargs: SimpleNamespace(x=answer.copy()))
    refused = escape_exists("iiwa", held, t, t_closest, truth, 0.0, critical_m=critical, kinematics=kin)
    assert not refused.exists and refused.best_min_distance_m < critical


@pytest.mark.parametrize("robot", ["iiwa", "panda"])
def test_the_cells_margins_match_pinocchio_and_their_gradient_finite_differences(robot):
    """The escape search keeps the cell's limitations every campaign controller keeps besides
    the person and the joint limits (the same table and reach objects as
    ``approach_step.make_controller``'s arm): each capsule end's height above the table less its
    radius, and the hand's distance from the reach's shoulder within its inner and extended
    reach, against pinocchio's forward kinematics (not the compiled step's), at random
    configurations; their gradient against central differences."""
    import pinocchio as pin

    from cobotsafety.experiments import approach_step
    from cobotsafety.tools.campaign.escape import _Kinematics

    kin = _Kinematics(robot)
    arm = approach_step.make_controller(robot, "anticipative").arm
    assert kin.table == arm.table and kin.reach == arm.reach
    state, model = kin.state, kin.state.model
    data = model.createData()
    ee = model.getFrameId(state.spec.ee_frame)
    shoulder = np.asarray(kin.reach.shoulder)
    rng = np.random.default_rng(21)
    for _ in range(5):
        q = np.clip(state.q + rng.normal(scale=0.4, size=state.nv), kin.lower, kin.upper)
        margins, gradient = kin.cell_margins(q)
        pin.framesForwardKinematics(model, data, q)
        expected = []
        for c in range(kin.table.skip_capsules, len(state.capsule_radius)):
            placement = data.oMi[state.capsule_joint_ids[c]]
            for local in (state.capsule_p0_local[c], state.capsule_p1_local[c]):
                expected.append(placement.act(local)[2] - state.capsule_radius[c] - kin.table.height_m)
        r = np.linalg.norm(data.oMf[ee].translation - shoulder)
        expected += [r - kin.reach.inner_m, kin.reach.outer_m - r]
        np.testing.assert_allclose(margins, expected, atol=1e-9)
        h = 1e-6
        numeric = np.stack([(kin.cell_margins(q + h * e)[0] - kin.cell_margins(q - h * e)[0]) / (2 * h)
                            for e in np.eye(len(q))], axis=1)
        np.testing.assert_allclose(gradient, numeric, atol=1e-6)


def test_an_escape_keeps_the_cell_the_controllers_keep(monkeypatch):
    """The person of the first scene closes on the resting iiwa's hand from +y at 0.8 m/s: with
    no reach to keep, the search's escape pulls the hand back toward the base, centimetres off
    its radius from the reach's shoulder. With the reach narrowed to a shell 1 cm either side of
    that radius (a reach the controllers would have to keep), the escape it finds slides the hand
    along the shell instead, within it at every sample; and the first escape, handed back as an
    optimiser's answer, is refused."""
    from types import SimpleNamespace

    from cobotsafety.arm.limitations import ReachLimits
    from cobotsafety.tools.campaign import escape
    from cobotsafety.tools.campaign.escape import CELL_TOLERANCE_M, _weights

    kin, q_home, truth, t, held = _resting_iiwa(1.0, 0.1, 0.8)
    shoulder = kin.reach.shoulder
    radius = float(np.linalg.norm(kin.state.p_world_ee - np.asarray(shoulder)))

    def sampled_margins(found):
        _, W = _weights(found.window_s[1] - found.window_s[0])
        return np.array([kin.cell_margins(q)[0] for q in q_home + W @ found.witness_rad_s])

    kin.reach = ReachLimits(shoulder, 0.0, 10.0)
    free = escape_exists("iiwa", held, t, 1.5, truth, 0.0, critical_m=0.1, kinematics=kin)
    kin.reach = ReachLimits(shoulder, radius - 0.01, radius + 0.01)
    assert free.exists and sampled_margins(free).min() < -0.01
    shell = escape_exists("iiwa", held, t, 1.5, truth, 0.0, critical_m=0.1, kinematics=kin)
    assert shell.exists and sampled_margins(shell).min() >= -CELL_TOLERANCE_M
    answer = np.concatenate([free.witness_rad_s.ravel(), [free.best_min_distance_m]])
    monkeypatch.setattr(escape, "minimize", lambda *args, **kwargs: SimpleNamespace(x=answer.copy()))
    handed = escape_exists("iiwa", held, t, 1.5, truth, 0.0, critical_m=0.1, kinematics=kin)
    if handed.witness_rad_s is not None:
        assert sampled_margins(handed).min() >= -CELL_TOLERANCE_M
        assert not np.allclose(handed.witness_rad_s, free.witness_rad_s)


def test_an_escape_keeps_the_critical_distance_between_the_searchs_samples_too(monkeypatch):
    """The person of the first scene: the search's optimum keeps the critical distance at its
    16 samples and touches it at several, so between them the motion it found dipped 6 mm below
    it (at 1 ms, integrated by the test); checked every ``VERIFY_S`` before it counts, the
    escape it reports keeps it throughout. Without the check (``VERIFY_S`` longer than the
    window) the dipping motion was counted."""
    from cobotsafety.tools.campaign import escape

    kin, q_home, truth, t, held = _resting_iiwa(1.0, 0.1, 0.8)
    checked = escape_exists("iiwa", held, t, 1.5, truth, 0.0, critical_m=0.1, kinematics=kin)
    assert checked.exists
    _assert_a_real_arm_could_follow(checked, q_home, truth, critical_m=0.1)
    monkeypatch.setattr(escape, "VERIFY_S", 1e9)
    unchecked = escape_exists("iiwa", held, t, 1.5, truth, 0.0, critical_m=0.1, kinematics=kin)
    assert unchecked.exists and _separation_at_1ms(unchecked, _path_at_1ms(unchecked, q_home), truth, kin) < 0.1 - 0.003


def test_a_campaign_persons_escapes_nest_from_the_window_to_detection_to_the_approach():
    """One drawn person the anticipative iiwa breaches for (seed 0, person 163: walks in, stops,
    reaches at the arm; 245 mm at the closest, an escape keeping 515 mm): the searches from later
    starts are asked only when the earlier found an escape, so each answer implies the one
    before; the approach began after the person was first seen, before the closest moment, and
    the search from it was asked (a bool). (Person 124 until the hand's limits gave way first:
    its run now comes 1 mm inside the critical distance and the search finds no escape.)"""
    from cobotsafety.tools.campaign.person_run import run_person

    r = run_person("iiwa", 163, 0, ("anticipative",))[0]
    assert r["breach"] and r["escape_exists"] and r["escape_after_detection"]
    assert 0.0 < r["approach_onset_before_closest_s"] < r["detected_before_closest_s"]
    assert isinstance(r["escape_after_approach_onset"], bool)
    nobody = run_person("iiwa", 0, 0, ("anticipative",))[0]  # walks past: no breach, nothing asked
    assert not nobody["breach"]
    assert nobody["escape_after_approach_onset"] is None and nobody["approach_onset_before_closest_s"] is None


def test_the_summary_counts_what_each_person_gave():
    """``summarise`` over hand-made results: the escapes nest (window, detection, approach), a
    None (not asked) is not a yes, and a run counts over the acceleration limit only above
    ``OVER_LIMIT`` (a kept run's 0.9999 / 1.0000 is not)."""
    from cobotsafety.tools.campaign.report import OVER_LIMIT, summarise

    def person(i, true_m, escape=None, detection=None, onset=None, ratio=0.9999):
        return {"robot": "iiwa", "controller": "anticipative", "person": i, "true_min_distance_m": true_m,
                "breach": true_m < 0.3, "escape_exists": escape, "escape_after_detection": detection,
                "escape_after_approach_onset": onset, "completed": True, "time_lost_s": 1.0,
                "max_joint_acceleration_ratio": ratio, "posture_recoveries": 0}

    rows = [person(0, 0.5), person(1, 0.1, True, True, True, 40.0), person(2, 0.2, True, True, False, 1.0),
            person(3, 0.25, True, False, False, OVER_LIMIT + 1e-6), person(4, 0.05, False, False, False),
            person(5, 0.6, ratio=OVER_LIMIT)]
    (s,) = summarise(rows)
    assert (s["people"], s["breaches"], s["breaches_with_escape"]) == (6, 4, 3)
    assert (s["breaches_with_escape_after_detection"], s["breaches_with_escape_after_approach_onset"]) == (2, 1)
    assert s["people_over_acceleration_limit"] == 2 and s["max_joint_acceleration_ratio"] == 40.0
    assert (s["plant"], s["people_rate_limited"]) == ("ideal", 0)  # rows from before the plant was recorded
    assert s["people_with_safety_over_smoothness"] is None  # not kept then: unknown, not 0
    limited = [dict(r, plant="rate-limited", rate_limited_steps=k, safety_over_smoothness_steps=n)
               for r, k, n in zip(rows, (0, 3, 0, 1, 0, 2), (0, 2, 0, 0, 0, 0))]
    (s,) = summarise(limited)
    assert (s["plant"], s["people_rate_limited"], s["people_with_safety_over_smoothness"]) == ("rate-limited", 3, 1)
    assert (s["max_ee_acceleration_ratio"], s["people_over_hand_limits"]) == (None, None)  # not kept then
    hands = [dict(r, max_ee_acceleration_ratio=a, max_ee_jerk_ratio=j)
             for r, a, j in zip(limited, (0.9, 1.7, OVER_LIMIT, 0.5, 0.2, 0.95), (0.9, 0.8, 0.7, OVER_LIMIT + 1e-6, 0.1, 1.0))]
    (s,) = summarise(hands)
    assert (s["max_ee_acceleration_ratio"], s["people_over_hand_limits"]) == (1.7, 2)  # person 1's acceleration, 3's jerk
    (s,) = summarise(hands[:5] + [dict(hands[5], max_ee_jerk_ratio=None)])
    assert s["people_over_hand_limits"] is None  # one person unknown: the count is unknown


@pytest.mark.parametrize("robot, person", [("iiwa", 5), ("panda", 5)])
def test_the_rate_limited_arm_moves_within_its_limits_where_the_ideal_one_did_not(robot, person):
    """The same person, the anticipative filter: the ideal plant follows commands beyond the
    joint acceleration limit (the precondition: this person's run has them); through the
    robot's rate limiter (closed loop) the arm's motion stays within the limit, the steps it
    changed are counted, and the run still ends (the task completes)."""
    from cobotsafety.tools.campaign.person_run import run_person

    ideal, = run_person(robot, person, 0, ("anticipative",), escape_check=False, plant="ideal")
    limited, = run_person(robot, person, 0, ("anticipative",), escape_check=False)  # the default plant
    assert ideal["max_joint_acceleration_ratio"] > 2.0 and ideal["rate_limited_steps"] == 0
    assert limited["max_joint_acceleration_ratio"] <= 1.0 + 1e-4  # (the result is rounded to 4 digits)
    assert limited["rate_limited_steps"] > 0 and limited["plant"] == "rate-limited" and limited["completed"]
    assert ideal["safety_over_smoothness_steps"] > 0  # the filter counted the steps it commanded beyond them


@pytest.mark.parametrize("robot, person", [("iiwa", 31), ("panda", 21)])
def test_a_run_within_the_limits_is_the_same_on_both_plants(robot, person):
    """People the filter keeps within the limits (no step counted beyond them, and no joint
    accelerating in the last part of its speed, where the limiter's bound is stricter than the
    filter's ramp): the rate limiter changes no step, so every result is the same bit for bit
    (the limiter lets a feasible command through exactly). Panda 21 holds joint 6 at its speed
    limit, where the solver's rounding asked 1e-14 rad/s more: 5 steps "changed" by that before
    ``rate_limiter.ROUNDING_RAD_S``."""
    from cobotsafety.tools.campaign.person_run import run_person

    ideal, = run_person(robot, person, 0, ("anticipative",), escape_check=False, plant="ideal")
    limited, = run_person(robot, person, 0, ("anticipative",), escape_check=False, plant="rate-limited")
    assert ideal["max_joint_acceleration_ratio"] <= 1.0 and ideal["safety_over_smoothness_steps"] == 0
    assert limited["rate_limited_steps"] == 0
    assert {k: v for k, v in limited.items() if k != "plant"} == {k: v for k, v in ideal.items() if k != "plant"}


def test_the_campaigns_ssm_reaches_each_controller_and_is_recorded():
    """``--ssm``: ISO/TS 15066's speed and separation monitoring on every controller of the run.
    A person approaching the panda (person 4 of seed 0): with the protective stop every
    controller's arm is held for a while, without it never; each result says which SSM ran; a
    mode that does not exist is one clear error."""
    from cobotsafety.tools.campaign.person_run import run_person

    controllers = ("anticipative", "reactive", "stop")
    off = run_person("panda", 4, 0, controllers, escape_check=False)  # the default
    stop = run_person("panda", 4, 0, controllers, escape_check=False, ssm="stop")
    assert [r["ssm"] for r in off + stop] == ["off"] * 3 + ["stop"] * 3
    assert all(r["protective_stop_time_s"] == 0.0 for r in off)
    assert all(r["protective_stop_time_s"] > 0.0 for r in stop)
    with pytest.raises(ValueError, match="ssm must be one of"):
        run_person("panda", 4, 0, ("anticipative",), escape_check=False, ssm="slow")


def test_a_directory_holding_another_campaign_is_refused(tmp_path):
    """Resuming a directory with another plant, seed or SSM would mix two campaigns' results: one
    clear error, nothing run."""
    from cobotsafety.errors import CampaignError

    (tmp_path / "campaign.json").write_text(json.dumps({"seed": 0, "dt_s": 1 / 275, "plant": "ideal"}))
    with pytest.raises(CampaignError, match="plant 'ideal' there, 'rate-limited' asked"):
        run_campaign(tmp_path, ("iiwa",), ("stop",), people=1, seed=0, workers=1, progress=False,
                     plant="rate-limited")
    with pytest.raises(CampaignError, match="seed 0 there, 3 asked"):
        run_campaign(tmp_path, ("iiwa",), ("stop",), people=1, seed=3, workers=1, progress=False)
    # (a campaign from before the SSM was recorded ran without it)
    with pytest.raises(CampaignError, match="ssm 'off' there, 'stop' asked"):
        run_campaign(tmp_path, ("iiwa",), ("stop",), people=1, seed=0, workers=1, progress=False, plant="ideal",
                     ssm="stop")
    assert not (tmp_path / "results").exists()
    for text in ("{not json", "[1, 2]"):
        (tmp_path / "campaign.json").write_text(text)
        with pytest.raises(CampaignError, match="is not a campaign's settings"):
            run_campaign(tmp_path, ("iiwa",), ("stop",), people=1, seed=0, workers=1, progress=False)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("campaign")
    first = run_campaign(out, ("iiwa",), ("stop",), people=2, seed=5, workers=1, escape_check=False, progress=False)
    return out, first


def test_a_tiny_campaign_reports_every_key(tiny):
    out, first = tiny
    (row,) = json.loads((out / "report.json").read_text())
    assert set(row) == set(REPORT_KEYS)
    assert (row["robot"], row["controller"], row["people"]) == ("iiwa", "stop", 2)
    assert row["breach_rate_upper_95"] == pytest.approx(clopper_pearson_upper(row["breaches"], 2))
    assert (out / "report.md").read_text().count("| iiwa | stop |") >= 1 and (out / "histogram_iiwa.png").exists()
    assert first["timing"]["tasks_run"] == 2


def test_the_campaign_resumes_and_is_deterministic(tiny):
    out, _ = tiny
    files = {p: p.read_bytes() for p in (result_path(out, "iiwa", "stop", i) for i in range(2))}
    again = run_campaign(out, ("iiwa",), ("stop",), people=2, seed=5, workers=1, escape_check=False, progress=False)
    assert again["timing"]["tasks_run"] == 0  # nothing re-run
    victim = result_path(out, "iiwa", "stop", 1)
    victim.unlink()
    redo = run_campaign(out, ("iiwa",), ("stop",), people=2, seed=5, workers=1, escape_check=False, progress=False)
    assert redo["timing"]["tasks_run"] == 1
    assert {p: p.read_bytes() for p in files} == files  # the same bytes: deterministic per seed


def test_a_tiny_campaign_on_a_local_ray_instance_gives_the_same_results(tiny, tmp_path):
    import ray
    out, _ = tiny
    try:  # the runner starts the local instance: ray.init(num_cpus=2) on 127.0.0.1
        result = run_campaign(tmp_path, ("iiwa",), ("stop",), people=2, seed=5, workers=2, ray_address="local",
                              escape_check=False, progress=False)
        assert ray.is_initialized() and ray.cluster_resources()["CPU"] == 2
    finally:
        ray.shutdown()
    assert result["timing"]["tasks_run"] == 2
    for i in range(2):
        assert result_path(tmp_path, "iiwa", "stop", i).read_bytes() == result_path(out, "iiwa", "stop", i).read_bytes()


def test_a_robot_whose_task_does_not_complete_alone_is_refused_in_one_line(tmp_path, capsys):
    """The z1's hand cannot finish the campaign's pick-and-place path with nobody there: no time
    lost could be measured, so the command refuses it, one line, exit 2 (a RuntimeError's
    traceback before)."""
    from cobotsafety.cli import main

    assert main(["campaign", "--robot", "z1", "--people", "1", "--controller", "anticipative", "--workers", "1",
                 "--no-escape-check", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == ("cobotsafety campaign: z1: the campaign task does not complete with nobody there (in "
                       "120 s): no time lost or completion can be measured on it")
    assert not any("Traceback" in line for line in err)
