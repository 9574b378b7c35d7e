"""Durable trial logs: one JSON line per finished trial, plus one trajectory file per trial.

Each record is appended with flush + fsync, and its trajectory is written to a temporary
file and renamed into place before the record is appended, so killing the process at any
moment leaves every finished trial complete and readable. Reading reports each problem
(corrupt or non-UTF-8 line, duplicate trial, missing or unreadable trajectory) with file and
line, and keeps the rest.
Participant ids are pseudonyms; nothing else personal is stored.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

LOG_NAME = "trials.jsonl"
REQUIRED = ("participant", "condition", "attention", "order", "seed", "completion_time_s", "errors",
            "response_times_s", "trajectory")


@dataclass
class LoadedLog:
    records: list[dict]
    problems: list[str]


class LogStore:
    def __init__(self, directory: Path):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.path = self.directory / LOG_NAME

    def append(self, record: dict, trajectory: np.ndarray) -> None:
        """Write the trajectory (atomically), then append the record (flushed and fsynced)."""
        name = f"traj_{record['participant']}_{record['attention']}_{record['condition']}.npy"
        tmp = self.directory / (name + ".tmp")
        with open(tmp, "wb") as f:
            np.save(f, np.asarray(trajectory, dtype=float))
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.directory / name)
        line = json.dumps({**record, "trajectory": name}) + "\n"
        with open(self.path, "a", encoding="utf-8") as f:
            f.write(line)
            f.flush()
            os.fsync(f.fileno())

    def done(self) -> set[tuple[str, str, str]]:
        """(participant, attention, condition) of every finished trial: what a resume skips."""
        records = load(self.directory, read_trajectories=False).records
        return {(r["participant"], r["attention"], r["condition"]) for r in records}


def trajectory_problem(path: Path, read: bool = True) -> str:
    """What is wrong with a trajectory file ("" when it loads as an (n, 4) array of numbers;
    ``read=False``: when it exists)."""
    if not path.is_file():
        return "is missing"
    if not read:
        return ""
    try:
        trajectory = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as error:
        return f"is unreadable, truncated? ({' '.join(str(error).split())[:80]})"
    if trajectory.ndim != 2 or trajectory.shape[1:] != (4,) or trajectory.dtype.kind not in "fi":
        return f"holds a {trajectory.dtype} array of shape {trajectory.shape}, not (n, 4) numbers"
    return ""


def load(directory: Path, read_trajectories: bool = True) -> LoadedLog:
    """Every valid record of ``directory``'s log, and each problem with file and line.

    ``read_trajectories``: also load each trajectory file to report a truncated one (the
    analysis); ``False`` only checks that it exists (a resume's list of finished trials).
    """
    directory = Path(directory)
    path = directory / LOG_NAME
    records, problems, seen = [], [], {}
    if not path.exists():
        return LoadedLog([], [f"{path}: no trial log"])
    with open(path, "rb") as f:
        for number, raw in enumerate(f, start=1):
            where = f"{path}:{number}"
            try:
                line = raw.decode("utf-8")
            except UnicodeDecodeError:
                problems.append(f"{where}: not UTF-8 text; skipped")
                continue
            if not line.strip():
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError as error:
                problems.append(f"{where}: corrupt line ({error.msg}); skipped")
                continue
            if not isinstance(record, dict):
                problems.append(f"{where}: not a trial record (a JSON {type(record).__name__}); skipped")
                continue
            missing = [k for k in REQUIRED if k not in record]
            if missing:
                problems.append(f"{where}: missing fields {missing}; skipped")
                continue
            key = (record["participant"], record["attention"], record["condition"])
            if not all(isinstance(k, str) for k in key) or not isinstance(record["trajectory"], str):
                problems.append(f"{where}: participant, attention, condition and trajectory must be text; skipped")
                continue
            if key in seen:
                problems.append(f"{where}: duplicate trial {key} (first at line {seen[key]}); skipped")
                continue
            trajectory = Path(record["trajectory"])
            problem = ("is not a file name in the log's folder" if trajectory.name != record["trajectory"]
                       or trajectory.name in ("", ".", "..") else trajectory_problem(directory / trajectory, read_trajectories))
            if problem:
                problems.append(f"{where}: trajectory file {record['trajectory']} {problem}; record kept")
            seen[key] = number
            records.append(record)
    return LoadedLog(records, problems)
