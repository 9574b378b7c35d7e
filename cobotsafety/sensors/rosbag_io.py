"""Read laser scans, IMU samples and labelled leg positions from ROS1 and ROS2 bags.

Uses ``rosbags.highlevel.AnyReader`` (no ROS install needed). Times are the message
header stamps in seconds. Every failure is a ``RecordingError`` naming the bag.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cobotsafety.errors import RecordingError
from cobotsafety.sensors.laser_scan import LaserScan


def _reader(path: Path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: no such bag")
    store = get_typestore(Stores.ROS1_NOETIC if path.suffix == ".bag" else Stores.ROS2_HUMBLE)
    return AnyReader([path], default_typestore=store)


def _stamp(msg) -> float:
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def _messages(path: Path, msgtype_suffix: str, topic: str | None):
    try:
        with _reader(path) as reader:
            connections = [c for c in reader.connections
                           if c.msgtype.endswith(msgtype_suffix) and (topic is None or c.topic == topic)]
            if not connections:
                found = sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections})
                raise RecordingError(f"{path}: no {msgtype_suffix} topic{f' {topic}' if topic else ''}; found {found}")
            for i, (connection, _, raw) in enumerate(reader.messages(connections=connections)):
                try:
                    yield reader.deserialize(raw, connection.msgtype)
                except Exception as error:  # a truncated or corrupt record
                    raise RecordingError(f"{path}: message {i} on {connection.topic} is corrupt: {error}") from error
    except RecordingError:
        raise
    except Exception as error:
        raise RecordingError(f"{path}: cannot read the bag: {error}") from error


def read_laser_scans(path: Path, topic: str | None = None) -> list[LaserScan]:
    """Every sensor_msgs/LaserScan on ``topic`` (or the only LaserScan topic), in bag order."""
    return [
        LaserScan(m.angle_min, m.angle_increment, m.range_min, m.range_max,
                  np.asarray(m.ranges, dtype=float), _stamp(m))
        for m in _messages(path, "LaserScan", topic)
    ]


def read_imu(path: Path, topic: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """sensor_msgs/Imu orientations: ``(t_s (k,), q_xyzw (k, 4))``, scalar-last quaternions."""
    t, q = [], []
    for m in _messages(path, "Imu", topic):
        t.append(_stamp(m))
        o = m.orientation
        q.append((o.x, o.y, o.z, o.w))
    return np.array(t), np.array(q).reshape(-1, 4)


def read_pose_arrays(path: Path, topic: str | None = None) -> list[tuple[float, np.ndarray]]:
    """geometry_msgs/PoseArray (e.g. labelled leg clusters): ``[(t_s, xy (k, 2)), ...]``."""
    return [
        (_stamp(m), np.array([(p.position.x, p.position.y) for p in m.poses]).reshape(-1, 2))
        for m in _messages(path, "PoseArray", topic)
    ]
