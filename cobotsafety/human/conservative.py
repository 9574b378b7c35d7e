"""The degraded human model: stale or silent sensors make the human bigger, never smaller.

Rules (``conservative_capsules``), with ``age`` the time since a stream's newest sample:

* Every capsule radius grows by ``speed_m_s * torso_age`` (ISO 13855 walking speed 1.6 m/s):
  the human may have moved that far since the laser last saw the legs. While the laser is
  fresh this is a latency margin of a few cm; once ``torso_age > laser_stale_after_s`` the
  last pose is held, the radius keeps growing and the result is flagged stale.
* An IMU older than ``imu_stale_after_s`` (silent, or refusing garbage): the arm pose is unknown,
  so the human becomes one capsule that holds any arm pose (``one_capsule``), flagged stale.
* No IMUs at all (a laser-only recording): one capsule, not flagged stale (it is the model).

The growth depends only on the age, which only increases until a fresh sample arrives, so
while a stream stays silent the capsules never shrink.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from cobotsafety.human.body import CAPSULE_NAMES_5, BodyDimensions, HumanCapsules
from cobotsafety.human.capsule_kernel import five_capsules_packed
from cobotsafety.human.body_capsules import five_capsules, one_capsule

#: ISO 13855 walking speed K [m/s].
ISO13855_WALKING_SPEED_M_S = 1.6


@dataclass(frozen=True)
class StalePolicy:
    """Thresholds [s] and the growth speed [m/s] of the degraded model."""

    laser_stale_after_s: float = 0.10
    imu_stale_after_s: float = 0.05
    speed_m_s: float = ISO13855_WALKING_SPEED_M_S

    def __post_init__(self):
        for name in ("laser_stale_after_s", "imu_stale_after_s", "speed_m_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"StalePolicy.{name} must be finite and > 0, got {value}")


def grown(capsules: HumanCapsules, growth_m: float, *, stale: bool, reason: str) -> HumanCapsules:
    """The same capsules with every radius increased by ``growth_m >= 0`` [m]."""
    if not growth_m >= 0.0:
        raise ValueError(f"growth_m must be >= 0, got {growth_m}")
    return HumanCapsules(
        capsules.p0_b_m, capsules.p1_b_m, capsules.radius_m + growth_m, capsules.names,
        t_s=capsules.t_s, stale=stale or capsules.stale,
        reason="; ".join(r for r in (capsules.reason, reason) if r), ages_s=capsules.ages_s,
    )


def conservative_capsules(
    t_s: float,
    xy_b_torso_m: np.ndarray,
    torso_age_s: float,
    body: BodyDimensions,
    r_b_imu: Rotation | None = None,
    imu_ages_s: dict[str, float] | None = None,
    policy: StalePolicy = StalePolicy(),
) -> HumanCapsules:
    """The human at ``t_s`` from the held torso xy [m] (shape (2,)) and IMU orientations.

    ``torso_age_s``: time since the legs were last seen [s]. ``r_b_imu``: 5 base-frame IMU
    rotations (``IMU_NAMES`` order) or None without IMUs; ``imu_ages_s``: name -> age [s].
    """
    if not (np.isfinite(torso_age_s) and torso_age_s >= 0):
        raise ValueError(f"torso_age_s must be finite and >= 0, got {torso_age_s}")
    imu_ages_s = dict(imu_ages_s or {})
    ages = {"laser": float(torso_age_s), **{k: float(v) for k, v in imu_ages_s.items()}}
    reasons = []
    stale = False
    silent = sorted(name for name, age in imu_ages_s.items() if not age <= policy.imu_stale_after_s)
    if r_b_imu is None:
        model = one_capsule(xy_b_torso_m, body, t_s)
    elif silent:
        model = one_capsule(xy_b_torso_m, body, t_s)
        stale = True
        worst = max(imu_ages_s[name] for name in silent)
        reasons.append(f"IMU {', '.join(silent)} silent for {worst:.2f} s: 1-capsule human")
    else:
        model = five_capsules(xy_b_torso_m, r_b_imu, body, t_s)
    growth, laser_stale, laser_reason = laser_margin(torso_age_s, policy)
    if laser_stale:
        stale = True
        reasons.append(laser_reason)
    return HumanCapsules(model.p0_b_m, model.p1_b_m, model.radius_m + growth, model.names, t_s=t_s,
                         stale=stale, reason="; ".join(reasons), ages_s=ages)


def laser_margin(torso_age_s: float, policy: StalePolicy = StalePolicy()) -> tuple[float, bool, str]:
    """``(growth [m], stale, reason)`` for legs last seen ``torso_age_s`` ago (rule 1)."""
    growth = policy.speed_m_s * torso_age_s
    if torso_age_s > policy.laser_stale_after_s:
        return growth, True, f"laser: legs not seen for {torso_age_s:.2f} s: last pose held, radius +{growth:.2f} m"
    return growth, False, ""


def fresh_five_capsules(t_s: float, xy_b_torso_m: np.ndarray, torso_age_s: float, q0_ref_imu: np.ndarray,
                        q1_ref_imu: np.ndarray, frac: np.ndarray, r_b_ref: np.ndarray, body_vec: np.ndarray,
                        imu_ages_s: dict[str, float], policy: StalePolicy = StalePolicy()) -> HumanCapsules | None:
    """``conservative_capsules`` for five fresh IMUs, in one compiled call (``capsule_kernel``).

    The IMUs are given as their bracketing samples (``q0``/``q1`` (5, 4) xyzw, slerp ``frac``
    (5,)) and calibrations ``r_b_ref`` (5, 3, 3); ``body_vec`` from ``capsule_kernel.body_vector``.
    Returns None when an IMU is stale or a result is not finite: the caller then takes the
    readable, validating path.
    """
    if not (np.isfinite(torso_age_s) and torso_age_s >= 0):
        raise ValueError(f"torso_age_s must be finite and >= 0, got {torso_age_s}")
    if not all(age <= policy.imu_stale_after_s for age in imu_ages_s.values()):
        return None
    growth, stale, reason = laser_margin(torso_age_s, policy)
    p0, p1, radius, finite = five_capsules_packed(xy_b_torso_m, q0_ref_imu, q1_ref_imu, frac, r_b_ref, body_vec, growth)
    if not finite:
        return None
    return HumanCapsules.trusted(p0, p1, radius, CAPSULE_NAMES_5, t_s=t_s, stale=stale, reason=reason,
                                 ages_s={"laser": float(torso_age_s), **imu_ages_s})


def could_have_left(distance_scanner_torso_m: float, torso_age_s: float, max_range_m: float,
                    policy: StalePolicy = StalePolicy()) -> bool:
    """True when a human last seen ``distance_scanner_torso_m`` from the scanner ``torso_age_s``
    ago may have walked out of the monitored range ``max_range_m`` (at ``policy.speed_m_s``).

    Only then may fresh scans without legs be read as "nobody in range".
    """
    return distance_scanner_torso_m + policy.speed_m_s * torso_age_s >= max_range_m
