"""Replay playback for the demo: which recording, playing or paused, time, speed, loop.

Loading goes through ``cobotsafety.human.replay.Replay`` (its loader validates); a file that
fails validation is refused with the loader's message and the previous replay keeps running.
Time advances with the wall clock times ``speed`` while playing.
"""

from __future__ import annotations

import math
import re
import threading
from pathlib import Path

from cobotsafety.errors import CobotSafetyError
from cobotsafety.human.body import HumanCapsules

BAG_SUFFIXES = (".bag", ".db3", ".mcap")


def load_replay(path: Path):
    """A ``Replay`` of a recording (.jsonl.gz) or a laser-only ROS bag (file or folder)."""
    from cobotsafety.human.replay import Replay  # noqa: PLC0415

    path = Path(path)
    if path.is_dir() or path.suffix in BAG_SUFFIXES:
        return Replay.from_bag(path)
    return Replay.from_file(path)


def seek_maximum_s(duration_s: float) -> float:
    """The seek slider's maximum: the duration rounded down to the slider's 0.01 s step."""
    return max(math.floor(duration_s * 100.0 + 1e-6) / 100.0, 0.01)


def without_server_paths(message: str, path: Path) -> str:
    """``message`` with the server-side location of ``path`` removed (only its name is shown)."""
    for location in (str(path), str(path.parent) + "/", str(path.parent)):
        message = message.replace(location, "" if location.endswith("/") else path.name)
    return re.sub(r"/(?:tmp|var|root|home)/\S*", "<file>", message)


class ReplayControl:
    """Thread-safe playback state over one ``Replay`` at a time."""

    def __init__(self, replay=None, name: str = ""):
        self.lock = threading.Lock()
        self.replay, self.name = replay, name
        self.playing = replay is not None
        self.speed = 1.0
        self.loop = True
        self.time_s = 0.0
        """Seconds since the recording's start."""

    def load(self, path: Path, name: str | None = None) -> str:
        """Switch to ``path``; returns "" or the loader's error (and keeps the previous replay)."""
        try:
            replay = load_replay(path)
        except (CobotSafetyError, OSError, ValueError) as error:
            return f"refused {Path(path).name}: {error}"
        with self.lock:
            self.replay, self.name = replay, name or Path(path).name
            self.time_s, self.playing = 0.0, True
        return ""

    @property
    def duration_s(self) -> float:
        return 0.0 if self.replay is None else float(self.replay.duration_s)

    def advance(self, wall_dt_s: float) -> None:
        """Move time on by ``wall_dt_s * speed`` when playing; loop or pause at the end."""
        with self.lock:
            if self.replay is None or not self.playing:
                return
            self.time_s += max(0.0, wall_dt_s) * self.speed
            if self.time_s > self.duration_s:
                if self.loop and self.duration_s > 0:
                    self.time_s %= self.duration_s
                else:
                    self.time_s, self.playing = self.duration_s, False

    def seek(self, time_s: float) -> None:
        with self.lock:
            self.time_s = min(max(0.0, float(time_s)), self.duration_s)

    def capsules(self) -> HumanCapsules | None:
        """The human now, or None without a replay."""
        with self.lock:
            if self.replay is None:
                return None
            return self.replay.capsules_at(self.replay.start_s + self.time_s)
