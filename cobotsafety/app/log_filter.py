"""``RepeatedWarningFilter``: a log message template shown at most once per interval."""

from __future__ import annotations

import logging
import time


class RepeatedWarningFilter(logging.Filter):
    """Let one log message template through at most once per ``interval_s`` [s].

    The filter's "stopped the robot" warning can fire at every 1 kHz step while a person stands
    in the arm; the demo's terminal shows it once per interval instead.
    """

    def __init__(self, interval_s: float = 5.0):
        super().__init__()
        self.interval_s = interval_s
        self._last_s: dict[str, float] = {}

    def filter(self, record: logging.LogRecord) -> bool:
        now = time.monotonic()
        key = str(record.msg)
        if now - self._last_s.get(key, float("-inf")) < self.interval_s:
            return False
        self._last_s[key] = now
        return True
