"""Replay playback state and the human display quantities (no browser)."""

import gzip

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from cobotsafety.app.replay_control import ReplayControl
from cobotsafety.human.recording import bundled_recording
from cobotsafety.app.scene_human import minimum_distance
from cobotsafety.human.body import HumanCapsules


@pytest.fixture(scope="module")
def control():
    c = ReplayControl()
    assert c.load(bundled_recording()) == ""
    return c


def test_bundled_recording_plays_loops_and_seeks(control):
    control.playing, control.loop, control.speed = True, True, 2.0
    control.seek(0.0)
    control.advance(1.5)
    assert control.time_s == pytest.approx(3.0)
    control.seek(control.duration_s - 0.5)
    control.advance(1.0)  # 2 s of recording past the end: wraps to 1.5 s
    assert control.time_s == pytest.approx(1.5, abs=1e-9)
    control.loop = False
    control.seek(control.duration_s - 0.1)
    control.advance(1.0)
    assert control.time_s == pytest.approx(control.duration_s) and not control.playing
    control.seek(-5.0)
    assert control.time_s == 0.0


def test_paused_replay_does_not_advance(control):
    control.seek(2.0)
    control.playing = False
    control.advance(10.0)
    assert control.time_s == 2.0


@pytest.mark.parametrize("content", [b"not gzip at all", gzip.compress(b"{}\n"), gzip.compress(b'{"format": "x"}\n')])
def test_invalid_file_is_refused_and_previous_replay_keeps_running(control, tmp_path, content):
    previous = control.replay
    bad = tmp_path / "broken.jsonl.gz"
    bad.write_bytes(content)
    message = control.load(bad)
    assert message.startswith("broken.jsonl.gz is not a readable recording (") and message.count("broken.jsonl.gz") == 1
    assert control.replay is previous and control.name == "reach-over.jsonl.gz"


def test_missing_bag_is_refused(control, tmp_path):
    message = control.load(tmp_path / "nothing.bag")
    assert message == "nothing.bag is not a readable ROS bag (no such bag)"
    assert control.name == "reach-over.jsonl.gz"


def brute_force(rp0, rp1, rr, human, samples=201):
    s = np.linspace(0, 1, samples)[:, None]
    best = np.inf
    for a0, a1, ra in zip(rp0, rp1, rr):
        pa = a0 + s * (a1 - a0)
        for b0, b1, rb in zip(human.p0_b_m, human.p1_b_m, human.radius_m):
            pb = b0 + s * (b1 - b0)
            d = np.linalg.norm(pa[:, None, :] - pb[None, :, :], axis=2).min() - ra - rb
            best = min(best, d)
    return best


points = st.lists(st.floats(-1, 1), min_size=3, max_size=3)


@settings(max_examples=40, deadline=None)
@given(points, points, points, points, st.floats(0.01, 0.1), st.floats(0.01, 0.2))
def test_minimum_distance_matches_brute_force_and_points_are_on_surfaces(a0, a1, b0, b1, ra, rb):
    rp0, rp1, rr = np.array([a0]), np.array([a1]), np.array([ra])
    human = HumanCapsules(np.array([b0]), np.array([b1]), np.array([rb]), ("torso",))
    distance, p_robot, p_human = minimum_distance(rp0, rp1, rr, human)
    assert distance <= brute_force(rp0, rp1, rr, human) + 1e-9
    assert distance >= brute_force(rp0, rp1, rr, human) - 0.02  # sampling resolution of the oracle
    if distance > 1e-6:
        assert np.linalg.norm(p_human - p_robot) == pytest.approx(distance, abs=1e-9)


def test_minimum_distance_hand_worked_and_absent_human():
    # robot link along x at z = 0 (r 0.03); human torso vertical at x = 0.5, y = 0.4 (r 0.15):
    # axis distance 0.4, surface distance 0.4 - 0.03 - 0.15 = 0.22 m.
    human = HumanCapsules(np.array([[0.5, 0.4, 0.0]]), np.array([[0.5, 0.4, 1.2]]), np.array([0.15]), ("torso",))
    d, p_robot, p_human = minimum_distance(np.zeros((1, 3)), np.array([[1.0, 0, 0]]), np.array([0.03]), human)
    assert d == pytest.approx(0.22)
    np.testing.assert_allclose(p_robot, [0.5, 0.03, 0.0])
    np.testing.assert_allclose(p_human, [0.5, 0.25, 0.0])
    nobody = HumanCapsules(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), ())
    assert minimum_distance(np.zeros((1, 3)), np.ones((1, 3)), np.array([0.03]), nobody) is None
