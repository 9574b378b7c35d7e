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
"""

from __future__ import annotations

import gc
import html
import logging
import sys
import threading
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import viser

from cobotsafety.app import draw
from cobotsafety.app import jog as jog_module
from cobotsafety.app.camera import reset_view
from cobotsafety.app.control_loop import ControlLoop, LoopSettings
from cobotsafety.app.gizmo import GizmoSettings, GizmoSettingsError, add_gizmo
from cobotsafety.app.limit_words import vocabulary_of
from cobotsafety.app.panel import PLANAR_SCENES, make_panel, play_button_look
from cobotsafety.app.log_filter import RepeatedWarningFilter
from cobotsafety.app.plots import PlotHistory, Plots
from cobotsafety.app.replay_control import ReplayControl, seek_maximum_s, without_server_paths
from cobotsafety.app.scene_human import HumanView, minimum_distance
from cobotsafety.app.scenes import PLANAR, make_scene
from cobotsafety.app.status import StatusFacts, status_html, status_lines
from cobotsafety.app.zones_editor import ZoneEditor
from cobotsafety.errors import CobotSafetyError, RecordingError
from cobotsafety.human.recording import bundled_recording

logger = logging.getLogger(__name__)
logging.getLogger("cobotsafety.filter").addFilter(RepeatedWarningFilter())


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
    port: int = 8080
    rate_hz: float = 1000.0
    render_hz: float = 30.0


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
    """``planar`` plus the arm names of ``cobotsafety.arm`` when its ``ArmTeleop`` can be loaded.

    Looked up without importing it (that would load numba and pinocchio, seconds of the planar
    demo's start-up): the modules are found, their names read from ``arm.robots``.
    """
    from importlib.util import find_spec  # noqa: PLC0415

    try:
        available = all(find_spec(name) is not None for name in ("pinocchio", "numba", "cobotsafety.arm.teleop"))
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
        robot_name = PLANAR if config.scene == "planar" else (config.robot or "panda")
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
        self.server = viser.ViserServer(host=config.host, port=config.port, verbose=False)
        self._first_client = threading.Event()
        self.server.on_client_connect(lambda _client: self._first_client.set())
        self.server.gui.configure_theme(control_width="large")
        try:
            self._build(robot_name, announce)
        except BaseException:
            self.server.stop()
            raise

    def _build(self, robot_name: str, announce: Callable[[str], None] | None) -> None:
        """The panel first (a tab opened on the announced URL shows it and waits), then the
        robot and its scene, the loop, the human, the zone editor, the charts, the gizmo."""
        config = self.config
        dim = 2 if robot_name == PLANAR else 3
        self.panel = make_panel(self.server, supported_robots(), robot_name, dim, tuple(self.recordings),
                                GizmoSettings(), ssm_available=dim == 3)
        self.panel.status.content = status_html((f"<b>Loading the {html.escape(robot_name)} scene...</b>",))
        if announce is not None:
            announce(self.url)
        self.scene = make_scene(self.server, robot_name)
        self._planar_label = PLANAR_SCENES[0]
        self.loop = ControlLoop(self.scene.robot, LoopSettings(rate_hz=config.rate_hz, fifo_priority=CONTROL_FIFO_PRIORITY))
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
        self._wire()

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
            path = self.recordings.get(panel.recording.value)
            if path is not None and panel.recording.value != replay.name and panel.recording.value != self._pending:
                with self._replay_lock:
                    self._pending = None
                    self.show_replay_message(replay.load(path, panel.recording.value))
                    replay.playing = False  # a new recording waits for Play, from its start
                self.panel.seek_s.max = seek_maximum_s(replay.duration_s)
                self._show_play_button()

        @panel.upload.on_upload
        def _(event) -> None:
            upload = panel.upload.value
            self.load_uploaded(upload.name, upload.content, event.client)

    # ---- actions ------------------------------------------------------------------------
    def load_uploaded(self, name: str, content: bytes, client: viser.ClientHandle | None = None) -> str:
        """Save an uploaded recording or bag and switch to it; returns the refusal or "".

        A refusal names the file and the loader's reason, never a server path; it goes to the
        uploading tab as a red notification, and the previous replay keeps running.
        """
        import tempfile  # noqa: PLC0415

        path = Path(tempfile.mkdtemp(prefix="cobotsafety-upload-")) / Path(name).name
        path.write_bytes(content)
        message = without_server_paths(self.replay.load(path, path.name), path)
        if not message:
            self.recordings[path.name] = path
            self.panel.recording.options = tuple(self.recordings)
            self.panel.recording.value = path.name
            self.panel.seek_s.max = seek_maximum_s(self.replay.duration_s)
            self._show_play_button()
        elif client is not None:
            client.add_notification("Recording refused", message, color="red", with_close_button=True)
        self.show_replay_message(message)
        return message

    def show_replay_message(self, message: str) -> None:
        self.panel.replay_message.content = f"**{message}**" if message else f"ready: {self.replay.name}"
        if message:
            logger.warning("%s", message)

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
                    self.scene = scene
                self.gizmo = self._make_gizmo()
                self.zones.carry_over()
                self.history.clear()
                self.human.visible = scene.dim == 3
                self.plots.distance.visible = scene.dim == 3
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
    def closest_pair(self, report, capsules, human) -> tuple[float, np.ndarray, np.ndarray] | None:
        """The robot-human minimum distance [m] and its witness points (robot, human; (3,) each,
        base frame) shown everywhere: the controller's own, from its report.

        FALLBACK, to delete once ``StepReport`` carries ``p_robot_closest_m`` and
        ``p_human_closest_m``: the display computes the pair itself from the robot capsules
        (but the ones the human constraint skips) and the replayed human.
        """
        if self.scene.dim != 3:
            return None
        distance = getattr(report, "min_distance_m", None)
        p_robot = getattr(report, "p_robot_closest_m", None)
        p_human = getattr(report, "p_human_closest_m", None)
        if p_robot is not None and p_human is not None:
            if distance is None or not np.isfinite(distance):
                return None
            return float(distance), np.asarray(p_robot, dtype=float), np.asarray(p_human, dtype=float)
        return self.display_distance(capsules, human)  # FALLBACK (see above)

    def display_distance(self, capsules, human) -> tuple[float, np.ndarray, np.ndarray] | None:
        """FALLBACK (``closest_pair``): the closest robot-human pair computed by the display.

        Robot capsules skip the ones the human constraint skips (the fixed base), so the value
        is the controller's separation, not a second definition.
        """
        if human is None or self.scene.dim != 3:
            return None
        p0, p1, radius = capsules
        skip = int(getattr(getattr(getattr(self.loop.robot, "arm", None), "human", None), "skip_capsules", 1))
        skip = min(skip, max(len(radius) - 1, 0))
        return minimum_distance(p0[skip:], p1[skip:], radius[skip:], human)

    def _critical_m(self) -> float | None:
        """The distance the human constraint keeps [m], when the robot says."""
        human = getattr(getattr(self.loop.robot, "arm", None), "human", None)
        critical = getattr(human, "critical_m", None)
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
            replay_playing=self.replay.playing, replay_state=replay_state)

    def render_once(self, wall_dt_s: float = 0.0) -> None:
        self.frames += 1
        status_frame = self.frames % STATUS_EVERY_FRAMES == 0
        with self._switching:
            scene = self.scene
            snapshot = self.loop.snapshot()
            data = self.loop.read(scene.read)
            self.replay.advance(wall_dt_s)
            human = self.replay.capsules() if scene.dim == 3 else None
            # The replayed human drives the arm's human constraint at the render rate; between
            # frames the constraint extrapolates with the estimated human velocity.
            if human is not None:
                self.loop.read(lambda robot: robot.set_human(human) if hasattr(robot, "set_human") else None)
            self._follow_scripted_pull(snapshot)
            with self.server.atomic():
                capsules = scene.render(snapshot, data)
                closest = self.closest_pair(snapshot.report, capsules, human)
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
        host = self.server.get_host()
        shown = "127.0.0.1" if host in ("0.0.0.0", "") else host
        return f"http://{shown}:{self.server.get_port()}"

    def start(self) -> "DemoApp":
        # The control thread must not wait CPython's default 5 ms for the GIL while the render
        # thread or the websocket loop serialise frames: hand it over every 0.5 ms instead.
        sys.setswitchinterval(GIL_SWITCH_INTERVAL_S)
        settle_heap()
        self.loop.start()
        self._stop.clear()
        self._render_thread = threading.Thread(target=self._render_run, name="cobotsafety-render", daemon=True)
        self._render_thread.start()
        if self._pending is not None:
            self._preload_thread = threading.Thread(target=self._preload, name="cobotsafety-preload", daemon=True)
            self._preload_thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._render_thread is not None:
            self._render_thread.join(timeout=2.0)
        if self._preload_thread is not None:
            self._preload_thread.join(timeout=10.0)
        self.loop.stop()
        self.server.stop()
        gc.unfreeze()  # the stopped demo's objects can be collected again
