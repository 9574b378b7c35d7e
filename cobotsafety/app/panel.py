"""The control panel: every GUI handle made once by ``make_panel`` and kept in ``Panel``.

Callbacks are wired by ``cobotsafety.app.demo_app``; this module only lays the widgets out.
"""

from __future__ import annotations

from dataclasses import dataclass

import viser

from cobotsafety.app.gizmo import GizmoSettings
from cobotsafety.app.status import status_html
from cobotsafety.teleoperated import METHODS

PLANAR_SCENES = ("all limitations A-G", "Fig. 9 a (blocked)", "Fig. 9 b (gap)")
HINT = ("**Drag the arrow handle** at the end-effector: its offset from the end-effector is the "
        "velocity command. The filter slides the motion along the limits it meets (highlighted).")


@dataclass(frozen=True)
class Panel:
    hint: viser.GuiMarkdownHandle
    status: viser.GuiHtmlHandle
    mode: viser.GuiDropdownHandle
    ssm: viser.GuiCheckboxHandle
    reset: viser.GuiButtonHandle
    reset_view: viser.GuiButtonHandle
    robot: viser.GuiDropdownHandle
    planar_scene: viser.GuiDropdownHandle
    fig9: viser.GuiButtonHandle
    dead_band_m: viser.GuiSliderHandle
    gain_per_s: viser.GuiSliderHandle
    max_speed_m_s: viser.GuiSliderHandle
    jog: viser.GuiButtonGroupHandle
    jog_speed_m_s: viser.GuiSliderHandle
    replay_folder: viser.GuiFolderHandle
    recording: viser.GuiDropdownHandle
    upload: viser.GuiUploadButtonHandle
    play: viser.GuiButtonHandle
    seek_s: viser.GuiSliderHandle
    speed: viser.GuiSliderHandle
    loop: viser.GuiCheckboxHandle
    replay_message: viser.GuiMarkdownHandle
    legend: viser.GuiMarkdownHandle


def make_panel(server: viser.ViserServer, robots: tuple[str, ...], robot: str, dim: int,
               recordings: tuple[str, ...], gizmo: GizmoSettings, ssm_available: bool) -> Panel:
    """Lay out the panel; ``robots``/``recordings`` are the dropdown options.

    The status is a block of fixed height (``status.status_html``): nothing below it moves
    while its text changes. The Replay folder shows only where a person is modelled (3D).
    """
    gui = server.gui
    hint = gui.add_markdown(HINT)
    status = gui.add_html(status_html(("starting...",)))
    mode = gui.add_dropdown("Mode", METHODS, initial_value="anticipative",
                            hint="anticipative: slide along limits; stop: halt at a limit; reactive: repel; off")
    ssm = gui.add_checkbox("SSM", False, disabled=not ssm_available,
                           hint="ISO/TS 15066 speed and separation monitoring (needs the human layer)")
    reset = gui.add_button("Reset", icon=viser.Icon.HOME, hint="back to the home pose")
    reset_view = gui.add_button("Reset view", icon=viser.Icon.CAMERA, hint="every tab back to the initial view")
    with gui.add_folder("Robot and scene"):
        robot_dropdown = gui.add_dropdown("Robot", robots, initial_value=robot)
        planar_scene = gui.add_dropdown("Planar scene", PLANAR_SCENES, initial_value=PLANAR_SCENES[0],
                                        disabled=dim != 2)
        fig9 = gui.add_button("Fig. 9 scenario", disabled=dim != 2,
                              hint="paper 1, Fig. 9 b: pull the end-effector to the target through the gap")
        legend = gui.add_markdown("")
    with gui.add_folder("Teleoperation", expand_by_default=False):
        dead_band = gui.add_slider("Dead band [m]", 0.0, 0.05, 0.001, gizmo.dead_band_m)
        gain = gui.add_slider("Gain [1/s]", 0.1, 10.0, 0.1, gizmo.gain_per_s)
        max_speed = gui.add_slider("Max speed [m/s]", 0.01, 0.5, 0.01, gizmo.max_speed_m_s)
        axes = ("+x", "-x", "+y", "-y") + (("+z", "-z") if dim == 3 else ())
        jog = gui.add_button_group("Jog", axes)
        jog_speed = gui.add_slider("Jog speed [m/s]", 0.01, 0.25, 0.01, 0.05)
    replay_folder = gui.add_folder("Replay", expand_by_default=False, visible=dim == 3)
    with replay_folder:
        recording = gui.add_dropdown("Recording", recordings or ("(none)",), initial_value=(recordings or ("(none)",))[0])
        upload = gui.add_upload_button("Load recording or ROS bag", hint=".jsonl.gz recording or a ROS bag")
        play = gui.add_button("Play", icon=viser.Icon.PLAYER_PLAY, hint="the replay starts paused")
        seek = gui.add_slider("Time [s]", 0.0, 1.0, 0.01, 0.0)
        speed = gui.add_slider("Speed", 0.1, 4.0, 0.1, 1.0)
        loop = gui.add_checkbox("Loop", True)
        replay_message = gui.add_markdown("")
    return Panel(hint, status, mode, ssm, reset, reset_view, robot_dropdown, planar_scene, fig9, dead_band, gain,
                 max_speed, jog, jog_speed, replay_folder, recording, upload, play, seek, speed, loop, replay_message,
                 legend)


def play_button_look(playing: bool) -> tuple[str, viser.Icon]:
    """Label and icon of the replay button: it shows what a click does."""
    return ("Pause", viser.Icon.PLAYER_PAUSE) if playing else ("Play", viser.Icon.PLAYER_PLAY)
