"""Paper 2's experiments (section 5), headless: a recorded human next to a robot doing its task.

    cobotsafety experiment human-approach --scenario exp1|exp2|reach-over [--scanner corner|edge]
        [--robot iiwa] [--replay FILE] [--controller C ...] [--ssm off|scaling|stop]
        [--capsules paper|fitted] [--json] [--out DIR]

A bundled recording (``assets/recordings/<scenario>[-corner].jsonl.gz``, made by
``cobotsafety.tools.generate_recording``: the scanner at the table's corner as in paper 2
(``exp1-corner``, ``exp2-corner``, the default), or under its front edge (``exp1``, ``exp2``)) or ``--replay`` (a recording in the documented format, or a ROS bag:
laser only, 1-capsule human) is replayed through the whole sensor pipeline (laser legs ->
torso, IMUs -> arms) causally: at control time t only samples stamped <= t are used. The
control loop runs at paper 2's 275 Hz; the robot follows its task path
(``cobotsafety.control.nominal_path``) through the anti-windup PI on the error to the moving
target (eqs. 14-15), filtered by the chosen controller (through ``approach_step``, the one place
that touches it):

* ``exp1``: the pick-and-place task (``paper_pick_and_place``): home until the box is placed
  and the co-worker gone (10.5 s), pick, carry, place, home. Also the task for ``--replay``.
* ``exp2``: hold the home pose until the recording ends.
* ``reach-over``: the stress case's two-cycle pick-and-place (``pick_and_place``).

Every setting (speed limit, critical and activation distances, field gain) is in
``approach_settings``, one for all scenarios, fixed before the results. Each run reports the
distance the controller saw, to the pipeline's five-capsule human, to its one-capsule fallback
(separately), and to the ground truth (``<recording>_truth.npz`` beside the recording, when
there is one), with the estimate's error at the true closest moment (``approach_metrics``).
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cobotsafety.cli.arguments import bounded_float
from cobotsafety.experiments import approach_settings as settings
from cobotsafety.experiments.approach_metrics import RunMetrics, plain_distance_m, run_metrics
from cobotsafety.experiments.approach_truth import TruthHuman

SCENARIOS = ("exp1", "exp2", "reach-over")
SCANNERS = ("corner", "edge")
CONTROLLERS = ("anticipative", "reactive", "stop")
DEFAULT_ROBOT = "iiwa"


def recording_name(scenario: str, scanner: str = "corner") -> str:
    """The bundled recording of ``scenario`` with the scanner at the table's ``corner`` (paper 2's
    set-up) or under its front ``edge``. ``reach-over`` has its scanner at the corner only."""
    if scanner not in SCANNERS:
        raise ValueError(f"scanner must be one of {SCANNERS}, got {scanner!r}")
    if scenario == "reach-over" or scanner == "edge":
        return scenario
    return f"{scenario}-corner"


@dataclass
class EpisodeLog:
    """Per-step arrays of one run (n steps): see ``approach_metrics``."""

    t_s: list = field(default_factory=list)
    seen_m: list = field(default_factory=list)
    estimate_m: list = field(default_factory=list)
    one_capsule_m: list = field(default_factory=list)
    true_m: list = field(default_factory=list)
    p_ee_m: list = field(default_factory=list)
    v_ee_m_s: list = field(default_factory=list)
    v_att_m_s: list = field(default_factory=list)
    stopped: list = field(default_factory=list)
    protective: list = field(default_factory=list)
    q_rad: list = field(default_factory=list)
    torso_xy_m: list = field(default_factory=list)
    completion_s: float | None = None
    posture_recoveries: int = 0
    """Posture moves home after the task stalled at joint limits (``control.recovery``)."""
    rate_limited_steps: int = 0
    """Steps whose joint velocity the robot's rate limiter changed (``rate_limited`` runs)."""
    #: The arm's configuration and hand position before the first step (the per-step lists
    #: start after it): the motion's ratios are measured from rest there.
    q_start_rad: np.ndarray | None = None
    p_ee_start_m: np.ndarray | None = None

    def commanded_path(self) -> tuple[np.ndarray, np.ndarray]:
        """The joint path (n + 1, nq) [rad] and the hand's (n + 1, 3) [m] from the run's start."""
        q = np.vstack((self.q_start_rad, np.asarray(self.q_rad, dtype=float).reshape(-1, len(self.q_start_rad))))
        return q, np.vstack((self.p_ee_start_m, np.asarray(self.p_ee_m, dtype=float).reshape(-1, 3)))


class HumanSeries:
    """The pipeline's human at control steps ``k`` (time ``start_s + k dt_s``), computed once and
    shared by every controller run on the same replay (the pipeline does not depend on the robot).
    None after ``end_s`` (the recording is over: the human has left)."""

    def __init__(self, capsules_at, start_s: float, end_s: float, dt_s: float):
        self._at, self.start_s, self.end_s, self.dt_s = capsules_at, start_s, end_s, dt_s
        self._cache: list = []

    def __getitem__(self, k: int):
        while len(self._cache) <= k:
            t = len(self._cache) * self.dt_s
            self._cache.append(self._at(self.start_s + t) if t <= self.end_s - self.start_s else None)
        return self._cache[k]


def run_episode(controller, humans: HumanSeries, body, path, dt_s: float, end_s: float,
                truth: TruthHuman | None = None, truth_offset_s: float = 0.0,
                completion_tolerance_m: float = 0.01, rate_limited: bool = False) -> EpisodeLog:
    """Drive ``controller`` (``approach_step.Controller``) along ``path`` next to ``humans``
    until the path is done (end-effector within ``completion_tolerance_m`` of its end) or
    ``end_s``. ``truth`` at generator time ``truth_offset_s + t`` gives the true distance. A task
    stalled at joint limits moves its posture home and resumes (``control.recovery``).
    ``rate_limited``: the arm follows each step's joint velocity through the robot's rate
    limiter (``arm.rate_limiter``, libfranka's rule), and the next step starts from the state
    it reached (closed loop); else it follows every command exactly. (On a step the limiter
    changed, the logged pipeline distance is the one the step computed at its commanded pose;
    the true distance, the joint path and the hand's are the arm's.)"""
    from cobotsafety.arm.rate_limiter import follow_rate_limited
    from cobotsafety.control.pi import AntiWindupPI
    from cobotsafety.control.recovery import PostureRecovery
    from cobotsafety.experiments import approach_step

    state = approach_step.state(controller)
    arm = controller.arm
    skip = arm.human.skip_capsules
    pi = AntiWindupPI(kp_per_s=3.0, ki_per_s2=1.0, limit=settings.ATTRACTION_LIMIT_M_S)
    recovery = PostureRecovery(arm.model.home_q, arm.model.limits.velocity_rad_s, near_m=path.max_lag_m,
                               difference=arm.model.difference)
    blocked = False
    log = EpisodeLog()
    end_point = path.point(path.length_m)
    log.q_start_rad, log.p_ee_start_m = state.q.copy(), state.p_world_ee.copy()
    k, t = 0, 0.0
    while t < end_s:
        human = humans[k]
        present = human is not None and human.present
        p_ee = state.p_world_ee
        target = path.advance(p_ee, dt_s)
        error = target - p_ee
        posture = recovery.command(t, state.q, p_ee, target, blocked)
        if rate_limited:
            q_before, last = state.q.copy(), (arm.joint_velocity_rad_s, arm.joint_acceleration_rad_s2)
        if posture is None:
            v_att = pi.update(error, dt_s)
            out = approach_step.step(controller, human if present else None, v_att, dt_s)
        else:
            pi.reset()  # (its integral is the stall's)
            out = approach_step.step(controller, human if present else None, posture, dt_s, joints=True)
            v_att = out.report.v_desired_m_s
        blocked = arm.blocked_by_joint_limits(out.report)
        q_now, p_now, v_now = out.q, out.report.p_base_ee_m, out.report.v_executed_m_s
        if rate_limited and follow_rate_limited(arm, q_before, *last, dt_s):
            log.rate_limited_steps += 1
            q_now, p_now, v_now = state.q.copy(), state.p_world_ee.copy(), state.J_ee @ arm.joint_velocity_rad_s
        k += 1
        t = k * dt_s
        robot = (state.capsule_p0[skip:], state.capsule_p1[skip:], state.capsule_radius[skip:])
        five = one = np.nan
        if present:
            log.torso_xy_m.append(0.5 * (human.p0_b_m[0, :2] + human.p1_b_m[0, :2]))
            plain = plain_distance_m(*robot, human, body)
            if "torso" in human.names:  # the wearer's five capsules (and any other person's one)
                five = plain
            else:  # the wearer's one-capsule fallback, or other people alone
                one = plain
        true = truth.distance_m(*robot, truth_offset_s + t) if truth is not None else np.nan
        log.t_s.append(t)
        log.seen_m.append(out.min_distance_m)
        log.estimate_m.append(five)
        log.one_capsule_m.append(one)
        log.true_m.append(true)
        log.p_ee_m.append(p_now)
        log.v_ee_m_s.append(v_now)
        log.v_att_m_s.append(v_att)
        log.stopped.append(out.report.stopped)
        log.protective.append(out.protective_stop)
        log.q_rad.append(q_now)
        if path.finished and np.linalg.norm(state.p_world_ee - end_point) < completion_tolerance_m:
            log.completion_s = t
            break
    log.posture_recoveries = recovery.count
    return log


def episode_ratios(log: EpisodeLog, dt_s: float, controller):
    """The run's motion against the robot's own limits (``MotionLimits``): ``MotionRatios``."""
    from cobotsafety.experiments.motion_ratios import motion_ratios

    model = controller.arm.model
    q, p_ee = log.commanded_path()  # from rest where the run began, not after its first step
    return motion_ratios(q, dt_s, model.limits, model.difference, p_ee)


def episode_metrics(log: EpisodeLog, dt_s: float, controller, ratios=None) -> RunMetrics:
    """The run's metrics; ``ratios`` its ``episode_ratios`` (measured here when not given)."""
    ratios = episode_ratios(log, dt_s, controller) if ratios is None else ratios
    return run_metrics(dt_s, log.t_s, log.seen_m, log.estimate_m, log.one_capsule_m, log.true_m, log.v_ee_m_s,
                       log.v_att_m_s, log.stopped, log.protective, ratios, log.completion_s,
                       controller.arm.smoothness_steps, controller.arm.hand_over_limit_steps)


@dataclass
class ApproachRun:
    scenario: str
    recording: str
    robot: str
    controller: str
    ssm: str
    metrics: RunMetrics
    log: EpisodeLog
    ratios: object
    """``MotionRatios``: the run's motion against the robot's limits (``metrics`` carries its ratios)."""
    critical_m: float = settings.CRITICAL_M

    @property
    def label(self) -> str:
        return f"{Path(self.recording).name.split('.')[0]}_{self.robot}_{self.controller}" + (
            "" if self.ssm == "off" else f"_ssm-{self.ssm}")

    def as_json(self) -> dict:
        return {"scenario": self.scenario, "recording": self.recording, "robot": self.robot,
                "controller": self.controller, "ssm": self.ssm, **self.metrics.as_dict(),
                "posture_recoveries": self.log.posture_recoveries}


def load_replay(scenario: str, replay_file: Path | None, scanner: str = "corner"):
    """``(replay, recording path)``: ``replay_file`` (a recording or a ROS bag) or the scenario's
    bundled recording with the scanner at ``scanner``."""
    from cobotsafety.human.recording import bundled_recording
    from cobotsafety.human.replay import Replay

    # Paper 2's experiments find the legs with paper 2's rule (eqs. 2-3), as the paper did.
    if replay_file is None:
        path = bundled_recording(recording_name(scenario, scanner))
        return Replay.from_file(path, leg_method="paper"), path
    if Path(replay_file).suffix in (".bag", ".mcap", ".db3") or Path(replay_file).is_dir():
        return Replay.from_bag(replay_file, leg_method="paper"), Path(replay_file)
    return Replay.from_file(replay_file, leg_method="paper"), Path(replay_file)


def load_truth(recording_path: Path) -> TruthHuman | None:
    """The ground truth beside a recording (``NAME_truth.npz``), or None."""
    from cobotsafety.experiments.approach_truth import truth_path

    path = truth_path(Path(recording_path))
    return TruthHuman.load(path) if path.is_file() else None


def task_path(scenario: str, home_m: np.ndarray, duration_s: float, replayed: bool):
    from cobotsafety.control.nominal_path import hold, paper_pick_and_place, pick_and_place

    if scenario == "exp2" and not replayed:
        return hold(home_m, until_s=duration_s)
    if scenario == "reach-over" and not replayed:
        return pick_and_place()
    return paper_pick_and_place(home_m, speed_m_s=settings.TASK_SPEED_M_S)


@dataclass
class LoadedScenario:
    """A replay, its truth and its shared human series, reused by every controller."""

    scenario: str
    recording_path: Path
    replay: object
    truth: TruthHuman | None
    replayed: bool
    humans: HumanSeries | None = None

    def series(self, dt_s: float) -> HumanSeries:
        if self.humans is None or self.humans.dt_s != dt_s:
            r = self.replay
            self.humans = HumanSeries(r.capsules_at, r.start_s, r.start_s + r.duration_s, dt_s)
        return self.humans


def load_scenario(scenario: str = "exp1", replay_file: Path | None = None, scanner: str = "corner") -> LoadedScenario:
    replay, path = load_replay(scenario, replay_file, scanner)
    return LoadedScenario(scenario, path, replay, load_truth(path), replay_file is not None)


def run_approach(controller: str, ssm: str = "off", scenario: str = "exp1", robot: str = DEFAULT_ROBOT,
                 replay_file: Path | None = None, capsules: str = "paper", dt_s: float = 1 / settings.CONTROL_RATE_HZ,
                 timeout_s: float = 90.0, duration_s: float | None = None, loaded: LoadedScenario | None = None,
                 scanner: str = "corner", **controller_settings) -> ApproachRun:
    """One run; ``duration_s`` cuts it short (tests), ``loaded`` reuses a ``load_scenario``.
    ``controller_settings`` (``critical_m``, ``activation_m``, ``k_rep_m_s``) override
    ``approach_settings`` (tests that break a controller on purpose)."""
    from cobotsafety.experiments import approach_step

    loaded = loaded or load_scenario(scenario, replay_file, scanner)
    ctrl = approach_step.make_controller(robot, controller, ssm, capsules, **controller_settings)
    state = approach_step.state(ctrl)
    path = task_path(loaded.scenario, state.p_world_ee.copy(), loaded.replay.duration_s, loaded.replayed)
    end_s = min(timeout_s, duration_s if duration_s is not None else np.inf)
    log = run_episode(ctrl, loaded.series(dt_s), loaded.replay.recording.body, path, dt_s, end_s,
                      loaded.truth, loaded.replay.start_s)
    ratios = episode_ratios(log, dt_s, ctrl)
    return ApproachRun(loaded.scenario, str(loaded.recording_path.name), robot, controller, ssm,
                       episode_metrics(log, dt_s, ctrl, ratios), log, ratios)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenario", choices=SCENARIOS, default="exp1",
                        help="paper 2's experiment 1 or 2, or the reach-over stress case (default exp1)")
    parser.add_argument("--scanner", choices=SCANNERS, default="corner",
                        help="the scanner at the table's corner (paper 2, default) or under its front edge")
    parser.add_argument("--robot", default=DEFAULT_ROBOT, help="robot name (default iiwa, paper 2's robot)")
    parser.add_argument("--replay", type=Path, default=None, metavar="FILE",
                        help="replay this recording or ROS bag instead, with the pick-and-place task path")
    parser.add_argument("--controller", choices=CONTROLLERS, action="append",
                        help="controller(s) to run (default: all three)")
    parser.add_argument("--ssm", choices=("off", "scaling", "stop"), default="off",
                        help="ISO/TS 15066 SSM: speed scaling or the protective stop at S (default off)")
    parser.add_argument("--capsules", choices=["paper", "fitted"], default="paper",
                        help="robot capsule model (default: paper 2's three capsules)")
    parser.add_argument("--json", action="store_true", help="print a JSON list of result objects")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR", help="write PNG plots (Figs. 11, 12, 14) there")
    parser.add_argument("--dt", type=bounded_float(0.0, 0.05, "s"), default=1 / settings.CONTROL_RATE_HZ,
                        help=f"control period [s] (default 1/{settings.CONTROL_RATE_HZ:.0f}, paper 2's robot update rate)")


def run(args: argparse.Namespace) -> int:
    from cobotsafety.arm.robots import robot_spec

    robot_spec(args.robot)  # a clear error for an unknown robot before the replay loads
    loaded = load_scenario(args.scenario, args.replay, args.scanner)
    runs = [run_approach(c, args.ssm, args.scenario, args.robot, args.replay, args.capsules, args.dt, loaded=loaded)
            for c in (args.controller or CONTROLLERS)]
    written = []
    if args.out is not None:
        from cobotsafety.experiments.approach_plots import plot

        written = plot(runs, args.out)
    if args.json:
        print(json.dumps([r.as_json() for r in runs]))
    else:
        for r in runs:
            print(json.dumps(r.as_json()))
        if written:
            print("plots: " + ", ".join(str(p) for p in written))
    return 0
