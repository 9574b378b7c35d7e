"""Run a campaign: people x robots x controllers on a process pool or Ray, resumable.

Results go to ``DIR/results/<robot>/<controller>/person-<index>.json`` (one file per person x
controller, written atomically); a person whose files all exist is not run again, so an
interrupted campaign picks up where it stopped. The pipeline of one person runs once for all
its controllers (one task = one robot x one person). Deterministic per seed: person ``i`` is
drawn from ``default_rng([seed, i])`` whatever worker runs it. Parallel on
``concurrent.futures.ProcessPoolExecutor`` (``workers``), or on Ray (``ray_address``: a cluster
address, or ``"local"`` for a local instance with ``workers`` CPUs).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from cobotsafety.experiments import approach_settings as settings
from cobotsafety.tools.campaign.person_run import DEFAULT_PLANT, DEFAULT_SSM

CONTROLLERS = ("anticipative", "reactive", "stop")


def result_path(out_dir: Path, robot: str, controller: str, person: int) -> Path:
    return Path(out_dir) / "results" / robot / controller / f"person-{person:06d}.json"


def _write_atomic(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_suffix(f".{os.getpid()}.part")
    partial.write_text(text)
    partial.replace(path)


def pending_tasks(out_dir: Path, robots, controllers, people: int) -> list[tuple[str, int, tuple[str, ...]]]:
    """(robot, person, controllers still missing) for every person with a missing result."""
    tasks = []
    for robot in robots:
        for person in range(people):
            missing = tuple(c for c in controllers if not result_path(out_dir, robot, c, person).exists())
            if missing:
                tasks.append((robot, person, missing))
    return tasks


def run_task(robot: str, person: int, seed: int, controllers: tuple[str, ...], dt_s: float, escape_check: bool,
             nominal_s: float | None = None, plant: str = DEFAULT_PLANT,
             ssm: str = DEFAULT_SSM) -> tuple[list[dict], float]:
    """One task in a worker (``person_run.run_person``): its results and the CPU time it took
    [s] (the worker process's, so a shared machine's load does not count); the step's warnings
    are not printed."""
    import logging

    from cobotsafety.tools.campaign.person_run import run_person

    logger = logging.getLogger("cobotsafety")
    level = logger.level
    logger.setLevel(logging.ERROR)  # for this task only (it may run in the caller's process)
    try:
        start = time.process_time()
        results = run_person(robot, person, seed, controllers, dt_s, escape_check, nominal_s, plant, ssm)
        return results, time.process_time() - start
    finally:
        logger.setLevel(level)


def _save(out_dir: Path, outcome: tuple[list[dict], float], cpu: list) -> None:
    results, cpu_s = outcome
    cpu.append(cpu_s)
    for r in results:
        _write_atomic(result_path(out_dir, r["robot"], r["controller"], r["person"]), json.dumps(r, sort_keys=True) + "\n")


#: Settings ``campaign.json`` gained after its first campaigns, as those ran.
_RECORDED_LATER = {"ssm": "off"}


def _check_settings(out_dir: Path, wanted: dict) -> None:
    """``DIR/campaign.json`` records the seed, period, plant and SSM the first run used; a later run
    with others raises ``CampaignError`` (a directory without it, from before it was written, is
    taken as it is; one without the SSM, from before it was recorded, ran without it)."""
    from cobotsafety.errors import CampaignError

    path = Path(out_dir) / "campaign.json"
    if path.exists():
        try:
            found = json.loads(path.read_text())
        except (ValueError, UnicodeDecodeError) as error:
            raise CampaignError(f"{path} is not a campaign's settings ({error}): use a new --out directory") from None
        if not isinstance(found, dict):
            raise CampaignError(f"{path} is not a campaign's settings (not an object): use a new --out directory")
        found = {**_RECORDED_LATER, **found}
        differ = {k: (found[k], v) for k, v in wanted.items() if k in found and found[k] != v}
        if differ:
            said = ", ".join(f"{k} {was!r} there, {now!r} asked" for k, (was, now) in differ.items())
            raise CampaignError(f"{out_dir} holds another campaign ({said}): use a new --out directory")
        return
    _write_atomic(path, json.dumps(wanted, sort_keys=True) + "\n")


def load_results(out_dir: Path, robots, controllers, people: int) -> list[dict]:
    rows = []
    for robot in robots:
        for controller in controllers:
            for person in range(people):
                path = result_path(out_dir, robot, controller, person)
                if path.exists():
                    rows.append(json.loads(path.read_text()))
    return rows


def run_campaign(out_dir: Path, robots, controllers=CONTROLLERS, people: int = 100, seed: int = 0, workers: int = 2,
                 ray_address: str | None = None, dt_s: float = 1 / settings.CONTROL_RATE_HZ, escape_check: bool = True,
                 progress: bool = True, plant: str = DEFAULT_PLANT, ssm: str = DEFAULT_SSM) -> dict:
    """Run what is missing, then write the report; returns ``{"summary", "timing"}``. A
    directory holds one campaign: resuming it with another seed, period, plant or SSM raises
    ``CampaignError`` (its results would mix)."""
    from tqdm import tqdm

    from cobotsafety.tools.campaign.report import write_report

    out_dir = Path(out_dir)
    from cobotsafety.tools.campaign.person_run import nominal_completion_s

    _check_settings(out_dir, {"seed": seed, "dt_s": dt_s, "plant": plant, "ssm": ssm})
    tasks = pending_tasks(out_dir, robots, controllers, people)
    start = time.perf_counter()
    nominal = {robot: nominal_completion_s(robot, dt_s) for robot in {t[0] for t in tasks}}  # once, not per worker
    tasks = [(robot, person, missing, nominal[robot]) for robot, person, missing in tasks]
    bar = tqdm(total=len(tasks), desc="people", unit="person", disable=not progress)
    cpu: list[float] = []
    if tasks and ray_address:
        _run_on_ray(out_dir, tasks, seed, dt_s, escape_check, ray_address, workers, bar, cpu, plant, ssm)
    elif tasks and workers <= 1:
        for robot, person, missing, nominal_s in tasks:
            _save(out_dir, run_task(robot, person, seed, missing, dt_s, escape_check, nominal_s, plant, ssm), cpu)
            bar.update()
    elif tasks:
        from concurrent.futures import ProcessPoolExecutor, as_completed

        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = [pool.submit(run_task, robot, person, seed, missing, dt_s, escape_check, nominal_s, plant, ssm)
                       for robot, person, missing, nominal_s in tasks]
            for future in as_completed(futures):
                _save(out_dir, future.result(), cpu)
                bar.update()
    bar.close()
    wall_s = time.perf_counter() - start
    person_controllers = sum(len(task[2]) for task in tasks)
    cpu_s = float(sum(cpu))
    timing = {"tasks_run": len(tasks), "person_controllers_run": person_controllers, "wall_s": round(wall_s, 2),
              "workers": workers, "ray": ray_address, "cpu_s": round(cpu_s, 2),
              "person_controllers_per_s_per_core": round(person_controllers / wall_s / workers, 4) if tasks else None,
              "person_controllers_per_cpu_s": round(person_controllers / cpu_s, 4) if cpu_s > 0 else None,
              "load_average": list(os.getloadavg())}
    (out_dir / "timing.json").write_text(json.dumps(timing, indent=1) + "\n")
    header = (f"{people} people (seed {seed}) x robots {', '.join(robots)} x controllers {', '.join(controllers)}; "
              f"control at {1 / dt_s:.0f} Hz; plant {plant}; SSM {ssm}; scanner at the table corner; "
              "learned leg detector + person tracker.")
    summary = write_report(load_results(out_dir, robots, controllers, people), out_dir, header)
    return {"summary": summary, "timing": timing}


def _run_on_ray(out_dir, tasks, seed, dt_s, escape_check, address, workers, bar, cpu, plant, ssm) -> None:
    import ray

    if not ray.is_initialized():
        if address == "local":
            package_root = str(Path(__file__).resolve().parents[3])
            # Bound to 127.0.0.1 (a local instance has no authentication), no dashboard.
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False, _node_ip_address="127.0.0.1",
                     runtime_env={"env_vars": {"PYTHONPATH": package_root}})
        else:
            ray.init(address=address, log_to_driver=False)
    remote = ray.remote(run_task)
    pending = [remote.remote(robot, person, seed, missing, dt_s, escape_check, nominal_s, plant, ssm)
               for robot, person, missing, nominal_s in tasks]
    while pending:
        done, pending = ray.wait(pending, num_returns=1)
        for ref in done:
            _save(out_dir, ray.get(ref), cpu)
            bar.update()
