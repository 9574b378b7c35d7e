"""The view: a scene's initial camera, a "Reset view" for every tab, and orbiting locked where
the view is part of the task (the planar scene seen from above, the trial).

viser has no switch to turn orbiting off. It does lock the camera while a left-button drag
draws a selection rectangle, and draws that rectangle only when the server listens for one:
``lock_orbit`` listens (and ignores what it hears), so a drag that misses the gizmo draws a
faint rectangle instead of tilting the top-down view into an oblique one. The wheel still
zooms and the right button still pans: both keep the view from above.
"""

from __future__ import annotations

import numpy as np
import viser


def _ignore(_event) -> None:
    """A selection rectangle means nothing here: the listener exists to lock the camera."""


def lock_orbit(server: viser.ViserServer) -> None:
    """Left-button drags off the gizmo no longer turn the camera, in every tab."""
    server.scene.remove_rect_select_callback(_ignore)  # at most one registration
    server.scene.on_rect_select()(_ignore)


def unlock_orbit(server: viser.ViserServer) -> None:
    server.scene.remove_rect_select_callback(_ignore)


def set_initial_view(server: viser.ViserServer, position_m, look_at_m) -> None:
    """The view new tabs open with (base frame, +z up)."""
    server.scene.set_up_direction("+z")
    server.initial_camera.position = tuple(float(c) for c in position_m)
    server.initial_camera.look_at = tuple(float(c) for c in look_at_m)


def reset_view(server: viser.ViserServer) -> int:
    """Every connected tab back to the initial view; returns how many tabs were reset (a tab
    that has not reported its camera yet still shows the initial view: it is skipped)."""
    position = np.asarray(server.initial_camera.position, dtype=float)
    look_at = np.asarray(server.initial_camera.look_at, dtype=float)
    count = 0
    for client in list(server.get_clients().values()):
        try:
            with client.atomic():
                client.camera.position = tuple(position)  # moves look_at along: set it after
                client.camera.look_at = tuple(look_at)
        except AssertionError:  # viser: no camera state from this tab yet
            continue
        count += 1
    return count
