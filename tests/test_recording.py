"""The recording loader refuses each kind of corrupt file, naming file and line; round trip."""

from __future__ import annotations

import gzip
import json

import numpy as np
import pytest

from cobotsafety.errors import RecordingError
from cobotsafety.human.body import BodyDimensions
from cobotsafety.human.recording import Recording, load_recording, write_recording
from cobotsafety.sensors.scanner_pose import ScannerPose

Q = [0.0, 0.0, 0.0, 1.0]


def header(imus=("chest",)):
    return {
        "format": "cobotsafety-recording", "version": 1, "quaternion_order": "xyzw",
        "body": BodyDimensions().to_dict(),
        "scanner": {"x_m": 0.4, "y_m": -0.4, "yaw_rad": -0.785, "height_m": -0.45},
        "laser": {"angle_min": -2.356, "angle_increment": 0.01745, "range_min": 0.05, "range_max": 8.0, "beams": 3},
        "imus": {name: {"q_base_imu_init": Q, "q_ref_imu_init": Q} for name in imus},
    }


GOOD = [
    {"t": 0.0, "laser": [1.0, 2.0, 0.0]},
    {"t": 0.003, "imu": "chest", "q": Q},
    {"t": 0.006, "imu": "chest", "q": [0.0, 0.0, 0.7071068, 0.7071068]},
    {"t": 0.02, "laser": [1.0, 2.1, 3.0]},
]


def write(path, head, records, raw_lines=()):
    lines = [json.dumps(head)] + [json.dumps(r) for r in records] + list(raw_lines)
    with gzip.open(path, "wt") as f:
        f.write("\n".join(lines) + "\n")
    return path


def refused(tmp_path, records, line, match, head=None, raw_lines=()):
    path = write(tmp_path / "bad.jsonl.gz", head or header(), records, raw_lines)
    with pytest.raises(RecordingError) as info:
        load_recording(path)
    message = str(info.value)
    assert message.startswith(f"{path}:{line}:") if line else message.startswith(str(path)), message
    assert match in message, message
    return message


def test_good_file_loads(tmp_path):
    rec = load_recording(write(tmp_path / "ok.jsonl.gz", header(), GOOD))
    assert np.allclose(rec.laser_t_s, [0.0, 0.02])
    assert rec.laser_ranges_m.shape == (2, 3)
    assert np.allclose(rec.imu_q_ref["chest"][1], [0, 0, 0.7071068, 0.7071068], atol=1e-6)
    assert rec.scanner == ScannerPose(0.4, -0.4, -0.785) and rec.scanner_height_m == -0.45
    assert rec.imu_names == ("chest",)


def test_refuses_nan(tmp_path):
    bad = [dict(GOOD[0], laser=[1.0, float("nan"), 0.0])] + GOOD[1:]
    refused(tmp_path, bad, 2, "not a number")


def test_refuses_time_going_backwards(tmp_path):
    bad = GOOD[:3] + [{"t": 0.001, "laser": [1.0, 2.0, 3.0]}]
    refused(tmp_path, bad, 5, "time goes backwards")


def test_refuses_non_unit_quaternion(tmp_path):
    bad = GOOD[:2] + [{"t": 0.006, "imu": "chest", "q": [0.0, 0.0, 0.0, 1.01]}] + GOOD[3:]
    refused(tmp_path, bad, 4, "quaternion norm 1.010000")


def test_refuses_missing_imu_stream(tmp_path):
    refused(tmp_path, GOOD, 5, "missing stream: no sample of IMU 'forearm_left'", head=header(("chest", "forearm_left")))


def test_refuses_missing_laser_stream(tmp_path):
    refused(tmp_path, GOOD[1:3], 3, "missing stream: no laser scan")


def test_refuses_truncated_line(tmp_path):
    text = json.dumps(GOOD[3])
    refused(tmp_path, GOOD[:3], 5, "not valid JSON", raw_lines=[text[: len(text) // 2]])


def test_refuses_truncated_gzip(tmp_path):
    good = write(tmp_path / "ok.jsonl.gz", header(), GOOD * 1)
    data = good.read_bytes()
    cut = tmp_path / "cut.jsonl.gz"
    cut.write_bytes(data[: len(data) - 12])
    with pytest.raises(RecordingError, match=f"^{cut}"):
        load_recording(cut)


def test_refuses_wrong_beam_count(tmp_path):
    bad = [dict(GOOD[0], laser=[1.0, 2.0])] + GOOD[1:]
    refused(tmp_path, bad, 2, "3 ranges")


def test_refuses_unknown_imu_and_unknown_record(tmp_path):
    refused(tmp_path, GOOD[:1] + [{"t": 0.003, "imu": "knee", "q": Q}], 3, "IMU 'knee'")
    refused(tmp_path, GOOD[:1] + [{"t": 0.003, "sonar": 1.0}], 3, "unknown record keys")


def test_refuses_bad_header(tmp_path):
    refused(tmp_path, GOOD, 1, "quaternion_order", head=dict(header(), quaternion_order="wxyz"))
    refused(tmp_path, GOOD, 1, "not a cobotsafety-recording", head=dict(header(), format="other"))
    body = dict(BodyDimensions().to_dict())
    del body["d3_m"]
    refused(tmp_path, GOOD, 1, "d3_m", head=dict(header(), body=body))


def test_refuses_missing_file_and_empty_file(tmp_path):
    with pytest.raises(RecordingError, match="no such recording"):
        load_recording(tmp_path / "nope.jsonl.gz")
    empty = tmp_path / "empty.jsonl"
    empty.write_text("")
    with pytest.raises(RecordingError, match=f"{empty}:1: empty"):
        load_recording(empty)


def test_write_load_round_trip(tmp_path):
    rng = np.random.default_rng(3)
    q = rng.normal(size=(4, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    rec = Recording(
        body=BodyDimensions(d3_m=0.31), scanner=ScannerPose(0.4, -0.4, -0.7), scanner_height_m=-0.45,
        laser={"angle_min": -1.0, "angle_increment": 0.5, "range_min": 0.05, "range_max": 8.0, "beams": 5},
        laser_t_s=np.array([0.0, 0.02]), laser_ranges_m=rng.uniform(0, 8, (2, 5)),
        imu_t_s={"chest": np.array([0.001, 0.004, 0.007, 0.0101])}, imu_q_ref={"chest": q},
        calibration={"chest": (np.array(Q), q[0])}, description="round trip",
    )
    path = tmp_path / "rt.jsonl.gz"
    write_recording(path, rec)
    back = load_recording(path)
    assert back.body == rec.body and back.description == "round trip"
    assert np.allclose(back.laser_ranges_m, rec.laser_ranges_m, atol=5e-4)
    assert np.allclose(back.imu_q_ref["chest"], q, atol=2e-6)
    assert np.allclose(back.imu_t_s["chest"], rec.imu_t_s["chest"])
