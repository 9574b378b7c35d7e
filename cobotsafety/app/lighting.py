"""The scene's light: viser's default lights without shadows, and no environment map.

Under software WebGL (a laptop without a usable GPU, a headless browser, a loaded machine) the
shadow pass renders the scene a second time every frame and the default environment map (an
HDR image prefiltered on the client) costs its first frame: a page with a grid and two shapes
drew its first frame in 4.3-5.2 s instead of 5.8-6.1 s at load 14.5 (``cobotsafety bench app``'s
canvas probe, 2 runs each). The scenes are lines, capsules and a robot's meshes, readable with
plain lights.
"""

from __future__ import annotations

import viser

AMBIENT_INTENSITY = 2.0
"""A hemisphere light in place of the environment map's light (the URDF meshes read dark without)."""


def light_scene(server: viser.ViserServer) -> None:
    """Plain lights, no shadows, no environment map, for every tab."""
    server.scene.configure_environment_map(hdri=None)
    server.scene.configure_default_lights(True, cast_shadow=False)
    server.scene.add_light_hemisphere("/light/sky", sky_color=(255, 255, 255), ground_color=(160, 155, 150),
                                      intensity=AMBIENT_INTENSITY)
