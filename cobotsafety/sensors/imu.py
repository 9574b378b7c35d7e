"""Paper 2's IMU limb chain (section 2.2, eqs. 5-12, erratum 7).

Quaternions are scalar-last ``(x, y, z, w)`` (scipy's ``Rotation.from_quat`` default), at the
API and in files. Notation: ``q_a_b`` is the orientation of frame ``b`` expressed in frame ``a``
(it maps ``b`` coordinates to ``a`` coordinates); the paper writes it ``w_b^a``.

* Calibration, eq. 5: with an IMU held in a known orientation ``q_b_imu_init`` while it reads
  ``q_ref_imu_init``, ``R_ref_b = R_ref_imu_init R_imu_b_init`` and ``R_b_ref`` is its inverse.
  Each IMU has its own reference frame, so each is calibrated on its own.
* Eq. 6: ``R_b_imu = R_b_ref R_ref_imu``.
* Eq. 7: ``v_b = R_b_imu v_imu``.
* Eqs. 8-12: chest point ``p0 = [x_t, y_t, l]``, shoulder ``p1 = p0 + v1``, elbow
  ``p2 = p1 + v2``, wrist ``p3 = p2 + v3``.

Mounting (paper 2.2.3): the chest IMU's x axis points vertically down when the co-worker stands
straight and its z axis points forward, out of the chest, so its y axis points to the
co-worker's left. The chest-to-shoulder vector is then ``[-d1, +d2, 0]`` for the left shoulder
and ``[-d1, -d2, 0]`` for the right (erratum 7: the paper prints ``+d2`` for both). The upper-arm
and forearm IMUs have x along the limb, pointing away from the body (shoulder -> elbow,
elbow -> wrist): ``[d3, 0, 0]`` and ``[d4, 0, 0]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

#: IMU names: one on the chest, one on each upper arm and forearm.
IMU_NAMES = ("chest", "upper_arm_left", "forearm_left", "upper_arm_right", "forearm_right")


def calibrate(q_ref_imu_init: np.ndarray, q_b_imu_init: np.ndarray) -> Rotation:
    """Eq. 5: ``R_b_ref`` from one reading taken in a known orientation.

    ``q_ref_imu_init``: shape (4,) or (n, 4), the IMU's reading (xyzw) while held at
    ``q_b_imu_init`` (xyzw, the known orientation in the robot base frame). Returns the rotation
    from the IMU's reference frame to the base frame, one per IMU when batched.
    """
    r_ref_b = Rotation.from_quat(q_ref_imu_init) * Rotation.from_quat(q_b_imu_init).inv()
    return r_ref_b.inv()


def base_orientation(r_b_ref: Rotation, q_ref_imu: np.ndarray) -> Rotation:
    """Eq. 6: ``R_b_imu = R_b_ref R_ref_imu``; ``q_ref_imu`` shape (4,) or (n, 4), xyzw."""
    return r_b_ref * Rotation.from_quat(q_ref_imu)


@dataclass(frozen=True)
class ArmPoints:
    """Chain points in the base frame [m], each shape (3,)."""

    chest: np.ndarray
    shoulder_left: np.ndarray
    elbow_left: np.ndarray
    wrist_left: np.ndarray
    shoulder_right: np.ndarray
    elbow_right: np.ndarray
    wrist_right: np.ndarray


def arm_chain(
    p_b_chest: np.ndarray,
    r_b_imu: Rotation,
    d1_m: float,
    d2_m: float,
    d3_m: float,
    d4_m: float,
) -> ArmPoints:
    """Eqs. 7-12: shoulders, elbows and wrists in the base frame.

    ``p_b_chest``: shape (3,) [m], the chest point ``[x_t, y_t, l]`` (eq. 9). ``r_b_imu``: 5
    rotations (eq. 6) in ``IMU_NAMES`` order. Dimensions in metres.
    """
    if len(r_b_imu) != len(IMU_NAMES):
        raise ValueError(f"r_b_imu must hold {len(IMU_NAMES)} rotations ({IMU_NAMES}), got {len(r_b_imu)}")
    p0 = np.asarray(p_b_chest, dtype=float).reshape(3)
    # One batched product: both shoulder vectors in the chest frame, then the four limbs.
    m = r_b_imu.as_matrix()  # (5, 3, 3), columns = IMU axes in the base frame
    v_b = np.empty((6, 3))
    v_b[0] = m[0] @ [-d1_m, d2_m, 0.0]  # eq. 7, left shoulder (erratum 7: +d2)
    v_b[1] = m[0] @ [-d1_m, -d2_m, 0.0]  # right shoulder: -d2
    v_b[2] = d3_m * m[1, :, 0]  # [d3, 0, 0] in the upper-arm IMU frame
    v_b[3] = d4_m * m[2, :, 0]
    v_b[4] = d3_m * m[3, :, 0]
    v_b[5] = d4_m * m[4, :, 0]
    shoulder_left = p0 + v_b[0]  # eq. 8
    shoulder_right = p0 + v_b[1]
    elbow_left = shoulder_left + v_b[2]  # eq. 11
    wrist_left = elbow_left + v_b[3]  # eq. 12
    elbow_right = shoulder_right + v_b[4]
    wrist_right = elbow_right + v_b[5]
    return ArmPoints(p0, shoulder_left, elbow_left, wrist_left, shoulder_right, elbow_right, wrist_right)
