"""``cobotsafety experiment limits``: the commanded motion against the robot's own limits.

Scripted runs of one robot (``--robot``, default panda) at one control period (``--dt``, default
1 ms), each measured by ``experiments.motion_ratios`` (the commanded joint path by backward
differences from rest, against ``assets/limits/robot_limits.toml``):

* ``drag-turns``: hand drags at 0.25 m/s whose direction changes every 0.7 s (seeded: 0);
* ``drag-release``: 0.4 s drags at 0.5 m/s, each followed by a 0.4 s release (the arm holds;
  seeded: 1);
* ``joint-<name>-<end>``: from a pose 0.3 rad inside that joint's limit (or the nearest pose
  toward it from home that meets every other limitation), the hand dragged along the direction
  that joint's motion toward the limit moves it, for every limited joint and both ends;
* ``table``, ``reach``, ``zone``: the hand driven down into the table, out past the reach
  sphere, and at the demo cell's box zone;
* ``invariant``: random teleoperation (``tools.invariant``'s command: a new random direction
  every 100 steps);
* ``exp1``, ``exp2``, ``reach-over``: paper 2's recordings with the pick-and-place task
  (``experiment human-approach``'s runs, anticipative) unless ``--no-recordings``.

Each run prints ``run``, ``robot``, ``dt_s``, ``max_joint_velocity_ratio``,
``max_joint_acceleration_ratio``, ``max_joint_jerk_ratio``, ``max_ee_jerk_m_s3``,
``max_ee_speed_ratio``, ``max_ee_acceleration_ratio``, ``max_ee_jerk_ratio`` (the hand's norms
over the robot's end-effector limits), ``safety_over_smoothness_steps`` (steps the controller
kept a limitation over the acceleration or jerk limits; each counted, never silent) and
``hand_over_limit_steps`` (steps whose executed hand path went over the robot's end-effector
acceleration or jerk limit, each reported by the step: ``ArmStepReport.hand_over_limit``). The
table ends with the runs that went over a limit (any ratio above 1) without a step counted or
reported for it: what the controller did not know it did. ``--out DIR`` plots the first run's
joint velocity and acceleration against their limits.

``--periods N`` runs them all at N control periods spread evenly over ``--dt`` times ``1 +-
--spread`` (default 1 %; odd N: ``--dt`` itself in the middle) and ends the table with how many
periods gave up smoothness: a filter that holds the limits at exactly 1 ms may not 1 % off it
(docs/motion_limits.md), and a real controller's period is measured, not exact.

``--drag-seeds N`` runs each hand drag with N seeds (``drag-turns-seed0`` ... and
``drag-release-seed1`` ..., the default ones first) and ends the table with how many drags gave up
smoothness: two seeded drags are two samples of the user's hand, and a filter that holds the
limits on them may not on others (docs/motion_limits.md).
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cobotsafety.cli.arguments import bounded_float, positive_int
from cobotsafety.experiments.motion_ratios import JSON_KEYS

#: A run's ratios to the robot's limits (joints' and hand's); the table's columns and JSON keys.
RATIO_KEYS = tuple(key for key in JSON_KEYS if key.endswith("_ratio"))
KEYS = (*JSON_KEYS, "safety_over_smoothness_steps", "hand_over_limit_steps")
RECORDINGS = ("exp1", "exp2", "reach-over")
#: The stress case: a person reaching over the table faster than the arm can brake.
STRESS_RUN = "reach-over"
START_INSIDE_RAD = 0.3
"""How far inside a joint limit the joint runs start [rad]."""


@dataclass
class LimitRun:
    run: str
    robot: str
    dt_s: float
    ratios: object
    """``MotionRatios``."""
    safety_over_smoothness_steps: int
    q_path: np.ndarray
    """(T, nq) [rad], the commanded joint path (for the plots)."""
    hand_over_limit_steps: int = 0
    """Steps the controller reported over the hand's own limits (``ArmStepReport.hand_over_limit``)."""

    def as_json(self) -> dict:
        r = self.ratios
        out = {"run": self.run, "robot": self.robot, "dt_s": self.dt_s}
        values = r.as_json()
        out.update({k: (None if v is None else round(float(v), 4)) for k, v in values.items()})
        out["safety_over_smoothness_steps"] = int(self.safety_over_smoothness_steps)
        out["hand_over_limit_steps"] = int(self.hand_over_limit_steps)
        return out


def _measure(name: str, controller, commands, dt_s: float) -> LimitRun:
    """Step ``controller`` (at rest) through ``commands`` (an iterable of (3,) velocities)."""
    from cobotsafety.experiments.motion_ratios import motion_ratios

    state = controller.state
    qs, ps = [state.q.copy()], [state.p_world_ee.copy()]
    steps_before, hand_before = controller.smoothness_steps, controller.hand_over_limit_steps
    for v in commands:
        controller.step(v, dt_s, "anticipative")
        qs.append(state.q.copy())
        ps.append(state.p_world_ee.copy())
    q_path = np.array(qs)
    ratios = motion_ratios(q_path, dt_s, controller.model.limits, controller.model.difference, np.array(ps))
    return LimitRun(name, controller.model.name, dt_s, ratios, controller.smoothness_steps - steps_before, q_path,
                    controller.hand_over_limit_steps - hand_before)


def _steps(duration_s: float, dt_s: float) -> int:
    return int(round(duration_s / dt_s))


def drag_turns(controller, dt_s: float, seed: int = 0, duration_s: float = 10.0):
    rng = np.random.default_rng(seed)
    every = _steps(0.7, dt_s)
    v = np.zeros(3)
    for k in range(_steps(duration_s, dt_s)):
        if k % every == 0:
            d = rng.normal(size=3)
            v = 0.25 * d / np.linalg.norm(d)
        yield v


def drag_release(controller, dt_s: float, seed: int = 1, pulls: int = 6):
    rng = np.random.default_rng(seed)
    for _ in range(pulls):
        d = rng.normal(size=3)
        v = 0.5 * d / np.linalg.norm(d)
        for _ in range(_steps(0.4, dt_s)):
            yield v
        for _ in range(_steps(0.4, dt_s)):
            yield np.zeros(3)


def toward_joint_limit(controller, dt_s: float, iq: int, iv: int, upper: bool, duration_s: float = 1.5):
    """The hand dragged along the direction joint ``iv``'s motion toward its limit moves it."""
    sign = 1.0 if upper else -1.0
    for _ in range(_steps(duration_s, dt_s)):
        column = sign * controller.state.J_ee[:3, iv]
        size = float(np.linalg.norm(column))
        yield np.zeros(3) if size < 1e-6 else 0.4 * column / size


def constant(v, duration_s: float, dt_s: float):
    for _ in range(_steps(duration_s, dt_s)):
        yield np.asarray(v, dtype=float)


def invariant_commands(dt_s: float, steps: int = 5000, seed: int = 0):
    rng = np.random.default_rng(seed)
    direction = np.zeros(3)
    for i in range(steps):
        if i % 100 == 0:
            direction = rng.normal(size=3) * rng.uniform(0.05, 1.0)
        yield direction


def _start_near(fresh, model, iq: int, upper: bool, dt_s: float):
    """A controller at rest with joint ``iq`` ``START_INSIDE_RAD`` inside its limit, or as close
    to that as a pose that meets every other limitation allows (the home pose moved toward it;
    a start inside the table or a zone would be a start inside a limit, not a drive into one)."""
    home = model.home_q.copy()
    span = model.upper[iq] - model.lower[iq]
    inside = min(START_INSIDE_RAD, 0.25 * span)
    target = home.copy()
    target[iq] = model.upper[iq] - inside if upper else model.lower[iq] + inside
    for share in np.linspace(1.0, 0.0, 11):
        c = fresh()
        c.set_configuration(home + share * (target - home))
        probe = c.step(np.zeros(3), dt_s, "anticipative")
        if not probe.safety_over_smoothness and not probe.binding:
            c.set_configuration(home + share * (target - home))
            return c
    return fresh()


DRAGS = (("drag-turns", drag_turns, 0), ("drag-release", drag_release, 1))
"""The hand drags: run name, commands, default seed."""


def drag_runs(robot: str, dt_s: float, drag_seeds: int = 1) -> list[LimitRun]:
    """The hand drags of ``robot``, each with ``drag_seeds`` seeds from its default one (more
    than one: the seed in the run's name)."""
    from cobotsafety.arm.controller import ArmController

    runs = []
    for name, commands, first in DRAGS:
        for seed in range(first, first + drag_seeds):
            c = ArmController(robot)
            runs.append(_measure(name if drag_seeds == 1 else f"{name}-seed{seed}", c, commands(c, dt_s, seed=seed),
                                 dt_s))
    return runs


def scripted_runs(robot: str, dt_s: float, drag_seeds: int = 1) -> list[LimitRun]:
    """Every scripted run of ``robot`` (hand drags, joint limits, table, reach, zone, invariant);
    the hand drags as ``drag_runs``."""
    from cobotsafety.arm.controller import ArmController

    def fresh():
        return ArmController(robot)

    runs = drag_runs(robot, dt_s, drag_seeds)
    model = fresh().model
    for (iq, iv), name in zip(model.limited, model.limited_names):
        for upper in (False, True):
            c = _start_near(fresh, model, iq, upper, dt_s)
            end = "upper" if upper else "lower"
            runs.append(_measure(f"joint-{name}-{end}", c, toward_joint_limit(c, dt_s, iq, iv, upper), dt_s))
    c = fresh()
    runs.append(_measure("table", c, constant((0.0, 0.0, -0.5), 3.0, dt_s), dt_s))
    c = fresh()
    out = np.asarray(c.state.p_world_ee, dtype=float).copy()
    out[2] = 0.0
    out = out / max(float(np.linalg.norm(out)), 1e-9)
    runs.append(_measure("reach", c, constant(0.5 * out, 4.0, dt_s), dt_s))
    c = fresh()
    box = next(z for z in c.zones if type(z).__name__ == "BoxZone")
    to_box = np.asarray(box.center, dtype=float) - c.state.p_world_ee
    runs.append(_measure("zone", c, constant(0.4 * to_box / np.linalg.norm(to_box), 3.0, dt_s), dt_s))
    c = fresh()
    runs.append(_measure("invariant", c, invariant_commands(dt_s), dt_s))
    return runs


def recording_runs(robot: str, dt_s: float) -> list[LimitRun]:
    """Paper 2's recordings with the pick-and-place task (anticipative)."""
    from cobotsafety.experiments.human_approach import load_scenario, run_approach

    runs = []
    for scenario in RECORDINGS:
        run = run_approach("anticipative", scenario=scenario, robot=robot, dt_s=dt_s, loaded=load_scenario(scenario))
        runs.append(LimitRun(scenario, robot, dt_s, run.ratios, run.metrics.safety_over_smoothness_steps,
                             run.log.commanded_path()[0], run.metrics.hand_over_limit_steps))
    return runs


def periods(dt_s: float, count: int, spread: float) -> list[float]:
    """``count`` control periods [s] spread evenly over ``dt_s (1 +- spread)``; one: ``dt_s``
    (an odd count has ``dt_s`` itself, bit for bit, in the middle)."""
    if count == 1:
        return [dt_s]
    return [float(dt_s * (1.0 + spread * f)) for f in np.linspace(-1.0, 1.0, count)]


def period_summary(rows: list[dict]) -> str:
    """One line: how many of the rows' periods gave up smoothness in any run, and in a run other
    than the stress case (``STRESS_RUN``: a person reaching faster than the arm brakes, counted at
    every period), with each such period's counted steps over those runs."""
    counted: dict[float, int] = {}
    anywhere: set[float] = set()
    for row in rows:
        steps = row["safety_over_smoothness_steps"]
        if steps:
            anywhere.add(row["dt_s"])
        counted[row["dt_s"]] = counted.get(row["dt_s"], 0) + (0 if row["run"] == STRESS_RUN else steps)
    bad = {dt: n for dt, n in counted.items() if n}
    detail = ", ".join(f"{dt * 1e3:.6g} ms: {n}" for dt, n in sorted(bad.items()))
    return (f"periods giving up smoothness: {len(anywhere)} of {len(counted)}; outside {STRESS_RUN}: "
            f"{len(bad)} of {len(counted)}" + (f" ({detail})" if detail else ""))


def drag_summary(rows: list[dict]) -> str:
    """One line: how many hand-drag rows (``drag-*``) gave up smoothness, and the worst ratios
    over the drags."""
    drags = [row for row in rows if row["run"].startswith("drag-")]
    bad = [row for row in drags if row["safety_over_smoothness_steps"]]
    worst = {key: max((row[key] for row in drags), default=0.0)
             for key in ("max_joint_acceleration_ratio", "max_joint_jerk_ratio")}
    return (f"hand drags giving up smoothness: {len(bad)} of {len(drags)} "
            f"({sum(row['safety_over_smoothness_steps'] for row in bad)} steps); worst joint acceleration "
            f"{worst['max_joint_acceleration_ratio']:.4g}, jerk {worst['max_joint_jerk_ratio']:.4g} times the limits")


def over_summary(runs: list[LimitRun]) -> str:
    """One line: how many runs went over a limit (a ratio above ``OVER_LIMIT_RATIO``, before the
    JSON's rounding) without a step the controller counted (a joint's or the hand's limit given
    way for safety) or reported (the hand's executed path over its own limits), and the worst such
    ratio with its run; then how many runs went over the hand's limits with each such step
    reported."""
    from cobotsafety.experiments.motion_ratios import OVER_LIMIT_RATIO

    silent, reported = [], 0
    for run in runs:
        if run.safety_over_smoothness_steps:
            continue
        ratios = run.ratios.as_json()
        over = [(ratios[key], key) for key in RATIO_KEYS if ratios[key] is not None and ratios[key] > OVER_LIMIT_RATIO]
        if run.hand_over_limit_steps and over:
            reported += 1
            over = [(value, key) for value, key in over if not key.startswith("max_ee_")]
        if over:
            silent.append((*max(over), run.run, run.dt_s))
    line = f"runs over a limit without a counted or reported step: {len(silent)} of {len(runs)}"
    if silent:
        value, key, name, dt_s = max(silent)
        line += f" (worst: {key.replace('max_', '').replace('_ratio', '')} {value:.4g} times the limit in {name}"
        line += f" at {dt_s * 1e3:.6g} ms)" if len({run.dt_s for run in runs}) > 1 else ")"
    return line + f"; over the hand's limits, reported: {reported}"


def plot(run: LimitRun, controller_limits, out: Path) -> Path:
    """The run's joint velocity and acceleration, each over its limit (1 = the limit)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    q = run.q_path
    qd = np.diff(q, axis=0) / run.dt_s
    qdd = np.diff(qd, axis=0, prepend=np.zeros((1, qd.shape[1]))) / run.dt_s
    t = run.dt_s * np.arange(1, len(q))
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for ax, values, limit, label in ((axes[0], qd, controller_limits.velocity_rad_s, "|joint velocity| / limit"),
                                     (axes[1], qdd, controller_limits.acceleration_rad_s2,
                                      "|joint acceleration| / limit")):
        for j in range(values.shape[1]):
            ax.plot(t, np.abs(values[:, j]) / limit[j], lw=0.8, label=f"joint {j + 1}")
        ax.axhline(1.0, color="k", ls="--", lw=1)
        ax.set_ylabel(label)
    axes[1].set_xlabel("time [s]")
    axes[0].legend(ncol=4, fontsize=7)
    axes[0].set_title(f"{run.robot}, {run.run}, dt {run.dt_s * 1e3:g} ms")
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"limits_{run.robot}_{run.run}.png"
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robot", default="panda", help="robot name (default panda)")
    parser.add_argument("--dt", type=bounded_float(0.0, 0.01, "s"), default=0.001,
                        help="control period [s] (default 0.001; paper 2's robot: 1/275)")
    parser.add_argument("--periods", type=positive_int, default=1, metavar="N",
                        help="run at N periods spread over DT (1 +- SPREAD) (default 1: DT alone)")
    parser.add_argument("--spread", type=bounded_float(0.0, 0.1, "of DT"), default=0.01,
                        help="the periods' relative spread with --periods (default 0.01: 1 %%)")
    parser.add_argument("--drag-seeds", type=positive_int, default=1, metavar="N",
                        help="run each hand drag with N seeds (default 1: the default seed alone)")
    parser.add_argument("--no-recordings", action="store_true", help="skip paper 2's three recordings")
    parser.add_argument("--json", action="store_true", help="print a JSON list, one object per run")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="plot the first run's joint velocity and acceleration against their limits there")


def run(args: argparse.Namespace) -> int:
    from cobotsafety.arm.robots import robot_spec

    robot_spec(args.robot)
    runs = []
    for dt_s in periods(args.dt, args.periods, args.spread):
        runs += scripted_runs(args.robot, dt_s, args.drag_seeds)
        if not args.no_recordings:
            runs += recording_runs(args.robot, dt_s)
    rows = [r.as_json() for r in runs]
    if args.json:
        print(json.dumps(rows))
    else:
        several = args.periods > 1
        print(f"{'run':<28}" + (f"{'dt [ms]':>12}" if several else "")
              + "".join(f" {k.replace('max_', '').replace('_ratio', ''):>21}" for k in KEYS))
        for row in rows:  # (a space before each column: a label wider than it stays apart)
            cells = "".join(f" {'-' if row[k] is None else row[k]:>21}" for k in KEYS)
            print(f"{row['run']:<28}" + (f"{row['dt_s'] * 1e3:>12.6g}" if several else "") + cells)
        print(over_summary(runs))
        if several:
            print(period_summary(rows))
        if args.drag_seeds > 1:
            print(drag_summary(rows))
    if args.out is not None:
        from cobotsafety.arm.controller import ArmController

        # On stderr: with --json, stdout holds the JSON alone.
        print(f"wrote {plot(runs[0], ArmController(args.robot).model.limits, args.out)}", file=sys.stderr)
    return 0
