"""The 3D arm's limits other than zones, drawn where they bind: joint arcs, joint rings, reach
spheres, the table.

``LimitMarks.show(limits)`` takes the binding rows read by ``limit_words.describe`` and makes
visible what each one means (zones and the human are their own nodes, in ``scene_arm`` and
``scene_human``):

* a joint at a position limit: an arc at the joint over its whole range (thin), the binding end
  (thick) and a needle that turns with the joint, so the needle sits at the thick end;
* a joint at its speed or acceleration limit: a ring round the joint's axis;
* the reach limit: a see-through sphere about the shoulder point (inner or extended);
* the table: the table top (always drawn, at the table constraint's height) turns magenta.

Everything is in the highlight colour. The arcs and rings hang on the URDF's link frames, so
they move with the arm at no cost per frame; they are made the first time they are needed and
then only shown or hidden (a visibility change reaches tabs opened earlier, a new colour on a
drawn line does not).
"""

from __future__ import annotations

import numpy as np
import viser

from cobotsafety.app import draw
from cobotsafety.app.limit_words import JOINT_ACCELERATION, JOINT_POSITION, JOINT_SPEED, REACH, TABLE, Limit

ARC_RADIUS_M = 0.17
"""Joint arcs stand out of the link meshes and capsules (~0.08 m across the arm's axis)."""
RING_RADIUS_M = 0.13
END_ARC_RAD = 0.35
"""The thick part of a joint arc: this much of the range before the binding end [rad]."""
TABLE_SIZE_M = ((-0.45, 0.6), (-0.6, 0.6))
"""The table top drawn under the arm: x and y extents in the base frame [m] (the recordings'
table edge is at x = 0.6 m, the demo's wall at x = -0.45 m)."""
TABLE_THICKNESS_M = 0.03
TABLE_RGB = (205, 190, 165)
FLOOR_BELOW_TABLE_M = 0.75
"""The floor under the table top [m] (the bundled recordings' scene: table at 0, floor at -0.75)."""


def _perpendicular(axis: np.ndarray) -> np.ndarray:
    """A unit vector at right angles to ``axis`` (the joint's zero direction for its arc)."""
    trial = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    side = np.cross(axis, trial)
    return side / np.linalg.norm(side)


def table_height_m(limitations) -> float:
    """The table's height [m] (a limitation with ``height_m`` named "table"), 0 without one."""
    for limitation in limitations:
        if hasattr(limitation, "height_m") and getattr(limitation, "name", "") == "table":
            return float(limitation.height_m)
    return 0.0


def reach_geometry(limitations) -> tuple[np.ndarray, float, float] | None:
    """``(shoulder (3,), inner [m], extended [m])`` of the reach limitation, or None."""
    for limitation in limitations:
        if all(hasattr(limitation, key) for key in ("shoulder", "inner_m", "outer_m")):
            return np.asarray(limitation.shoulder, dtype=float), float(limitation.inner_m), float(limitation.outer_m)
    return None


class LimitMarks:
    """Highlight nodes for the non-zone limits of one arm (see the module docstring)."""

    def __init__(self, server: viser.ViserServer, root: str, teleop, viser_urdf=None):
        self.server, self.root, self.teleop = server, root, teleop
        self.urdf = viser_urdf
        self.nodes: dict[str, object] = {}
        """Key -> scene node: ``"<joint> arc"``, ``"<joint> lower"``, ``"<joint> upper"``,
        ``"<joint> needle"``, ``"<joint> ring"``, ``"reach inner"``, ``"reach extended"``,
        ``"table"``, ``"table bound"``."""
        self.shown: tuple[str, ...] = ()
        z = table_height_m(getattr(teleop, "limitations", ()))
        (x0, x1), (y0, y1) = TABLE_SIZE_M
        centre = ((x0 + x1) / 2, (y0 + y1) / 2, z - TABLE_THICKNESS_M / 2)
        size = (x1 - x0, y1 - y0, TABLE_THICKNESS_M)
        self.nodes["table"] = server.scene.add_box(f"{root}/table", TABLE_RGB, dimensions=size, position=centre)
        self.nodes["table bound"] = server.scene.add_box(f"{root}/table_bound", draw.HIGHLIGHT, dimensions=size,
                                                         position=centre, visible=False)

    # ---- geometry made on first use -----------------------------------------------------------
    def _link_frames(self) -> dict[str, object]:
        frames = {}
        urdf = self.urdf
        try:
            for joint, frame in zip(urdf._joint_map_values, urdf._joint_frames, strict=True):
                frames.setdefault(joint.child, frame)
            frames.setdefault(urdf._urdf.base_link, urdf._visual_root_frame)
        except (AttributeError, TypeError, ValueError):  # another viser version: no joint marks
            return {}
        return frames

    def _joint_nodes(self, joint_name: str) -> bool:
        """Make the arc, its two ends, the needle and the ring of one joint; False if impossible."""
        if f"{joint_name} arc" in self.nodes:
            return True
        if self.urdf is None:
            return False
        joint = getattr(self.urdf, "_urdf", None) and self.urdf._urdf.joint_map.get(joint_name)
        frames = self._link_frames()
        if joint is None or joint.parent not in frames or joint.child not in frames or joint.axis is None:
            return False
        model = self.teleop.state.model
        if not model.existJointName(joint_name) or model.joints[model.getJointId(joint_name)].nq != 1:
            return False
        index = model.joints[model.getJointId(joint_name)].idx_q
        lower, upper = float(model.lowerPositionLimit[index]), float(model.upperPositionLimit[index])
        if not (np.isfinite(lower) and np.isfinite(upper) and upper - lower < 4 * np.pi):
            return False
        origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=float)
        axis_local = np.asarray(joint.axis, dtype=float) / np.linalg.norm(joint.axis)
        zero_local = _perpendicular(axis_local)
        centre, axis, zero = origin[:3, 3], origin[:3, :3] @ axis_local, origin[:3, :3] @ zero_local
        parent, child = frames[joint.parent].name, frames[joint.child].name
        add = self.server.scene.add_line_segments

        def arc(a: float, b: float, radius: float = ARC_RADIUS_M):
            return draw.polyline_segments(draw.arc_points(centre, axis, zero, a, b, radius, 32), closed=False)

        tag = joint_name.replace("/", "_")
        self.nodes[f"{joint_name} arc"] = add(f"{parent}/limit_{tag}_arc", arc(lower, upper), draw.HIGHLIGHT,
                                              thickness=0.008, visible=False)
        end = min(END_ARC_RAD, upper - lower)
        self.nodes[f"{joint_name} lower"] = add(f"{parent}/limit_{tag}_lower", arc(lower, lower + end), draw.HIGHLIGHT,
                                                thickness=0.016, visible=False)
        self.nodes[f"{joint_name} upper"] = add(f"{parent}/limit_{tag}_upper", arc(upper - end, upper), draw.HIGHLIGHT,
                                                thickness=0.016, visible=False)
        self.nodes[f"{joint_name} needle"] = add(
            f"{child}/limit_{tag}_needle", np.array([[np.zeros(3), zero_local * ARC_RADIUS_M * 1.15]]), draw.HIGHLIGHT,
            thickness=0.008, visible=False)
        ring = draw.polyline_segments(draw.arc_points(centre, axis, zero, 0.0, 2 * np.pi, RING_RADIUS_M, 40)[:-1])
        self.nodes[f"{joint_name} ring"] = add(f"{parent}/limit_{tag}_ring", ring, draw.HIGHLIGHT,
                                               thickness=0.012, visible=False)
        return True

    def _reach_node(self, side: str) -> bool:
        key = f"reach {side}"
        if key in self.nodes:
            return True
        geometry = reach_geometry(getattr(self.teleop, "limitations", ()))
        if geometry is None:
            return False
        shoulder, inner, extended = geometry
        radius = inner if side == "inner" else extended
        self.nodes[key] = self.server.scene.add_line_segments(
            f"{self.root}/reach_{side}", draw.sphere_wireframe(shoulder, radius), draw.HIGHLIGHT, thickness=0.002,
            visible=False)
        return True

    # ---- per frame --------------------------------------------------------------------------
    def keys_for(self, limit: Limit) -> tuple[str, ...]:
        """The node keys that draw ``limit`` (made now if needed); () when it has no drawing."""
        if limit.kind == JOINT_POSITION and limit.side in ("lower", "upper") and self._joint_nodes(limit.joint):
            return (f"{limit.joint} arc", f"{limit.joint} {limit.side}", f"{limit.joint} needle")
        if limit.kind in (JOINT_SPEED, JOINT_ACCELERATION) and self._joint_nodes(limit.joint):
            return (f"{limit.joint} ring",)
        if limit.kind == REACH and self._reach_node(limit.side):
            return (f"reach {limit.side}",)
        if limit.kind == TABLE:
            return ("table bound",)
        return ()

    def show(self, limits: list[Limit]) -> tuple[str, ...]:
        """Make visible exactly the nodes of ``limits``; returns their keys."""
        keys = tuple(dict.fromkeys(key for limit in limits for key in self.keys_for(limit)))
        if keys == self.shown:
            return keys
        for key, node in self.nodes.items():
            if key == "table":
                node.visible = "table bound" not in keys
            else:
                node.visible = key in keys
        self.shown = keys
        return keys

    def remove(self) -> None:
        for node in self.nodes.values():
            node.remove()
        self.nodes, self.shown = {}, ()
