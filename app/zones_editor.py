"""Protection-zone editor for the planar scene: add, move, resize and delete a box or a sphere.

In the plane a box is a ``RectangleZone`` and a sphere a ``CircleKeepOut``. Edits replace the
frozen limitation in the scene's list under the control loop's lock, then redraw.
"""

from __future__ import annotations

from typing import Callable

import viser

from cobotsafety.app.control_loop import ControlLoop
from cobotsafety.planar.limitations import CircleKeepOut, PlanarLimitation, RectangleZone

SHAPES = ("box", "sphere")
NONE = "(none)"


def make_zone(name: str, shape: str, x_m: float, y_m: float, size_m: float) -> PlanarLimitation:
    """A zone centred at (x, y) [m]; ``size_m`` is the half side (box) or the radius (sphere)."""
    if shape == "box":
        return RectangleZone(name, (x_m, y_m), (size_m, size_m))
    if shape == "sphere":
        return CircleKeepOut(name, size_m, (x_m, y_m))
    raise ValueError(f"shape must be one of {SHAPES}, got {shape!r}")


class PlanarZoneEditor:
    """GUI handles of the editor (made once) and the edits they make."""

    def __init__(self, server: viser.ViserServer, loop: ControlLoop, redraw: Callable[[], None]):
        self.loop, self.redraw = loop, redraw
        self.count = 0
        gui = server.gui
        with gui.add_folder("Protection zones", expand_by_default=False):
            self.shape = gui.add_dropdown("Shape", SHAPES)
            self.x = gui.add_slider("x [m]", -0.6, 0.6, 0.005, 0.3)
            self.y = gui.add_slider("y [m]", -0.6, 0.6, 0.005, 0.0)
            self.size = gui.add_slider("Size [m]", 0.01, 0.2, 0.005, 0.04)
            self.add = gui.add_button("Add zone")
            self.selected = gui.add_dropdown("Zone", (NONE,))
            self.delete = gui.add_button("Delete zone")
        self.add.on_click(lambda _: self.add_zone())
        self.delete.on_click(lambda _: self.delete_zone())
        for slider in (self.x, self.y, self.size):
            slider.on_update(lambda _: self.edit_selected())

    def _names(self) -> tuple[str, ...]:
        return tuple(z.name for z in self.loop.robot.scene.limitations if z.name.startswith("Z"))

    def add_zone(self) -> str:
        self.count += 1
        name = f"Z{self.count} {self.shape.value}"
        zone = make_zone(name, self.shape.value, self.x.value, self.y.value, self.size.value)
        with self.loop.lock:
            self.loop.robot.scene.limitations.append(zone)
        self.selected.options = self._names()
        self.selected.value = name
        self.redraw()
        return name

    def edit_selected(self) -> None:
        name = self.selected.value
        with self.loop.lock:
            zones = self.loop.robot.scene.limitations
            for i, zone in enumerate(zones):
                if zone.name == name:
                    shape = "box" if isinstance(zone, RectangleZone) else "sphere"
                    zones[i] = make_zone(name, shape, self.x.value, self.y.value, self.size.value)
                    break
            else:
                return
        self.redraw()

    def delete_zone(self) -> None:
        name = self.selected.value
        with self.loop.lock:
            zones = self.loop.robot.scene.limitations
            zones[:] = [z for z in zones if z.name != name]
        self.selected.options = self._names() or (NONE,)
        self.redraw()

    def reset(self) -> None:
        """After the scene changed: forget the selection."""
        self.selected.options = self._names() or (NONE,)


