"""The planar scene of paper 1 seen from above: RR arm, limitations A-G, binding highlighted.

Nodes are made once (``PlanarView(...)``); ``update`` only moves them and recolours the
limitations the command slides on (``limit_words.in_play``: not the one a released arm rests
against). A joint limit is two drawings, its lower and its upper end, so only the end that
binds lights up. ``redraw_limitations`` rebuilds the limitation drawings after the zone editor
or the scene selector changed the scene. The view from above is the task: orbiting is locked
(``camera.lock_orbit``).
"""

from __future__ import annotations

import math

import numpy as np
import viser

from cobotsafety.app import draw
from cobotsafety.app.camera import lock_orbit, set_initial_view, unlock_orbit
from cobotsafety.app.control_loop import LoopSnapshot
from cobotsafety.app.lighting import light_scene
from cobotsafety.app.limit_words import RobotVocabulary, describe, in_play
from cobotsafety.planar.limitations import (
    CircleKeepIn,
    CircleKeepOut,
    JointLimit,
    LinkCircleZone,
    PlanarLimitation,
    PolygonZone,
    RectangleZone,
)
from cobotsafety.planar.planar_teleop import PlanarTeleop

LINK_RADIUS_M = 0.012
ROOT = "/planar"

ARM_COLOUR = (90, 140, 230)
ZONE_COLOUR = draw.ZONE
PLANAR_WORDS = RobotVocabulary(planar=True)
CAMERA_POSITION_M = (0.15, -0.01, 1.0)
CAMERA_LOOK_AT_M = (0.15, 0.0, 0.0)
"""Top-down, close enough that the reach circle fills most of the canvas height, shifted so the
workspace sits left of the control panel."""
LIMIT_COLOUR = (110, 110, 120)


CAPSULE_RADIUS_M = 2.5 * LINK_RADIUS_M


def planar_capsules(p_base_elbow_m: np.ndarray, p_base_ee_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The two links as capsules ``(p0 (2, 3), p1 (2, 3), radius (2,))`` [m], drawn translucent."""
    p0 = np.array([np.zeros(3), p_base_elbow_m], dtype=float)
    p1 = np.array([p_base_elbow_m, p_base_ee_m], dtype=float)
    return p0, p1, np.full(2, CAPSULE_RADIUS_M)


def limitation_parts(limitation: PlanarLimitation, teleop: PlanarTeleop) -> list[tuple[str, np.ndarray]]:
    """``[(key, segments (m, 2, 3))]`` drawing ``limitation``: a joint limit's two ends apart
    (keys ``"<name> lower"``, ``"<name> upper"``, as its binding rows are named), any other
    drawable limitation whole (key: its name); [] when it cannot be drawn."""
    if isinstance(limitation, JointLimit) and limitation.joint in (1, 2):
        arm = teleop.scene.arm
        parts = []
        for side, angle in (("lower", limitation.lower_rad), ("upper", limitation.upper_rad)):
            if limitation.joint == 2:
                l1, l2 = arm.link_1_m, arm.link_2_m
                radius = math.sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * math.cos(angle))
                segments = draw.polyline_segments(draw.circle_points((0.0, 0.0), radius))
            else:
                reach = arm.link_1_m + arm.link_2_m
                segments = np.array([[[0.0, 0.0, 0.0], [reach * math.cos(angle), reach * math.sin(angle), 0.0]]])
            parts.append((f"{limitation.name} {side}", segments))
        return parts
    segments = limitation_outline(limitation, teleop)
    return [] if segments is None else [(limitation.name, segments)]


def limitation_outline(limitation: PlanarLimitation, teleop: PlanarTeleop) -> np.ndarray | None:
    """Shape (m, 2, 3) segments drawing ``limitation`` in the plane, or None (not drawable)."""
    arm = teleop.scene.arm
    if isinstance(limitation, (CircleKeepOut, CircleKeepIn)):
        return draw.polyline_segments(draw.circle_points(limitation.center_m, limitation.radius_m))
    if isinstance(limitation, LinkCircleZone):
        return draw.polyline_segments(draw.circle_points(limitation.center_m, limitation.radius_m))
    if isinstance(limitation, RectangleZone):
        return draw.polyline_segments(np.array(limitation.vertices()))
    if isinstance(limitation, PolygonZone):
        return draw.polyline_segments(np.array(limitation.vertices_m))
    if isinstance(limitation, JointLimit) and limitation.joint == 2:
        l1, l2 = arm.link_1_m, arm.link_2_m
        parts = []
        for theta_2 in (limitation.lower_rad, limitation.upper_rad):
            radius = math.sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * math.cos(theta_2))
            parts.append(draw.polyline_segments(draw.circle_points((0.0, 0.0), radius)))
        return np.concatenate(parts)
    if isinstance(limitation, JointLimit) and limitation.joint == 1:
        reach = arm.link_1_m + arm.link_2_m
        rays = [[[0.0, 0.0, 0.0], [reach * math.cos(a), reach * math.sin(a), 0.0]]
                for a in (limitation.lower_rad, limitation.upper_rad)]
        return np.array(rays)
    return None


def label_text(name: str) -> str:
    """The short label of a limitation: its letter ("B joint 2" -> "B")."""
    return name.split(" ")[0]


def label_anchor(limitation: PlanarLimitation, segments: np.ndarray, rank: int) -> np.ndarray:
    """Where a limitation's label sits [m], shape (3,).

    Zones: their centroid. Circles and rays: a point on the outline at a fraction that differs
    per limitation (``rank``), so labels of concentric circles do not land on one ray.
    """
    if is_zone(limitation):
        return segments[:, 0, :].mean(axis=0)
    fraction = (0.05 + 0.13 * rank) % 1.0
    if isinstance(limitation, JointLimit) and limitation.joint == 1:
        return segments[rank % len(segments), 1, :] * 0.85
    return segments[int(fraction * len(segments)) % len(segments), 0, :]


def is_zone(limitation: PlanarLimitation) -> bool:
    return isinstance(limitation, (RectangleZone, PolygonZone, LinkCircleZone)) or (
        isinstance(limitation, CircleKeepOut) and limitation.center_m != (0.0, 0.0))


class PlanarView:
    """Scene nodes of the planar arm; ``update`` moves them from a loop snapshot."""

    def __init__(self, server: viser.ViserServer, teleop: PlanarTeleop):
        self.server = server
        self.teleop = teleop
        scene = server.scene
        set_initial_view(server, CAMERA_POSITION_M, CAMERA_LOOK_AT_M)
        lock_orbit(server)
        light_scene(server)
        self.grid = scene.add_grid(f"{ROOT}/grid", width=1.4, height=1.4, cell_size=0.1, section_size=0.5,
                                   position=(0.0, 0.0, -0.002))
        arm = teleop.scene.arm
        self.base = scene.add_icosphere(f"{ROOT}/base", radius=0.03, color=(60, 60, 70))
        self.links = [
            scene.add_mesh_simple(f"{ROOT}/link_{i}", *draw.capsule_mesh(length, LINK_RADIUS_M),
                                  color=(70, 70, 80))
            for i, length in ((1, arm.link_1_m), (2, arm.link_2_m))
        ]
        self.capsules = [
            scene.add_mesh_simple(f"{ROOT}/capsule_{i}", *draw.capsule_mesh(length, CAPSULE_RADIUS_M),
                                  color=ARM_COLOUR, opacity=0.35)
            for i, length in ((1, arm.link_1_m), (2, arm.link_2_m))
        ]
        self.ee = scene.add_icosphere(f"{ROOT}/ee", radius=0.015, color=(30, 30, 200))
        self._limit_nodes: dict[str, tuple[object, object]] = {}
        """Drawing key (``limitation_parts``) -> (normal node, highlight node)."""
        self._drawn: list[str] = []
        """Names of the limitations drawn, in the scene's order."""
        self._label_nodes: list[object] = []
        self._highlighted: tuple[str, ...] = ()
        self.redraw_limitations()

    # -- limitations ---------------------------------------------------------------------
    def redraw_limitations(self) -> None:
        """(Re)build the drawings of the current scene's limitations.

        Each drawable limitation gets two line nodes made once, its normal colour and the
        highlight (thicker, magenta), and ``highlight`` only toggles their ``visible``: a
        visibility change reaches every open tab, whereas viser does not re-colour line
        segments in a tab that already drew them. Labels are the limitation letters, spread
        along each outline so concentric circles do not stack them; ``legend()`` names them.
        """
        for normal, bright in self._limit_nodes.values():
            normal.remove()
            bright.remove()
        for label in self._label_nodes:
            label.remove()
        self._limit_nodes, self._label_nodes, self._highlighted, self._drawn = {}, [], (), []
        drawable = [(i, lim, limitation_parts(lim, self.teleop)) for i, lim in enumerate(self.teleop.scene.limitations)]
        drawable = [(i, lim, parts) for i, lim, parts in drawable if parts]
        for rank, (index, limitation, parts) in enumerate(drawable):
            colour = ZONE_COLOUR if is_zone(limitation) else LIMIT_COLOUR
            for part, (key, part_segments) in enumerate(parts):
                node = f"{ROOT}/limits/{index}" + (f"_{part}" if len(parts) > 1 else "")
                normal = self.server.scene.add_line_segments(node, part_segments, colour, thickness=0.004)
                bright = self.server.scene.add_line_segments(f"{node}_active", part_segments, draw.HIGHLIGHT,
                                                             thickness=0.009, visible=False)
                self._limit_nodes[key] = (normal, bright)
            self._drawn.append(limitation.name)
            segments = np.concatenate([part_segments for _, part_segments in parts])
            self._label_nodes.append(self.server.scene.add_label(
                f"{ROOT}/labels/{index}", label_text(limitation.name), position=label_anchor(limitation, segments, rank),
                font_screen_scale=0.8))

    def legend(self) -> str:
        """Markdown: one line per limitation, its letter and its name."""
        names = [limitation.name for limitation in self.teleop.scene.limitations if limitation.name in self._drawn]
        return "  \n".join(f"**{label_text(name)}** {name.partition(' ')[2]}" for name in names)

    def set_teleop(self, teleop: PlanarTeleop) -> None:
        self.teleop = teleop
        self.redraw_limitations()

    def highlight(self, binding: tuple[str, ...]) -> None:
        """Show the highlight of the drawings ``binding``'s rows name (``limit_words``: a joint
        limit's binding end, a link zone whatever the link, any other limitation whole)."""
        if binding == self._highlighted:
            return
        keys = set()
        for row in binding:
            limit = describe(row, PLANAR_WORDS)
            keys.add(f"{limit.target} {limit.side}" if limit.side else limit.target)
        for key, (normal, bright) in self._limit_nodes.items():
            active = key in keys
            bright.visible = active
            normal.visible = not active
        self._highlighted = binding

    def active_limitations(self) -> tuple[str, ...]:
        """Drawing keys highlighted now (a limitation's name, or "<name> lower/upper")."""
        return tuple(name for name, (_, bright) in self._limit_nodes.items() if bright.visible)

    # -- per frame -----------------------------------------------------------------------
    def end_effector_m(self) -> np.ndarray:
        return np.asarray(self.teleop.p_base_ee_m, dtype=float)

    def update(self, snapshot: LoopSnapshot, elbow_m: np.ndarray) -> None:
        """Move links and end-effector to the snapshot's pose; ``elbow_m`` shape (3,) [m]."""
        ee = snapshot.p_base_ee_m
        for i, (start, end) in enumerate(((np.zeros(3), elbow_m), (elbow_m, ee))):
            wxyz = draw.wxyz_z_to(end - start)
            for node in (self.links[i], self.capsules[i]):
                node.position = start
                node.wxyz = wxyz
        self.ee.position = ee
        self.highlight(in_play(snapshot.report))

    def remove(self) -> None:
        unlock_orbit(self.server)
        for normal, bright in self._limit_nodes.values():
            normal.remove()
            bright.remove()
        for node in [*self._label_nodes, *self.links, *self.capsules, self.ee, self.base, self.grid]:
            node.remove()

