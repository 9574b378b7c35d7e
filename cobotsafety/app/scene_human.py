"""Human capsules coloured by distance, and the minimum-distance segment with its value.

``HumanView`` makes its nodes once: the capsules are two batched meshes (a unit cylinder per
capsule body, scaled to its radius and length, and a unit sphere per end point), so a frame
sends only instance poses, scales and a colour, never a mesh. Slots beyond the capsules present
get scale 0. ``minimum_distance`` picks the closest robot-human capsule pair with
``cobotsafety.geometry.capsule_distance``: the one "min distance" the demo shows (status, label,
plot).
"""

from __future__ import annotations

import numpy as np
import trimesh
import viser

from cobotsafety.app import draw
from cobotsafety.geometry.capsule import capsule_distance
from cobotsafety.human.body import HumanCapsules

MAX_CAPSULES = 5
ROOT = "/human"
OPACITY = 0.85


def minimum_distance(robot_p0_m: np.ndarray, robot_p1_m: np.ndarray, robot_radius_m: np.ndarray,
                     human: HumanCapsules) -> tuple[float, np.ndarray, np.ndarray] | None:
    """``(distance_m, p_robot_m, p_human_m)`` of the closest pair, or None without a human.

    Robot capsules: shapes (r, 3), (r, 3), (r,). The points are on the capsule surfaces
    (axis closest points moved by the radii), shape (3,) each.
    """
    if not human.present or len(robot_radius_m) == 0:
        return None
    distance, a, b = capsule_distance(robot_p0_m[:, None, :], robot_p1_m[:, None, :], robot_radius_m[:, None],
                                      human.p0_b_m[None, :, :], human.p1_b_m[None, :, :], human.radius_m[None, :])
    i, j = np.unravel_index(int(np.argmin(distance)), distance.shape)
    gap = b[i, j] - a[i, j]
    length = float(np.linalg.norm(gap))
    unit = gap / length if length > 1e-12 else np.zeros(3)
    return float(distance[i, j]), a[i, j] + unit * robot_radius_m[i], b[i, j] - unit * human.radius_m[j]


def capsule_instances(p0_m: np.ndarray, p1_m: np.ndarray, radius_m: np.ndarray, slots: int = MAX_CAPSULES):
    """Instance arrays for ``slots`` capsules; rows beyond the given capsules have scale 0.

    Returns ``(body_positions (slots, 3), body_wxyzs (slots, 4), body_scales (slots, 3),
    end_positions (2 slots, 3), end_scales (2 slots,))``: a unit cylinder from z = 0 to 1 of
    radius 1 scaled by ``(r, r, length)`` and turned onto the axis, a unit sphere at each end
    scaled by ``r``. Float32, metres.
    """
    count = min(len(radius_m), slots)
    body_positions = np.zeros((slots, 3), np.float32)
    body_wxyzs = np.tile(np.array([1.0, 0.0, 0.0, 0.0], np.float32), (slots, 1))
    body_scales = np.zeros((slots, 3), np.float32)
    end_positions = np.zeros((2 * slots, 3), np.float32)
    end_scales = np.zeros(2 * slots, np.float32)
    for i in range(count):
        axis = np.asarray(p1_m[i], dtype=float) - np.asarray(p0_m[i], dtype=float)
        radius = float(radius_m[i])
        body_positions[i] = p0_m[i]
        body_wxyzs[i] = draw.wxyz_z_to(axis)
        body_scales[i] = (radius, radius, max(float(np.linalg.norm(axis)), 1e-6))
        end_positions[2 * i], end_positions[2 * i + 1] = p0_m[i], p1_m[i]
        end_scales[2 * i] = end_scales[2 * i + 1] = radius
    return body_positions, body_wxyzs, body_scales, end_positions, end_scales


def _unit_cylinder() -> trimesh.Trimesh:
    mesh = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=20)
    mesh.apply_translation([0.0, 0.0, 0.5])
    return mesh


class HumanView:
    """The human layer; ``visible = False`` hides it (the planar scene ignores the human)."""

    def __init__(self, server: viser.ViserServer):
        self.server = server
        cylinder, sphere = _unit_cylinder(), trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        bodies, wxyzs, scales, ends, end_scales = capsule_instances(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
        self.bodies = server.scene.add_batched_meshes_simple(
            f"{ROOT}/bodies", np.asarray(cylinder.vertices, np.float32), np.asarray(cylinder.faces, np.uint32),
            batched_wxyzs=wxyzs, batched_positions=bodies, batched_scales=scales, batched_colors=draw.GREY,
            opacity=OPACITY, lod="off", cast_shadow=False, receive_shadow=False)
        self.ends = server.scene.add_batched_meshes_simple(
            f"{ROOT}/ends", np.asarray(sphere.vertices, np.float32), np.asarray(sphere.faces, np.uint32),
            batched_wxyzs=np.tile(np.array([1.0, 0.0, 0.0, 0.0], np.float32), (len(ends), 1)),
            batched_positions=ends, batched_scales=end_scales, batched_colors=draw.GREY, opacity=OPACITY,
            lod="off", cast_shadow=False, receive_shadow=False)
        self.segment = server.scene.add_line_segments(f"{ROOT}/min_distance", np.zeros((1, 2, 3)), draw.RED,
                                                      thickness=0.006, visible=False)
        self.label = server.scene.add_label(f"{ROOT}/min_distance_label", "", visible=False)
        self.shown_capsules = 0
        """How many human capsules the last ``update`` drew (0 when hidden or absent)."""
        self._visible = True

    @property
    def visible(self) -> bool:
        return self._visible

    @visible.setter
    def visible(self, visible: bool) -> None:
        self._visible = bool(visible)
        for node in (self.bodies, self.ends):
            node.visible = self._visible
        if not self._visible:
            self.segment.visible = self.label.visible = False

    def update(self, human: HumanCapsules | None, closest: tuple[float, np.ndarray, np.ndarray] | None,
               refresh_text: bool = True) -> None:
        """Move the capsules to ``human`` and show ``closest`` (from ``minimum_distance``).

        ``refresh_text``: rewrite the label's value (the server does it in the frames that
        refresh the status line, so the scene and the status always show the same number).
        """
        present = self._visible and human is not None and human.present
        if present:
            bodies, wxyzs, scales, ends, end_scales = capsule_instances(human.p0_b_m, human.p1_b_m, human.radius_m)
            self.shown_capsules = min(len(human.radius_m), MAX_CAPSULES)
        else:
            bodies, wxyzs, scales, ends, end_scales = capsule_instances(np.zeros((0, 3)), np.zeros((0, 3)),
                                                                        np.zeros(0))
            self.shown_capsules = 0
        self.bodies.batched_positions, self.bodies.batched_wxyzs = bodies, wxyzs
        self.bodies.batched_scales = scales
        self.ends.batched_positions, self.ends.batched_scales = ends, end_scales
        colour = draw.distance_colour(None if closest is None else closest[0])
        for node, count in ((self.bodies, MAX_CAPSULES), (self.ends, 2 * MAX_CAPSULES)):
            node.batched_colors = np.tile(np.array(colour, np.uint8), (count, 1))
        if closest is None or not present:
            self.segment.visible = self.label.visible = False
            return
        distance_m, p_robot, p_human = closest
        self.segment.points = np.array([[p_robot, p_human]], dtype=np.float32)
        self.label.position = (p_robot + p_human) / 2.0
        if refresh_text or not self.label.visible:
            self.label.text = f"{distance_m * 1e3:.0f} mm"
        self.segment.visible = self.label.visible = True
