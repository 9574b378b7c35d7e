"""HumanTracker fed by the PersonTracker: torso velocity, the human chosen, a lost track."""

from __future__ import annotations

import dataclasses
from importlib.resources import files

import numpy as np
import pytest

from cobotsafety.human.conservative import could_have_left
from cobotsafety.human.recording import load_recording
from cobotsafety.human.replay import Replay
from cobotsafety.sensors.person_tracker import Person

ASSETS = files("cobotsafety.assets") / "recordings"


@pytest.fixture(scope="module")
def recording():
    return load_recording(ASSETS / "reach-over.jsonl.gz")


@pytest.fixture(scope="module")
def truth():
    return dict(np.load(ASSETS / "reach-over_truth.npz"))


def test_torso_velocity_follows_the_generator_truth(recording, truth):
    """The track's velocity (Kalman, causal) against the derivative of the true torso path."""
    replay = Replay(recording)
    t = truth["t_s"]
    v_true = np.gradient(truth["torso_xy_b_m"], t, axis=0)
    errors = []
    for i, t_i in enumerate(t):
        caps = replay.capsules_at(t_i)
        v = replay.tracker.torso_velocity_at(t_i, t_i)
        if v is not None and caps.present and not caps.stale:
            errors.append(np.linalg.norm(v - v_true[i]))
    errors = np.array(errors)
    assert errors.size > 900
    assert np.median(errors) < 0.08  # m/s; the walk is 0.7-0.9 m/s
    assert np.percentile(errors, 95) < 0.25
    assert replay.tracker.torso_velocity_at(t[0], t[0]) is None  # not seen yet: no velocity


def end_point_velocity_errors(name):
    """Per fresh five-capsule human at the truth's samples: the error of every end point's
    velocity (10,) [m/s] against the derivative of the generator's true end points, for the
    capsules' velocities and for the tracked torso velocity alone; and the true speeds."""
    recording, truth = load_recording(ASSETS / f"{name}.jsonl.gz"), dict(np.load(ASSETS / f"{name}_truth.npz"))
    replay = Replay(recording)
    t = truth["t_s"]
    v_true = np.concatenate([np.gradient(truth["p0_b_m"], t, axis=0), np.gradient(truth["p1_b_m"], t, axis=0)], axis=1)
    errors, torso_only, speeds, without = [], [], [], 0
    for i, t_i in enumerate(t):
        caps = replay.tracker.wearer_at(t_i, t_i)  # (the IMU wearer's: without the laser's other people)
        if not caps.present:
            assert caps.v0_b_m_s is None
            continue
        if caps.v0_b_m_s is None:
            without += 1
            continue
        if len(caps.names) != 5:
            continue
        v = np.concatenate([caps.v0_b_m_s, caps.v1_b_m_s])
        torso = np.zeros_like(v)
        torso[:, :2] = replay.tracker.torso_velocity_at(t_i, t_i)
        errors.append(np.linalg.norm(v - v_true[i], axis=1))
        torso_only.append(np.linalg.norm(torso - v_true[i], axis=1))
        speeds.append(np.linalg.norm(v_true[i], axis=1))
    return np.array(errors), np.array(torso_only), np.array(speeds), without


@pytest.mark.parametrize("name", ["exp1-corner", "reach-over"])
def test_the_capsules_move_with_the_torso_and_the_arms_own_motion(name):
    """Every end point of a fresh five-capsule human carries the tracked torso velocity plus its
    own motion from the IMUs (a backward difference of the IMU chain), compared here with the
    derivative of the generator's true end points. The torso's velocity alone misses a reaching
    hand: ``torso_only`` is the error the capsules had when the arms' motion was not estimated
    (kept to show the test can fail). A human not seen fresh carries no velocity."""
    errors, torso_only, speeds, without = end_point_velocity_errors(name)
    assert errors.shape[0] > 500 and without < errors.shape[0]
    moving = speeds > 0.5  # m/s: the reaching and swinging end points
    assert moving.sum() > 1000
    assert np.median(errors[moving]) < 0.2  # m/s (torso only: 0.26-0.37)
    assert np.percentile(errors, 95) < 0.4  # m/s (torso only: 0.50-1.03)
    assert np.median(torso_only[moving]) > np.median(errors[moving])


def person(track_id, xy, confirmed=True, seen_s=0.0):
    return Person(track_id, np.array(xy, float), np.zeros(2), np.zeros((0, 2)), confirmed, seen_s)


def test_the_human_is_the_confirmed_person_nearest_the_robot(recording):
    tracker = Replay(recording).tracker
    people = [person(1, [0.5, 0.0], confirmed=False), person(2, [1.0, 0.2]), person(3, [-0.8, -0.9])]
    assert tracker.human_from_people(people).track_id == 2
    assert tracker.human_from_people(people[:1]) is None


def test_legs_lost_with_the_laser_alive_grow_the_human_then_let_it_go(recording):
    """From t = 10 s the scans show the empty scene (the human hidden, or gone): the human stays,
    flagged stale, at the last pose with a radius growing with the time since seen; nobody is
    in range only once the human could have walked out of the clipped range."""
    hidden_from_s = 10.0
    later = recording.laser_t_s > hidden_from_s
    empty_scene = np.max(recording.laser_ranges_m, axis=0)  # the farthest reading of every beam
    hidden = recording.laser_ranges_m.copy()
    hidden[later] = empty_scene
    replay = Replay(dataclasses.replace(recording, laser_ranges_m=hidden))
    before = replay.capsules_at(hidden_from_s)
    assert before.present and not before.stale
    scanner = np.array([recording.scanner.x_m, recording.scanner.y_m])
    distance = float(np.linalg.norm(before.p0_b_m[0, :2] - scanner))
    previous = before.radius_m
    gone = False
    for t in np.arange(hidden_from_s + 0.02, hidden_from_s + 2.0, 0.02):
        caps = replay.capsules_at(t)
        age = replay.tracker.torso.age_s(t, t)
        if not caps.present:
            assert could_have_left(distance, age, replay.tracker.max_range_m, replay.tracker.policy)
            gone = True
            continue
        assert not gone, "the human came back from an empty scene"
        assert np.allclose(caps.p0_b_m[0, :2], before.p0_b_m[0, :2], atol=0.05)  # held
        assert np.all(caps.radius_m >= previous - 1e-12)
        if age > replay.tracker.policy.laser_stale_after_s:
            assert caps.stale and "legs not seen" in caps.reason
            assert np.all(caps.radius_m >= before.radius_m + replay.tracker.policy.speed_m_s * (age - 0.03))
        previous = caps.radius_m
    assert gone


@pytest.mark.parametrize("name", ["exp1-corner", "reach-over"])
def test_between_sightings_the_torso_moves_on_at_its_tracked_velocity(name):
    """Between two scans the causal human's torso moves at the velocity its capsules carry (held
    at its last sighting it stood still while the rows braked for that velocity, and jumped at
    the next scan), and is nearer the generator's true torso (interpolated between its samples)
    than the held sighting is."""
    recording, truth = load_recording(ASSETS / f"{name}.jsonl.gz"), dict(np.load(ASSETS / f"{name}_truth.npz"))
    replay = Replay(recording)
    t, xy_true = truth["t_s"], truth["torso_xy_b_m"]
    moved, predicted, held = 0, [], []
    for i in range(len(t) - 1):
        for frac in (0.25, 0.5, 0.75):
            t_i = t[i] + frac * (t[i + 1] - t[i])
            caps = replay.tracker.wearer_at(t_i, t_i)
            if not caps.present or caps.stale or caps.v0_b_m_s is None:
                continue
            sighting = replay.tracker.torso.value_at(t_i, t_i)
            later = replay.tracker.wearer_at(t_i + 1e-3, t_i)  # no new sample visible: moved on
            velocity = replay.tracker.torso_velocity_at(t_i, t_i)
            assert (later.p0_b_m[0, :2] - caps.p0_b_m[0, :2]) / 1e-3 == pytest.approx(velocity, abs=1e-6)
            moved += np.linalg.norm(caps.p0_b_m[0, :2] - sighting) > 1e-6
            true = xy_true[i] + frac * (xy_true[i + 1] - xy_true[i])
            predicted.append(np.linalg.norm(caps.p0_b_m[0, :2] - true))
            held.append(np.linalg.norm(sighting - true))
    assert len(predicted) > 1000 and moved > 0.9 * len(predicted)
    assert np.percentile(predicted, 95) < np.percentile(held, 95)  # (exp1-corner 17.7 vs 25.3 mm)


def _two_people(second_keyframes):
    """A scene of two people: the first (the IMU wearer) walks in and stands before the
    scanner's corner from 1.5 s on, the second moves through ``second_keyframes`` (seen by the
    laser only). (Nobody stands still throughout: the background is estimated from the scans.)"""
    from cobotsafety.tools.generate_recording import generate
    from cobotsafety.tools.scripted_people import Group, KeyframedHuman

    first = KeyframedHuman("first", 6.0, "stands", keyframes=((0.0, 2.4, -0.4, np.pi), (1.5, 1.1, -0.4, np.pi),
                                                                (6.0, 1.1, -0.4, np.pi)))
    second = KeyframedHuman("second", 6.0, "the other", keyframes=second_keyframes)
    return generate(Group("two", 6.0, "two people", first, (second,)), seed=3)


def _nearest_other(caps, xy):
    """Index of the other person's capsule (``body k``) whose axis is nearest ``xy`` (2,)."""
    others = [j for j, n in enumerate(caps.names) if n.startswith("body ")]
    assert others, caps.names
    return min(others, key=lambda j: np.linalg.norm(caps.p0_b_m[j, :2] - xy))


def test_every_other_person_the_laser_tracks_is_one_capsule_that_holds_them():
    """The filter must see everyone, not only the IMU wearer: a second person standing near
    the first is a ``body k`` capsule holding all of their true capsules (its axis on their
    torso within the tracker's error), after the wearer's five (unchanged). (The tracker's
    ghost tracks at the clipped range's edge are others too: a phantom only slows the robot.)"""
    recording, truth = _two_people(((0.0, 0.6, -2.6, np.pi / 2), (1.5, 0.6, -1.2, np.pi / 2), (6.0, 0.6, -1.2, np.pi / 2)))
    replay = Replay(recording)
    names = [str(n) for n in truth["names"]]
    checked = 0
    for t in np.arange(2.5, 5.75, 0.25):
        caps = replay.capsules_at(replay.start_s + t)
        wearer = replay.tracker.wearer_at(replay.start_s + t, replay.start_s + t)
        assert wearer.names == caps.names[:5] == ("torso", "upper_arm_left", "forearm_left", "upper_arm_right",
                                                  "forearm_right")
        np.testing.assert_array_equal(caps.p0_b_m[:5], wearer.p0_b_m)
        k = int(np.argmin(np.abs(truth["t_s"] - replay.start_s - t)))
        j = _nearest_other(caps, truth["torso_xy_b_m"][k, 1])
        p0, p1, r = caps.p0_b_m[j], caps.p1_b_m[j], caps.radius_m[j]
        axis = p1 - p0
        for i, name in enumerate(names):
            if not name.endswith(" 2"):
                continue
            for end in (truth["p0_b_m"][k, i], truth["p1_b_m"][k, i]):
                u = np.clip((end - p0) @ axis / (axis @ axis), 0.0, 1.0)
                assert np.linalg.norm(end - (p0 + u * axis)) + truth["radius_m"][i] <= r + 0.1, (t, name)
        assert np.linalg.norm(caps.v0_b_m_s[j]) < 0.3  # standing
        checked += 1
    assert checked == 13
    # A silent laser: the others go with it, and the wearer's rules for a silent laser hold alone
    # (the watchdog stops the arm on them), never an old scan's people moving on.
    t = replay.start_s + 4.0
    silent = replay.tracker.capsules_at(t + 1.0, until_s=t)
    assert silent.stale and silent.names == replay.tracker.wearer_at(t + 1.0, until_s=t).names
    assert not any(n.startswith("body ") for n in silent.names)


def test_another_person_walking_is_seen_coming():
    """A second person walking at the base carries the track's velocity on their capsule, and
    the capsule keeps up with them between scans."""
    recording, truth = _two_people(((0.0, 1.9, -1.3, np.pi), (1.0, 1.9, -1.3, np.pi), (4.0, 0.4, -1.3, np.pi),
                                    (6.0, 0.4, -1.3, np.pi)))
    replay = Replay(recording)
    speeds, errors = [], []
    for t in np.arange(2.2, 3.2, 0.01):  # (from 0.2 s after they enter the 1.4 m clip)
        caps = replay.capsules_at(replay.start_s + t)
        k = int(np.argmin(np.abs(truth["t_s"] - replay.start_s - t)))
        true_xy = truth["torso_xy_b_m"][k, 1]
        j = _nearest_other(caps, true_xy)
        errors.append(np.linalg.norm(caps.p0_b_m[j, :2] - true_xy))
        speeds.append(-caps.v0_b_m_s[j, 0])
    # (the track's error is well inside the capsule's arm reach)
    assert np.median(errors) < 0.1 and max(errors) < 0.25
    assert 0.5 < np.median(speeds) < 0.95  # a smoothstep walk at 0.5 m/s mean peaks at 0.75 m/s


def test_a_track_is_another_person_only_while_it_shows_two_legs(recording):
    """A one-legged track (the time filter's tail at the clip ring leaves such ghosts) is no
    person; a track whose two legs were seen within the laser's staleness threshold is one, and
    stays one through a scan that sees a single leg of it; a track nearer the wearer than a
    shoulder width is the wearer tracked twice."""
    tracker = Replay(recording).tracker
    stale = tracker.policy.laser_stale_after_s
    legs = lambda n: np.zeros((n, 2))  # noqa: E731
    wearer = Person(1, np.array([0.9, 0.0]), np.zeros(2), legs(2), True, 0.0)
    ghost = Person(2, np.array([1.5, -0.5]), np.zeros(2), legs(1), True, 0.0)
    other = Person(3, np.array([1.0, 0.8]), np.array([-0.5, 0.0]), legs(2), True, 0.0)
    t0 = 1000.0  # after the recording: only these scans are visible
    tracker.persons = [wearer, ghost, other]
    tracker._record_others(t0, wearer)
    caps = tracker.others_at(t0 + 0.01, until_s=t0 + 0.01)
    assert caps.names == ("body 2",)
    np.testing.assert_allclose(caps.p0_b_m[0, :2], [1.0 - 0.5 * 0.01, 0.8])
    one_leg = dataclasses.replace(other, leg_xy_m=legs(1))
    tracker.persons = [wearer, ghost, one_leg]
    tracker._record_others(t0 + 0.5 * stale, wearer)
    assert tracker.others_at(t0 + 0.5 * stale, until_s=t0 + 0.5 * stale).names == ("body 2",)
    tracker._record_others(t0 + 2.0 * stale, wearer)
    assert not tracker.others_at(t0 + 2.0 * stale, until_s=t0 + 2.0 * stale).present
    # Two legs 0.3 m from the wearer's torso are the wearer tracked twice, not a person.
    twice = Person(4, wearer.p_xy_m + [0.0, 0.3], np.zeros(2), legs(2), True, 0.0)
    tracker.persons = [wearer, twice]
    tracker._record_others(t0 + 3.0 * stale, wearer)
    assert not tracker.others_at(t0 + 3.0 * stale, until_s=t0 + 3.0 * stale).present
