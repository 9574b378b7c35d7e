"""ConstantVelocityKalman against a textbook full-state Kalman filter, and on noisy tracks."""

from __future__ import annotations

import numpy as np
import pytest

from cobotsafety.estimation.constant_velocity import ConstantVelocityKalman, KalmanNoise


def textbook_filter(times, measurements, noise: KalmanNoise):
    """Full (2*dim)-state Kalman filter written with matrices, one point."""
    dim = measurements.shape[1]
    x = np.concatenate([measurements[0], np.zeros(dim)])
    P = np.diag([noise.measurement_std_m ** 2] * dim + [noise.initial_speed_std_m_s ** 2] * dim)
    H = np.hstack([np.eye(dim), np.zeros((dim, dim))])
    R = noise.measurement_std_m ** 2 * np.eye(dim)
    out = [x.copy()]
    for k in range(1, len(times)):
        dt = times[k] - times[k - 1]
        F = np.block([[np.eye(dim), dt * np.eye(dim)], [np.zeros((dim, dim)), np.eye(dim)]])
        q = noise.accel_density_m2_s3
        Q = q * np.block([[dt ** 3 / 3 * np.eye(dim), dt ** 2 / 2 * np.eye(dim)],
                          [dt ** 2 / 2 * np.eye(dim), dt * np.eye(dim)]])
        x, P = F @ x, F @ P @ F.T + Q
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        x = x + K @ (measurements[k] - H @ x)
        P = (np.eye(2 * dim) - K @ H) @ P
        out.append(x.copy())
    return np.array(out)


def test_equals_the_textbook_filter_on_random_irregular_samples():
    rng = np.random.default_rng(3)
    noise = KalmanNoise(accel_density_m2_s3=1.5, measurement_std_m=0.05, initial_speed_std_m_s=0.8)
    for _ in range(20):
        n = 40
        times = np.cumsum(rng.uniform(0.005, 0.05, n))
        z = rng.normal(size=(n, 3)).cumsum(axis=0) * 0.02
        expected = textbook_filter(times, z, noise)
        kf = ConstantVelocityKalman(times[0], z[0], noise)
        for k in range(1, n):
            kf.update(times[k], z[k][None])
            np.testing.assert_allclose(kf.position[0], expected[k, :3], atol=1e-12)
            np.testing.assert_allclose(kf.velocity[0], expected[k, 3:], atol=1e-12)


def test_velocity_of_a_walking_point_converges_under_noise():
    rng = np.random.default_rng(0)
    v_true = np.array([1.2, -0.4])
    times = np.arange(0, 4, 0.02)  # 50 Hz
    truth = np.array([0.5, 1.0]) + times[:, None] * v_true
    z = truth + rng.normal(scale=0.03, size=truth.shape)
    kf = ConstantVelocityKalman(times[0], z[0])
    errors = []
    for k in range(1, len(times)):
        kf.update(times[k], z[k][None])
        errors.append(np.linalg.norm(kf.velocity[0] - v_true))
    # Finite differences of the same data are off by ~sqrt(2) * 0.03 / 0.02 = 2 m/s.
    finite_difference = np.median(np.linalg.norm(np.diff(z, axis=0) / 0.02 - v_true, axis=1))
    assert finite_difference > 1.0
    assert np.median(errors[100:]) < 0.3 < finite_difference / 3


def test_masked_and_nan_measurements_only_predict():
    kf = ConstantVelocityKalman(0.0, np.zeros((2, 3)))
    kf.velocity[:] = [[1.0, 0, 0], [0, 1.0, 0]]
    kf.update(0.1, np.array([[5.0, 5, 5], [np.nan, 0, 0]]), mask=np.array([False, True]))
    np.testing.assert_allclose(kf.position, [[0.1, 0, 0], [0, 0.1, 0]])
    assert kf.covariance[0, 0, 0] > KalmanNoise().measurement_std_m ** 2


def test_gate_distance_grows_with_the_miss():
    kf = ConstantVelocityKalman(0.0, np.zeros((1, 2)))
    d2 = kf.mahalanobis2(0.02, np.array([[0.01, 0.0], [0.5, 0.0]]))
    assert d2.shape == (1, 2) and d2[0, 0] < 1.0 < d2[0, 1]


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="measurement_std_m"):
        KalmanNoise(measurement_std_m=0.0)
    with pytest.raises(ValueError, match="finite"):
        ConstantVelocityKalman(0.0, np.array([[np.nan, 0.0]]))
