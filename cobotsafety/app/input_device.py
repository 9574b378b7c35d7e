"""Teleoperation devices read on the server: a joystick or gamepad, a 3D mouse, a test double.

Paper 1's participants drove the robot with a joystick; the usual device for Cartesian
teleoperation is a 3D mouse (SpaceMouse). Each device here is a class whose
``velocity_m_s()`` returns the desired end-effector velocity, shape (3,), base frame [m/s]
(zero inside the dead zone; None when the device is gone), from axes in [-1, 1] through
``axes_to_velocity``. ``DeviceFeeder`` polls one at a fixed rate and hands the velocity to
``ControlLoop.set_device_velocity`` (the loop uses it when no gizmo drag is in progress).

* ``JoystickDevice``: pygame (``SDL_VIDEODRIVER=dummy``, no window): left stick x -> +x,
  left stick up -> +y, right stick up -> +z.
* ``SpaceMouseDevice``: pyspacemouse (HID); translation x, y, z.
* ``ScriptedDevice``: the device-free test double (axes from a list or a function of time).

Both libraries are optional (``pip install cobotsafety[devices]``); ``open_device(kind)`` raises
``RuntimeError`` with one line saying what is missing.
"""

from __future__ import annotations

import logging
import math
import os
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

logger = logging.getLogger(__name__)

DEVICES = ("joystick", "spacemouse")


@dataclass(frozen=True)
class AxisSettings:
    max_speed_m_s: float = 0.25
    """Speed at full deflection [m/s]."""
    dead_zone: float = 0.08
    """Deflections (norm, in [0, 1]) below this command nothing; above, rescaled from 0."""


def axes_to_velocity(axes: Sequence[float], settings: AxisSettings = AxisSettings()) -> np.ndarray:
    """Shape (3,) velocity [m/s] from three axis deflections in [-1, 1] (base x, y, z).

    Non-finite axes give zero; each axis is clipped to [-1, 1]; the deflection's norm is capped
    at 1, zeroed inside the dead zone and rescaled from its edge, so the velocity grows
    continuously from 0 to ``max_speed_m_s``.
    """
    a = np.asarray(list(axes)[:3] + [0.0] * (3 - min(len(axes), 3)), dtype=float)
    if not np.all(np.isfinite(a)):
        return np.zeros(3)
    a = np.clip(a, -1.0, 1.0)
    size = float(np.linalg.norm(a))
    if size <= settings.dead_zone:
        return np.zeros(3)
    scaled = (min(size, 1.0) - settings.dead_zone) / (1.0 - settings.dead_zone)
    return a / size * scaled * settings.max_speed_m_s


class ScriptedDevice:
    """Test double: ``axes`` is a list of (x, y, z) deflections read in turn (the last one
    repeats) or a function of the time since the first read [s]; None reads as a lost device."""

    def __init__(self, axes, settings: AxisSettings = AxisSettings()):
        self.axes = axes
        self.settings = settings
        self.reads = 0
        self._t0: float | None = None

    def velocity_m_s(self) -> np.ndarray | None:
        if callable(self.axes):
            now = time.perf_counter()
            self._t0 = now if self._t0 is None else self._t0
            value = self.axes(now - self._t0)
        else:
            value = self.axes[min(self.reads, len(self.axes) - 1)]
        self.reads += 1
        return None if value is None else axes_to_velocity(value, self.settings)

    def close(self) -> None:
        pass


class JoystickDevice:
    """The first joystick or gamepad pygame finds (initialised on the first read, in the
    reading thread)."""

    def __init__(self, index: int = 0, settings: AxisSettings = AxisSettings()):
        os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
        os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
        try:
            import pygame  # noqa: PLC0415
        except ImportError:
            raise RuntimeError("joystick: pygame is not installed (pip install cobotsafety[devices])") from None
        self._pygame = pygame
        self.index = index
        self.settings = settings
        pygame.init()
        pygame.joystick.init()
        if pygame.joystick.get_count() <= index:
            raise RuntimeError(f"joystick: no joystick or gamepad #{index} found "
                               f"({pygame.joystick.get_count()} connected)")
        self._stick = pygame.joystick.Joystick(index)
        self._stick.init()

    def velocity_m_s(self) -> np.ndarray | None:
        pygame = self._pygame
        try:
            pygame.event.pump()
            count = self._stick.get_numaxes()
            x = self._stick.get_axis(0) if count > 0 else 0.0
            y = -self._stick.get_axis(1) if count > 1 else 0.0  # stick up is negative
            z = -self._stick.get_axis(3) if count > 3 else 0.0
        except pygame.error:
            return None
        return axes_to_velocity((x, y, z), self.settings)

    def close(self) -> None:
        self._pygame.joystick.quit()


class SpaceMouseDevice:
    """A 3Dconnexion SpaceMouse through pyspacemouse (translation only)."""

    def __init__(self, settings: AxisSettings = AxisSettings()):
        try:
            import pyspacemouse  # noqa: PLC0415
        except ImportError:
            raise RuntimeError("spacemouse: pyspacemouse is not installed (pip install cobotsafety[devices])") from None
        self.settings = settings
        try:
            self._mouse = pyspacemouse.open(axis_convention=pyspacemouse.AxisConvention.HID_Z_UP)
        except Exception as error:  # noqa: BLE001 - the HID layer raises many kinds
            raise RuntimeError(f"spacemouse: could not open a SpaceMouse ({error})") from None
        if self._mouse is None:
            raise RuntimeError("spacemouse: no SpaceMouse found")

    def velocity_m_s(self) -> np.ndarray | None:
        try:
            state = self._mouse.read()
        except Exception:  # noqa: BLE001
            return None
        return axes_to_velocity((state.x, state.y, state.z), self.settings)

    def close(self) -> None:
        self._mouse.close()


def open_device(kind: str, settings: AxisSettings = AxisSettings()):
    """``"joystick"`` or ``"spacemouse"``; ``RuntimeError`` (one line) when it cannot be used."""
    if kind == "joystick":
        return JoystickDevice(settings=settings)
    if kind == "spacemouse":
        return SpaceMouseDevice(settings=settings)
    raise RuntimeError(f"unknown device {kind!r}; known: {', '.join(DEVICES)}")


class DeviceFeeder:
    """Polls ``device.velocity_m_s()`` at ``rate_hz`` in a daemon thread and calls
    ``sink(v)`` with it (``v[:dim]``; None when the device is lost or failed: logged once)."""

    def __init__(self, device, sink: Callable[[np.ndarray | None], object], dim: int, rate_hz: float = 100.0):
        self.device = device
        self.sink = sink
        self.dim = dim
        self.period_s = 1.0 / rate_hz
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._failed = False

    def poll_once(self) -> np.ndarray | None:
        try:
            v = self.device.velocity_m_s()
        except Exception:  # noqa: BLE001 - a device error must not stop the robot's loop
            if not self._failed:
                logger.exception("input device failed; commanding nothing from it")
            self._failed = True
            v = None
        if v is not None:
            v = np.asarray(v, dtype=float)[:self.dim]
            if v.shape != (self.dim,) or not all(math.isfinite(c) for c in v):
                v = None
        self.sink(v)
        return v

    def start(self) -> "DeviceFeeder":
        self._thread = threading.Thread(target=self._run, daemon=True, name="input-device")
        self._thread.start()
        return self

    def _run(self) -> None:
        while not self._stop.is_set():
            self.poll_once()
            self._stop.wait(self.period_s)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
        self.sink(None)
        try:
            self.device.close()
        except Exception:  # noqa: BLE001
            pass
