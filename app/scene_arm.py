"""The 3D arm scene: URDF meshes (``viser.extras.ViserUrdf``), translucent robot capsules,
protection zones, and the zone the command slides on highlighted.

Nodes are made once; ``update`` only sets the URDF joint configuration and the capsule poses,
and only when a joint moved by more than ``REDRAW_TOLERANCE_RAD`` since the last frame sent (an
arm holding still, or creeping in its null space, sends nothing).
"""

from __future__ import annotations


import numpy as np
import viser

from cobotsafety.app import draw
from cobotsafety.app.control_loop import LoopSnapshot
from cobotsafety.arm.zones import BoxZone, CapsuleZone, HalfSpaceZone

ROOT = "/arm"
CAPSULE_COLOUR = (90, 140, 230)
ZONE_COLOUR = (230, 120, 40)
HALF_SPACE_SIZE_M = 1.5
REDRAW_TOLERANCE_RAD = 1e-3
"""Joint change [rad] (or [m] for prismatic joints) below which a frame does not move the arm."""


def urdf_joint_values(model, q: np.ndarray, joint_names: tuple[str, ...]) -> np.ndarray:
    """URDF actuated-joint values [rad or m] from pinocchio ``q``; locked joints give 0.

    Continuous joints (``nq = 2``: cos, sin) become an angle.
    """
    values = np.zeros(len(joint_names))
    for i, name in enumerate(joint_names):
        if not model.existJointName(name):
            continue
        joint = model.joints[model.getJointId(name)]
        if joint.nq == 1:
            values[i] = q[joint.idx_q]
        elif joint.nq == 2:
            values[i] = np.arctan2(q[joint.idx_q + 1], q[joint.idx_q])
    return values


def _mesh_arrays(mesh):
    return np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32)


class ArmView:
    def __init__(self, server: viser.ViserServer, teleop):
        self.server, self.teleop = server, teleop
        state = teleop.state
        server.scene.set_up_direction("+z")
        server.initial_camera.position = (1.6, -1.4, 1.1)
        server.initial_camera.look_at = (0.3, 0.0, 0.35)
        self.grid = server.scene.add_grid(f"{ROOT}/grid", width=2.0, height=2.0, cell_size=0.1, section_size=0.5)
        self.urdf = None
        if state.spec.loader is not None:
            from viser.extras import ViserUrdf  # noqa: PLC0415

            from cobotsafety.arm.robots import urdf_path  # noqa: PLC0415

            path = urdf_path(state.spec.name)
            self.urdf = ViserUrdf(server, path, root_node_name=f"{ROOT}/urdf")
            self.joint_names = tuple(self.urdf.get_actuated_joint_names())
        self.capsules = []
        for i in range(len(state.capsule_radius)):
            length = float(np.linalg.norm(state.capsule_p1_local[i] - state.capsule_p0_local[i]))
            self.capsules.append(server.scene.add_mesh_simple(
                f"{ROOT}/capsules/{i}", *_mesh_arrays(draw.capsule_mesh(length, float(state.capsule_radius[i]))),
                color=CAPSULE_COLOUR, opacity=0.25 if self.urdf is not None else 0.9))
        self.zone_nodes: dict[str, object] = {}
        self._q_drawn: np.ndarray | None = None
        self._highlighted: tuple[str, ...] = ()
        self.redraw_zones()

    def redraw_zones(self) -> None:
        for node in self.zone_nodes.values():
            node.remove()
        self.zone_nodes, self._highlighted = {}, ()
        scene = self.server.scene
        for i, zone in enumerate(self.teleop.zones):
            name = f"{ROOT}/zones/{i}"
            if isinstance(zone, BoxZone):
                node = scene.add_box(name, ZONE_COLOUR, dimensions=2 * np.asarray(zone.half_size), opacity=0.35,
                                     position=zone.center)
            elif isinstance(zone, CapsuleZone):
                axis = np.asarray(zone.p1) - np.asarray(zone.p0)
                mesh = draw.capsule_mesh(float(np.linalg.norm(axis)), zone.radius_m)
                node = scene.add_mesh_simple(name, *_mesh_arrays(mesh), color=ZONE_COLOUR, opacity=0.35,
                                             position=zone.p0, wxyz=draw.wxyz_z_to(axis))
            elif isinstance(zone, HalfSpaceZone):
                normal = np.asarray(zone.normal, dtype=float)
                node = scene.add_box(name, ZONE_COLOUR, dimensions=(HALF_SPACE_SIZE_M, HALF_SPACE_SIZE_M, 0.005),
                                     opacity=0.2, position=zone.point, wxyz=draw.wxyz_z_to(normal))
            else:
                continue
            self.zone_nodes[zone.name] = node

    def highlight(self, binding: tuple[str, ...]) -> None:
        if binding == self._highlighted:
            return
        for name, node in self.zone_nodes.items():
            active = any(row == name or row.startswith(name + " ") for row in binding)
            node.color = draw.HIGHLIGHT if active else ZONE_COLOUR
        self._highlighted = binding

    def robot_capsules(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        state = self.teleop.state
        return state.capsule_p0.copy(), state.capsule_p1.copy(), state.capsule_radius.copy()

    def update(self, snapshot: LoopSnapshot, q: np.ndarray, capsules) -> None:
        """``q``: pinocchio configuration; ``capsules``: ``(p0, p1, radius)`` world frame [m]."""
        self.highlight(snapshot.report.binding if snapshot.report is not None else ())
        q = np.asarray(q, dtype=float)
        if self._q_drawn is not None and self._q_drawn.shape == q.shape and \
                float(np.max(np.abs(q - self._q_drawn), initial=0.0)) < REDRAW_TOLERANCE_RAD:
            return
        self._q_drawn = q.copy()
        if self.urdf is not None:
            self.urdf.update_cfg(urdf_joint_values(self.teleop.state.model, q, self.joint_names))
        p0, p1, _ = capsules
        for i, node in enumerate(self.capsules):
            node.position = p0[i]
            node.wxyz = draw.wxyz_z_to(p1[i] - p0[i])

    def remove(self) -> None:
        for node in [*self.zone_nodes.values(), *self.capsules, self.grid]:
            node.remove()
        if self.urdf is not None:
            self.urdf.remove()
