"""Protection-zone editor: add, move, resize and delete a box or a sphere in the current scene.

In the plane a box is a ``RectangleZone`` and a sphere a ``CircleKeepOut``; in 3D they are the
arm's ``BoxZone`` and ``SphereZone``. Edits replace the frozen zone in the scene's live list
under the control loop's lock, then the scene redraws.
"""

from __future__ import annotations

from typing import Callable

import viser

from cobotsafety.app.control_loop import ControlLoop
from cobotsafety.planar.limitations import CircleKeepOut, PlanarLimitation, RectangleZone

SHAPES = ("box", "sphere")
NONE = "(none)"
PREFIX = "Z"


def make_planar_zone(name: str, shape: str, p_m: tuple[float, float, float], size_m: float) -> PlanarLimitation:
    """A planar zone centred at ``p_m[:2]`` [m]; ``size_m`` is the half side (box) or the radius."""
    if shape == "box":
        return RectangleZone(name, (p_m[0], p_m[1]), (size_m, size_m))
    if shape == "sphere":
        return CircleKeepOut(name, size_m, (p_m[0], p_m[1]))
    raise ValueError(f"shape must be one of {SHAPES}, got {shape!r}")


class ZoneEditor:
    """GUI handles of the editor (made once) and the edits they make on ``scene()``."""

    def __init__(self, server: viser.ViserServer, loop: ControlLoop, scene: Callable[[], object]):
        self.loop, self.scene = loop, scene
        self.count = 0
        self.shapes: dict[str, str] = {}
        gui = server.gui
        with gui.add_folder("Protection zones", expand_by_default=False):
            self.shape = gui.add_dropdown("Shape", SHAPES)
            self.x = gui.add_slider("x [m]", -1.0, 1.0, 0.005, 0.3)
            self.y = gui.add_slider("y [m]", -1.0, 1.0, 0.005, 0.0)
            self.z = gui.add_slider("z [m] (3D)", 0.0, 1.5, 0.005, 0.3)
            self.size = gui.add_slider("Size [m]", 0.01, 0.3, 0.005, 0.05)
            self.add = gui.add_button("Add zone")
            self.selected = gui.add_dropdown("Zone", (NONE,))
            self.delete = gui.add_button("Delete zone")
        self.add.on_click(lambda _: self.add_zone())
        self.delete.on_click(lambda _: self.delete_zone())
        for slider in (self.x, self.y, self.z, self.size):
            slider.on_update(lambda _: self.edit_selected())

    def _names(self) -> tuple[str, ...]:
        return tuple(z.name for z in self.scene().zones() if z.name.startswith(PREFIX))

    def _build(self, name: str, shape: str):
        return self.scene().make_zone(name, shape, (self.x.value, self.y.value, self.z.value), self.size.value)

    def add_zone(self) -> str:
        self.count += 1
        shape = self.shape.value
        name = f"{PREFIX}{self.count} {shape}"
        zone = self._build(name, shape)
        with self.loop.lock:
            self.scene().zones().append(zone)
        self.shapes[name] = shape
        self.selected.options = self._names()
        self.selected.value = name
        self.scene().redraw()
        return name

    def edit_selected(self) -> None:
        name = self.selected.value
        if name not in self.shapes:
            return
        with self.loop.lock:
            zones = self.scene().zones()
            for i, zone in enumerate(zones):
                if zone.name == name:
                    zones[i] = self._build(name, self.shapes[name])
                    break
            else:
                return
        self.scene().redraw()

    def delete_zone(self) -> None:
        name = self.selected.value
        with self.loop.lock:
            zones = self.scene().zones()
            zones[:] = [z for z in zones if z.name != name]
        self.shapes.pop(name, None)
        self.reset()
        self.scene().redraw()

    def reset(self) -> None:
        """After the scene changed: offer its zones."""
        names = self._names()
        self.selected.options = names or (NONE,)
        self.selected.value = (names or (NONE,))[0]
