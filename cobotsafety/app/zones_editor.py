"""Protection-zone editor: add, move, resize and delete boxes and spheres in the current scene.

In the plane a box is a ``RectangleZone`` and a sphere a ``CircleKeepOut``; in 3D they are the
arm's ``BoxZone`` and ``SphereZone``. The scene's built-in zones of those kinds are editable
too. Edits replace the frozen zone in the scene's live list under the control loop's lock, then
the scene redraws. Zones added by hand are remembered (shape, centre, size) and re-added after
a robot or scene switch. A zone whose placement would contain the end-effector is refused with
a message: the filter would otherwise push the arm out of it by itself.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np
import viser

from cobotsafety.app.control_loop import ControlLoop
from cobotsafety.planar.limitations import CircleKeepOut, PlanarLimitation, RectangleZone

SHAPES = ("box", "sphere")
NONE = "(none)"
PREFIX = "Z"
EE_CLEARANCE_M = 0.03
"""A zone must keep this far from the end-effector when placed [m] (the arm's capsule radius)."""


def make_planar_zone(name: str, shape: str, p_m: tuple[float, float, float], size_m: float) -> PlanarLimitation:
    """A planar zone centred at ``p_m[:2]`` [m]; ``size_m`` is the half side (box) or the radius."""
    if shape == "box":
        return RectangleZone(name, (p_m[0], p_m[1]), (size_m, size_m))
    if shape == "sphere":
        return CircleKeepOut(name, size_m, (p_m[0], p_m[1]))
    raise ValueError(f"shape must be one of {SHAPES}, got {shape!r}")


def zone_geometry(zone) -> tuple[str, np.ndarray, np.ndarray] | None:
    """``(shape, centre (3,), half sizes (3,))`` [m] of an editable zone, or None.

    Editable: planar rectangles and off-origin keep-out circles, 3D boxes and spheres.
    """
    if isinstance(zone, RectangleZone):
        return "box", np.array([*zone.center_m, 0.0]), np.array([*zone.half_size_m, np.inf])
    if isinstance(zone, CircleKeepOut) and tuple(zone.center_m) != (0.0, 0.0):
        return "sphere", np.array([*zone.center_m, 0.0]), np.full(3, zone.radius_m)
    if not type(zone).__module__.startswith("cobotsafety.arm"):
        return None  # a planar limitation: no need to load the 3D zones (numba) to say so
    from cobotsafety.arm.limitations import BoxZone, SphereZone  # noqa: PLC0415

    if isinstance(zone, BoxZone):
        return "box", np.asarray(zone.center, float), np.asarray(zone.half_size, float)
    if isinstance(zone, SphereZone):
        return "sphere", np.asarray(zone.center, float), np.full(3, zone.radius_m)
    return None


def contains_point(shape: str, centre_m: np.ndarray, half_m: np.ndarray, p_m: np.ndarray, dim: int,
                   clearance_m: float = EE_CLEARANCE_M) -> bool:
    """Whether ``p_m`` lies inside the zone grown by ``clearance_m`` (first ``dim`` axes)."""
    offset = np.asarray(p_m, float)[:dim] - centre_m[:dim]
    if shape == "sphere":
        return float(np.linalg.norm(offset)) < half_m[0] + clearance_m
    return bool(np.all(np.abs(offset) < half_m[:dim] + clearance_m))


class ZoneEditor:
    """GUI handles of the editor (made once) and the edits they make on ``scene()``."""

    def __init__(self, server: viser.ViserServer, loop: ControlLoop, scene: Callable[[], object]):
        self.server, self.loop, self.scene = server, loop, scene
        self.count = 0
        self.added: dict[str, tuple[str, tuple[float, float, float], float]] = {}
        """Zones added by hand: name -> (shape, centre [m], size [m]), carried over on a switch."""
        self.last_refusal = ""
        self._syncing = False
        gui = server.gui
        with gui.add_folder("Protection zones", expand_by_default=False):
            self.shape = gui.add_dropdown("Shape", SHAPES)
            self.x = gui.add_slider("x [m]", -1.0, 1.0, 0.005, 0.3)
            self.y = gui.add_slider("y [m]", -1.0, 1.0, 0.005, 0.0)
            self.z = gui.add_slider("z [m] (3D)", 0.0, 1.5, 0.005, 0.3)
            self.size = gui.add_slider("Size [m]", 0.01, 0.3, 0.005, 0.05)
            self.add = gui.add_button("Add zone")
            self.selected = gui.add_dropdown("Zone", (NONE,), hint="built-in boxes and spheres are editable too")
            self.delete = gui.add_button("Delete zone")
            self.message = gui.add_markdown("")
        self.add.on_click(lambda event: self.add_zone(event.client))
        self.delete.on_click(lambda _: self.delete_zone())
        self.selected.on_update(lambda _: self._load_selected())
        for slider in (self.x, self.y, self.z, self.size):
            slider.on_update(lambda event: self.edit_selected(getattr(event, "client", None)))

    # ---- helpers ---------------------------------------------------------------------------
    def _names(self) -> tuple[str, ...]:
        return tuple(z.name for z in self.scene().zones() if zone_geometry(z) is not None)

    def _centre(self) -> tuple[float, float, float]:
        return (self.x.value, self.y.value, self.z.value)

    def _refuse_if_on_end_effector(self, shape: str, centre, size_m: float, client) -> bool:
        """True (and a message) when the zone would contain the end-effector."""
        scene = self.scene()
        ee = np.asarray(self.loop.snapshot().p_base_ee_m, float)
        half = np.full(3, size_m)
        if not contains_point(shape, np.asarray(centre, float), half, ee, scene.dim):
            return False
        self.last_refusal = ("Zone not placed: it would contain the end-effector, and the filter would push "
                             "the arm out of it by itself. Move the zone or the arm first.")
        self.message.content = f"**{self.last_refusal}**"
        if client is not None:
            client.add_notification("Zone refused", self.last_refusal, color="orange", auto_close_seconds=8.0)
        return True

    def _load_selected(self) -> None:
        """Show the selected zone's centre and size on the sliders (without editing it)."""
        for zone in self.scene().zones():
            if zone.name == self.selected.value:
                shape, centre, half = zone_geometry(zone)
                self._syncing = True
                try:
                    self.x.value, self.y.value = float(centre[0]), float(centre[1])
                    if self.scene().dim == 3:
                        self.z.value = float(centre[2])
                    self.size.value = float(np.clip(np.min(half[: self.scene().dim]), 0.01, 0.3))
                finally:
                    self._syncing = False
                return

    def _replace(self, zone, centre, size_m: float):
        """``zone`` moved to ``centre`` and resized to ``size_m`` (its own type kept)."""
        shape, _, half = zone_geometry(zone)
        if hasattr(zone, "center_m"):  # planar
            if shape == "box":
                scale = size_m / float(np.min(half[:2]))
                return dataclasses.replace(zone, center_m=(centre[0], centre[1]),
                                           half_size_m=tuple(float(h * scale) for h in half[:2]))
            return dataclasses.replace(zone, center_m=(centre[0], centre[1]), radius_m=size_m)
        if shape == "box":
            scale = size_m / float(np.min(half))
            return dataclasses.replace(zone, center=tuple(centre), half_size=tuple(float(h * scale) for h in half))
        return type(zone)(zone.name, tuple(centre), size_m)

    # ---- edits -----------------------------------------------------------------------------
    def add_zone(self, client=None) -> str:
        """Add a zone of the chosen shape at the sliders; returns its name, or "" if refused."""
        shape, centre, size = self.shape.value, self._centre(), self.size.value
        if self._refuse_if_on_end_effector(shape, centre, size, client):
            return ""
        self.count += 1
        name = f"{PREFIX}{self.count} {shape}"
        zone = self.scene().make_zone(name, shape, centre, size)
        with self.loop.lock:
            self.scene().zones().append(zone)
        self.added[name] = (shape, centre, size)
        self.message.content = ""
        self.selected.options = self._names()
        self.selected.value = name
        self.scene().redraw()
        return name

    def edit_selected(self, client=None) -> None:
        name = self.selected.value
        if self._syncing or name == NONE:
            return
        centre, size = self._centre(), self.size.value
        with self.loop.lock:
            zones = self.scene().zones()
            for i, zone in enumerate(zones):
                if zone.name == name and zone_geometry(zone) is not None:
                    if self._refuse_if_on_end_effector(zone_geometry(zone)[0], centre, size, client):
                        return
                    zones[i] = self._replace(zone, centre, size)
                    if name in self.added:
                        self.added[name] = (self.added[name][0], centre, size)
                    break
            else:
                return
        self.message.content = ""
        self.scene().redraw()

    def delete_zone(self) -> None:
        name = self.selected.value
        with self.loop.lock:
            zones = self.scene().zones()
            zones[:] = [z for z in zones if z.name != name]
        self.added.pop(name, None)
        self.reset()
        self.scene().redraw()

    def reset(self) -> None:
        """After the scene changed: offer its editable zones."""
        names = self._names()
        self.selected.options = names or (NONE,)
        self.selected.value = (names or (NONE,))[0]

    def carry_over(self) -> None:
        """After a robot or scene switch: re-add the zones added by hand to the new scene."""
        scene = self.scene()
        with self.loop.lock:
            zones = scene.zones()
            present = {z.name for z in zones}
            for name, (shape, centre, size) in self.added.items():
                if name not in present:
                    zones.append(scene.make_zone(name, shape, centre, size))
        if self.added:
            scene.redraw()
        self.reset()
