"""The browser trial: a participant view and an operator panel behind a token.

Participant view (every browser at the URL): the robot (the planar arm seen from above, or a 3D
arm with ``robot="panda"`` etc., its course in a horizontal plane), the course
(targets in order, triangles), the gizmo to drag, the trial's progress and, in divided
attention, the colour word with four answer buttons. It never names the condition.
Operator panel: enter the token printed at start in *Operator*; that browser alone gets the
participant selector, the session plan (with conditions), Start / Abort / Repeat, and live
progress. Finished trials go to the ``LogStore`` at once (durable, resumable).
"""

from __future__ import annotations

import logging
import secrets
import threading
import time
from pathlib import Path

import numpy as np
import viser

from cobotsafety.app.control_loop import ControlLoop, LoopSettings
from cobotsafety.app.scenes import make_scene
from cobotsafety.trial.colour_task import COLOURS
from cobotsafety.trial.course import Course, arm_course, planar_course
from cobotsafety.trial.log_store import LogStore
from cobotsafety.trial.plan import PlannedTrial, session_plan
from cobotsafety.trial.session import TrialRun

logger = logging.getLogger(__name__)
INK_RGB = {"red": "#d62728", "green": "#2ca02c", "blue": "#1f77b4", "yellow": "#e6b800"}


class TrialServer:
    def __init__(self, out: Path, participants: list[str], seed: int = 0, host: str = "127.0.0.1",
                 port: int = 8080, course: Course | None = None, robot: str = "planar"):
        self.store = LogStore(out)
        self.seed = seed
        self.plan = session_plan(participants, seed=seed)
        self.course = course or (planar_course() if robot == "planar" else arm_course())
        self.token = secrets.token_hex(4)
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.scene = make_scene(self.server, robot)
        self.teleop = self.scene.robot
        if robot != "planar":  # the course's triangles are the only obstacles of the task
            self.teleop.zones = []
            self.scene.redraw()
        self.loop = ControlLoop(self.teleop, LoopSettings())
        self.loop.before_step.append(self._before_step)
        self.current: tuple[PlannedTrial, TrialRun] | None = None
        self._finished: list[tuple[PlannedTrial, TrialRun]] = []
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._draw_course()
        self._make_participant_gui()
        self.gizmo = self.server.scene.add_transform_controls(
            "/gizmo", scale=0.15, line_width=4.0, active_axes=self.scene.gizmo_axes, disable_rotations=True,
            depth_test=False, position=tuple(self.teleop.p_base_ee_m))

        @self.gizmo.on_update
        def _(event: viser.TransformControlsEvent) -> None:
            if event.phase == "end":
                self.loop.release_gizmo()
            elif self.current is not None:
                self.loop.set_gizmo_target(np.asarray(event.target.position, dtype=float))

        @self.server.on_client_connect
        def _(client: viser.ClientHandle) -> None:
            self._offer_operator_login(client)

    # ---- views -----------------------------------------------------------------------------
    def _draw_course(self) -> None:
        scene = self.server.scene
        z = self.course.height_m or 0.0
        self.target_nodes = [scene.add_icosphere(f"/course/target{i}", radius=self.course.target_radius_m,
                                                 color=(120, 120, 120), position=(x, y, z), opacity=0.6)
                             for i, (x, y) in enumerate(self.course.targets_m)]
        for i, tri in enumerate(self.course.obstacles_m):
            pts = np.array([[*tri[k], z] for k in (0, 1, 1, 2, 2, 0)]).reshape(3, 2, 3)
            scene.add_line_segments(f"/course/obstacle{i}", pts, (200, 40, 40), thickness=0.004)

    def _make_participant_gui(self) -> None:
        gui = self.server.gui
        self.progress = gui.add_markdown("**Waiting for the operator to start the trial.**")
        self.word = gui.add_html("")
        self.answer_buttons = []
        for colour in COLOURS:
            button = gui.add_button(colour.capitalize(), visible=False)

            @button.on_click
            def _(_event, colour=colour) -> None:
                with self._lock:
                    if self.current is not None and self.current[1].colour is not None:
                        self.current[1].colour.answer(self.loop.snapshot().t_s, colour)
            self.answer_buttons.append(button)
        gui.add_folder("Operator")

    def _offer_operator_login(self, client: viser.ClientHandle) -> None:
        with client.gui.add_folder("Operator login"):
            token = client.gui.add_text("Token", initial_value="")

        @token.on_update
        def _(_event) -> None:
            if token.value.strip() == self.token:
                self._make_operator_panel(client)

    def _make_operator_panel(self, client: viser.ClientHandle) -> None:
        gui = client.gui
        with gui.add_folder("Operator panel"):
            plan = gui.add_markdown(self._plan_text())
            start = gui.add_button("Start next trial")
            abort = gui.add_button("Abort trial")
            repeat = gui.add_button("Repeat last trial")
        start.on_click(lambda _e: (self.start_next(), setattr(plan, "content", self._plan_text())))
        abort.on_click(lambda _e: (self.abort(), setattr(plan, "content", self._plan_text())))
        repeat.on_click(lambda _e: (self.repeat_last(), setattr(plan, "content", self._plan_text())))

    def _plan_text(self) -> str:
        done = self.store.done()
        rows = [f"- {'~~' if (t.participant, t.attention, t.condition) in done else ''}{t.participant} "
                f"#{t.order} {t.attention} / {t.condition}{'~~' if (t.participant, t.attention, t.condition) in done else ''}"
                for t in self.plan]
        current = f"**Running:** {self.current[0].participant} {self.current[0].attention} / {self.current[0].condition}\n\n" if self.current else ""
        return f"Seed {self.seed}. Log: `{self.store.path}`\n\n{current}" + "\n".join(rows)

    # ---- operator actions ------------------------------------------------------------------
    def start_next(self) -> PlannedTrial | None:
        done = self.store.done()
        for trial in self.plan:
            if (trial.participant, trial.attention, trial.condition) not in done:
                return self.start(trial)
        return None

    def start(self, trial: PlannedTrial) -> PlannedTrial:
        with self._lock:
            self.loop.reset()
            self.loop.method = trial.condition  # never shown to the participant
            k = self.plan.index(trial)
            self.current = (trial, TrialRun(self.course, trial.attention == "divided", self.seed * 1000 + k))
        for button in self.answer_buttons:
            button.visible = trial.attention == "divided"
        self.progress.content = f"**Trial {trial.order} of 4.** Reach target 1 of {len(self.course.targets_m)}."
        return trial

    def abort(self) -> None:
        with self._lock:
            self.current = None
        self.loop.release_gizmo()
        self.progress.content = "**Trial stopped. Waiting for the operator.**"
        self.word.content = ""

    def repeat_last(self) -> None:
        with self._lock:
            trial = self.current[0] if self.current else None
        if trial is not None:
            self.start(trial)

    # ---- loop and rendering ------------------------------------------------------------
    def _before_step(self, t_s: float) -> None:
        if self.current is None:
            return
        trial, run = self.current
        report = self.loop._report
        moving = report is not None and float(np.linalg.norm(report.v_executed_m_s)) > 1e-3
        run.update(t_s, self.teleop.p_base_ee_m, moving)
        if run.colour is not None:  # the secondary task runs from the operator's start
            run.colour.tick(t_s)
        if run.finished:
            self._finished.append(self.current)
            self.current = None

    def render_once(self) -> None:
        snapshot = self.loop.snapshot()
        self.scene.render(snapshot, self.loop.read(self.scene.read))
        if not snapshot.dragging:
            self.gizmo.position = tuple(snapshot.p_base_ee_m)
        with self._lock:
            finished, self._finished = self._finished, []
            current = self.current
        for trial, run in finished:
            record = run.record(trial.participant, trial.condition, trial.order, run.seed)
            self.store.append(record, np.array(run.trajectory).reshape(-1, 4))
            self.progress.content = "**Trial complete. Thank you! Waiting for the operator.**"
            self.word.content = ""
            for button in self.answer_buttons:
                button.visible = False
        if current is not None:
            _, run = current
            for i, node in enumerate(self.target_nodes):
                node.color = (40, 160, 40) if i == run.next_target else ((150, 150, 150) if i > run.next_target else (200, 200, 200))
            self.progress.content = f"Reach target {min(run.next_target + 1, len(self.target_nodes))} of {len(self.target_nodes)}."
            if run.colour is not None and run.colour.current is not None:
                s = run.colour.current
                self.word.content = f'<div style="font-size:48px;font-weight:bold;color:{INK_RGB[s.ink]}">{s.word.upper()}</div>'

    def start_server(self) -> "TrialServer":
        self.loop.start()
        threading.Thread(target=self._render_run, daemon=True, name="trial-render").start()
        return self

    def _render_run(self) -> None:
        while not self._stop.is_set():
            try:
                self.render_once()
            except Exception:  # noqa: BLE001 - rendering must not stop the trial
                logger.exception("render failed")
            time.sleep(1 / 30)

    @property
    def url(self) -> str:
        return f"http://{self.server.get_host()}:{self.server.get_port()}"

    def stop(self) -> None:
        self._stop.set()
        self.loop.stop()
        self.server.stop()
