"""The browser trial: a participant view and, on its own port, an operator view behind a token.

Participant view (every browser at ``url``): the robot (the planar arm seen from above, or a 3D
arm with ``robot="panda"`` etc., its course in a horizontal plane), the course (targets in
order, triangles that flash when touched), the gizmo to drag, "Trial k of 4" with the target
to reach, and, in divided attention, the colour word with four answer buttons. It never names
the condition and shows no operator box or login.
Operator view (``operator_url``, printed with the token at start): enter the token; a wrong
token is said so and cleared, the right one replaces the login with the participant
selector-free plan (with conditions), Start / Abort / Repeat and live status. Finished trials
go to the ``LogStore`` at once (durable, resumable).

The trial, and with it the colour task, starts at the participant's first motion after the
operator's Start: no colour word is shown before it. The demo's protection zones (F, G) are not
part of the trial scene: the course's triangles are the only obstacles.
"""

from __future__ import annotations

import logging
import secrets
import threading
import time
from pathlib import Path

import numpy as np
import viser

from cobotsafety.app.camera import lock_orbit
from cobotsafety.app.control_loop import ControlLoop, LoopSettings
from cobotsafety.app.gizmo import add_gizmo
from cobotsafety.app.scenes import make_scene
from cobotsafety.trial.colour_task import COLOURS
from cobotsafety.trial.course import Course, arm_course, planar_course
from cobotsafety.trial.log_store import LogStore
from cobotsafety.trial.plan import PlannedTrial, session_plan
from cobotsafety.trial.session import TrialRun

logger = logging.getLogger(__name__)
INK_RGB = {"red": "#d62728", "green": "#2ca02c", "blue": "#1f77b4", "yellow": "#e6b800"}
TOUCH_FLASH_S = 0.8
"""How long a touched triangle stays highlighted and the touch message shows [s]."""
OBSTACLE_RGB = (200, 40, 40)
TOUCHED_RGB = (255, 150, 0)


class TrialServer:
    def __init__(self, out: Path, participants: list[str], seed: int = 0, host: str = "127.0.0.1",
                 port: int = 8080, course: Course | None = None, robot: str = "planar",
                 operator_port: int | None = None):
        self.store = LogStore(out)
        self.seed = seed
        self.plan = session_plan(participants, seed=seed)
        self.course = course or (planar_course() if robot == "planar" else arm_course())
        self.token = secrets.token_hex(4)
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.operator_server = viser.ViserServer(host=host, port=operator_port or self.server.get_port() + 1,
                                                 verbose=False)
        self.scene = make_scene(self.server, robot)
        self.teleop = self.scene.robot
        self._remove_demo_zones()
        self.loop = ControlLoop(self.teleop, LoopSettings())
        self.loop.before_step.append(self._before_step)
        self.current: tuple[PlannedTrial, TrialRun] | None = None
        self.last_trial: PlannedTrial | None = None
        """The trial started last (Repeat restarts it, also after an Abort)."""
        self.status = "Waiting: no trial started yet."
        """The operator's one-line state of the session (plan status)."""
        self._finished: list[tuple[PlannedTrial, TrialRun]] = []
        self._operator_plans: list[viser.GuiMarkdownHandle] = []
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._touch_until_s = 0.0
        self._touch_obstacle: int | None = None
        self._errors_seen = 0
        self._draw_course()
        self._make_participant_gui()
        self.gizmo = add_gizmo(self.server, self.scene.gizmo_axes, self.teleop.p_base_ee_m)  # the demo's handle
        lock_orbit(self.server)  # the view is part of the task (issue 25 item 5)

        @self.gizmo.on_update
        def _(event: viser.TransformControlsEvent) -> None:
            if event.phase == "end":
                self.loop.release_gizmo()
            elif self.current is not None:
                self.loop.set_gizmo_target(np.asarray(event.target.position, dtype=float))

        @self.operator_server.on_client_connect
        def _(client: viser.ClientHandle) -> None:
            self._offer_operator_login(client)

    # ---- views -----------------------------------------------------------------------------
    def _remove_demo_zones(self) -> None:
        """The course's triangles are the only obstacles: drop the demo's protection zones."""
        from cobotsafety.app.scene_planar import is_zone  # noqa: PLC0415

        if self.scene.dim == 2:
            limitations = self.teleop.scene.limitations
            limitations[:] = [lim for lim in limitations if not is_zone(lim)]
        else:
            self.teleop.zones = []
        self.scene.redraw()

    def _draw_course(self) -> None:
        scene = self.server.scene
        z = self.course.height_m or 0.0
        self.target_nodes = [scene.add_icosphere(f"/course/target{i}", radius=self.course.target_radius_m,
                                                 color=(120, 120, 120), position=(x, y, z), opacity=0.6)
                             for i, (x, y) in enumerate(self.course.targets_m)]
        # Two nodes per triangle, toggled by visibility: a line colour change does not reach a
        # tab that already drew the line.
        self.obstacle_nodes = []
        for i, tri in enumerate(self.course.obstacles_m):
            pts = np.array([[*tri[k], z] for k in (0, 1, 1, 2, 2, 0)]).reshape(3, 2, 3)
            normal = scene.add_line_segments(f"/course/obstacle{i}", pts, OBSTACLE_RGB, thickness=0.004)
            touched = scene.add_line_segments(f"/course/obstacle{i}_touched", pts, TOUCHED_RGB, thickness=0.012,
                                              visible=False)
            self.obstacle_nodes.append((normal, touched))

    def _make_participant_gui(self) -> None:
        gui = self.server.gui
        self.progress = gui.add_markdown("**Waiting for the operator to start the trial.**")
        self.feedback = gui.add_markdown("")
        self.word = gui.add_html("")
        self.answer_buttons = []
        for colour in COLOURS:
            button = gui.add_button(colour.capitalize(), visible=False, color="gray")  # no ink colour of its own

            @button.on_click
            def _(_event, colour=colour) -> None:
                with self._lock:
                    if self.current is not None and self.current[1].colour is not None:
                        self.current[1].colour.answer(self.loop.snapshot().t_s, colour)
            self.answer_buttons.append(button)

    def _offer_operator_login(self, client: viser.ClientHandle) -> None:
        with client.gui.add_folder("Operator login") as folder:
            token = client.gui.add_text("Token", initial_value="", hint="the token printed when the trial started")
            feedback = client.gui.add_markdown("Enter the operator token.")

        @token.on_update
        def _(_event) -> None:
            entered = token.value.strip()
            if not entered:
                return
            if entered == self.token:
                folder.remove()  # the token leaves the page once accepted
                self._make_operator_panel(client)
            elif len(entered) >= len(self.token):
                token.value = ""
                feedback.content = "**Wrong token.** Try again."
                logger.warning("operator login refused (client %s)", client.client_id)

    def _make_operator_panel(self, client: viser.ClientHandle) -> None:
        gui = client.gui
        with gui.add_folder("Operator panel"):
            plan = gui.add_markdown(self._plan_text())
            start = gui.add_button("Start next trial")
            abort = gui.add_button("Abort trial")
            repeat = gui.add_button("Repeat last trial")
        self._operator_plans.append(plan)
        start.on_click(lambda _e: (self.start_next(), self._refresh_plans()))
        abort.on_click(lambda _e: (self.abort(), self._refresh_plans()))
        repeat.on_click(lambda _e: (self.repeat_last(), self._refresh_plans()))

    def _plan_text(self) -> str:
        done = self.store.done()
        rows = []
        for t in self.plan:
            strike = "~~" if (t.participant, t.attention, t.condition) in done else ""
            rows.append(f"- {strike}{t.participant} #{t.order} {t.attention} / {t.condition}{strike}")
        return f"Seed {self.seed}. Log: `{self.store.path}`\n\n**{self.status}**\n\n" + "\n".join(rows)

    def _refresh_plans(self) -> None:
        text = self._plan_text()
        for plan in list(self._operator_plans):
            try:
                if plan.content != text:
                    plan.content = text
            except RuntimeError:  # that operator tab has gone
                self._operator_plans.remove(plan)

    @staticmethod
    def _describe(trial: PlannedTrial) -> str:
        return f"{trial.participant} #{trial.order} {trial.attention} / {trial.condition}"

    # ---- operator actions ------------------------------------------------------------------
    def start_next(self) -> PlannedTrial | None:
        done = self.store.done()
        for trial in self.plan:
            if (trial.participant, trial.attention, trial.condition) not in done:
                return self.start(trial)
        self.status = "Session complete: every planned trial is logged."
        return None

    def start(self, trial: PlannedTrial) -> PlannedTrial:
        with self._lock:
            self.loop.reset()
            self.loop.method = trial.condition  # never shown to the participant
            k = self.plan.index(trial)
            self.current = (trial, TrialRun(self.course, trial.attention == "divided", self.seed * 1000 + k))
            self.last_trial = trial
            self.status = f"Running: {self._describe(trial)} (starts at the first motion)"
            self._errors_seen = 0
        for button in self.answer_buttons:
            button.visible = trial.attention == "divided"
        self.word.content = ""
        self.feedback.content = ""
        self.progress.content = self._progress_text(trial, 0)
        return trial

    def abort(self) -> None:
        with self._lock:
            aborted, self.current = self.current, None
            if aborted is not None:
                self.status = f"Aborted: {self._describe(aborted[0])} (not logged; Repeat restarts it)"
        self.loop.release_gizmo()
        self.progress.content = "**Trial stopped. Waiting for the operator.**"
        self.word.content = ""
        self.feedback.content = ""
        for button in self.answer_buttons:
            button.visible = False

    def repeat_last(self) -> PlannedTrial | None:
        """Restart the trial started last, whether it is running, aborted or finished."""
        with self._lock:
            trial = self.last_trial
        return None if trial is None else self.start(trial)

    # ---- loop and rendering ------------------------------------------------------------
    def _progress_text(self, trial: PlannedTrial, next_target: int) -> str:
        count = len(self.course.targets_m)
        return f"**Trial {trial.order} of 4.** Reach target {min(next_target + 1, count)} of {count}."

    def _before_step(self, t_s: float) -> None:
        if self.current is None:
            return
        trial, run = self.current
        report = self.loop._report
        moving = report is not None and float(np.linalg.norm(report.v_executed_m_s)) > 1e-3
        run.update(t_s, self.teleop.p_base_ee_m, moving)
        if run.colour is not None and run.started_s is not None:  # the colour task starts with the trial
            run.colour.tick(t_s)
        if run.finished:
            self._finished.append(self.current)
            self.current = None

    def _show_touches(self, run: TrialRun | None) -> None:
        now = time.perf_counter()
        if run is not None and len(run.errors) > self._errors_seen:
            self._touch_obstacle = run.errors[-1].get("obstacle")
            self._touch_until_s = now + TOUCH_FLASH_S
            self._errors_seen = len(run.errors)
            self.feedback.content = "**Obstacle touched!** Keep clear of the triangles."
        flashing = now < self._touch_until_s
        for i, (normal, touched) in enumerate(self.obstacle_nodes):
            on = flashing and i == self._touch_obstacle
            touched.visible, normal.visible = on, not on
        if not flashing and self.feedback.content:
            self.feedback.content = ""

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
            self.status = f"Finished: {self._describe(trial)} (logged). Start the next trial."
            self.progress.content = "**Trial complete. Thank you! Waiting for the operator.**"
            self.word.content = ""
            for button in self.answer_buttons:
                button.visible = False
        self._show_touches(current[1] if current is not None else None)
        if current is not None:
            trial, run = current
            if run.started_s is not None:
                self.status = f"Running: {self._describe(trial)}, target {run.next_target + 1}"
            for i, node in enumerate(self.target_nodes):
                node.color = (40, 160, 40) if i == run.next_target else ((150, 150, 150) if i > run.next_target else (200, 200, 200))
            text = self._progress_text(trial, run.next_target)
            if text != self.progress.content:
                self.progress.content = text
            if run.colour is not None and run.colour.current is not None:
                s = run.colour.current
                html = (f'<div style="font-size:48px;font-weight:bold;padding:0 0.4em;'
                        f'color:{INK_RGB[s.ink]}">{s.word.upper()}</div>')
                if html != self.word.content:
                    self.word.content = html
        self._refresh_plans()

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

    @property
    def operator_url(self) -> str:
        return f"http://{self.operator_server.get_host()}:{self.operator_server.get_port()}"

    def stop(self) -> None:
        self._stop.set()
        self.loop.stop()
        self.server.stop()
        self.operator_server.stop()
