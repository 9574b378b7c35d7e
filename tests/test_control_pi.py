"""The anti-windup PI (``control/pi.py``): saturates, holds no windup, reverses at once."""

from __future__ import annotations

import numpy as np

from cobotsafety.control.pi import AntiWindupPI


def test_pi_anti_windup_saturates_and_recovers():
    pi = AntiWindupPI(kp_per_s=2.0, ki_per_s2=1.0, limit=0.3)
    for _ in range(2000):  # 4 s far from the target: saturated
        out = pi.update(np.array([1.0, 0.0, 0.0]), 0.002)
        assert np.linalg.norm(out) <= 0.3 + 1e-12
    assert pi.saturated
    assert np.linalg.norm(pi.integral) < 0.05  # no windup
    out = pi.update(np.array([-0.01, 0.0, 0.0]), 0.002)  # the target is passed: reverse at once
    assert out[0] < 0.0 and not pi.saturated
    naive_integral = 2000 * 0.002  # what an unclamped integrator would hold (4 m.s)
    assert naive_integral * pi.ki_per_s2 > 1.0  # which would have overshot for seconds
