"""Human capsules coloured by distance, and the minimum-distance segment between the witness points.

``HumanView`` makes its nodes once: the capsules are two batched meshes (a unit tube per
capsule body, scaled to its radius and length, and a unit sphere per end point), so a frame
sends only instance poses, scales and a colour, never a mesh. Slots beyond the capsules present
get scale 0. The human is drawn opaque: translucent tubes and spheres overlapping at every
joint drew dark speckles (unsorted transparency).

The distance's value is written once, in the status (a label in the scene is drawn by the WebGL
canvas, which on a slow client lags the panel by seconds: two numbers disagreed on one
screen). The scene shows where it is: the red segment between the two witness points.
``minimum_distance`` is the display's own computation of that pair, used only while the
controller's report does not carry it (``StepReport.p_robot_closest_m``).
"""

from __future__ import annotations

import numpy as np
import viser

from cobotsafety.app import draw
from cobotsafety.human.body import HumanCapsules

MAX_CAPSULES = 8
"""The wearer's five and three other people (``HumanTracker.others_at``)."""
ROOT = "/human"
RADIUS_STEP_M = 0.002
"""Radii are drawn to this step [m] (a stale sensor grows them a little every frame)."""
COLOUR_STEP_M = 0.02
"""The human's colour follows the distance in steps of this size [m] (not re-sent every frame)."""


def minimum_distance(robot_p0_m: np.ndarray, robot_p1_m: np.ndarray, robot_radius_m: np.ndarray,
                     human: HumanCapsules) -> tuple[float, np.ndarray, np.ndarray] | None:
    """``(distance_m, p_robot_m, p_human_m)`` of the closest pair, or None without a human.

    Robot capsules: shapes (r, 3), (r, 3), (r,). The points are on the capsule surfaces
    (axis closest points moved by the radii), shape (3,) each.
    """
    if not human.present or len(robot_radius_m) == 0:
        return None
    from cobotsafety.geometry.capsule import capsule_distance  # noqa: PLC0415 - numba: not on the planar path

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
        radius = round(float(radius_m[i]) / RADIUS_STEP_M) * RADIUS_STEP_M  # grows with sensor age: not every frame
        body_positions[i] = p0_m[i]
        body_wxyzs[i] = draw.wxyz_z_to(axis)
        body_scales[i] = (radius, radius, round(max(float(np.linalg.norm(axis)), 1e-6), 4))
        end_positions[2 * i], end_positions[2 * i + 1] = p0_m[i], p1_m[i]
        end_scales[2 * i] = end_scales[2 * i + 1] = radius
    return body_positions, body_wxyzs, body_scales, end_positions, end_scales


class HumanView:
    """The human layer; ``visible = False`` hides it (the planar scene ignores the human)."""

    def __init__(self, server: viser.ViserServer):
        self.server = server
        tube, sphere = draw.tube_mesh(), draw.capsule_mesh(0.0, 1.0, segments=16, rings=5)
        bodies, wxyzs, scales, ends, end_scales = capsule_instances(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
        self.bodies = server.scene.add_batched_meshes_simple(
            f"{ROOT}/bodies", *tube, batched_wxyzs=wxyzs, batched_positions=bodies, batched_scales=scales,
            batched_colors=draw.GREY, lod="off", cast_shadow=False, receive_shadow=False)
        self.ends = server.scene.add_batched_meshes_simple(
            f"{ROOT}/ends", *sphere, batched_wxyzs=np.tile(np.array([1.0, 0.0, 0.0, 0.0], np.float32), (len(ends), 1)),
            batched_positions=ends, batched_scales=end_scales, batched_colors=draw.GREY,
            lod="off", cast_shadow=False, receive_shadow=False)
        self.segment = server.scene.add_line_segments(f"{ROOT}/min_distance", np.zeros((1, 2, 3)), draw.RED,
                                                      thickness=0.008, visible=False)
        self.shown_capsules = 0
        """How many human capsules the last ``update`` drew (0 when hidden or absent)."""
        self._sent: dict[tuple[int, str], np.ndarray] = {}
        """(node id, property) -> the value last sent."""
        self._segment_points: np.ndarray | None = None
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
            self.segment.visible = False

    def update(self, human: HumanCapsules | None, closest: tuple[float, np.ndarray, np.ndarray] | None) -> int:
        """Move the capsules to ``human`` and draw ``closest``: ``(distance [m], robot witness
        point (3,), human witness point (3,))``, base frame, or None.

        Sends only what changed since the last call (a paused replay, an unchanged colour or
        segment send nothing: a slow client fell seconds behind a stream of repeats); returns
        the number of properties sent."""
        present = self._visible and human is not None and human.present
        if present:
            arrays = capsule_instances(human.p0_b_m, human.p1_b_m, human.radius_m)
            self.shown_capsules = min(len(human.radius_m), MAX_CAPSULES)
        else:
            arrays = capsule_instances(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
            self.shown_capsules = 0
        distance = None if closest is None else round(closest[0] / COLOUR_STEP_M) * COLOUR_STEP_M
        colour = np.array(draw.distance_colour(distance), np.uint8)
        bodies, wxyzs, scales, ends, end_scales = arrays
        wanted = (
            (self.bodies, "batched_positions", bodies), (self.bodies, "batched_wxyzs", wxyzs),
            (self.bodies, "batched_scales", scales), (self.ends, "batched_positions", ends),
            (self.ends, "batched_scales", end_scales),
            (self.bodies, "batched_colors", np.tile(colour, (MAX_CAPSULES, 1))),
            (self.ends, "batched_colors", np.tile(colour, (2 * MAX_CAPSULES, 1))),
        )
        sent = 0
        for node, name, value in wanted:
            key = (id(node), name)
            if key not in self._sent or not np.array_equal(self._sent[key], value):
                setattr(node, name, value)
                self._sent[key] = value
                sent += 1
        if closest is None or not present:
            if self.segment.visible:
                self.segment.visible = False
                sent += 1
            return sent
        _, p_robot, p_human = closest
        points = np.array([[p_robot, p_human]], dtype=np.float32)
        if self._segment_points is None or not np.array_equal(points, self._segment_points):
            self.segment.points = points
            self._segment_points = points
            sent += 1
        if not self.segment.visible:
            self.segment.visible = True
            sent += 1
        return sent
