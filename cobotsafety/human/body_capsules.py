"""The human as 5 capsules (torso+head, upper arms, forearms) or 1 (paper 2, Fig. 1).

Inputs: the torso xy in the robot base frame (from the laser, eq. 10) and, for 5 capsules, the
five IMU orientations in the base frame (eq. 6, scalar-last quaternions through
``scipy.spatial.transform.Rotation``). The co-worker stands straight (paper 2.2), so the torso
capsule is vertical.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from cobotsafety.human.body import CAPSULE_NAMES_1, CAPSULE_NAMES_5, BodyDimensions, HumanCapsules
from cobotsafety.sensors.imu import arm_chain


def chest_point(xy_b_torso_m: np.ndarray, body: BodyDimensions) -> np.ndarray:
    """Eq. 9: shape (3,) [m], ``[x_t, y_t, l]`` in the base frame."""
    xy = np.asarray(xy_b_torso_m, dtype=float).reshape(2)
    return np.array([xy[0], xy[1], body.chest_height_m])


def _torso_axis(xy: np.ndarray, body: BodyDimensions) -> tuple[np.ndarray, np.ndarray]:
    bottom = np.array([xy[0], xy[1], body.chest_height_m - body.torso_below_chest_m])
    top = np.array([xy[0], xy[1], body.chest_height_m + body.head_above_chest_m])
    return bottom, top


def five_capsules(
    xy_b_torso_m: np.ndarray, r_b_imu: Rotation, body: BodyDimensions, t_s: float = 0.0
) -> HumanCapsules:
    """Torso+head, left upper arm, left forearm, right upper arm, right forearm.

    ``xy_b_torso_m``: shape (2,) [m]; ``r_b_imu``: 5 rotations in ``IMU_NAMES`` order.
    """
    p0 = chest_point(xy_b_torso_m, body)
    arm = arm_chain(p0, r_b_imu, body.d1_m, body.d2_m, body.d3_m, body.d4_m)
    bottom, top = _torso_axis(p0, body)
    starts = np.stack([bottom, arm.shoulder_left, arm.elbow_left, arm.shoulder_right, arm.elbow_right])
    ends = np.stack([top, arm.elbow_left, arm.wrist_left, arm.elbow_right, arm.wrist_right])
    radius = np.array(
        [body.torso_radius_m, body.upper_arm_radius_m, body.forearm_radius_m,
         body.upper_arm_radius_m, body.forearm_radius_m]
    )
    return HumanCapsules(starts, ends, radius, CAPSULE_NAMES_5, t_s=t_s)


def one_capsule(xy_b_torso_m: np.ndarray, body: BodyDimensions, t_s: float = 0.0) -> HumanCapsules:
    """One vertical capsule holding torso, head and both arms in any pose (no IMUs needed).

    Axis from the torso bottom to shoulder height, radius ``body.one_capsule_radius_m``.
    """
    xy = np.asarray(xy_b_torso_m, dtype=float).reshape(2)
    bottom, _ = _torso_axis(xy, body)
    top = np.array([xy[0], xy[1], body.chest_height_m + body.d1_m])
    top[2] = max(top[2], body.chest_height_m + body.head_above_chest_m - body.one_capsule_radius_m + body.torso_radius_m)
    return HumanCapsules(bottom[None], top[None], [body.one_capsule_radius_m], CAPSULE_NAMES_1, t_s=t_s)
