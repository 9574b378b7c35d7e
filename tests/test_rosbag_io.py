"""ROS1 reading of the real bags, a ROS2 round trip, and corrupt bags refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from cobotsafety.errors import RecordingError
from cobotsafety.sensors.rosbag_io import read_imu, read_laser_scans, read_pose_arrays


def test_reads_the_real_ros1_bags(shared_data, full_bags):
    path = shared_data / "leg_tracker" / "positive_2_extracted.bag"
    scans = read_laser_scans(path, "/training_scan")
    labels = read_pose_arrays(path, "/leg_cluster_positions")
    assert len(scans) == len(labels) == 83
    assert scans[0].ranges.shape == (768,)
    assert scans[0].angle_increment == pytest.approx(0.00613592)
    assert all(1 <= xy.shape[0] <= 2 for _, xy in labels)
    demo = read_laser_scans(shared_data / "leg_tracker" / "demo_stationary_simple_environment.bag")
    assert len(demo) == (1265 if full_bags else 400) and demo[0].ranges.shape == (512,)
    assert np.all(np.diff([s.stamp_s for s in demo]) > 0)


def write_ros2_bag(path, n=5):
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    LaserScanMsg = store.types["sensor_msgs/msg/LaserScan"]
    Imu = store.types["sensor_msgs/msg/Imu"]
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    Quaternion = store.types["geometry_msgs/msg/Quaternion"]
    Vector3 = store.types["geometry_msgs/msg/Vector3"]
    with Writer(path, version=8) as writer:
        scan_conn = writer.add_connection("/scan", LaserScanMsg.__msgtype__, typestore=store)
        imu_conn = writer.add_connection("/imu", Imu.__msgtype__, typestore=store)
        for i in range(n):
            header = Header(stamp=Time(sec=10 + i, nanosec=500_000_000), frame_id="laser")
            scan = LaserScanMsg(header=header, angle_min=-1.0, angle_max=1.0, angle_increment=0.5,
                                time_increment=0.0, scan_time=0.02, range_min=0.05, range_max=8.0,
                                ranges=np.array([1.0, 2.0, float(i), np.inf, 0.0], dtype=np.float32),
                                intensities=np.zeros(5, dtype=np.float32))
            writer.write(scan_conn, i * 1000, store.serialize_cdr(scan, LaserScanMsg.__msgtype__))
            q = Quaternion(x=0.0, y=0.0, z=np.sin(0.1 * i), w=np.cos(0.1 * i))
            imu = Imu(header=header, orientation=q, orientation_covariance=np.zeros(9),
                      angular_velocity=Vector3(x=0.0, y=0.0, z=0.0), angular_velocity_covariance=np.zeros(9),
                      linear_acceleration=Vector3(x=0.0, y=0.0, z=9.81), linear_acceleration_covariance=np.zeros(9))
            writer.write(imu_conn, i * 1000 + 1, store.serialize_cdr(imu, Imu.__msgtype__))


def test_ros2_round_trip(tmp_path):
    path = tmp_path / "bag"
    write_ros2_bag(path)
    scans = read_laser_scans(path)
    assert len(scans) == 5
    assert scans[3].stamp_s == pytest.approx(13.5)
    np.testing.assert_array_equal(scans[3].ranges[:3], [1.0, 2.0, 3.0])
    assert not scans[3].valid[3] and not scans[3].valid[4]
    t, q = read_imu(path)
    assert q.shape == (5, 4)
    np.testing.assert_allclose(q[2], [0.0, 0.0, np.sin(0.2), np.cos(0.2)], atol=1e-7)
    np.testing.assert_allclose(t, 10.5 + np.arange(5))


def test_missing_topic_and_corrupt_bags_are_refused_with_the_file_named(tmp_path, shared_data):
    path = shared_data / "leg_tracker" / "demo_stationary_simple_environment.bag"
    with pytest.raises(RecordingError, match="no Imu topic"):
        read_imu(path)
    truncated = tmp_path / "truncated.bag"
    truncated.write_bytes(path.read_bytes()[:5000])
    with pytest.raises(RecordingError, match="truncated.bag"):
        read_laser_scans(truncated)
    garbage = tmp_path / "garbage.bag"
    garbage.write_bytes(b"#ROSBAG V2.0\n" + b"\x00" * 100)
    with pytest.raises(RecordingError, match="garbage.bag"):
        read_laser_scans(garbage)
    with pytest.raises(RecordingError, match="no such bag"):
        read_laser_scans(tmp_path / "missing.bag")


def test_the_shipped_excerpt_holds_what_its_readme_says():
    """tests/data/leg_tracker, the fallback of a fresh clone, checked whatever data the other
    tests use: the BSD-3 licence beside the bags, every labelled scan of both positive bags,
    every 4th scan of negative_2's three scanners, the demo bag's first 400 scans; and the
    scans are the full bags' own (same ranges, same stamps) where those are present."""
    from conftest import EXCERPT_DATA, SHARED_DATA

    folder = EXCERPT_DATA / "leg_tracker"
    assert (folder / "LICENSE").read_text().startswith("BSD 3-Clause License")
    counts = {"positive_1_extracted.bag": 197, "positive_2_extracted.bag": 83}
    for name, scans in counts.items():
        assert len(read_laser_scans(folder / name, "/training_scan")) == scans
        assert len(read_pose_arrays(folder / name, "/leg_cluster_positions")) == scans
    negative = {topic: read_laser_scans(folder / "negative_2.bag", topic)
                for topic in ("/left_scan", "/rear_scan", "/right_scan")}
    assert [len(v) for v in negative.values()] == [109, 109, 109]
    demo = read_laser_scans(folder / "demo_stationary_simple_environment.bag")
    assert len(demo) == 400
    full = SHARED_DATA / "leg_tracker"
    if full.is_dir():
        whole = read_laser_scans(full / "negative_2.bag", "/rear_scan")
        for mine, theirs in zip(negative["/rear_scan"], whole[::4], strict=True):
            np.testing.assert_array_equal(mine.ranges, theirs.ranges)
            assert mine.stamp_s == theirs.stamp_s
        first = read_laser_scans(full / "demo_stationary_simple_environment.bag")[:400]
        assert [s.stamp_s for s in first] == [s.stamp_s for s in demo]
