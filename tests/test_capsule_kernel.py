"""The compiled 5-capsule path equals the readable one (slerp, eq. 6, eqs. 7-12, margin)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from cobotsafety.human.body import BodyDimensions
from cobotsafety.human.capsule_kernel import body_vector, five_capsules_packed
from cobotsafety.human.conservative import StalePolicy, conservative_capsules
from cobotsafety.sensors.imu import IMU_NAMES
from cobotsafety.sensors.streams import QuaternionStream, rotations_at

POLICY = StalePolicy()


def reference(xy, q0, q1, frac, r_b_ref, body, torso_age_s):
    """Streams holding q0 at t=0 and q1 at t=1, queried at ``frac`` -> the conservative model."""
    streams = [QuaternionStream.from_arrays(name, [0.0, 1.0], [q0[i], q1[i]], stale_after_s=2.0)
               for i, name in enumerate(IMU_NAMES)]
    rotations = []
    for i, stream in enumerate(streams):  # each IMU at its own fraction of the interval
        rotations.append(rotations_at([stream], float(frac[i])))
    r_b_imu = r_b_ref * Rotation.concatenate(rotations)
    ages = {name: 0.0 for name in IMU_NAMES}
    return conservative_capsules(0.0, xy, torso_age_s, body, r_b_imu, ages, POLICY)


def random_inputs(rng, kind):
    xy = rng.uniform(-2, 2, 2)
    q0 = Rotation.random(5, random_state=rng).as_quat()
    if kind == "far":
        q1 = Rotation.random(5, random_state=rng).as_quat()
    else:  # close to q0: tiny or moderate rotations, on either sign of the double cover
        step = 10.0 ** rng.uniform(-9, -1, 5)
        delta = Rotation.from_rotvec(step[:, None] * Rotation.random(5, random_state=rng).as_rotvec())
        q1 = (Rotation.from_quat(q0) * delta).as_quat()
    q1 *= np.where(rng.random(5) < 0.5, -1.0, 1.0)[:, None]
    frac = np.where(rng.random(5) < 0.2, 0.0, rng.uniform(0, 1, 5))
    r_b_ref = Rotation.random(5, random_state=rng)
    body = BodyDimensions(*rng.uniform(0.05, 0.6, 10))
    torso_age_s = float(rng.choice([0.0, rng.uniform(0, 0.1), rng.uniform(0.1, 2.0)]))
    return xy, q0, q1, frac, r_b_ref, body, torso_age_s


@pytest.mark.parametrize("kind", ["far", "near"])
def test_packed_five_capsules_equal_the_reference(kind):
    rng = np.random.default_rng(0 if kind == "far" else 1)
    worst = 0.0
    for _ in range(2000):
        xy, q0, q1, frac, r_b_ref, body, torso_age_s = random_inputs(rng, kind)
        expected = reference(xy, q0, q1, frac, r_b_ref, body, torso_age_s)
        p0, p1, radius, finite = five_capsules_packed(
            xy, q0, q1, frac, r_b_ref.as_matrix(), body_vector(body), POLICY.speed_m_s * torso_age_s)
        assert finite
        for got, want in ((p0, expected.p0_b_m), (p1, expected.p1_b_m), (radius, expected.radius_m)):
            worst = max(worst, float(np.max(np.abs(got - want))))
    assert worst < 1e-12, worst


def test_packed_path_flags_non_finite_input():
    rng = np.random.default_rng(2)
    xy, q0, q1, frac, r_b_ref, body, _ = random_inputs(rng, "far")
    *_, finite = five_capsules_packed(np.array([np.nan, 0.0]), q0, q1, frac, r_b_ref.as_matrix(),
                                      body_vector(body), 0.0)
    assert not finite
