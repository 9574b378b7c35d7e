"""The browser trial: a participant view and, on its own port, an operator view behind a token.

Participant view (every browser at ``url``): the robot (the planar arm seen from above, or a 3D
arm with ``robot="panda"`` etc., its course in a horizontal plane), the course (targets in
order, triangles that flash when touched), the gizmo to drag, "Trial k of 4" with the target
to reach, and, in divided attention, the colour word. It never names the condition and shows
no operator box or login. The robot may also be driven with a joystick or a 3D mouse read on
the server (``device``, ``app.input_device``), as paper 1's participants drove with a joystick.
Colour answers: ``answers="aloud"`` (default, as in paper 1): the participant says the ink
aloud and the operator presses Right / Wrong / Missed in the operator view, which shows the
current word (the key press time is logged as the answer time); ``answers="buttons"``: four
answer buttons on the participant's page (clicking them stops the drag: the dual task is then
not the paper's, and the report should say so).
Operator view (``operator_url``, printed with the token at start): enter the token; a wrong
token is said so and cleared, the right one replaces the login with the participant's scene
(mirrored), the trial's progress, the plan (with conditions), Start next / Abort / Repeat /
Skip and live status. Start next and Repeat never discard a trial in progress: while a trial
runs they are refused (Abort first), and after an Abort Start next refuses to restart the
aborted trial silently (Repeat restarts it, Skip logs it as not finished with a reason).
Finished and skipped trials go to the ``LogStore`` at once (durable, resumable); ``plan.json``
(the plan and the pre-declared analysis) is written before the first trial.
retries a trial that cannot be written every ``RETRY_WRITE_S`` and shows it to the operator as an
error until it is.

Access (issue 22): both servers refuse viser's share tunnel and check every value a browser
sends (``cobotsafety.app.access.ServerGuard``); the operator token has 128 bits, is compared in
constant time, and each connection waits longer after each wrong one (``TokenGate``).
Pseudonyms are checked before anything starts (``cobotsafety.trial.pseudonyms``).

The trial, and with it the colour task, starts at the participant's first motion after the
operator's Start: no colour word is shown before it. The scene and the course are
``trial_scene``'s, the ones the simulated participant drives: the course's triangles are the
only obstacles.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import viser

from cobotsafety.app.access import ServerGuard, TokenGate, Verdict, check_bindable
from cobotsafety.app.camera import lock_orbit
from cobotsafety.app.control_loop import ControlLoop, LoopSettings
from cobotsafety.app.gizmo import add_gizmo
from cobotsafety.app.scenes import make_scene
from cobotsafety.errors import CobotSafetyError
from cobotsafety.trial.colour_task import COLOURS, VERDICTS
from cobotsafety.trial.course import Course
from cobotsafety.trial.log_store import LogStore
from cobotsafety.trial.plan import PlannedTrial, session_plan, write_plan
from cobotsafety.trial.pseudonyms import check_pseudonyms
from cobotsafety.trial.session import TrialRun
from cobotsafety.trial.trial_scene import prepare_trial_robot, trial_course

logger = logging.getLogger(__name__)
INK_RGB = {"red": "#d62728", "green": "#2ca02c", "blue": "#1f77b4", "yellow": "#e6b800"}
TOUCH_FLASH_S = 0.8
"""How long a touched triangle stays highlighted and the touch message shows [s]."""
OBSTACLE_RGB = (200, 40, 40)
TOUCHED_RGB = (255, 150, 0)
DEFAULT_PORT = 8090
"""The participant view's port (the operator's is the next one); the demo's is 8080."""
RETRY_WRITE_S = 5.0
"""How often a finished trial that could not be written is tried again [s]."""

ANSWER_MODES = ("aloud", "buttons")
MAX_REASON_CHARS = 200


def clean_reason(text: str) -> str | None:
    """A skip reason fit for the log: one line, printable, at most ``MAX_REASON_CHARS``; None
    when empty."""
    line = " ".join(str(text).split())
    line = "".join(ch for ch in line if ch.isprintable())[:MAX_REASON_CHARS]
    return line or None


@dataclass
class OperatorPanel:
    """One operator tab's live elements."""

    plan: viser.GuiMarkdownHandle
    progress: viser.GuiMarkdownHandle
    word: viser.GuiHtmlHandle
    verdicts: list


class CourseNodes:
    """The course drawn on one server: targets (coloured by progress) and triangles (two nodes
    each, toggled by visibility: a line colour change does not reach a tab that drew it)."""

    def __init__(self, server: viser.ViserServer, course: Course):
        scene = server.scene
        z = course.height_m or 0.0
        self.targets = [scene.add_icosphere(f"/course/target{i}", radius=course.target_radius_m,
                                            color=(120, 120, 120), position=(x, y, z), opacity=0.6)
                        for i, (x, y) in enumerate(course.targets_m)]
        self.obstacles = []
        for i, tri in enumerate(course.obstacles_m):
            pts = np.array([[*tri[k], z] for k in (0, 1, 1, 2, 2, 0)]).reshape(3, 2, 3)
            normal = scene.add_line_segments(f"/course/obstacle{i}", pts, OBSTACLE_RGB, thickness=0.004)
            touched = scene.add_line_segments(f"/course/obstacle{i}_touched", pts, TOUCHED_RGB, thickness=0.012,
                                              visible=False)
            self.obstacles.append((normal, touched))
        self._next: int | None = None
        self._flash: int | None = None

    def show(self, next_target: int | None, flashing: int | None) -> None:
        if next_target != self._next:
            for i, node in enumerate(self.targets):
                node.color = ((120, 120, 120) if next_target is None else (40, 160, 40) if i == next_target
                              else (150, 150, 150) if i > next_target else (200, 200, 200))
            self._next = next_target
        if flashing != self._flash:
            for i, (normal, touched) in enumerate(self.obstacles):
                on = i == flashing
                touched.visible, normal.visible = on, not on
            self._flash = flashing


def mirror_view(server: viser.ViserServer, teleop, dim: int):
    """The robot's view on another server (the operator's), fed the same render data."""
    if dim == 2:
        from cobotsafety.app.scene_planar import PlanarView  # noqa: PLC0415

        return PlanarView(server, teleop)
    from cobotsafety.app.scene_arm import ArmView  # noqa: PLC0415

    return ArmView(server, teleop)


def render_mirror(view, dim: int, snapshot, data: dict) -> None:
    if dim == 2:
        view.update(snapshot, data["elbow"])
    else:
        view.update(snapshot, data["q"], data["capsules"])


class TrialServer:
    def __init__(self, out: Path, participants: list[str], seed: int = 0, host: str = "127.0.0.1",
                 port: int = DEFAULT_PORT, course: Course | None = None, robot: str = "planar",
                 operator_port: int | None = None, answers: str = "aloud", device=None):
        if answers not in ANSWER_MODES:
            raise ValueError(f"answers must be one of {ANSWER_MODES}, got {answers!r}")
        check_pseudonyms(participants)
        check_bindable(host)
        self.store = LogStore(out)
        self.seed = seed
        self.answers = answers
        self.plan = session_plan(participants, seed=seed)
        self.scene_kind = "planar" if robot == "planar" else "arm"
        self.course = course or trial_course(self.scene_kind)
        write_plan(out, self.plan, seed, answers=answers, scene=self.scene_kind, robot=robot)
        self.gate = TokenGate(what="operator token")
        self.token = self.gate.token
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.operator_server = viser.ViserServer(host=host, port=operator_port or self.server.get_port() + 1,
                                                 verbose=False)
        self.guard = ServerGuard(self.server)
        self.operator_guard = ServerGuard(self.operator_server, may_change=self.gate.is_authorised)
        self._unwritten: list[tuple[PlannedTrial, TrialRun, str | None]] = []
        self._retry_write_s = 0.0
        self._write_error = ""
        self.scene = make_scene(self.server, robot)
        self.teleop = self.scene.robot
        prepare_trial_robot(self.teleop, self.scene_kind)
        self.scene.redraw()
        self.loop = ControlLoop(self.teleop, LoopSettings())
        self.loop.before_step.append(self._before_step)
        self.current: tuple[PlannedTrial, TrialRun] | None = None
        self.last_trial: PlannedTrial | None = None
        """The trial started last (Repeat restarts it after an Abort)."""
        self.aborted: PlannedTrial | None = None
        """The trial aborted last and not restarted or skipped since (Start next will not restart it)."""
        self.status = "Waiting: no trial started yet."
        """The operator's one-line state of the session (plan status)."""
        self._finished: list[tuple[PlannedTrial, TrialRun, str | None]] = []
        self._operator_panels: list[OperatorPanel] = []
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._touch_until_s = 0.0
        self._touch_obstacle: int | None = None
        self._errors_seen = 0
        self.course_nodes = CourseNodes(self.server, self.course)
        self.operator_course_nodes = CourseNodes(self.operator_server, self.course)
        self.operator_view = mirror_view(self.operator_server, self.teleop, self.scene.dim)
        self._make_participant_gui()
        self.gizmo = add_gizmo(self.server, self.scene.gizmo_axes, self.teleop.p_base_ee_m)  # the demo's handle
        lock_orbit(self.server)  # the view is part of the task (issue 25 item 5)
        self.device_feeder = None
        if device is not None:
            from cobotsafety.app.input_device import DeviceFeeder  # noqa: PLC0415

            self.device_feeder = DeviceFeeder(device, self._device_velocity, self.scene.dim)

        @self.gizmo.on_update
        def _(event: viser.TransformControlsEvent) -> None:
            if event.phase == "end":
                self.loop.release_gizmo()
            elif self.current is not None:
                self.loop.set_gizmo_target(np.asarray(event.target.position, dtype=float))

        @self.operator_server.on_client_connect
        def _(client: viser.ClientHandle) -> None:
            self._offer_operator_login(client)

        @self.operator_server.on_client_disconnect
        def _(client: viser.ClientHandle) -> None:
            self.gate.forget(client.client_id)

    @property
    def target_nodes(self) -> list:
        return self.course_nodes.targets

    @property
    def obstacle_nodes(self) -> list:
        return self.course_nodes.obstacles

    def _device_velocity(self, v_m_s) -> None:
        """The input device drives the robot only while a trial is on."""
        self.loop.set_device_velocity(v_m_s if self.current is not None else None)

    # ---- views -----------------------------------------------------------------------------
    def _make_participant_gui(self) -> None:
        gui = self.server.gui
        self.progress = gui.add_markdown("**Waiting for the operator to start the trial.**")
        self.feedback = gui.add_markdown("")
        self.word = gui.add_html("")
        self.answer_buttons = []
        if self.answers != "buttons":
            return
        for colour in COLOURS:
            button = gui.add_button(colour.capitalize(), visible=False, color="gray")  # no ink colour of its own

            @button.on_click
            def _(_event, colour=colour) -> None:
                with self._lock:
                    if self.current is not None and self.current[1].colour is not None:
                        self.current[1].colour.answer(self.loop.snapshot().t_s, colour)
            self.answer_buttons.append(button)

    def _offer_operator_login(self, client: viser.ClientHandle) -> None:
        self.operator_guard.protect_client(client)  # before its controls exist
        with client.gui.add_folder("Operator login") as folder:
            token = client.gui.add_text("Token", initial_value="", hint="the token printed when the trial started")
            feedback = client.gui.add_markdown("Enter the operator token.")

        @token.on_update
        def _(_event) -> None:
            verdict = self.gate.check(client.client_id, token.value)
            if verdict is Verdict.ACCEPTED:
                folder.remove()  # the token leaves the page once accepted
                self._make_operator_panel(client)
            elif verdict in (Verdict.WRONG, Verdict.WAIT):
                token.value = ""
                wait_s = self.gate.wait_s(client.client_id)
                feedback.content = (f"**Wrong token.** Try again in {wait_s:.0f} s." if verdict is Verdict.WRONG
                                    else f"**Too soon.** Wait {wait_s:.0f} s, then try again.")

    def _make_operator_panel(self, client: viser.ClientHandle) -> None:
        gui = client.gui
        with gui.add_folder("Trial"):
            progress = gui.add_markdown(self._operator_progress())
            word = gui.add_html("")
            verdicts = []
            for verdict in VERDICTS:
                button = gui.add_button(verdict.capitalize(), visible=False,
                                        hint="the participant's spoken answer to the word shown (time logged)")
                button.on_click(lambda _e, verdict=verdict: self.judge(verdict))
                verdicts.append(button)
        with gui.add_folder("Session"):
            plan = gui.add_markdown(self._plan_text())
            start = gui.add_button("Start next trial")
            abort = gui.add_button("Abort trial")
            repeat = gui.add_button("Repeat last trial")
            reason = gui.add_text("Skip reason", initial_value="", hint="why the participant cannot finish (logged)")
            skip = gui.add_button("Skip trial", hint="log the current or aborted trial as not finished, with the reason")
        self._operator_panels.append(OperatorPanel(plan, progress, word, verdicts))
        start.on_click(lambda _e: (self.start_next(), self._refresh_operator()))
        abort.on_click(lambda _e: (self.abort(), self._refresh_operator()))
        repeat.on_click(lambda _e: (self.repeat_last(), self._refresh_operator()))

        @skip.on_click
        def _(_event) -> None:
            if self.skip(reason.value) is not None:
                reason.value = ""
            self._refresh_operator()

    def _plan_text(self) -> str:
        done = self.store.done()
        rows = []
        for t in self.plan:
            strike = "~~" if (t.participant, t.attention, t.condition) in done else ""
            rows.append(f"- {strike}{t.participant} #{t.order} {t.attention} / {t.condition}{strike}")
        unwritten = f"**{self._write_error}**\n\n" if self._unwritten else ""  # shown until written
        return f"Seed {self.seed}. Log: `{self.store.path}`\n\n{unwritten}**{self.status}**\n\n" + "\n".join(rows)

    def _operator_progress(self) -> str:
        current = self.current
        if current is None:
            return "No trial running."
        trial, run = current
        count = len(self.course.targets_m)
        if run.started_s is None:
            return f"**{self._describe(trial)}**: waiting for the participant's first motion."
        elapsed = self.loop.snapshot().t_s - run.started_s
        words = "" if run.colour is None else f", words shown {len(run.colour.stimuli)}"
        return (f"**{self._describe(trial)}**: target {min(run.next_target + 1, count)} of {count}, "
                f"{elapsed:.0f} s, triangles touched {len(run.errors)}{words}")

    def _word_html(self, stimulus, size_px: int) -> str:
        return (f'<div style="font-size:{size_px}px;font-weight:bold;padding:0 0.4em;'
                f'color:{INK_RGB[stimulus.ink]}">{stimulus.word.upper()}</div>')

    def _refresh_operator(self) -> None:
        plan_text, progress = self._plan_text(), self._operator_progress()
        current = self.current
        run = current[1] if current is not None else None
        stimulus = run.colour.current if run is not None and run.colour is not None else None
        aloud = self.answers == "aloud" and run is not None and run.colour is not None
        word = ""
        if stimulus is not None and aloud:
            state = "" if stimulus.judged_by is None else f" <small>({self._verdict_of(stimulus)})</small>"
            word = (self._word_html(stimulus, 36)[:-6] + f'</div><div>answer the <b>ink</b>: '
                    f'{stimulus.ink}{state}</div>')
        for panel in list(self._operator_panels):
            try:
                if panel.plan.content != plan_text:
                    panel.plan.content = plan_text
                if panel.progress.content != progress:
                    panel.progress.content = progress
                if panel.word.content != word:
                    panel.word.content = word
                for button in panel.verdicts:
                    if button.visible != aloud:
                        button.visible = aloud
            except RuntimeError:  # that operator tab has gone
                self._operator_panels.remove(panel)

    _refresh_plans = _refresh_operator

    @staticmethod
    def _verdict_of(stimulus) -> str:
        return "missed" if stimulus.answer is None else ("right" if stimulus.answer == stimulus.ink else "wrong")

    @staticmethod
    def _describe(trial: PlannedTrial) -> str:
        return f"{trial.participant} #{trial.order} {trial.attention} / {trial.condition}"

    # ---- operator actions ------------------------------------------------------------------
    def _refuse(self, why: str) -> None:
        self.status = f"Refused: {why}"
        logger.info("operator action refused: %s", why)

    def start_next(self) -> PlannedTrial | None:
        """Start the next planned trial not yet logged; refused (None, status says why) while a
        trial runs, and when the next one is the trial just aborted."""
        with self._lock:
            if self.current is not None:
                self._refuse(f"{self._describe(self.current[0])} is running. Abort it first (its progress is "
                             "not logged), then Start next.")
                return None
            done = self.store.done()
            upcoming = next((t for t in self.plan if (t.participant, t.attention, t.condition) not in done), None)
            if upcoming is None:
                self.status = "Session complete: every planned trial is logged."
                return None
            if upcoming == self.aborted:
                self._refuse(f"the next trial, {self._describe(upcoming)}, was aborted. Repeat restarts it from the "
                             "beginning; Skip logs it as not finished (with a reason).")
                return None
            return self.start(upcoming)

    def start(self, trial: PlannedTrial) -> PlannedTrial:
        with self._lock:
            self.loop.reset()
            self.loop.method = trial.condition  # never shown to the participant
            k = self.plan.index(trial)
            self.current = (trial, TrialRun(self.course, trial.attention == "divided", self.seed * 1000 + k))
            self.last_trial = trial
            self.aborted = None
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
                self.aborted = aborted[0]
                self.status = (f"Aborted: {self._describe(aborted[0])} (not logged; Repeat restarts it, Skip logs it "
                               "as not finished)")
        self.loop.release_gizmo()
        self.loop.set_device_velocity(None)
        self._participant_idle("**Trial stopped. Waiting for the operator.**")

    def repeat_last(self) -> PlannedTrial | None:
        """Restart the trial started last if it is aborted (or was never finished); refused while
        a trial runs and for a trial already logged."""
        with self._lock:
            trial = self.last_trial
            if trial is None:
                self._refuse("no trial to repeat yet.")
                return None
            if self.current is not None:
                self._refuse(f"{self._describe(self.current[0])} is running. Abort it first, then Repeat.")
                return None
            if (trial.participant, trial.attention, trial.condition) in self.store.done():
                self._refuse(f"{self._describe(trial)} is already logged; Start next goes on with the plan.")
                return None
        return self.start(trial)

    def skip(self, reason: str) -> PlannedTrial | None:
        """Log the running or the aborted trial as not finished, with ``reason`` (required)."""
        cleaned = clean_reason(reason)
        with self._lock:
            if cleaned is None:
                self._refuse("give the reason for skipping the trial (it is logged).")
                return None
            if self.current is not None:
                trial, run = self.current
                self.current = None
            elif self.aborted is not None:
                trial, run = self.aborted, TrialRun(self.course, self.aborted.attention == "divided",
                                                    self.seed * 1000 + self.plan.index(self.aborted))
            else:
                self._refuse("no running or aborted trial to skip.")
                return None
            self.aborted = None
            self._finished.append((trial, run, cleaned))
        self.loop.release_gizmo()
        self.loop.set_device_velocity(None)
        self._log_finished()
        return trial

    def judge(self, verdict: str) -> bool:
        """The operator's Right / Wrong / Missed for the word shown (answers said aloud)."""
        with self._lock:
            if self.current is None or self.current[1].colour is None:
                return False
            ok = self.current[1].colour.judge(self.loop.snapshot().t_s, verdict)
        self._refresh_operator()
        return ok

    # ---- loop and rendering ------------------------------------------------------------
    def _progress_text(self, trial: PlannedTrial, next_target: int) -> str:
        count = len(self.course.targets_m)
        return f"**Trial {trial.order} of 4.** Reach target {min(next_target + 1, count)} of {count}."

    def _participant_idle(self, text: str) -> None:
        self.progress.content = text
        self.word.content = ""
        self.feedback.content = ""
        for button in self.answer_buttons:
            button.visible = False

    def _before_step(self, t_s: float) -> None:
        if self.current is None:
            return
        trial, run = self.current
        report = self.loop._report
        moving = report is not None and float(np.linalg.norm(report.v_executed_m_s)) > 1e-3
        run.update(t_s, self.teleop.p_base_ee_m, moving)
        run.tick_colour(t_s)  # from the start to the end of the trial only
        if run.finished:
            self._finished.append((trial, run, None))
            self.current = None

    def _log_finished(self) -> None:
        with self._lock:
            finished, self._finished = self._finished, []
        if self._unwritten and time.monotonic() >= self._retry_write_s:
            finished, self._unwritten = self._unwritten + finished, []
        for trial, run, skipped in finished:
            record = run.record(trial.participant, trial.condition, trial.order, run.seed, skip_reason=skipped)
            record["answers"] = self.answers
            try:
                self.store.append(record, np.array(run.trajectory).reshape(-1, 4))
            except (OSError, CobotSafetyError, ValueError) as error:  # kept in memory, retried, shown
                self._unwritten.append((trial, run, skipped))
                self._retry_write_s = time.monotonic() + RETRY_WRITE_S
                message = (f"NOT LOGGED: {self._describe(trial)} could not be written to {self.store.directory} "
                           f"({error}); kept in memory and retried every {RETRY_WRITE_S:.0f} s")
                if message != self._write_error:  # logged once, not at every retry
                    logger.error("%s", message)
                self._write_error = message
                continue
            if skipped is None:
                self.status = f"Finished: {self._describe(trial)} (logged). Start the next trial."
                self._participant_idle("**Trial complete. Thank you! Waiting for the operator.**")
            else:
                self.status = f"Skipped: {self._describe(trial)} (logged as not finished: {skipped})."
                self._participant_idle("**Trial stopped. Waiting for the operator.**")

    def _show_touches(self, run: TrialRun | None) -> int | None:
        now = time.perf_counter()
        if run is not None and len(run.errors) > self._errors_seen:
            self._touch_obstacle = run.errors[-1].get("obstacle")
            self._touch_until_s = now + TOUCH_FLASH_S
            self._errors_seen = len(run.errors)
            self.feedback.content = "**Obstacle touched!** Keep clear of the triangles."
        flashing = now < self._touch_until_s
        if not flashing and self.feedback.content:
            self.feedback.content = ""
        return self._touch_obstacle if flashing else None

    def render_once(self) -> None:
        snapshot = self.loop.snapshot()
        data = self.loop.read(self.scene.read)
        self.scene.render(snapshot, data)
        render_mirror(self.operator_view, self.scene.dim, snapshot, data)
        if not snapshot.dragging:
            self.gizmo.position = tuple(snapshot.p_base_ee_m)
        self._log_finished()
        with self._lock:
            current = self.current
        flashing = self._show_touches(current[1] if current is not None else None)
        next_target = current[1].next_target if current is not None else None
        self.course_nodes.show(next_target, flashing)
        self.operator_course_nodes.show(next_target, flashing)
        if current is not None:
            trial, run = current
            if run.started_s is not None:
                self.status = f"Running: {self._describe(trial)}, target {run.next_target + 1}"
            text = self._progress_text(trial, run.next_target)
            if text != self.progress.content:
                self.progress.content = text
            if run.colour is not None and run.colour.current is not None:
                html = self._word_html(run.colour.current, 48)
                if html != self.word.content:
                    self.word.content = html
        self._refresh_operator()

    def start_server(self) -> "TrialServer":
        self.loop.start()
        if self.device_feeder is not None:
            self.device_feeder.start()
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
        if self.device_feeder is not None:
            self.device_feeder.stop()
        self.loop.stop()
        self.server.stop()
        self.operator_server.stop()
