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
        from cobotsafety.planar.planar_teleop import PlanarTeleop

        return PlanarTeleop(), planar_course()
    from cobotsafety.arm.teleop import ArmTeleop

    return ArmTeleop("panda", zones=[]), arm_course()


def simulated_study(participants: int, seed: int = 0, scene: str = "planar", dt_s: float = 0.01,
                    skip: set | None = None):
    """Yield ``(record, trajectory)`` for every planned trial of one study (``skip``: keys done).

    Participant ``P03`` is the same simulated person in their four trials (parameters drawn
    with seed ``seed * 1000 + 3``); each trial has its own noise seed.
    """
    ids = [f"P{i + 1:02d}" for i in range(participants)]
    robot, course = make_robot(scene)
    for k, trial in enumerate(session_plan(ids, seed=seed)):
        if skip and (trial.participant, trial.attention, trial.condition) in skip:
            continue
        trial_seed = seed * 1000 + k
        person_seed = 10_000_000 + seed * 1000 + ids.index(trial.participant)
        agent = SimulatedParticipant.from_population(person_seed, trial_seed)
        run, trajectory = simulate_trial(robot, course, agent, trial.condition, trial.attention == "divided", trial_seed, dt_s)
        yield run.record(trial.participant, trial.condition, trial.order, trial_seed), trajectory


def run_simulated_sessions(out: Path, participants: int, seed: int = 0, scene: str = "planar",
                           dt_s: float = 0.01) -> list[dict]:
    """Run (or resume) every planned trial; returns the records written this time."""
    store = LogStore(out)
    written = []
    for record, trajectory in simulated_study(participants, seed, scene, dt_s, skip=store.done()):
        store.append(record, trajectory)
        written.append(record)
    return written
