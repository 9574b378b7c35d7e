"""``Replay``: a recording (or a laser-only ROS bag) played back as human capsules at any time.

    replay = Replay(load_recording(path))        # or Replay.from_file(path), Replay.from_bag(bag)
    replay.duration_s, replay.start_s
    caps = replay.capsules_at(t_s)               # HumanCapsules, with .stale and .reason

The laser pipeline runs once over every scan in order at construction (it has state: eq. 1),
through ``HumanTracker``; ``capsules_at`` then interpolates and applies the IMU chain. By
default a query is causal (``causal=True``): only samples stamped at or before ``t_s`` are
used, as a live system would see them. ``causal=False`` interpolates between the samples
around ``t_s`` (offline analysis).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cobotsafety.errors import RecordingError
from cobotsafety.human.body import BodyDimensions, HumanCapsules
from cobotsafety.human.conservative import StalePolicy
from cobotsafety.human.recording import Recording, load_recording
from cobotsafety.human.tracker import MAX_RANGE_M, HumanTracker
from cobotsafety.sensors.imu import IMU_NAMES
from cobotsafety.sensors.laser_scan import LaserScan
from cobotsafety.sensors.legs import estimate_background
from cobotsafety.sensors.scanner_pose import ScannerPose
from cobotsafety.sensors.streams import QuaternionStream


class Replay:
    """Human capsules at any time of a validated ``Recording``."""

    def __init__(self, recording: Recording, policy: StalePolicy = StalePolicy(),
                 max_range_m: float = MAX_RANGE_M, use_background: bool = True, leg_method: str = "learned"):
        self.recording = recording
        geometry = recording.laser
        scans = [LaserScan(geometry["angle_min"], geometry["angle_increment"], geometry["range_min"],
                           geometry["range_max"], ranges) for ranges in recording.laser_ranges_m]
        if recording.calibration and set(recording.calibration) != set(IMU_NAMES):
            raise RecordingError(f"{recording.source or 'recording'}: IMUs {sorted(recording.calibration)} "
                                 f"are not the five {IMU_NAMES} (or none)")
        background = estimate_background(scans) if use_background and len(scans) > 1 else None
        self.tracker = HumanTracker(recording.body, recording.scanner, recording.calibration or None,
                                    background, policy, max_range_m, leg_method=leg_method)
        for t, scan in zip(recording.laser_t_s, scans):
            self.tracker.push_scan(float(t), scan)
        for name in self.tracker.imus:
            self.tracker.imus[name] = QuaternionStream.from_arrays(
                name, recording.imu_t_s[name], recording.imu_q_ref[name], policy.imu_stale_after_s)

    @classmethod
    def from_file(cls, path: str | Path, **kw) -> "Replay":
        return cls(load_recording(path), **kw)

    @classmethod
    def from_bag(cls, path: str | Path, topic: str | None = None, scanner: ScannerPose = ScannerPose(),
                 body: BodyDimensions = BodyDimensions(), **kw) -> "Replay":
        """A laser-only ROS1/ROS2 bag: no IMUs, so a 1-capsule human at the torso.

        ``scanner``: the scanner's pose in the robot base frame (the bag does not say).
        Raises ``RecordingError`` for an unreadable bag or one without scans.
        """
        from cobotsafety.sensors.rosbag_io import read_laser_scans

        scans = read_laser_scans(Path(path), topic)
        if not scans:
            raise RecordingError(f"{path}: no LaserScan messages")
        beams = scans[0].ranges.size
        if any(s.ranges.size != beams for s in scans):
            raise RecordingError(f"{path}: the beam count changes between scans")
        t = np.array([s.stamp_s for s in scans])
        if not (np.diff(t) > 0).all():
            raise RecordingError(f"{path}: scan stamps do not increase")
        first = scans[0]
        ranges = np.array([np.where(s.valid, s.ranges, 0.0) for s in scans])
        recording = Recording(
            body=body, scanner=scanner, scanner_height_m=0.0,
            laser={"angle_min": first.angle_min, "angle_increment": first.angle_increment,
                   "range_min": first.range_min, "range_max": first.range_max, "beams": beams},
            laser_t_s=t, laser_ranges_m=ranges, description=f"laser-only ROS bag {Path(path).name}",
            source=str(path),
        )
        return cls(recording, **kw)

    @property
    def start_s(self) -> float:
        return self.recording.start_s

    @property
    def duration_s(self) -> float:
        return self.recording.end_s - self.recording.start_s

    def capsules_at(self, t_s: float, causal: bool = True) -> HumanCapsules:
        """The human at absolute time ``t_s`` [s] (recording clock; see ``start_s``)."""
        return self.tracker.capsules_at(float(t_s), until_s=float(t_s) if causal else None)
