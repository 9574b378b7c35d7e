"""Complete headless sessions with simulated participants (``cobotsafety trial --simulate N``)."""

from __future__ import annotations

from pathlib import Path

from cobotsafety.trial.course import arm_course, planar_course
from cobotsafety.trial.log_store import LogStore
from cobotsafety.trial.plan import session_plan
from cobotsafety.trial.session import simulate_trial
from cobotsafety.trial.simulated_participant import SimulatedParticipant


def make_robot(scene: str):
    if scene == "planar":
        from cobotsafety.planar.teleop import PlanarTeleop

        return PlanarTeleop(), planar_course()
    from cobotsafety.arm.teleop import ArmTeleop

    return ArmTeleop("panda", zones=[]), arm_course()


def run_simulated_sessions(out: Path, participants: int, seed: int = 0, scene: str = "planar",
                           dt_s: float = 0.01) -> list[dict]:
    """Run (or resume) every planned trial; returns the records written this time."""
    store = LogStore(out)
    done = store.done()
    ids = [f"P{i + 1:02d}" for i in range(participants)]
    robot, course = make_robot(scene)
    written = []
    for k, trial in enumerate(session_plan(ids, seed=seed)):
        if (trial.participant, trial.attention, trial.condition) in done:
            continue
        trial_seed = seed * 1000 + k
        agent = SimulatedParticipant(seed=trial_seed)
        run, trajectory = simulate_trial(robot, course, agent, trial.condition, trial.attention == "divided", trial_seed, dt_s)
        record = run.record(trial.participant, trial.condition, trial.order, trial_seed)
        store.append(record, trajectory)
        written.append(record)
    return written
