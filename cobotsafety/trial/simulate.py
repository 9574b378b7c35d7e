"""Complete headless sessions with simulated participants (``cobotsafety trial --simulate N``).

The robot and the course come from ``trial_scene`` (the ones people drive in the browser);
the plan from ``plan.session_plan`` (conditions and attention order counterbalanced). Each
simulated person keeps their ``Experience`` across their four trials, in the plan's order.
"""

from __future__ import annotations

from pathlib import Path

from cobotsafety.trial.log_store import LogStore
from cobotsafety.trial.plan import session_plan, write_plan
from cobotsafety.trial.session import simulate_trial
from cobotsafety.trial.simulated_participant import Experience, SimulatedParticipant
from cobotsafety.trial.trial_scene import make_trial_robot


def simulated_study(participants: int, seed: int = 0, scene: str = "planar", dt_s: float = 0.01,
                    skip: set | None = None, overrides: dict[str, tuple[float, float]] | None = None):
    """Yield ``(record, trajectory)`` for every planned trial of one study (``skip``: keys done,
    whose practice still counts for the person's later trials).

    Participant ``P03`` is the same simulated person in their four trials (parameters drawn
    with seed ``10_000_000 + seed * 1000 + 2``, ranges with ``overrides`` applied); each trial
    has its own noise seed. Records carry the model's diagnostics under ``model``.
    """
    ids = [f"P{i + 1:02d}" for i in range(participants)]
    robot, course = make_trial_robot(scene)
    experience = {p: Experience() for p in ids}
    for k, trial in enumerate(session_plan(ids, seed=seed)):
        trial_seed = seed * 1000 + k
        person_seed = 10_000_000 + seed * 1000 + ids.index(trial.participant)
        agent = SimulatedParticipant.from_population(person_seed, trial_seed, experience[trial.participant], overrides)
        run, trajectory = simulate_trial(robot, course, agent, trial.condition, trial.attention == "divided",
                                         trial_seed, dt_s)
        if skip and (trial.participant, trial.attention, trial.condition) in skip:
            continue  # logged by an earlier run: simulated again only for what the person learned in it
        record = run.record(trial.participant, trial.condition, trial.order, trial_seed)
        record["model"] = agent.diagnostics.as_json()
        yield record, trajectory


def run_simulated_sessions(out: Path, participants: int, seed: int = 0, scene: str = "planar",
                           dt_s: float = 0.01, overrides: dict[str, tuple[float, float]] | None = None) -> list[dict]:
    """Run (or resume) every planned trial; returns the records written this time. The plan
    file (``plan.json``: the pre-declared analysis and the trial order) is written first."""
    store = LogStore(out)
    ids = [f"P{i + 1:02d}" for i in range(participants)]
    write_plan(out, session_plan(ids, seed=seed), seed, simulated={"participants": participants, "scene": scene,
                                                                   "overrides": overrides or {}})
    written = []
    for record, trajectory in simulated_study(participants, seed, scene, dt_s, skip=store.done(), overrides=overrides):
        store.append(record, trajectory)
        written.append(record)
    return written
