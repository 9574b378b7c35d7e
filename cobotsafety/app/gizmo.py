"""Gizmo offset -> desired end-effector velocity: dead band, gain, speed cap; and the gizmo itself.

The user drags a transform gizmo away from the end-effector; the offset ``p_ee_gizmo`` (gizmo
position minus end-effector position, base frame) is the desired Cartesian velocity, like a
spring pulling the end-effector to the gizmo.

``add_gizmo`` makes the handle the demo and the trial share: a fixed size on screen
(``GIZMO_PIXELS``, whatever the zoom; it was ~40 px across in the panda's view), thick arrows,
drawn over the robot, translation only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cobotsafety.errors import CobotSafetyError


GIZMO_PIXELS = 130.0
"""Length of the gizmo's arrows on screen [px] (``fixed``: the same at any zoom)."""
GIZMO_LINE_WIDTH = 7.0


def add_gizmo(server, active_axes: tuple[bool, bool, bool], p_base_m, name: str = "/gizmo"):
    """The transform gizmo at ``p_base_m`` (shape (3,) [m]) moving along ``active_axes``.

    With all three axes, only the arrows (the plane squares crowded them and hid the arrow
    pointing away from the camera); in the plane, the arrows and the square that drags both.
    """
    return server.scene.add_transform_controls(
        name, scale=GIZMO_PIXELS, fixed=True, line_width=GIZMO_LINE_WIDTH, active_axes=active_axes,
        disable_rotations=True, disable_sliders=all(active_axes), depth_test=False,
        position=tuple(float(c) for c in p_base_m))


class GizmoSettingsError(CobotSafetyError, ValueError):
    """A gizmo setting is negative, zero where it must not be, or not finite."""


@dataclass(frozen=True)
class GizmoSettings:
    """How a gizmo offset becomes a velocity."""

    dead_band_m: float = 0.005
    """Offsets shorter than this command nothing [m]."""
    gain_per_s: float = 2.0
    """Velocity per metre of offset beyond the dead band [1/s]."""
    max_speed_m_s: float = 0.25
    """Cap on the commanded speed [m/s]."""

    def __post_init__(self) -> None:
        for name in ("dead_band_m", "gain_per_s", "max_speed_m_s"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0.0:
                raise GizmoSettingsError(f"{name} must be finite and >= 0, got {value!r}")


def offset_to_velocity(p_ee_gizmo_m: np.ndarray, settings: GizmoSettings = GizmoSettings()) -> np.ndarray:
    """Desired velocity [m/s] for an offset [m]; same shape as the offset, never NaN.

    ``|v| = min(gain * (|offset| - dead_band), max_speed)`` along the offset, zero inside the
    dead band; a non-finite offset gives zero.
    """
    offset = np.asarray(p_ee_gizmo_m, dtype=float)
    zero = np.zeros(offset.shape)
    if not np.all(np.isfinite(offset)):
        return zero
    length_m = float(np.linalg.norm(offset))
    if length_m <= settings.dead_band_m:
        return zero
    speed = min(settings.gain_per_s * (length_m - settings.dead_band_m), settings.max_speed_m_s)
    return offset * (speed / length_m)
