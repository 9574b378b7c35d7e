"""The demo's control loop: a thread stepping a ``Teleoperated`` robot at a fixed rate, and
feeding it the human.

Inputs (gizmo target, jog buttons, mode) arrive from browser callbacks at any rate; they only
set fields under a lock. Each period the loop turns them into one desired velocity and calls
``robot.step`` with the nominal period; the robot checks it (``ArmController`` refuses
non-finite input, caps the speed, and keeps its own motion limits: no second cap here). The
human comes through this thread too: every ``LoopSettings.human_period_s`` the loop advances the
human source (a replay plays on with the loop's time) and hands the frame to
``robot.set_human``, so a stalled renderer never leaves the controller with an old human; the
snapshot carries that frame for the renderer to draw.

Ticks are due on a fixed grid; a loop held up by a few milliseconds catches up with nominal
steps, a loop further behind (or slower than its period) integrates the time that passed in one
step of at most ``MAX_DT_S`` (``TickSchedule``). ``LoopStats`` keeps the periods, how late each
tick started and the overruns. A step that raises stops the loop (``ControlLoop.failure`` says
why): a controller that failed once is not trusted to go on.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from cobotsafety.app.gizmo import GizmoSettings, offset_to_velocity
from cobotsafety.app.realtime import request_fifo
from cobotsafety.app.tick_schedule import TickSchedule
from cobotsafety.errors import CobotSafetyError
from cobotsafety.human.body import HumanCapsules
from cobotsafety.teleoperated import METHODS, StepReport, Teleoperated

logger = logging.getLogger(__name__)

MAX_DT_S = 0.010
"""Longest step the loop integrates [s] (the filters are tested for dt up to 10 ms)."""


@dataclass(frozen=True)
class LoopSettings:
    rate_hz: float = 1000.0
    """Control rate [Hz] (1 kHz by default, 500 Hz an option); the robot is integrated with
    ``dt_s = 1 / rate_hz``."""
    jog_hold_s: float = 0.3
    """A jog press commands its velocity for this long, then zero [s]."""
    workspace_radius_m: float = 2.0
    """Gizmo targets farther than this from the base are pulled back onto this sphere [m]."""
    max_lag_s: float = MAX_DT_S
    """A tick at most this late [s] still runs with the nominal period (the loop catches up on
    its schedule); later, the ticks missed are dropped and their time integrated in one step
    (``TickSchedule``)."""
    human_period_s: float = 1.0 / 300.0
    """How often the human source is read [s]: paper 2's IMUs come at ~300 Hz (its laser at
    50 Hz); between reads the controller extrapolates the human with its velocity."""
    fifo_priority: int = 0
    """``SCHED_FIFO`` priority of the loop's thread (1-99), where the OS allows it; 0 (default)
    leaves the thread under the normal policy (``cobotsafety.app.realtime``). The demo asks
    for it: with a browser on the same cores the thread otherwise waited up to 400 ms to run."""

    @property
    def dt_s(self) -> float:
        return 1.0 / self.rate_hz


class LoopStats:
    """Periods (tick start to tick start) and lateness of the last ``window`` control ticks, for
    the loop-rate readout and the bench; ``overruns`` counts the ticks that had to drop missed
    ticks (see ``TickSchedule``).

    ``add`` runs in the control thread and ``rate_hz`` is O(1) (a running sum), so a render
    frame can read the rate every frame; ``summary`` sorts the window (bench, status).
    """

    def __init__(self, window: int = 2000):
        self.periods_s: deque[float] = deque(maxlen=window)
        self.late_s: deque[float] = deque(maxlen=window)
        self.overruns = 0
        self._sum_s = 0.0
        self._adds = 0

    def add(self, period_s: float, late_s: float = 0.0) -> None:
        periods = self.periods_s
        if len(periods) == periods.maxlen:
            self._sum_s -= periods[0]
        periods.append(period_s)
        self.late_s.append(late_s)
        self._sum_s += period_s
        self._adds += 1
        if self._adds % periods.maxlen == 0:  # no drift of the running sum
            self._sum_s = math.fsum(periods)

    @property
    def rate_hz(self) -> float:
        """1 / mean period of the window [Hz]; 0 when empty."""
        count = len(self.periods_s)
        return count / self._sum_s if count and self._sum_s > 0.0 else 0.0

    def summary(self) -> dict[str, float]:
        """``rate_hz`` (1 / mean period), ``p50_ms``, ``p99_ms``, ``max_ms`` of the periods,
        ``late_p99_ms`` (tick start after its deadline) and ``overruns``; zeros when empty."""
        periods_list = list(self.periods_s)  # one C-level copy: safe against the control thread
        late_list = list(self.late_s)
        if not periods_list:
            return {"rate_hz": 0.0, "p50_ms": 0.0, "p99_ms": 0.0, "max_ms": 0.0, "late_p99_ms": 0.0,
                    "overruns": float(self.overruns)}
        periods = np.array(periods_list)
        p50, p99 = np.percentile(periods, [50, 99])
        late_p99 = float(np.percentile(late_list, 99)) if late_list else 0.0
        return {"rate_hz": float(1.0 / periods.mean()), "p50_ms": float(p50 * 1e3),
                "p99_ms": float(p99 * 1e3), "max_ms": float(periods.max() * 1e3),
                "late_p99_ms": late_p99 * 1e3, "overruns": float(self.overruns)}


HAND_OVER_SHOWN_S = 1.0
"""How long after the last step over the hand's own limits the snapshot still says so [s] (the
status block refreshes every few frames; an excess lasts tens of steps)."""


@dataclass(frozen=True)
class LoopSnapshot:
    """What the loop did last, for rendering and plots."""

    t_s: float
    """Simulated time since start or reset [s] (steps x dt)."""
    steps: int
    method: str
    report: StepReport | None
    p_base_ee_m: np.ndarray
    """Shape (3,) [m]."""
    v_sent_m_s: np.ndarray
    """Shape (dim,), the desired velocity given to ``robot.step`` [m/s]."""
    dragging: bool
    stats: dict = field(default_factory=dict)
    """``rate_hz``: the loop rate over the last ``LoopStats`` window [Hz] (the full summary is
    ``ControlLoop.stats.summary()``)."""
    human: HumanCapsules | None = None
    """The human frame the controller was given last (None: no human source)."""
    hand_over_limit: bool = False
    """A step within the last ``HAND_OVER_SHOWN_S`` went over the hand's own limits
    (``ArmStepReport.hand_over_limit``: tens of milliseconds at a time, held so that a status
    refresh sees it)."""


class ControlLoop:
    """Steps ``robot`` at ``settings.rate_hz`` in a daemon thread; thread-safe inputs."""

    clock: Callable[[], float] = staticmethod(time.perf_counter)
    """The loop's clock [s] (a test may give a simulated one, with ``sleep``)."""
    sleep: Callable[[float], None] = staticmethod(time.sleep)

    def __init__(self, robot: Teleoperated, settings: LoopSettings = LoopSettings(),
                 gizmo: GizmoSettings = GizmoSettings(), human_source=None):
        self.settings = settings
        self.gizmo = gizmo
        self.lock = threading.RLock()
        self.stats = LoopStats()
        self.human_source = human_source
        """Anything with ``advance(dt_s)`` (move its clock on) and ``capsules() -> HumanCapsules
        | None`` (the human now), e.g. ``ReplayControl``; None: no human."""
        self.failure = ""
        """Why the loop stopped ("" while it runs or was stopped on purpose)."""
        self._robot = robot
        self.before_step: list[Callable[[float], None]] = []
        """Called with the simulated time [s] under the lock before each step (e.g. the trial's
        clock); one that raises is logged (once per distinct error), counted in
        ``hook_failures`` and the step goes on (a failed *step* stops the loop)."""
        self.hook_failures = 0
        self._last_hook_error = ""
        self._method = "anticipative"
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.fifo_refused = ""
        """Why the thread did not get ``settings.fifo_priority`` ("" when it did or none was asked)."""
        self._reset_inputs()

    def _reset_inputs(self) -> None:
        dim = self._robot.dim
        self._gizmo_target_m: np.ndarray | None = None
        self._jog_m_s = np.zeros(dim)
        self._jog_until_s = -1.0
        self._v_sent = np.zeros(dim)
        self._t_s = 0.0
        self._steps = 0
        self._report: StepReport | None = None
        self._hand_over_until_s = -1.0
        self._human: HumanCapsules | None = None
        self._human_due_s = 0.0

    # ---- inputs (any thread) -------------------------------------------------------------
    @property
    def robot(self) -> Teleoperated:
        return self._robot

    @property
    def method(self) -> str:
        return self._method

    @method.setter
    def method(self, method: str) -> None:
        if method not in METHODS:
            raise CobotSafetyError(f"method must be one of {METHODS}, got {method!r}")
        self._method = method

    def set_gizmo_target(self, p_base_gizmo_m: np.ndarray) -> bool:
        """Drag in progress: the gizmo is at ``p_base_gizmo_m`` (shape (3,)) [m].

        Returns False (and ignores it) for a malformed or non-finite position; targets beyond
        ``workspace_radius_m`` are pulled back onto that sphere.
        """
        try:
            target = np.asarray(p_base_gizmo_m, dtype=float).reshape(3)
        except (TypeError, ValueError):
            return False
        if not np.all(np.isfinite(target)):
            return False
        radius = float(np.linalg.norm(target))
        if radius > self.settings.workspace_radius_m:
            target = target * (self.settings.workspace_radius_m / radius)
        with self.lock:
            self._gizmo_target_m = target
        return True

    _device_v_m_s: np.ndarray | None = None
    """The input device's last velocity (None: no device), set by ``set_device_velocity``."""

    def set_device_velocity(self, v_m_s: np.ndarray | None) -> bool:
        """The input device (joystick, 3D mouse; ``app.input_device``) asks for ``v_m_s`` [m/s]
        (shape (dim,), or more: the first dim components are used); None = no device. Used when
        no gizmo drag is in progress. Returns False (and drops the device's command) for a
        malformed or non-finite velocity."""
        if v_m_s is None:
            with self.lock:
                self._device_v_m_s = None
            return True
        try:
            v = np.asarray(v_m_s, dtype=float).reshape(-1)[:self._robot.dim]
        except (TypeError, ValueError):
            v = None
        ok = v is not None and v.shape == (self._robot.dim,) and bool(np.all(np.isfinite(v)))
        with self.lock:
            self._device_v_m_s = v.copy() if ok else None
        return ok

    def release_gizmo(self) -> None:
        """Drag ended (or its client left): the gizmo commands zero from now on."""
        with self.lock:
            self._gizmo_target_m = None

    def jog(self, v_m_s: np.ndarray) -> None:
        """Command ``v_m_s`` (shape (dim,)) for ``jog_hold_s`` of simulated time; NaN -> ignored."""
        v = np.asarray(v_m_s, dtype=float).reshape(-1)
        if v.shape != (self._robot.dim,) or not np.all(np.isfinite(v)):
            return
        with self.lock:
            self._jog_m_s = v
            self._jog_until_s = self._t_s + self.settings.jog_hold_s

    def reset(self) -> None:
        """Home pose, inputs cleared, time back to zero."""
        with self.lock:
            self._robot.reset()
            self._reset_inputs()

    def replace_robot(self, robot: Teleoperated) -> None:
        """Swap in another robot (robot selector, Fig. 9 scene); inputs are cleared."""
        with self.lock:
            self._robot = robot
            self._reset_inputs()

    def read(self, fn: Callable[[Teleoperated], object]) -> object:
        """Run ``fn(robot)`` under the lock (for renderers that need more than the snapshot)."""
        with self.lock:
            return fn(self._robot)

    # ---- one step ----------------------------------------------------------------------
    def desired_velocity(self) -> np.ndarray:
        """The raw user command now (gizmo while dragged, else jog, else the input device, else
        zero), shape (dim,)."""
        dim = self._robot.dim
        if self._gizmo_target_m is not None:
            offset = self._gizmo_target_m - np.asarray(self._robot.p_base_ee_m, dtype=float)
            return offset_to_velocity(offset[:dim], self.gizmo)
        if self._t_s < self._jog_until_s:
            return self._jog_m_s
        if self._device_v_m_s is not None and self._device_v_m_s.shape == (dim,):
            return self._device_v_m_s
        return np.zeros(dim)

    def _feed_human(self, dt_s: float) -> None:
        """Move the human source on by ``dt_s`` and, when a read is due, give the robot the human."""
        source = self.human_source
        if source is None or not hasattr(self._robot, "set_human"):
            return
        source.advance(dt_s)
        if self._t_s + 1e-12 < self._human_due_s:
            return
        period = self.settings.human_period_s
        self._human_due_s += period  # on the period's own grid: 300 Hz on average at any loop rate
        if self._human_due_s <= self._t_s:  # fell behind (a stall): the next read one period from now
            self._human_due_s = self._t_s + period
        self._human = source.capsules()
        self._robot.set_human(self._human)

    def step_once(self, dt_s: float | None = None) -> StepReport:
        """One control period of ``dt_s`` [s] (default: the nominal ``settings.dt_s``)."""
        dt_s = self.settings.dt_s if dt_s is None else float(dt_s)
        with self.lock:
            for hook in self.before_step:
                try:
                    hook(self._t_s)
                except Exception as error:  # noqa: BLE001 - a hook's fault is not the robot's
                    self.hook_failures += 1
                    if str(error) != self._last_hook_error:  # logged once per distinct error
                        logger.exception("a before-step hook failed (the step goes on)")
                        self._last_hook_error = str(error)
            self._feed_human(dt_s)
            v = self.desired_velocity()
            report = self._robot.step(v, dt_s, self._method)
            self._v_sent = v
            self._report = report
            if getattr(report, "hand_over_limit", False):
                self._hand_over_until_s = self._t_s + dt_s + HAND_OVER_SHOWN_S
            self._t_s += dt_s
            self._steps += 1
            return report

    def snapshot(self) -> LoopSnapshot:
        with self.lock:
            return LoopSnapshot(self._t_s, self._steps, self._method, self._report,
                                np.array(self._robot.p_base_ee_m, dtype=float), np.array(self._v_sent, dtype=float),
                                self._gizmo_target_m is not None, {"rate_hz": self.stats.rate_hz}, self._human,
                                self._t_s <= self._hand_over_until_s)

    # ---- thread ------------------------------------------------------------------------
    def start(self) -> None:
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="cobotsafety-control", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def _run(self) -> None:
        clock, sleep = self.clock, self.sleep
        s = self.settings
        if s.fifo_priority > 0:
            self.fifo_refused = request_fifo(s.fifo_priority)
            if self.fifo_refused:
                logger.info("control loop under the normal scheduling policy: %s", self.fifo_refused)
        schedule = TickSchedule(s.dt_s, s.max_lag_s, MAX_DT_S, clock())
        last = None
        while not self._stop.is_set():
            now = clock()
            tick = schedule.start(now)
            stats = self.stats  # the bench swaps in a fresh one between phases
            if tick.overrun:
                stats.overruns += 1
            if last is not None:
                stats.add(now - last, tick.late_s)
            last = now
            try:
                self.step_once(tick.dt_s)
            except Exception as error:  # noqa: BLE001 - a failed controller is not stepped again
                logger.exception("control step failed: the control loop stops")
                with self.lock:
                    self._gizmo_target_m = None
                    self.failure = f"control step failed: {error}"
                self._stop.set()
                break
            delay_s = schedule.finish(clock())
            if delay_s > 0.0:
                sleep(delay_s)
