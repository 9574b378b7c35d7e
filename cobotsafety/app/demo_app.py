"""``DemoApp``: the viser server, one shared robot for every browser tab, and the render loop.

viser broadcasts ``server.scene``/``server.gui`` to every client, so all tabs see the same robot;
a gizmo drag from any tab drives it. The control loop (``ControlLoop``, 1 kHz by default, 500 Hz
an option) and the render loop (``render_hz``) are separate threads; a client that disconnects
mid-drag releases the gizmo.

What a frame sends is bounded: scene nodes are made once and a frame only sets poses,
visibility and colours (no mesh is re-sent), the status is refreshed at ~5 Hz and the plots at
~2 Hz. The replay starts paused so a visitor first sees the robot at home, waiting for a drag.

Access (``cobotsafety.app.access``): no tab can publish the server (viser's share tunnel is
refused and its button hidden); every value a tab sends is checked against its control's
range; bound to loopback every tab may drive the robot, bound beyond it a tab must first
enter the token printed at start (``DemoApp.token``), and sees but changes nothing until
then. Uploads are received by ``cobotsafety.app.uploads`` (size limit, odd names refused,
nothing left on disk, no "uploaded" notice for a refused file).
"""

from __future__ import annotations

import gc
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

import numpy as np
import viser

from cobotsafety.app import draw
from cobotsafety.app.access import (ServerGuard, TokenGate, Verdict, check_bindable, hide_share_button, is_loopback,
                                    reachable_host)
from cobotsafety.app import jog as jog_module
from cobotsafety.app.control_loop import ControlLoop, LoopSettings
from cobotsafety.app.gizmo import GizmoSettings, GizmoSettingsError
from cobotsafety.app.panel import PLANAR_SCENES, make_panel, play_button_look, status_text
from cobotsafety.app.log_filter import RepeatedWarningFilter
from cobotsafety.app.plots import PlotHistory, Plots
from cobotsafety.app.replay_control import ReplayControl, load_replay, refusal_sentence, seek_maximum_s, without_server_paths
from cobotsafety.app.scene_human import HumanView, minimum_distance
from cobotsafety.app.scenes import PLANAR, make_scene
from cobotsafety.app.uploads import UploadReceiver, check_upload_name
from cobotsafety.app.zones_editor import ZoneEditor
from cobotsafety.cli.arguments import MAX_RATE_HZ, MIN_RATE_HZ
from cobotsafety.errors import CobotSafetyError, RecordingError, UnknownRobotError
from cobotsafety.human.recording import bundled_recording

logger = logging.getLogger(__name__)
logging.getLogger("cobotsafety.arm.controller").addFilter(RepeatedWarningFilter())


@dataclass(frozen=True)
class DemoConfig:
    scene: str = "planar"
    """``planar`` (paper 1's RR arm) or ``arm`` (a pinocchio arm)."""
    robot: str | None = None
    """Arm name for ``scene="arm"``; None = the arm package's default (panda)."""
    replay: Path | None = None
    """Human recording (.jsonl.gz) or ROS bag; None = the bundled recording."""
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


FIG9_MARKER_RADIUS_M = 0.05
"""Radius of the ring marking the Fig. 9 target [m] (wider than the end-effector drawn on it)."""
FIG9_MARKER_RGB = (40, 170, 60)
FIG9_ARRIVED_M = 0.005
"""A scripted pull ends when the end-effector is this close to its target [m]."""


def supported_robots() -> tuple[str, ...]:
    """``planar`` plus the arm names of ``cobotsafety.arm``."""
    try:
        from cobotsafety.arm.robots import ROBOTS  # noqa: PLC0415
        from cobotsafety.arm.controller import ArmController  # noqa: F401, PLC0415 - the 3D scene needs it
    except ImportError:
        return (PLANAR,)
    return (PLANAR, *(name for name in ROBOTS if name != PLANAR))


class DemoApp:
    """The running demo. ``start()`` then ``url``; ``stop()`` shuts everything down."""

    def __init__(self, config: DemoConfig = DemoConfig()):
        config.check()
        robot_name = PLANAR if config.scene == "planar" else (config.robot or "panda")
        known = supported_robots()
        if robot_name not in known:
            raise UnknownRobotError(f"unknown robot {robot_name!r}; known robots: {', '.join(known)}")
        check_bindable(config.host)
        self.config = config
        self.replay = ReplayControl()
        first = Path(config.replay) if config.replay is not None else bundled_recording()
        message = self.replay.load(first)
        if message:  # a bad --replay is refused at start-up with the loader's message
            raise RecordingError(message)
        self.replay.playing = False  # the robot waits at home until the visitor plays the human
        self.recordings: dict[str, Path | object] = {self.replay.name: first}
        """Recording list: bundled or --replay files by path, uploads as loaded replays."""
        self._uploaded: list[str] = []
        self.token_gate = None if is_loopback(config.host) else TokenGate(config.token, what="demo token")
        self.server = viser.ViserServer(host=config.host, port=config.port, verbose=False)
        try:
            self._build(robot_name)
        except BaseException:
            self.server.stop()
            raise

    @property
    def token(self) -> str | None:
        """The token a tab must enter to change the demo (None on loopback: every tab may)."""
        return None if self.token_gate is None else self.token_gate.token

    def _build(self, robot_name: str) -> None:
        config = self.config
        self.guard = ServerGuard(self.server, may_change=self.may_change,
                                 view_only_hint="Watching only: enter the token printed when the demo started "
                                                "(folder 'Change the demo') to drive the robot or change the scene.")
        hide_share_button(self.server, control_width="large")
        self.scene = make_scene(self.server, robot_name)
        self._planar_label = PLANAR_SCENES[0]
        self.loop = ControlLoop(self.scene.robot, LoopSettings(rate_hz=config.rate_hz, fifo_priority=CONTROL_FIFO_PRIORITY),
                                human_source=self.replay if self.scene.dim == 3 else None)
        self.panel = make_panel(self.server, supported_robots(), robot_name, self.scene.dim, tuple(self.recordings),
                                self.loop.gizmo, ssm_available=self.scene.dim == 3)
        self.panel.seek_s.max = seek_maximum_s(self.replay.duration_s)
        self.human = HumanView(self.server)
        self.human.visible = self.scene.dim == 3  # the planar arm ignores the human: so does its view
        self.panel.legend.content = self._legend()
        self.zones = ZoneEditor(self.server, self.loop, lambda: self.scene)
        self.plots = Plots(self.server, config.rate_hz, "Robot-human distance")
        self.plots.distance.visible = self.scene.dim == 3
        self.history = PlotHistory()
        self._dragging_client: int | None = None
        self._render_thread: threading.Thread | None = None
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
        """The one minimum distance shown by the status, the scene label and the plot [m]."""
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
        gizmo = self.server.scene.add_transform_controls(
            "/gizmo", scale=0.15, line_width=4.0, active_axes=self.scene.gizmo_axes, disable_rotations=True,
            depth_test=False, position=tuple(self.scene.robot.p_base_ee_m))

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
            replay.playing = not replay.playing
            self._show_play_button()

        @panel.seek_s.on_update
        def _(_event) -> None:
            if abs(panel.seek_s.value - replay.time_s) > 0.25:  # a user's seek, not our own refresh
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
            if source is None or name == replay.name:
                return
            if isinstance(source, Path):
                self.show_replay_message(replay.load(source, name))
            else:  # an upload, kept loaded
                replay.use(source, name)
                self.show_replay_message("")
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
        self.panel.replay_message.content = f"**{message}**" if message else f"loaded {self.replay.name}"
        self._refusal_shown = bool(message)
        if message:
            logger.warning("%s", message)

    def _clear_refusal(self, _client_id: int) -> None:
        if self._refusal_shown:
            self._refusal_shown = False
            self.panel.replay_message.content = ""

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

    def render_once(self, wall_dt_s: float = 0.0) -> None:
        self.frames += 1
        status_frame = self.frames % 6 == 0  # status (and the scene's distance label) at ~5 Hz
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
                self.human.update(human, closest, refresh_text=status_frame)
                if self._dragging_client is None:  # nobody holds it: the gizmo rides with the end-effector
                    if np.linalg.norm(np.asarray(self.gizmo.position) - snapshot.p_base_ee_m) > 1e-5:
                        self.gizmo.position = tuple(snapshot.p_base_ee_m)
        report = snapshot.report
        min_distance = None if closest is None else closest[0]
        self.last_min_distance_m = min_distance
        if self.frames % 3 == 0:  # plot samples at ~10 Hz
            self.history.add(snapshot, min_distance)
        if status_frame:
            ssm = bool(self.panel.ssm.value) if scene.dim == 3 else None
            text = status_text(snapshot.method, snapshot.stats["rate_hz"], min_distance,
                               report.binding if report is not None else (), snapshot.p_base_ee_m,
                               bool(report is not None and report.stopped), ssm=ssm,
                               distance_label="human distance" if scene.dim == 3 else None,
                               reason=report.reason if report is not None else "",
                               contradictions=report.contradictions if report is not None else 0)
            if human is not None and human.stale:
                text += f"  \n**sensor stale**: {human.reason}"
            if report is not None and report.human_status:
                text += f"  \n**careful**: {report.human_status}"
            if report is not None and report.motion_limited:
                text += "  \nlimited by the robot's acceleration: " + ", ".join(report.motion_limited)
            if self.loop.failure:
                text += f"  \n**control stopped**: {self.loop.failure}"
            if text != self.panel.status.content:
                self.panel.status.content = text
            if abs(self.panel.seek_s.value - self.replay.time_s) > 0.05:  # playing, or seeked elsewhere
                self.panel.seek_s.value = round(min(self.replay.time_s, self.panel.seek_s.max), 2)
        if self.frames % 15 == 0:  # plots at ~2 Hz
            self.plots.push(self.history)

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
        self.loop.start()
        self._stop.clear()
        self._render_thread = threading.Thread(target=self._render_run, name="cobotsafety-render", daemon=True)
        self._render_thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._render_thread is not None:
            self._render_thread.join(timeout=2.0)
        self.loop.stop()
        self.uploads.close()
        self.server.stop()
        gc.unfreeze()  # the stopped demo's objects can be collected again
