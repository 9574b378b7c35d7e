"""Replay playback for the demo: which recording, playing or paused, time, speed, loop.

Loading goes through ``cobotsafety.human.replay.Replay`` (its loader validates); a file that
fails validation is refused with one plain sentence naming it once (``refusal_sentence``) and
the previous replay keeps running.
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


def refusal_sentence(name: str, error: BaseException | str) -> str:
    """One plain sentence for a refused file: ``take.bag is not a readable ROS bag (no LaserScan messages)``.

    The loader's message names the file and line (``/tmp/x/take.bag:3: what (details)``): the
    location goes (the name is said once, the line kept as "line 3"), and so does a trailing
    parenthesised technical detail (a codec's or parser's own words).
    """
    kind = "ROS bag" if Path(name).suffix in BAG_SUFFIXES else "recording"
    text = " ".join(str(error).split())
    match = (re.match(rf"^.*?{re.escape(name)}(?::(?P<line>\d+))?: (?P<what>.+)$", text)
             or re.match(r"^\S*?(?::(?P<line>\d+))?: (?P<what>.+)$", text))
    what, line = (match.group("what"), match.group("line")) if match else (text, None)
    what = re.sub(r"\s*\((?:[^()]|\([^()]*\))*\)$", "", what).strip() or what  # drop a trailing "(...)"
    what = re.sub(r"/(?:tmp|var|root|home|opt|usr|work)/\S*", "the file", what)
    if len(what) > 90:
        what = what[:87].rstrip() + "..."
    where = f"line {line}: " if line else ""
    return f"{name} is not a readable {kind} ({where}{what})"


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
        """Switch to ``path``; returns "" or ``refusal_sentence`` (and keeps the previous replay)."""
        name = name or Path(path).name
        try:
            replay = load_replay(path)
        except (CobotSafetyError, OSError, ValueError) as error:
            return refusal_sentence(name, error)
        self.use(replay, name)
        return ""

    def use(self, replay, name: str) -> None:
        """Switch to an already loaded ``Replay`` (an upload kept in memory), from its start."""
        with self.lock:
            self.replay, self.name = replay, name
            self.time_s, self.playing = 0.0, True

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
