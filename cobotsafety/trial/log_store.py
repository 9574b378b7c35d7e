"""Durable trial logs: one JSON line per finished trial, plus one trajectory file per trial.

Each record is appended with flush + fsync, and its trajectory is written to a temporary
file and renamed into place before the record is appended, so killing the process at any
moment leaves every finished trial complete and readable. Reading reports each problem
(corrupt line, duplicate trial, missing trajectory) with file and line, and keeps the rest.
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
        return {(r["participant"], r["attention"], r["condition"]) for r in load(self.directory).records}


def load(directory: Path) -> LoadedLog:
    directory = Path(directory)
    path = directory / LOG_NAME
    records, problems, seen = [], [], {}
    if not path.exists():
        return LoadedLog([], [f"{path}: no trial log"])
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, start=1):
            if not line.strip():
                continue
            where = f"{path}:{number}"
            try:
                record = json.loads(line)
            except json.JSONDecodeError as error:
                problems.append(f"{where}: corrupt line ({error.msg}); skipped")
                continue
            missing = [k for k in REQUIRED if k not in record]
            if missing:
                problems.append(f"{where}: missing fields {missing}; skipped")
                continue
            key = (record["participant"], record["attention"], record["condition"])
            if key in seen:
                problems.append(f"{where}: duplicate trial {key} (first at line {seen[key]}); skipped")
                continue
            if not (directory / record["trajectory"]).exists():
                problems.append(f"{where}: trajectory file {record['trajectory']} is missing; record kept")
            seen[key] = number
            records.append(record)
    return LoadedLog(records, problems)
