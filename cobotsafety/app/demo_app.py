"""``DemoApp``: the viser server, one shared robot for every browser tab, and the render loop.

viser broadcasts ``server.scene``/``server.gui`` to every client, so all tabs see the same robot;
a gizmo drag from any tab drives it. The control loop (``ControlLoop``, 1 kHz by default, 500 Hz
an option) and the render loop (``render_hz``) are separate threads; a client that disconnects
mid-drag releases the gizmo.

What a frame sends is bounded: scene nodes are made once and a frame only sets poses,
visibility and colours (no mesh is re-sent). At ~5 Hz one atomic update carries the status, the
minimum-distance segment and the distance chart's new sample, all read from the same report;
the speed and rate charts follow at ~1.7 Hz. The replay starts paused so a visitor first sees the
robot at home, waiting for a drag; the default recording is paper 2's experiment 1 (a co-worker
walks in and reaches near the arm), the reach-over stress case is listed as such.

Start-up: the server answers before the recording is read. The bundled recording (a few
seconds of parsing and of the sensor pipeline) is loaded in the background once the first tab
has had time to draw, or at once when Play needs it; the planar scene, which has no person,
does not wait for it at all.

Access (``cobotsafety.app.access``): no tab can publish the server (viser's share tunnel is
refused and its button hidden); every value a tab sends is checked against its control's
range; bound to loopback every tab may drive the robot, bound beyond it a tab must first
enter the token printed at start (``DemoApp.token``), and sees but changes nothing until
then. Uploads are received by ``cobotsafety.app.uploads`` (size limit, odd names refused,
nothing left on disk, no "uploaded" notice for a refused file).
"""

from __future__ import annotations

import gc
import html
import logging
import math
import shutil
import sys
import tempfile
import threading
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import viser

from cobotsafety.app import draw
from cobotsafety.app.access import (ServerGuard, TokenGate, Verdict, check_bindable, hide_share_button, is_loopback,
                                    reachable_host)
from cobotsafety.app import jog as jog_module
from cobotsafety.app.camera import reset_view
from cobotsafety.app.control_loop import ControlLoop, LoopSettings
from cobotsafety.app.gizmo import GizmoSettings, GizmoSettingsError, add_gizmo
from cobotsafety.app.limit_words import vocabulary_of
from cobotsafety.app.panel import PLANAR_SCENES, make_panel, play_button_look
from cobotsafety.app.log_filter import RepeatedWarningFilter
from cobotsafety.app.plots import PlotHistory, Plots
from cobotsafety.app.replay_control import ReplayControl, load_replay, refusal_sentence, seek_maximum_s, without_server_paths
from cobotsafety.app.scene_human import HumanView
from cobotsafety.app.scenes import PLANAR, make_scene
from cobotsafety.app.uploads import UploadReceiver, check_upload_name
from cobotsafety.app.status import StatusFacts, status_html, status_lines
from cobotsafety.app.zones_editor import ZoneEditor
from cobotsafety.app.tick_schedule import MAX_RATE_HZ, MIN_RATE_HZ
from cobotsafety.errors import CobotSafetyError, RecordingError, UnknownRobotError
from cobotsafety.human.recording import bundled_recording

logger = logging.getLogger(__name__)
CONTROLLER_LOG = logging.getLogger("cobotsafety.arm.controller")
LOG_FILTER = RepeatedWarningFilter()
"""While a demo runs, the controller's repeated warnings reach its terminal once per interval."""


@dataclass(frozen=True)
class DemoConfig:
    scene: str = "planar"
    """``planar`` (paper 1's RR arm) or ``arm`` (a pinocchio arm)."""
    robot: str | None = None
    """Arm name for ``scene="arm"``; None = the arm package's default (panda)."""
    replay: Path | None = None
    """Human recording (.jsonl.gz) or ROS bag, read at start-up; None = the bundled recordings,
    ``DEFAULT_RECORDING`` first, read in the background."""
    host: str = "127.0.0.1"
    """Interface to bind; beyond loopback a tab needs ``token`` to change anything."""
    port: int = 8080
    """0-65535 (0: the OS picks a free port)."""
    rate_hz: float = 1000.0
    """Control rate [Hz], ``MIN_RATE_HZ``-``MAX_RATE_HZ``."""
    render_hz: float = 30.0
    token: str | None = None
    """The token a tab enters to change the demo when bound beyond loopback (None: a new
    random one); unused on loopback."""

    def check(self) -> None:
        """Raise ``CobotSafetyError`` naming the first field out of range."""
        if self.scene not in ("planar", "arm"):
            raise CobotSafetyError(f"--scene must be 'planar' or 'arm', got {self.scene!r}")
        if not (isinstance(self.port, int) and 0 <= self.port <= 65535):
            raise CobotSafetyError(f"port {self.port!r} is not a TCP port (0-65535)")
        if not (math.isfinite(self.rate_hz) and MIN_RATE_HZ <= self.rate_hz <= MAX_RATE_HZ):
            raise CobotSafetyError(f"control rate {self.rate_hz!r} Hz is outside {MIN_RATE_HZ:.0f}-{MAX_RATE_HZ:.0f} Hz")
        if not (math.isfinite(self.render_hz) and 1.0 <= self.render_hz <= 120.0):
            raise CobotSafetyError(f"render rate {self.render_hz!r} Hz is outside 1-120 Hz")


MAX_KEPT_UPLOADS = 8
"""Uploaded recordings kept (in memory) in the Recording list; older ones are dropped."""
GIL_SWITCH_INTERVAL_S = 0.0005
"""Python's thread switch interval while the demo runs [s] (default 0.005)."""
CONTROL_FIFO_PRIORITY = 10
"""``SCHED_FIFO`` priority asked for the control thread (low among real-time threads; refused
without the permission, then the loop runs under the normal policy)."""


def settle_heap() -> None:
    """Collect the garbage once, then hide every object alive now from the cyclic collector.

    The demo holds ~200,000 long-lived objects (viser, the URDF meshes, the robot models); a
    full collection walks all of them, ~90 ms with the GIL held, and the control loop stood
    still that long every few seconds. Frozen (``gc.freeze``), they are skipped; objects made
    later are collected as usual. Called at start and after each scene switch (the previous
    scene is collected first, so a frozen cycle does not outlive it).
    """
    gc.unfreeze()
    gc.collect()
    gc.freeze()


BUNDLED_RECORDINGS = (
    ("exp1", "exp1 · paper 2, experiment 1: walks in and reaches"),
    ("exp2", "exp2 · paper 2, experiment 2: walks past"),
    ("reach-over", "reach-over · stress case: reaches over the table"),
)
"""The bundled recordings in the Replay list: (asset name, what the list says)."""
DEFAULT_RECORDING = "exp1"
"""The recording a first Play shows: a co-worker walks in, the arm gives way and comes back."""
PRELOAD_AFTER_CONNECT_S = 3.0
"""The bundled recording is read this long after the first tab connected [s] (its first frame
first), or ``PRELOAD_AT_THE_LATEST_S`` after start-up without a tab."""
PRELOAD_AT_THE_LATEST_S = 20.0
STATUS_EVERY_FRAMES = 6
"""The status, the distance segment and the distance chart: every 6th render frame (~5 Hz)."""
CHARTS_EVERY_STATUS = 3
"""The speed and rate charts: every 3rd status refresh (~1.7 Hz)."""

FIG9_MARKER_RADIUS_M = 0.05
"""Radius of the ring marking the Fig. 9 target [m] (wider than the end-effector drawn on it)."""
FIG9_MARKER_RGB = (40, 170, 60)
FIG9_ARRIVED_M = 0.005
"""A scripted pull ends when the end-effector is this close to its target [m]."""


def supported_robots() -> tuple[str, ...]:
    """``planar`` plus the arm names of ``cobotsafety.arm`` when its ``ArmController`` can be loaded.

    Looked up without importing it (that would load numba and pinocchio, seconds of the planar
    demo's start-up): the modules are found, their names read from ``arm.robots``.
    """
    from importlib.util import find_spec  # noqa: PLC0415

    try:
        available = all(find_spec(name) is not None for name in ("pinocchio", "numba", "cobotsafety.arm.controller"))
        from cobotsafety.arm.robots import ROBOTS  # noqa: PLC0415 - numpy only
    except ImportError:
        return (PLANAR,)
    return (PLANAR, *(name for name in ROBOTS if name != PLANAR)) if available else (PLANAR,)


class DemoApp:
    """The running demo. ``start()`` then ``url``; ``stop()`` shuts everything down."""

    def __init__(self, config: DemoConfig = DemoConfig(), announce: Callable[[str], None] | None = None):
        """``announce(url)`` is called as soon as the server listens, before the robot and its
        scene are built: a tab opened then loads the page while the server builds the rest
        (the scene streams in as it is made), instead of after it."""
        if config.scene not in ("planar", "arm"):
            raise CobotSafetyError(f"--scene must be 'planar' or 'arm', got {config.scene!r}")
        config.check()
        robot_name = PLANAR if config.scene == "planar" else (config.robot or "panda")
        known = supported_robots()
        if robot_name not in known:
            raise UnknownRobotError(f"unknown robot {robot_name!r}; known robots: {', '.join(known)}")
        check_bindable(config.host)
        self.config = config
        self.replay = ReplayControl()
        self._replay_lock = threading.Lock()
        self._pending: str | None = None
        """The recording label still to read (``ensure_replay``), None once read."""
        if config.replay is not None:  # a bad --replay is refused at start-up with the loader's message
            first = Path(config.replay)
            message = self.replay.load(first)
            if message:
                raise RecordingError(message)
            self.recordings: dict[str, Path] = {self.replay.name: first}
        else:
            self.recordings = {label: bundled_recording(name) for name, label in BUNDLED_RECORDINGS}
            self._pending = dict(BUNDLED_RECORDINGS)[DEFAULT_RECORDING]
        self.replay.playing = False  # the robot waits at home until the visitor plays the human
        self.recordings: dict[str, Path | object] = dict(self.recordings)
        """Recording list: bundled or --replay files by path, uploads as loaded replays."""
        self._uploaded: list[str] = []
        self.token_gate = None if is_loopback(config.host) else TokenGate(config.token, what="demo token")
        self.server = viser.ViserServer(host=config.host, port=config.port, verbose=False)
        self._first_client = threading.Event()
        self.server.on_client_connect(lambda _client: self._first_client.set())
        try:
            self._build(robot_name, announce)
        except BaseException:
            self.server.stop()
            raise

    @property
    def token(self) -> str | None:
        """The token a tab must enter to change the demo (None on loopback: every tab may)."""
        return None if self.token_gate is None else self.token_gate.token

    def _build(self, robot_name: str, announce: Callable[[str], None] | None) -> None:
        """The panel first (a tab opened on the announced URL shows it and waits), then the
        robot and its scene, the loop, the human, the zone editor, the charts, the gizmo."""
        config = self.config
        self.guard = ServerGuard(self.server, may_change=self.may_change,
                                 view_only_hint="Watching only: enter the token printed when the demo started "
                                                "(folder 'Change the demo') to drive the robot or change the scene.")
        hide_share_button(self.server, control_width="large")
        dim = 2 if robot_name == PLANAR else 3
        self.panel = make_panel(self.server, supported_robots(), robot_name, dim, tuple(self.recordings),
                                GizmoSettings(), ssm_available=dim == 3)
        self.panel.status.content = status_html((f"<b>Loading the {html.escape(robot_name)} scene...</b>",))
        if announce is not None:
            announce(self.url)
        self.scene = make_scene(self.server, robot_name)
        self._planar_label = PLANAR_SCENES[0]
        self.loop = ControlLoop(self.scene.robot, LoopSettings(rate_hz=config.rate_hz, fifo_priority=CONTROL_FIFO_PRIORITY),
                                human_source=self.replay if self.scene.dim == 3 else None)
        if self._pending is not None:
            self.panel.recording.value = self._pending
        self.panel.seek_s.max = seek_maximum_s(self.replay.duration_s)
        self.human = HumanView(self.server)
        self.human.visible = self.scene.dim == 3  # the planar arm ignores the human: so does its view
        self.panel.legend.content = self._legend()
        self.zones = ZoneEditor(self.server, self.loop, lambda: self.scene)
        self.zones.reset()  # the scene's built-in zones are selectable from the first load
        self.plots = Plots(self.server, config.rate_hz, "Robot-human distance")
        self.plots.distance.visible = self.scene.dim == 3
        self.plots.acceleration.visible = self.scene.dim == 3  # the planar arm has no joint limits table
        self.history = PlotHistory()
        self.vocabulary = vocabulary_of(self.scene.robot)
        self._dragging_client: int | None = None
        self._render_thread: threading.Thread | None = None
        self._preload_thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._switching = threading.RLock()
        self.frames = 0
        self.last_gizmo_update_s = 0.0
        """``time.perf_counter()`` of the last accepted gizmo update (for the latency bench)."""
        self._last_render_error = ""
        self._scripted_target_m: np.ndarray | None = None
        """Target of a scripted pull (Fig. 9), released on arrival or when a user drags."""
        self._target_marker = None
        self._scripted_since_steps = 0
        self.last_min_distance_m: float | None = None
        """The one minimum distance shown by the status, the scene's segment and the plot [m]."""
        self.last_status_lines: tuple[str, ...] = ()
        self.gizmo = self._make_gizmo()
        self.uploads = UploadReceiver(self.server, self.panel.upload, self.load_uploaded, refused_title="Recording refused")
        self.guard.uploads[self.uploads.uuid] = self.uploads
        self._refusal_shown = False
        self.guard.on_change.append(self._clear_refusal)
        self._wire()
        if self.token_gate is not None:
            self.server.on_client_connect(self._offer_login)

    def may_change(self, client_id: int) -> bool:
        """Whether tab ``client_id`` may change the robot or the scene."""
        return self.token_gate is None or self.token_gate.is_authorised(client_id)

    def _offer_login(self, client: viser.ClientHandle) -> None:
        """Beyond loopback: a tab's own folder where it enters the token (removed once accepted)."""
        self.guard.protect_client(client)
        gate = self.token_gate
        with client.gui.add_folder("Change the demo") as folder:
            token = client.gui.add_text("Token", initial_value="", hint="the token printed when the demo started")
            feedback = client.gui.add_markdown("This tab is watching. Enter the token to drive the robot.")

        @token.on_update
        def _(_event) -> None:
            verdict = gate.check(client.client_id, token.value)
            if verdict is Verdict.ACCEPTED:
                folder.remove()  # the token leaves the page once accepted
                client.add_notification("Token accepted", "This tab may now drive the robot.", color="green",
                                        auto_close_seconds=4.0)
            elif verdict is Verdict.WRONG:
                token.value = ""
                feedback.content = f"**Wrong token.** Try again in {gate.wait_s(client.client_id):.0f} s."
            elif verdict is Verdict.WAIT:
                token.value = ""
                feedback.content = f"**Too soon.** Wait {gate.wait_s(client.client_id):.0f} s, then try again."

    # ---- wiring --------------------------------------------------------------------------
    def _make_gizmo(self) -> viser.TransformControlsHandle:
        gizmo = add_gizmo(self.server, self.scene.gizmo_axes, self.scene.robot.p_base_ee_m)

        @gizmo.on_update
        def _(event: viser.TransformControlsEvent) -> None:
            self._scripted_target_m = None  # a user's drag takes over from a scripted pull
            if event.phase == "end":
                self._dragging_client = None
                self.loop.release_gizmo()
            elif self.loop.set_gizmo_target(np.asarray(event.target.position, dtype=float)):
                self._dragging_client = event.client_id
                self.last_gizmo_update_s = time.perf_counter()

        return gizmo

    def _wire(self) -> None:
        panel, loop = self.panel, self.loop

        @self.server.on_client_disconnect
        def _(client: viser.ClientHandle) -> None:
            if self.token_gate is not None:
                self.token_gate.forget(client.client_id)
            if client.client_id == self._dragging_client:
                self._dragging_client = None
                loop.release_gizmo()

        @panel.mode.on_update
        def _(_event) -> None:
            loop.method = panel.mode.value

        @panel.ssm.on_update
        def _(_event) -> None:
            self.apply_ssm()

        @panel.reset.on_click
        def _(_event) -> None:
            loop.reset()
            self.history.clear()

        @panel.reset_view.on_click
        def _(_event) -> None:
            reset_view(self.server)

        @panel.robot.on_update
        def _(_event) -> None:
            if panel.robot.value != self.scene.name:
                self.switch_scene(panel.robot.value)

        @panel.planar_scene.on_update
        def _(_event) -> None:
            if self.scene.name == PLANAR and panel.planar_scene.value != self._planar_label:
                self.switch_scene(PLANAR, panel.planar_scene.value)

        @panel.fig9.on_click
        def _(_event) -> None:
            self.run_fig9()

        def settings_changed(_event) -> None:
            try:
                loop.gizmo = GizmoSettings(panel.dead_band_m.value, panel.gain_per_s.value, panel.max_speed_m_s.value)
            except GizmoSettingsError as error:
                logger.warning("gizmo settings refused: %s", error)

        for slider in (panel.dead_band_m, panel.gain_per_s, panel.max_speed_m_s):
            slider.on_update(settings_changed)

        @panel.jog.on_click
        def _(_event) -> None:
            try:
                loop.jog(jog_module.jog_velocity(panel.jog.value, panel.jog_speed_m_s.value, loop.robot.dim))
            except CobotSafetyError as error:
                logger.warning("jog refused: %s", error)

        self._wire_replay()

    def _wire_replay(self) -> None:
        panel, replay = self.panel, self.replay
        self._show_play_button()

        @panel.play.on_click
        def _(_event) -> None:
            self.ensure_replay()
            replay.playing = not replay.playing
            self._show_play_button()

        @panel.seek_s.on_update
        def _(_event) -> None:
            if abs(panel.seek_s.value - replay.time_s) > 0.25:  # a user's seek, not our own refresh
                self.ensure_replay()
                replay.seek(panel.seek_s.value)

        @panel.speed.on_update
        def _(_event) -> None:
            replay.speed = float(panel.speed.value)

        @panel.loop.on_update
        def _(_event) -> None:
            replay.loop = bool(panel.loop.value)

        @panel.recording.on_update
        def _(_event) -> None:
            name = panel.recording.value
            source = self.recordings.get(name)
            if source is None or name == replay.name or name == self._pending:
                return
            with self._replay_lock:
                self._pending = None
                if isinstance(source, Path):
                    self.show_replay_message(replay.load(source, name))
                else:  # an upload, kept loaded
                    replay.use(source, name)
                    self.show_replay_message("")
                replay.playing = False  # a new recording waits for Play, from its start
            self.panel.seek_s.max = seek_maximum_s(replay.duration_s)
            self._show_play_button()

    # ---- actions ------------------------------------------------------------------------
    def load_uploaded(self, name: str, content: bytes) -> str:
        """Load an uploaded recording or bag and switch to it; returns the refusal or "".

        The bytes go to a temporary folder that is deleted as soon as the loader is done,
        whether it accepted them or not; an accepted replay is kept in memory (the last
        ``MAX_KEPT_UPLOADS``). A refusal is one sentence naming the file once, never a server
        path; the previous replay keeps running. (The uploading tab's notification is the
        ``UploadReceiver``'s.)
        """
        refusal = check_upload_name(name)
        if refusal:
            self.show_replay_message(refusal)
            return refusal
        folder = Path(tempfile.mkdtemp(prefix="cobotsafety-upload-"))
        path = folder / name
        try:
            path.write_bytes(content)
            replay = load_replay(path)
        except (CobotSafetyError, OSError, ValueError) as error:
            refusal = without_server_paths(refusal_sentence(name, error), path)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        if refusal:
            self.show_replay_message(refusal)
            return refusal
        with self._replay_lock:
            self._pending = None  # the upload replaces the default still to read
            self.replay.use(replay, name)
        self._keep_upload(name, replay)
        self.panel.recording.options = tuple(self.recordings)
        self.panel.recording.value = name
        self.panel.seek_s.max = seek_maximum_s(self.replay.duration_s)
        self._show_play_button()
        self.show_replay_message("")
        return ""

    def _keep_upload(self, name: str, replay) -> None:
        if name in self._uploaded:
            self._uploaded.remove(name)
        self._uploaded.append(name)
        self.recordings[name] = replay
        while len(self._uploaded) > MAX_KEPT_UPLOADS:
            self.recordings.pop(self._uploaded.pop(0), None)

    def show_replay_message(self, message: str) -> None:
        """A refusal in the Replay folder (until the next action in any tab), or what is loaded."""
        self.panel.replay_message.content = f"**{message}**" if message else f"ready: {self.replay.name}"
        self._refusal_shown = bool(message)
        if message:
            logger.warning("%s", message)

    def _clear_refusal(self, _client_id: int) -> None:
        if self._refusal_shown:
            self._refusal_shown = False
            self.panel.replay_message.content = ""

    def ensure_replay(self) -> None:
        """Read the recording still pending (the bundled default), now; a no-op once read."""
        with self._replay_lock:
            label = self._pending
            if label is None:
                return
            self.panel.replay_message.content = f"reading {label}..."
            message = self.replay.load(self.recordings[label], label)
            self.replay.playing = False
            self._pending = None
        self.panel.seek_s.max = seek_maximum_s(self.replay.duration_s)
        self.show_replay_message(message)
        self._show_play_button()

    def _preload(self) -> None:
        """Read the pending recording in the background, once the first tab has had its scene
        (``PRELOAD_AFTER_CONNECT_S`` after it connected) and only for a scene with a person."""
        deadline = time.monotonic() + PRELOAD_AT_THE_LATEST_S
        if self._first_client.wait(PRELOAD_AT_THE_LATEST_S):
            deadline = min(deadline, time.monotonic() + PRELOAD_AFTER_CONNECT_S)
        while not self._stop.wait(max(0.0, deadline - time.monotonic())):
            if self.scene.dim == 3:
                self.ensure_replay()
                return
            deadline = time.monotonic() + 1.0  # the planar scene: read it when a 3D scene is chosen

    def _show_play_button(self) -> None:
        self.panel.play.label, self.panel.play.icon = play_button_look(self.replay.playing)

    def _legend(self) -> str:
        view = getattr(self.scene, "view", None)
        return view.legend() if hasattr(view, "legend") else ""

    def apply_ssm(self) -> None:
        """The ``SSM`` checkbox onto the robot (3D arms only: the planar scene has no human layer)."""
        with self.loop.lock:
            robot = self.loop.robot
            if hasattr(robot, "ssm"):
                robot.ssm = bool(self.panel.ssm.value)

    def switch_scene(self, robot_name: str, planar_label: str = PLANAR_SCENES[0]) -> None:
        """Swap robot and view (robot selector, planar scene, Fig. 9); the loop keeps running.

        The old nodes go first (the new scene reuses their names); if the new robot cannot be
        built, the previous one is rebuilt and the error re-raised. Zones added by hand are
        carried over into the new scene.
        """
        with self._switching:
            previous = self.scene.name
            self._scripted_target_m = None
            if self._target_marker is not None:
                self._target_marker.remove()
                self._target_marker = None
            with warnings.catch_warnings():  # ViserUrdf removes children twice
                warnings.simplefilter("ignore", UserWarning)
                self.scene.remove()
            self.gizmo.remove()
            try:
                scene = make_scene(self.server, robot_name, planar_label)
                self._planar_label = planar_label
            except CobotSafetyError:
                scene = make_scene(self.server, previous)
                self._planar_label = PLANAR_SCENES[0]
                raise
            finally:
                with self.loop.lock:
                    self.loop.replace_robot(scene.robot)
                    self.loop.human_source = self.replay if scene.dim == 3 else None
                    self.scene = scene
                self.gizmo = self._make_gizmo()
                self.zones.carry_over()
                self.history.clear()
                self.human.visible = scene.dim == 3
                self.plots.distance.visible = scene.dim == 3
                self.plots.acceleration.visible = scene.dim == 3
                self.panel.replay_folder.visible = scene.dim == 3
                self.vocabulary = vocabulary_of(scene.robot)
                if scene.dim == 3 and self._pending is not None and self._preload_thread is None:
                    self._preload_thread = threading.Thread(target=self.ensure_replay, name="cobotsafety-preload",
                                                            daemon=True)
                    self._preload_thread.start()  # a person can be played in this scene: read the recording
                self.panel.legend.content = self._legend()
                for handle in (self.panel.planar_scene, self.panel.fig9):
                    handle.disabled = scene.dim != 2
                self.panel.ssm.disabled = scene.dim != 3
                self.apply_ssm()
                self.panel.jog.options = ("+x", "-x", "+y", "-y") + (("+z", "-z") if scene.dim == 3 else ())
                self.panel.robot.value = scene.name  # the selector follows (no-op from its own callback)
                if scene.dim == 2:
                    self.panel.planar_scene.value = self._planar_label
                settle_heap()

    def run_fig9(self) -> None:
        """Paper 1, Fig. 9 b: start pose, then pull the end-effector to the marked target.

        The pull is a scripted drag: the gizmo rides with the end-effector, a marker shows the
        target, and control is released when the arm arrives (within ``FIG9_ARRIVED_M``) or
        stalls, or as soon as a user grabs the gizmo.
        """
        from cobotsafety.planar.planar_scenes import FIG9_TARGET_M  # noqa: PLC0415

        self.switch_scene(PLANAR, PLANAR_SCENES[2])
        target = np.array([*FIG9_TARGET_M, 0.0])
        ring = draw.polyline_segments(draw.circle_points(tuple(target[:2]), FIG9_MARKER_RADIUS_M, count=48))
        self._target_marker = self.server.scene.add_line_segments(
            "/planar/fig9_target", ring, FIG9_MARKER_RGB, thickness=0.008)
        self._scripted_target_m = target
        self._scripted_since_steps = self.loop.snapshot().steps
        self.loop.set_gizmo_target(target)

    def _follow_scripted_pull(self, snapshot) -> None:
        """Release a scripted pull on arrival, or when the arm has stopped short (blocked)."""
        target = self._scripted_target_m
        if target is None:
            return
        arrived = np.linalg.norm(snapshot.p_base_ee_m[:2] - target[:2]) < FIG9_ARRIVED_M
        report = snapshot.report
        settled = report is not None and float(np.linalg.norm(report.v_executed_m_s)) < 1e-4
        started = snapshot.steps - self._scripted_since_steps > 0.5 * self.config.rate_hz
        if arrived or (settled and started):
            self._scripted_target_m = None
            self.loop.release_gizmo()

    # ---- render loop --------------------------------------------------------------------
    @staticmethod
    def closest_pair(report) -> tuple[float, np.ndarray, np.ndarray] | None:
        """The robot-human minimum distance [m] and its witness points on the two surfaces, as
        the controller measured them this step (``StepReport``); None without a human."""
        if report is None or report.min_distance_m is None or report.p_robot_closest_m is None:
            return None
        return report.min_distance_m, report.p_robot_closest_m, report.p_human_closest_m

    def _critical_m(self) -> float | None:
        """The distance the human constraint keeps [m], when the robot says."""
        critical = getattr(getattr(self.loop.robot, "human", None), "critical_m", None)
        return float(critical) if critical is not None else None

    def status_facts(self, snapshot, closest, human) -> StatusFacts:
        report = snapshot.report
        dim = self.scene.dim
        replay_state = f"{self._pending}: reading it" if self._pending is not None and dim == 3 else ""
        return StatusFacts(
            method=snapshot.method, rate_hz=snapshot.stats.get("rate_hz", 0.0), report=report,
            p_base_ee_m=snapshot.p_base_ee_m, vocabulary=self.vocabulary, dim=dim,
            ssm=bool(self.panel.ssm.value) if dim == 3 else None,
            distance_m=None if closest is None else closest[0], critical_m=self._critical_m() if dim == 3 else None,
            human_present=bool(human is not None and human.present),
            stale_reason=human.reason if human is not None and human.stale else "",
            replay_playing=self.replay.playing, replay_state=replay_state,
            careful=getattr(report, "human_status", "") or "",
            motion_limited=tuple(getattr(report, "motion_limited", ())),
            hand_over_limit=snapshot.hand_over_limit, failure=self.loop.failure or "")

    def render_once(self, wall_dt_s: float = 0.0) -> None:
        self.frames += 1
        status_frame = self.frames % STATUS_EVERY_FRAMES == 0
        with self._switching:
            scene = self.scene
            snapshot = self.loop.snapshot()
            data = self.loop.read(scene.read)
            # The human and its distance as the controller had them this step (the control loop
            # feeds the replay to it; rendering only draws).
            human = snapshot.human if scene.dim == 3 else None
            self._follow_scripted_pull(snapshot)
            with self.server.atomic():
                scene.render(snapshot, data)
                closest = self.closest_pair(snapshot.report) if human is not None else None
                self.human.update(human, closest)
                if status_frame:  # the status and the chart: the segment's report, in its update
                    self.last_min_distance_m = None if closest is None else closest[0]
                    self.history.add(snapshot, self.last_min_distance_m)
                    lines = status_lines(self.status_facts(snapshot, closest, human))
                    if lines != self.last_status_lines:
                        self.panel.status.content = status_html(lines)
                        self.last_status_lines = lines
                    if scene.dim == 3:  # the planar scene has no person: its distance chart is hidden
                        self.plots.push_distance(self.history)
                    if self.frames % (STATUS_EVERY_FRAMES * CHARTS_EVERY_STATUS) == 0:
                        self.plots.push(self.history, distance=scene.dim == 3)
                    if abs(self.panel.seek_s.value - self.replay.time_s) > 0.05:  # playing, or seeked elsewhere
                        self.panel.seek_s.value = round(min(self.replay.time_s, self.panel.seek_s.max), 2)
                if self._dragging_client is None:  # nobody holds it: the gizmo rides with the end-effector
                    if np.linalg.norm(np.asarray(self.gizmo.position) - snapshot.p_base_ee_m) > 1e-5:
                        self.gizmo.position = tuple(snapshot.p_base_ee_m)

    def _render_run(self) -> None:
        period = 1.0 / self.config.render_hz
        last = time.perf_counter()
        while not self._stop.is_set():
            start = time.perf_counter()
            try:
                self.render_once(start - last)
            except Exception as error:  # noqa: BLE001 - a rendering glitch must not stop the demo
                if repr(error) != self._last_render_error:  # log each distinct failure once
                    logger.exception("render frame failed")
                    self._last_render_error = repr(error)
            last = start
            self._stop.wait(max(0.0, period - (time.perf_counter() - start)))

    # ---- lifecycle ----------------------------------------------------------------------
    @property
    def url(self) -> str:
        """The URL to open: on loopback this machine's; bound beyond, one other machines can use."""
        host = reachable_host(self.server.get_host())
        shown = f"[{host}]" if ":" in host else host
        return f"http://{shown}:{self.server.get_port()}"

    def start_lines(self) -> list[str]:
        """What ``cobotsafety demo`` prints once started: the URL, and beyond loopback a warning and the token."""
        lines = [f"open {self.url}"]
        if self.token_gate is not None:
            lines.insert(0, f"warning: listening on {self.config.host}, beyond this machine: anyone who can reach "
                            f"port {self.server.get_port()} can watch the demo")
            lines.append(f"to drive the robot or change the scene, enter this token in the page: {self.token}")
        return lines

    def failure(self) -> str:
        """Why the running demo cannot serve ("" while it can): its control or render thread died."""
        if not self.loop.running:
            return "the control loop stopped (see the log above)"
        if self._render_thread is not None and not self._render_thread.is_alive() and not self._stop.is_set():
            return "the render loop stopped (see the log above)"
        return ""

    def wait_until_running(self, timeout_s: float = 600.0) -> str:
        """Block until the loop has stepped and a frame was drawn (kernels compiled); returns ``failure()``."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            problem = self.failure()
            if problem or (self.frames > 0 and self.loop.snapshot().steps > 0):
                return problem
            time.sleep(0.05)
        return f"the demo did not draw its first frame within {timeout_s:.0f} s"

    def start(self) -> "DemoApp":
        # The control thread must not wait CPython's default 5 ms for the GIL while the render
        # thread or the websocket loop serialise frames: hand it over every 0.5 ms instead.
        sys.setswitchinterval(GIL_SWITCH_INTERVAL_S)
        settle_heap()
        CONTROLLER_LOG.addFilter(LOG_FILTER)  # once, however many demos run
        self.loop.start()
        self._stop.clear()
        self._render_thread = threading.Thread(target=self._render_run, name="cobotsafety-render", daemon=True)
        self._render_thread.start()
        if self._pending is not None:
            self._preload_thread = threading.Thread(target=self._preload, name="cobotsafety-preload", daemon=True)
            self._preload_thread.start()
        return self

    def stop(self) -> None:
        CONTROLLER_LOG.removeFilter(LOG_FILTER)
        self._stop.set()
        if self._render_thread is not None:
            self._render_thread.join(timeout=2.0)
        if self._preload_thread is not None:
            self._preload_thread.join(timeout=10.0)
        self.loop.stop()
        self.uploads.close()
        self.server.stop()
        gc.unfreeze()  # the stopped demo's objects can be collected again
