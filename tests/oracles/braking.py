"""Braking simulated step by step, the way the arm's command stream brakes (``arm/braking.py``)."""

from __future__ import annotations


def braking_travel(speed: float, accel: float, decel: float, jerk: float, dt_s: float, max_steps: int = 10**7) -> float:
    """The farthest a discrete jerk-limited stop goes toward the limitation [m or rad], from the
    approach ``speed`` and acceleration ``accel`` (toward the limitation: > 0; clipped to
    ``+-decel``): each step the acceleration ramps down by ``jerk dt`` (to ``-decel`` at most),
    the velocity changes by ``a dt`` and is held for the step (``x += v dt``), until the
    velocity is no longer positive while the acceleration is not."""
    a = min(max(accel, -decel), decel)
    v, x, farthest = speed, 0.0, 0.0
    for _ in range(max_steps):
        a = max(a - jerk * dt_s, -decel)
        v += a * dt_s
        x += v * dt_s
        farthest = max(farthest, x)
        if v <= 0.0 and a <= 0.0:
            return farthest
    raise RuntimeError("braking did not stop")


def braking_duration(speed: float, accel: float, decel: float, jerk: float, dt_s: float,
                     max_steps: int = 10**7) -> float:
    """How long [s] the same discrete stop as ``braking_travel`` takes: the steps until the
    velocity is no longer positive while the acceleration is not."""
    a = min(max(accel, -decel), decel)
    v = speed
    for k in range(1, max_steps + 1):
        a = max(a - jerk * dt_s, -decel)
        v += a * dt_s
        if v <= 0.0 and a <= 0.0:
            return k * dt_s
    raise RuntimeError("braking did not stop")
