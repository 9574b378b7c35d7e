"""PersonTracker: synthetic walkers with known truth, then the real bags of ../shared/data."""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cobotsafety.sensors.person_tracker import PersonTracker, PersonTrackerParams, pair_legs

SCAN_DT_S = 0.05
HIP_HALF_WIDTH_M = 0.10
STRIDE_AMPLITUDE_M = 0.20


def walker_legs(center_m: np.ndarray, velocity_m_s: np.ndarray, t_s: float) -> np.ndarray:
    """Two legs (2, 2) [m] either side of the torso, swinging in opposition along the walk."""
    speed = float(np.linalg.norm(velocity_m_s))
    heading = velocity_m_s / speed if speed > 0 else np.array([1.0, 0.0])
    side = np.array([-heading[1], heading[0]])
    swing = STRIDE_AMPLITUDE_M * min(speed, 1.0) * np.sin(2 * np.pi * 0.9 * t_s)
    return np.array([center_m + HIP_HALF_WIDTH_M * side + swing * heading,
                     center_m - HIP_HALF_WIDTH_M * side - swing * heading])


def run(walkers, duration_s, rng, noise_m=0.01, drop=lambda w, t, leg: False, tracker=None):
    """Feed the legs of ``walkers`` (functions t -> (p, v)) to a tracker; per scan, the output
    and the truth. ``drop(w, t, leg)`` hides a leg."""
    tracker = tracker or PersonTracker()
    history = []
    for t in np.arange(0.0, duration_s, SCAN_DT_S):
        legs, truth = [], []
        for w, walker in enumerate(walkers):
            p, v = walker(t)
            truth.append((p, v))
            for leg, xy in enumerate(walker_legs(p, v, t)):
                if not drop(w, t, leg):
                    legs.append(xy + rng.normal(0.0, noise_m, 2))
        history.append((t, tracker.update(t, np.array(legs).reshape(-1, 2)), truth))
    return tracker, history


def straight(p0, v):
    p0, v = np.array(p0, float), np.array(v, float)
    return lambda t: (p0 + v * t, v)


def nearest_confirmed(persons, p):
    confirmed = [q for q in persons if q.confirmed]
    if not confirmed:
        return None
    return min(confirmed, key=lambda q: np.linalg.norm(q.p_xy_m - p))


def test_pair_legs_closest_pairs_first_and_lone_legs():
    legs = np.array([[0.0, 0.0], [0.3, 0.0], [0.5, 0.0], [3.0, 0.0]])
    groups = [sorted(g.tolist()) for g in pair_legs(legs, 0.6)]
    assert groups == [[1, 2], [0], [3]]  # 0.2 m pair first; 0 and 3 alone
    assert pair_legs(np.zeros((0, 2)), 0.6) == []


def test_one_walker_velocity_and_position_match_the_truth():
    rng = np.random.default_rng(0)
    v_true = np.array([0.8, -0.5])
    tracker, history = run([straight([-1.0, 1.0], v_true)], 3.0, rng)
    assert tracker.births == 1
    for t, persons, truth in history:
        assert len(persons) == 1
        person = persons[0]
        assert person.confirmed  # born from a pair of legs: confirmed at birth
        assert person.leg_xy_m.shape == (2, 2)
        assert person.time_since_seen_s == 0.0
        if t >= 1.0:  # after the filter's velocity has settled
            p, v = truth[0]
            assert np.linalg.norm(person.p_xy_m - p) < 0.05
            assert np.linalg.norm(person.v_xy_m_s - v) < 0.15


@pytest.mark.parametrize("offset_s", [0.4, 0.7])
def test_crossing_walkers_keep_their_identities(offset_s):
    """Two people on perpendicular paths through the same point, one passing 0.4 m (0.7 m)
    before the other, their legs within pairing distance; and two passing each other 0.8 m
    apart: each keeps one track id from its confirmation on."""
    rng = np.random.default_rng(1)
    walkers = [straight([-2.0, 0.0], [1.0, 0.0]), straight([0.0, -2.0 - offset_s], [0.0, 1.0]),
               straight([3.0, 2.4], [-1.0, 0.0]), straight([-3.0, 3.2], [1.0, 0.0])]
    _, history = run(walkers, 4.0, rng)
    ids = defaultdict(set)
    for t, persons, truth in history:
        if t < 0.5:
            continue
        for w, (p, v) in enumerate(truth):
            if w < 2 and 1.6 < t < 2.6:
                continue  # close to the crossing: identities checked, positions not
            person = nearest_confirmed(persons, p)
            assert person is not None and np.linalg.norm(person.p_xy_m - p) < 0.25, (t, w)
            ids[w].add(person.track_id)
            assert {q.track_id for q in persons if len(q.leg_xy_m)
                    and np.linalg.norm(q.leg_xy_m.mean(axis=0) - p) < 0.35} <= {person.track_id}
    assert all(len(ids[w]) == 1 for w in range(4)), dict(ids)
    assert len(set.union(*ids.values())) == 4


def test_occluded_leg_keeps_the_track():
    """The far leg hidden for a second: a lone leg is the person, the same track follows it."""
    rng = np.random.default_rng(2)
    hidden = lambda w, t, leg: leg == 1 and 1.0 <= t < 2.0
    tracker, history = run([straight([0.0, 0.0], [0.5, 0.5])], 3.0, rng, drop=hidden)
    assert tracker.births == 1
    for t, persons, truth in history:
        assert len(persons) == 1
        if 1.0 <= t < 2.0:
            assert persons[0].leg_xy_m.shape == (1, 2)
            assert np.linalg.norm(persons[0].p_xy_m - truth[0][0]) < HIP_HALF_WIDTH_M + STRIDE_AMPLITUDE_M


def test_person_who_stops_keeps_the_track_and_velocity_falls_to_zero():
    rng = np.random.default_rng(3)

    def walk_then_stand(t):
        if t < 1.5:
            return np.array([1.0 * t, 0.0]), np.array([1.0, 0.0])
        return np.array([1.5, 0.0]), np.zeros(2)

    tracker, history = run([walk_then_stand], 4.0, rng)
    assert tracker.births == 1
    t, persons, truth = history[-1]
    assert np.linalg.norm(persons[0].v_xy_m_s) < 0.1
    assert np.linalg.norm(persons[0].p_xy_m - truth[0][0]) < 0.05


@pytest.mark.parametrize("pairs", [True, False])
def test_a_pair_is_confirmed_at_birth_and_a_lone_leg_after_three_sightings(pairs):
    """Confirmation keeps one stray detection from becoming a person; two legs paired in one
    scan are two detections agreeing on one (docs/leg_recall.md, amendment of 2026-12-04)."""
    tracker = PersonTracker(PersonTrackerParams(confirm_pairs_at_birth=pairs))
    pair, lone = np.array([[1.0, 0.1], [1.0, -0.1]]), np.array([[3.0, 2.0]])  # 2.2 m apart
    confirmed = []
    for k in range(3):
        people = tracker.update(k * SCAN_DT_S, np.concatenate([pair, lone]))
        assert len(people) == 2
        confirmed.append({len(p.leg_xy_m): p.confirmed for p in people})
    assert [c[2] for c in confirmed] == ([True, True, True] if pairs else [False, False, True])
    assert [c[1] for c in confirmed] == [False, False, True]  # a lone leg waits three scans either way


def test_unseen_track_coasts_then_dies_and_clutter_is_never_confirmed():
    params = PersonTrackerParams(delete_after_s=0.5)
    tracker = PersonTracker(params)
    v = np.array([1.0, 0.0])
    for k in range(20):
        t = k * SCAN_DT_S
        persons = tracker.update(t, walker_legs(v * t, v, t))
    seen_t = t
    for k in range(1, 12):
        t = seen_t + k * SCAN_DT_S
        persons = tracker.update(t, np.zeros((0, 2)))
        if k <= 9:
            assert len(persons) == 1 and persons[0].confirmed
            assert persons[0].time_since_seen_s == pytest.approx(t - seen_t)
            assert persons[0].leg_xy_m.shape == (0, 2)
            assert persons[0].p_xy_m[0] > v[0] * seen_t  # coasting forward
        elif k == 11:
            assert persons == []
    # A leg-like blob seen in two scans only stays tentative and then vanishes.
    t0 = t + 1.0
    assert [p.confirmed for p in tracker.update(t0, [[2.0, 2.0]])] == [False]
    assert [p.confirmed for p in tracker.update(t0 + SCAN_DT_S, [[2.0, 2.0]])] == [False]
    assert tracker.update(t0 + 1.0, np.zeros((0, 2))) == []


@pytest.mark.parametrize("packed", [True, False])
def test_a_stray_detection_never_takes_a_leg_from_a_confirmed_person(packed):
    """A person stands with legs 0.3 m apart (mid-stride); one scan shows a stray leg-like blob
    0.21 m beside one leg (a tentative track is born there), then nothing there. Unseen, the
    tentative track's covariance grows until that leg is a cheaper Mahalanobis match for it
    than for the person's torso 0.15 m away: the confirmed person must still get both legs
    (confirmed tracks are assigned first)."""
    tracker = PersonTracker(packed=packed)
    legs = np.array([[0.6, -0.32], [0.6, -0.02]])
    t = 0.0
    for _ in range(20):
        tracker.update(t, legs)
        t += 0.02
    assert len(tracker.update(t, np.vstack([legs, [[0.62, 0.19]]]))) == 2  # the stray: a new track
    for _ in range(13):  # just under tentative_delete_after_s
        t += 0.02
        people = tracker.update(t, legs)
        confirmed = [p for p in people if p.confirmed]
        assert len(confirmed) == 1 and len(confirmed[0].leg_xy_m) == 2
        np.testing.assert_allclose(confirmed[0].p_xy_m, legs.mean(axis=0), atol=0.01)


def test_bad_input_is_refused_with_the_argument_named():
    tracker = PersonTracker()
    tracker.update(1.0, np.zeros((0, 2)))
    with pytest.raises(ValueError, match="before the previous"):
        tracker.update(0.5, np.zeros((0, 2)))
    with pytest.raises(ValueError, match=r"legs_xy_m must have shape \(k, 2\)"):
        tracker.update(2.0, np.zeros((3, 3)))
    with pytest.raises(ValueError, match="legs_xy_m must be finite"):
        tracker.update(2.0, [[np.nan, 0.0]])
    with pytest.raises(ValueError, match="t_s must be finite"):
        tracker.update(np.inf, np.zeros((0, 2)))
    with pytest.raises(ValueError, match="confirm_after_hits"):
        PersonTrackerParams(confirm_after_hits=0)
    with pytest.raises(ValueError, match="confirm_pairs_at_birth"):
        PersonTrackerParams(confirm_pairs_at_birth="no")  # a string is truthy: refused, not read as True
    with pytest.raises(ValueError, match="tentative_delete_after_s"):
        PersonTrackerParams(delete_after_s=0.1)  # a tentative track would outlive a confirmed one
    for bad in (np.nan, -0.1, np.inf):
        with pytest.raises(ValueError, match="leg_carry_s"):
            PersonTrackerParams(leg_carry_s=bad)



def test_a_hidden_leg_is_carried_beside_the_seen_one_then_let_go():
    """The far leg hidden from t = 1.0 s: the tracker reports it where it was relative to the
    torso, moved with the torso, for leg_carry_s (0.5 s), then no longer. The true hidden leg
    swings; the carried one stays within the swing of it."""
    rng = np.random.default_rng(5)
    hidden = lambda w, t, leg: leg == 1 and t >= 1.0 - 1e-9
    _, history = run([straight([0.0, 0.0], [0.6, 0.3])], 2.0, rng, drop=hidden)
    carry_s = PersonTrackerParams().leg_carry_s
    for t, persons, truth in history:
        person = persons[0]
        p, v = truth[0]
        if t < 1.0 - 1e-9:
            assert person.carried_leg_xy_m.shape == (0, 2) and person.all_leg_xy_m.shape == (2, 2)
        elif abs(t - (1.0 - SCAN_DT_S + carry_s)) < 1e-6:
            continue  # the last sighting + leg_carry_s: either, by the floats of t
        elif t < 1.0 - SCAN_DT_S + carry_s:
            assert person.leg_xy_m.shape == (1, 2) and person.carried_leg_xy_m.shape == (1, 2)
            hidden_leg = walker_legs(p, v, t)[1]
            assert np.linalg.norm(person.carried_leg_xy_m[0] - hidden_leg) < 2 * STRIDE_AMPLITUDE_M * 0.67 + 0.03
            assert np.linalg.norm(person.carried_leg_xy_m[0] - person.leg_xy_m[0]) > HIP_HALF_WIDTH_M
            np.testing.assert_array_equal(person.all_leg_xy_m, np.vstack([person.leg_xy_m, person.carried_leg_xy_m]))
        else:
            assert person.carried_leg_xy_m.shape == (0, 2), t


def test_a_lone_leg_fills_the_nearer_slot_and_the_other_is_carried():
    """Two legs seen (in either order), then one hidden, then the other: the carried leg is
    always the hidden one, whichever slot the seen one had."""
    tracker = PersonTracker()
    left, right = np.array([1.0, 0.15]), np.array([1.0, -0.15])
    for k in range(6):
        tracker.update(0.1 * k, np.array([left, right] if k % 2 else [right, left]))
    person = tracker.update(0.6, right[None])[0]
    np.testing.assert_allclose(person.carried_leg_xy_m, left[None], atol=1e-9)
    person = tracker.update(0.7, left[None])[0]
    np.testing.assert_allclose(person.carried_leg_xy_m, right[None], atol=1e-9)


def test_both_legs_lost_are_carried_with_the_coasting_torso():
    tracker = PersonTracker()
    v = np.array([1.0, 0.0])
    for k in range(30):
        t = k * SCAN_DT_S
        tracker.update(t, walker_legs(v * t, v, t))
    seen_t = t
    for k in range(1, 15):
        t = seen_t + k * SCAN_DT_S
        person = tracker.update(t, np.zeros((0, 2)))[0]
        if abs(t - seen_t - 0.5) < 1e-6:
            continue
        if t - seen_t < 0.5:
            assert person.carried_leg_xy_m.shape == (2, 2)
            np.testing.assert_allclose(person.carried_leg_xy_m.mean(axis=0), person.p_xy_m, atol=0.05)
        else:
            assert person.carried_leg_xy_m.shape == (0, 2)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_carrying_never_changes_the_tracks(seed):
    """Carried legs are output only: with and without carrying (leg_carry_s = 0), the same
    tracks, states and seen legs on random walkers with legs hidden and clutter; never more
    than two legs per person, seen and carried."""
    rng = np.random.default_rng(seed)
    carrying, plain = PersonTracker(), PersonTracker(PersonTrackerParams(leg_carry_s=0.0))
    walkers = [straight(rng.uniform(-3, 3, 2), rng.uniform(-1, 1, 2)) for _ in range(rng.integers(1, 4))]
    t = 0.0
    for _ in range(60):
        t += rng.uniform(0.02, 0.2)
        legs = [xy for p, v in (w(t) for w in walkers) for xy in walker_legs(p, v, t) if rng.random() > 0.3]
        legs += list(rng.uniform(-3, 3, (rng.poisson(0.3), 2)))
        legs = np.array(legs).reshape(-1, 2)
        a, b = carrying.update(t, legs), plain.update(t, legs)
        assert [(p.track_id, p.confirmed, p.time_since_seen_s) for p in a] == \
               [(p.track_id, p.confirmed, p.time_since_seen_s) for p in b]
        for p, q in zip(a, b):
            np.testing.assert_array_equal(p.p_xy_m, q.p_xy_m)
            np.testing.assert_array_equal(p.leg_xy_m, q.leg_xy_m)
            assert q.carried_leg_xy_m.shape == (0, 2)
            assert len(p.all_leg_xy_m) <= 2 and np.isfinite(p.carried_leg_xy_m).all()
            if p.time_since_seen_s > 0.5:
                assert p.carried_leg_xy_m.shape == (0, 2)


# --- real data ---------------------------------------------------------------------------


def labelled_people_errors(scans, labels, legs_of):
    """Per labelled person (labels paired as legs), distance to the nearest confirmed track."""
    tracker, errors = PersonTracker(), []
    for scan, (_, truth) in zip(scans, labels):
        persons = tracker.update(scan.stamp_s, legs_of(scan, truth))
        confirmed = np.array([p.p_xy_m for p in persons if p.confirmed]).reshape(-1, 2)
        for group in pair_legs(truth, PersonTrackerParams().leg_pair_distance_m):
            person = truth[group].mean(axis=0)
            errors.append(np.min(np.linalg.norm(confirmed - person, axis=1)) if len(confirmed) else np.inf)
    return np.array(errors)


@pytest.mark.parametrize("bag", ["positive_1_extracted.bag", "positive_2_extracted.bag"])
def test_tracks_follow_the_labelled_people(shared_data, bag):
    """Real walking (the labels' motion, 7.5 Hz, gaps of seconds between sequences): fed the
    labelled legs with 20 % of them hidden and 2 cm noise, the confirmed tracks stay on the
    labelled people; fed the detector's legs (5 m, background), they still mostly do."""
    from cobotsafety.sensors.legs import detect_legs, estimate_background
    from cobotsafety.sensors.rosbag_io import read_laser_scans, read_pose_arrays

    path = shared_data / "leg_tracker" / bag
    scans = read_laser_scans(path, "/training_scan")
    labels = read_pose_arrays(path, "/leg_cluster_positions")
    rng = np.random.default_rng(4)

    def thinned_labels(scan, truth):
        keep = rng.random(len(truth)) > 0.2
        return truth[keep] + rng.normal(0.0, 0.02, (int(keep.sum()), 2))

    errors = labelled_people_errors(scans, labels, thinned_labels)
    assert np.mean(errors < 0.30) >= 0.90  # the rest: the first scans of each sequence
    assert np.median(errors) < 0.05
    background = estimate_background(scans)
    errors = labelled_people_errors(scans, labels, lambda scan, _: detect_legs(scan, 5.0, background))
    assert np.mean(errors < 0.50) >= 0.75
    assert np.median(errors) < 0.10


def test_people_walking_past_a_stationary_scanner_are_tracked_without_churn(shared_data):
    """demo_stationary_simple_environment.bag (10 Hz, 126 s, unlabelled): tracks persist and
    confirmed tracks (the only ones the human model sees; a flickering false leg makes a
    tentative track that dies unconfirmed) are rare, so most confirmed person-scans belong to
    tracks that lived >= 3 s."""
    from cobotsafety.sensors.legs import detect_legs, estimate_background
    from cobotsafety.sensors.rosbag_io import read_laser_scans

    scans = read_laser_scans(shared_data / "leg_tracker" / "demo_stationary_simple_environment.bag")
    background = estimate_background(scans)
    tracker = PersonTracker()
    scans_per_track = defaultdict(int)
    for scan in scans:
        for person in tracker.update(scan.stamp_s, detect_legs(scan, 5.0, background)):
            if person.confirmed:
                scans_per_track[person.track_id] += 1
    lives = np.array(list(scans_per_track.values()))
    assert lives.sum() > len(scans)  # somebody is in view most of the time
    assert len(lives) <= 0.1 * len(scans)  # confirmed tracks
    assert lives[lives >= 30].sum() >= 0.9 * lives.sum()


def test_packed_tracker_equals_the_reference_filter():
    """The compiled predict / gate / correction (``person_kernel``) against
    ``ConstantVelocityKalman``'s own methods: same tracks, same states, on walkers crossing,
    legs hidden at random and clutter appearing, at irregular scan times."""
    rng = np.random.default_rng(7)
    packed, reference = PersonTracker(), PersonTracker(packed=False)
    walkers = [straight([-2.0, 0.0], [1.0, 0.0]), straight([0.0, -2.4], [0.0, 1.0]),
               straight([3.0, 0.3], [-0.8, 0.1]), straight([0.5, 0.5], [0.0, 0.0])]
    t = 0.0
    worst = 0.0
    for _ in range(400):
        t += rng.uniform(0.01, 0.15)
        legs = [xy for p, v in (w(t) for w in walkers) for xy in walker_legs(p, v, t) if rng.random() > 0.25]
        legs += list(rng.uniform(-3, 3, (rng.poisson(0.5), 2)))  # clutter
        legs = np.array(legs).reshape(-1, 2) + rng.normal(0, 0.01, (len(legs), 2))
        a, b = packed.update(t, legs), reference.update(t, legs)
        assert [(p.track_id, p.confirmed, p.leg_xy_m.shape) for p in a] == \
               [(p.track_id, p.confirmed, p.leg_xy_m.shape) for p in b]
        for p, q in zip(a, b):
            worst = max(worst, float(np.abs(p.p_xy_m - q.p_xy_m).max()), float(np.abs(p.v_xy_m_s - q.v_xy_m_s).max()))
    assert packed.births == reference.births > 4
    assert worst < 1e-12, worst


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0.0, 0.3), st.lists(st.tuples(st.floats(-3, 3), st.floats(-3, 3)), max_size=6)),
                min_size=1, max_size=40))
def test_invariants_on_arbitrary_leg_sequences(scans):
    """Whatever the legs: ids unique, every leg given to exactly one person, ``time_since_seen``
    zero when the person has legs this scan, confirmation never revoked, all finite."""
    tracker, t, confirmed_ids = PersonTracker(), 0.0, set()
    for dt, legs in scans:
        t += dt
        legs = np.array(legs, dtype=float).reshape(-1, 2)
        persons = tracker.update(t, legs)
        ids = [p.track_id for p in persons]
        assert len(ids) == len(set(ids))
        given_legs = [tuple(leg) for p in persons for leg in p.leg_xy_m.tolist()]
        assert len(given_legs) == len(legs) and sorted(given_legs) == sorted(map(tuple, legs.tolist()))
        for p in persons:
            assert p.time_since_seen_s == 0.0 if len(p.leg_xy_m) else p.time_since_seen_s >= 0.0
            assert np.isfinite(p.p_xy_m).all() and np.isfinite(p.v_xy_m_s).all()
            if p.track_id in confirmed_ids:
                assert p.confirmed
            if p.confirmed:
                confirmed_ids.add(p.track_id)
