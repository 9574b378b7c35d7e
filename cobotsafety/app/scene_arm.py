"""The 3D arm scene: URDF meshes (``viser.extras.ViserUrdf``), translucent robot capsules,
protection zones, the table and the floor, and every limit the command meets highlighted (zones
here, joints, reach and table by ``scene_limits.LimitMarks``, all read by ``limit_words``).

Nodes are made once; ``update`` only turns the frames of the joints that moved by more than
``REDRAW_TOLERANCE_RAD`` since the last frame sent (``UrdfJointPoser``); an arm holding still,
or creeping in its null space, sends nothing. Each robot capsule is a child of its joint's URDF
frame, so it moves with its link at no cost (without a URDF, the capsules whose ends moved by
more than ``REDRAW_TOLERANCE_M`` are posed in the world frame). The render thread shares the
interpreter with the control loop, so a frame should be cheap: ``ViserUrdf.update_cfg`` re-posed
every frame of the URDF through yourdfpy's scene graph, and the capsules were posed one by one
(~3 ms a frame for the panda); the poser computes only the moving joints' rotations, in closed
form.
"""

from __future__ import annotations

import math

import numpy as np
import viser

from cobotsafety.app import draw
from cobotsafety.app.camera import set_initial_view
from cobotsafety.app.control_loop import LoopSnapshot
from cobotsafety.app.lighting import light_scene
from cobotsafety.app.limit_words import ZONE, describe, in_play, vocabulary_of
from cobotsafety.app.scene_limits import FLOOR_BELOW_TABLE_M, LimitMarks, table_height_m
from cobotsafety.arm.limitations import BoxZone, CapsuleZone, HalfSpaceZone, SphereZone

ROOT = "/arm"
CAPSULE_COLOUR = (90, 140, 230)
ZONE_COLOUR = draw.ZONE
CAMERA_POSITION_M = (-0.85, -1.35, 1.25)
CAMERA_LOOK_AT_M = (0.5, 0.05, 0.3)
"""The arm's initial view: from behind its left shoulder, above the table. The recorded people
come to the table's far edge (x >= 0.6 m), so they stand beyond the arm instead of between it
and the camera; no gizmo axis points at the camera (each is 50-65 degrees off the view line)."""
HALF_SPACE_SIZE_M = 1.5
REDRAW_TOLERANCE_RAD = 1e-3
"""Joint change [rad] (or [m] for prismatic joints) below which a frame does not turn that joint."""
REDRAW_TOLERANCE_M = 5e-4
"""Capsule end displacement [m] below which a frame does not move that capsule."""
MOVING_JOINT_TYPES = ("revolute", "continuous", "prismatic")


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


def _quaternion_product(a, b) -> tuple[float, float, float, float]:
    """Hamilton product of two ``wxyz`` quaternions."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


class UrdfJointPoser:
    """Poses a ``ViserUrdf``'s joint frames from the URDF joint values, moving joints only.

    ``pose(values)`` sets what ``ViserUrdf.update_cfg(values)`` would (the frame of each joint
    = its origin times its motion), but computes only revolute, continuous and prismatic joints
    (mimic joints follow their leader), in closed form, and only those whose value changed by
    ``tolerance`` or more since they were last posed. The first call goes through
    ``update_cfg`` itself, which also places the fixed joints once. Without the ``ViserUrdf``
    internals it reads (another viser version), every call goes through ``update_cfg``.
    """

    def __init__(self, viser_urdf, tolerance: float = REDRAW_TOLERANCE_RAD):
        self.viser_urdf, self.tolerance = viser_urdf, tolerance
        self.rows: list[tuple] | None = None
        """Per moving joint frame: (frame, leader index, multiplier, offset, type, origin wxyz,
        axis (3,), origin position [m], origin-rotated axis (3,)); None: ``update_cfg`` only."""
        self.frames: dict[str, object] = {}
        """Joint name -> the scene node of its child link's frame (empty without the internals)."""
        self._posed: np.ndarray | None = None
        try:
            urdf = viser_urdf._urdf
            pairs = list(zip(viser_urdf._joint_map_values, viser_urdf._joint_frames, strict=True))
            scale = float(viser_urdf._scale)
            names = list(urdf.actuated_joint_names)
        except (AttributeError, TypeError, ValueError):
            return
        for joint, frame in pairs:
            self.frames.setdefault(joint.name, frame)  # the visual tree's frame comes first
        from viser import transforms as tf  # noqa: PLC0415

        rows = []
        for joint, frame in pairs:
            if joint.type not in MOVING_JOINT_TYPES:
                continue
            leader, multiplier, offset = joint.name, 1.0, 0.0
            if joint.mimic is not None:
                leader = joint.mimic.joint
                multiplier, offset = float(joint.mimic.multiplier), float(joint.mimic.offset)
            if leader not in names:
                return  # yourdfpy's own fallbacks for odd URDFs: leave it to update_cfg
            origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=float)
            axis = np.asarray(joint.axis, dtype=float)
            axis = axis / np.linalg.norm(axis)
            rows.append((frame, names.index(leader), multiplier, offset, joint.type,
                         tuple(float(c) for c in tf.SO3.from_matrix(origin[:3, :3]).wxyz), axis,
                         origin[:3, 3] * scale, origin[:3, :3] @ axis * scale))
        self.rows = rows

    def pose(self, values: np.ndarray) -> int:
        """Joint values [rad or m] in ``get_actuated_joint_names()`` order; returns the number
        of joint frames set (all of them on the first call)."""
        values = np.asarray(values, dtype=float)
        if self.rows is None or self._posed is None or self._posed.shape != values.shape:
            self.viser_urdf.update_cfg(values)
            self._posed = values.copy()
            return len(getattr(self.viser_urdf, "_joint_frames", ()))
        moved = np.abs(values - self._posed) >= self.tolerance
        if not moved.any():
            return 0
        count = 0
        for frame, leader, multiplier, offset, kind, origin_wxyz, axis, origin_p, origin_axis in self.rows:
            if not moved[leader]:
                continue
            q = values[leader] * multiplier + offset
            if kind == "prismatic":
                frame.position = origin_p + origin_axis * q
            else:
                half = 0.5 * q
                sine = math.sin(half)
                frame.wxyz = _quaternion_product(
                    origin_wxyz, (math.cos(half), sine * axis[0], sine * axis[1], sine * axis[2]))
            count += 1
        self._posed[moved] = values[moved]
        return count


class ArmView:
    def __init__(self, server: viser.ViserServer, teleop):
        self.server, self.teleop = server, teleop
        state = teleop.state
        set_initial_view(server, CAMERA_POSITION_M, CAMERA_LOOK_AT_M)
        light_scene(server)
        floor_z = table_height_m(getattr(teleop, "limitations", ())) - FLOOR_BELOW_TABLE_M
        self.grid = server.scene.add_grid(f"{ROOT}/grid", width=4.0, height=4.0, cell_size=0.25, section_size=1.0,
                                          position=(0.5, 0.0, floor_z))
        self.vocabulary = vocabulary_of(teleop)
        self.urdf = None
        if state.spec.loader is not None:
            from viser.extras import ViserUrdf  # noqa: PLC0415

            from cobotsafety.arm.robots import urdf_path  # noqa: PLC0415

            path = urdf_path(state.spec.name)
            self.urdf = ViserUrdf(server, path, root_node_name=f"{ROOT}/urdf")
            self.joint_names = tuple(self.urdf.get_actuated_joint_names())
            self.poser = UrdfJointPoser(self.urdf)
        self.capsules = []
        self.capsule_attached = np.zeros(len(state.capsule_radius), dtype=bool)
        """True for a capsule made a child of its joint's URDF frame: it moves with the link and
        costs nothing per frame. The others are posed in the world frame by ``update``."""
        frames = self.poser.frames if self.urdf is not None else {}
        for i in range(len(state.capsule_radius)):
            axis = state.capsule_p1_local[i] - state.capsule_p0_local[i]
            mesh = draw.capsule_mesh(float(np.linalg.norm(axis)), float(state.capsule_radius[i]))
            look = {"color": CAPSULE_COLOUR, "opacity": 0.25 if self.urdf is not None else 0.9}
            parent = frames.get(state.capsules[i].joint)
            if parent is not None:  # capsule ends are fixed in the joint frame = the child link's frame
                self.capsules.append(server.scene.add_mesh_simple(
                    f"{parent.name}/capsule_{i}", *mesh, position=state.capsule_p0_local[i],
                    wxyz=draw.wxyz_z_to(axis), **look))
                self.capsule_attached[i] = True
            else:
                self.capsules.append(server.scene.add_mesh_simple(f"{ROOT}/capsules/{i}", *mesh, **look))
        self.zone_nodes: dict[str, object] = {}
        self._capsules_drawn: tuple[np.ndarray, np.ndarray] | None = None
        """Capsule ends (p0, p1) as last sent, shape (r, 3) each [m]."""
        self._highlighted: tuple[str, ...] = ()
        self.marks = LimitMarks(server, ROOT, teleop, self.urdf)
        self.redraw_zones()
        if self.urdf is not None:  # the fixed joints' frames are placed once, here
            self.poser.pose(urdf_joint_values(state.model, np.asarray(state.q, dtype=float), self.joint_names))

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
            elif isinstance(zone, SphereZone):
                mesh = draw.capsule_mesh(0.0, zone.radius_m)
                node = scene.add_mesh_simple(name, *mesh, color=ZONE_COLOUR, opacity=0.35,
                                             position=zone.center)
            elif isinstance(zone, CapsuleZone):
                axis = np.asarray(zone.p1) - np.asarray(zone.p0)
                mesh = draw.capsule_mesh(float(np.linalg.norm(axis)), zone.radius_m)
                node = scene.add_mesh_simple(name, *mesh, color=ZONE_COLOUR, opacity=0.35,
                                             position=zone.p0, wxyz=draw.wxyz_z_to(axis))
            elif isinstance(zone, HalfSpaceZone):
                normal = np.asarray(zone.normal, dtype=float)
                node = scene.add_box(name, ZONE_COLOUR, dimensions=(HALF_SPACE_SIZE_M, HALF_SPACE_SIZE_M, 0.005),
                                     opacity=0.2, position=zone.point, wxyz=draw.wxyz_z_to(normal))
            else:
                continue
            self.zone_nodes[zone.name] = node

    def highlight(self, binding: tuple[str, ...]) -> None:
        """Highlight what ``binding`` (the rows in play, ``limit_words.in_play``) names: zones
        turn magenta, joints, reach and table get their marks."""
        if binding == self._highlighted:
            return
        limits = [describe(name, self.vocabulary) for name in binding]
        zones = {limit.target for limit in limits if limit.kind == ZONE}
        for name, node in self.zone_nodes.items():
            node.color = draw.HIGHLIGHT if name in zones else ZONE_COLOUR
        self.marks.show(limits)
        self._highlighted = binding

    def highlighted(self) -> tuple[str, ...]:
        """What is drawn highlighted now: zone names and ``LimitMarks`` keys."""
        zones = tuple(name for name, node in self.zone_nodes.items() if tuple(node.color) == draw.HIGHLIGHT)
        return zones + self.marks.shown

    def robot_capsules(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        state = self.teleop.state
        return state.capsule_p0.copy(), state.capsule_p1.copy(), state.capsule_radius.copy()

    def update(self, snapshot: LoopSnapshot, q: np.ndarray, capsules) -> None:
        """``q``: pinocchio configuration; ``capsules``: ``(p0, p1, radius)`` world frame [m]."""
        self.highlight(in_play(snapshot.report))
        if self.urdf is not None:
            self.poser.pose(urdf_joint_values(self.teleop.state.model, np.asarray(q, dtype=float), self.joint_names))
        p0, p1, _ = capsules
        p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
        drawn = self._capsules_drawn
        if drawn is None or drawn[0].shape != p0.shape:
            moved = np.ones(len(self.capsules), dtype=bool)
            drawn = self._capsules_drawn = (p0.copy(), p1.copy())
        else:
            moved = np.maximum(np.abs(p0 - drawn[0]).max(axis=1), np.abs(p1 - drawn[1]).max(axis=1)) >= REDRAW_TOLERANCE_M
        for i in np.flatnonzero(moved[:len(self.capsules)] & ~self.capsule_attached):
            node = self.capsules[i]
            node.position = p0[i]
            node.wxyz = draw.wxyz_z_to(p1[i] - p0[i])
            drawn[0][i], drawn[1][i] = p0[i], p1[i]

    def remove(self) -> None:
        for node in [*self.zone_nodes.values(), *self.capsules, self.grid]:
            node.remove()
        self.marks.remove()
        if self.urdf is not None:
            self.urdf.remove()
