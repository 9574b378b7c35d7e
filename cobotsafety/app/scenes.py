"""The two scenes behind one small interface: the planar RR arm and a 3D pinocchio arm.

A scene owns its robot (a ``Teleoperated``) and its view. ``read(robot)`` copies, under the
control loop's lock, what rendering needs; ``render(snapshot, data)`` moves the nodes and returns
the robot capsules ``(p0 (r, 3), p1 (r, 3), radius (r,))`` [m] for the human distance display.
``zones()`` is the live list the zone editor edits; ``make_zone`` builds a box or a sphere.
"""

from __future__ import annotations

import numpy as np
import viser

from cobotsafety.app.panel import PLANAR_SCENES

PLANAR = "planar"


class PlanarScene:
    dim = 2
    gizmo_axes = (True, True, False)

    def __init__(self, server: viser.ViserServer, label: str = PLANAR_SCENES[0]):
        from cobotsafety.app.scene_planar import PlanarView  # noqa: PLC0415
        from cobotsafety.planar.planar_scenes import demo_scene, fig9_scene  # noqa: PLC0415
        from cobotsafety.planar.planar_teleop import PlanarTeleop  # noqa: PLC0415

        scenes = {PLANAR_SCENES[1]: lambda: fig9_scene("a"), PLANAR_SCENES[2]: lambda: fig9_scene("b")}
        self.name = PLANAR
        self.robot = PlanarTeleop(scenes.get(label, demo_scene)())
        self.view = PlanarView(server, self.robot)

    def read(self, robot) -> dict:
        return {"elbow": np.asarray(robot.p_base_elbow_m, dtype=float)}

    def render(self, snapshot, data: dict):
        from cobotsafety.app.scene_planar import planar_capsules  # noqa: PLC0415

        self.view.update(snapshot, data["elbow"])
        return planar_capsules(data["elbow"], snapshot.p_base_ee_m)

    def zones(self) -> list:
        return self.robot.scene.limitations

    @staticmethod
    def make_zone(name: str, shape: str, p_m: tuple[float, float, float], size_m: float):
        from cobotsafety.app.zones_editor import make_planar_zone  # noqa: PLC0415

        return make_planar_zone(name, shape, p_m, size_m)

    def redraw(self) -> None:
        self.view.redraw_limitations()

    def remove(self) -> None:
        self.view.remove()


class ArmScene:
    dim = 3
    gizmo_axes = (True, True, True)

    def __init__(self, server: viser.ViserServer, robot_name: str | None = None):
        from cobotsafety.app.scene_arm import ArmView  # noqa: PLC0415
        from cobotsafety.arm.controller import ArmController  # noqa: PLC0415
        from cobotsafety.arm.robots import DEFAULT_ROBOT  # noqa: PLC0415

        self.name = robot_name or DEFAULT_ROBOT
        # The human capsules of the replay are a moving protection zone: the control loop polls
        # the human source and hands each frame to ``robot.set_human``.
        self.robot = ArmController(self.name)  # raises UnknownRobotError listing the known names
        self.view = ArmView(server, self.robot)

    def read(self, robot) -> dict:
        state = robot.state
        return {"q": state.q.copy(), "capsules": (state.capsule_p0.copy(), state.capsule_p1.copy(),
                                                  state.capsule_radius.copy())}

    def render(self, snapshot, data: dict):
        self.view.update(snapshot, data["q"], data["capsules"])
        return data["capsules"]

    def zones(self) -> list:
        return self.robot.zones

    @staticmethod
    def make_zone(name: str, shape: str, p_m: tuple[float, float, float], size_m: float):
        from cobotsafety.arm.limitations import BoxZone, SphereZone  # noqa: PLC0415

        if shape == "box":
            return BoxZone(name, tuple(p_m), (size_m, size_m, size_m))
        return SphereZone(name, tuple(p_m), size_m)

    def redraw(self) -> None:
        self.view.redraw_zones()

    def remove(self) -> None:
        self.view.remove()


def make_scene(server: viser.ViserServer, robot_name: str, planar_label: str = PLANAR_SCENES[0]):
    """``planar`` -> the RR arm of paper 1; any other name -> that pinocchio arm."""
    if robot_name == PLANAR:
        return PlanarScene(server, planar_label)
    return ArmScene(server, robot_name)
