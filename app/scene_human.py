"""Human capsules coloured by distance, and the minimum-distance segment with its value.

``HumanView`` keeps one capsule node per slot (at most ``MAX_CAPSULES``) and only moves and
recolours them; a node is rebuilt only when its capsule's length changes (5- <-> 1-capsule
model). ``minimum_distance`` picks the closest robot-human capsule pair with
``cobotsafety.geometry.capsule_distance``; it is a display quantity, not a safety decision.
"""

from __future__ import annotations

import numpy as np
import viser

from cobotsafety.app import draw
from cobotsafety.geometry.capsule import capsule_distance
from cobotsafety.human.body import HumanCapsules

MAX_CAPSULES = 5
ROOT = "/human"


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


class HumanView:
    def __init__(self, server: viser.ViserServer):
        self.server = server
        self.nodes: list = [None] * MAX_CAPSULES
        self.lengths = [-1.0] * MAX_CAPSULES
        self.radii = [-1.0] * MAX_CAPSULES
        self.segment = server.scene.add_line_segments(f"{ROOT}/min_distance", np.zeros((1, 2, 3)), draw.RED,
                                                      thickness=0.006, visible=False)
        self.label = server.scene.add_label(f"{ROOT}/min_distance_label", "", visible=False)

    def _node(self, slot: int, length_m: float, radius_m: float):
        if (abs(length_m - self.lengths[slot]) > 1e-3 or abs(radius_m - self.radii[slot]) > 1e-3
                or self.nodes[slot] is None):
            if self.nodes[slot] is not None:
                self.nodes[slot].remove()
            mesh = draw.capsule_mesh(length_m, radius_m)
            self.nodes[slot] = self.server.scene.add_mesh_simple(
                f"{ROOT}/capsule_{slot}", np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32),
                color=draw.GREEN, opacity=0.6)
            self.lengths[slot], self.radii[slot] = length_m, radius_m
        return self.nodes[slot]

    def update(self, human: HumanCapsules | None, closest: tuple[float, np.ndarray, np.ndarray] | None) -> None:
        count = 0 if human is None else min(len(human.names), MAX_CAPSULES)
        colour = draw.distance_colour(None if closest is None else closest[0])
        for slot in range(count):
            axis = human.p1_b_m[slot] - human.p0_b_m[slot]
            node = self._node(slot, float(np.linalg.norm(axis)), float(human.radius_m[slot]))
            node.position = human.p0_b_m[slot]
            node.wxyz = draw.wxyz_z_to(axis)
            node.color = colour
            node.visible = True
        for slot in range(count, MAX_CAPSULES):
            if self.nodes[slot] is not None:
                self.nodes[slot].visible = False
        if closest is None:
            self.segment.visible = self.label.visible = False
            return
        distance_m, p_robot, p_human = closest
        self.segment.points = np.array([[p_robot, p_human]], dtype=np.float32)
        self.segment.colors = np.tile(np.array(colour, dtype=np.uint8), (1, 2, 1))
        self.label.position = (p_robot + p_human) / 2.0
        self.label.text = f"{distance_m * 1e3:.0f} mm"
        self.segment.visible = self.label.visible = True
