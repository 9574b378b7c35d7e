"""The human model: body dimensions, capsules from torso + IMUs, recordings and replay.

Data flow: laser scan -> legs -> torso xy (``cobotsafety.sensors``) and IMU quaternions ->
limb chain (``cobotsafety.sensors.imu``) -> ``HumanCapsules`` (``capsules.py``), made more
conservative when a stream is stale (``conservative.py``). ``recording.py`` is the file format,
``replay.py`` plays a recording (or a laser-only ROS bag) back as capsules at any time.
Quaternions are scalar-last ``(x, y, z, w)`` everywhere.
"""

from cobotsafety.human.body import CAPSULE_NAMES_1, CAPSULE_NAMES_5, BodyDimensions, HumanCapsules

__all__ = ["BodyDimensions", "HumanCapsules", "CAPSULE_NAMES_5", "CAPSULE_NAMES_1"]
