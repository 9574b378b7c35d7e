"""Say when numba compiles: the first start of the demo spends ~40 s there, silently otherwise.

``announce_compilation(prefix)`` listens to numba's ``numba:compile`` events (fired only when a
kernel is really compiled, not when it is loaded from the ``cache=True`` files) while its
block runs: at the first one it prints one progress line, at the end one line with the count
and the time. A start that finds every kernel cached prints nothing.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from typing import Callable, Iterator

FIRST_START_S = 120
"""About how long a first start compiles on the project's 2-core machine [s] (README): 196
kernels in 115 s for the panda demo, measured 2026-12-01 with an empty cache at load 0.5."""


class _Announcer:
    def __init__(self, prefix: str, write: Callable[[str], None]):
        self.prefix, self.write = prefix, write
        self.lock = threading.Lock()
        self.compiled = 0
        self.started_s: float | None = None

    def on_start(self, _event) -> None:
        with self.lock:
            first = self.started_s is None
            if first:
                self.started_s = time.perf_counter()
        if first:
            self.write(f"{self.prefix}: compiling the numba kernels (first start only, about "
                       f"{FIRST_START_S} s on 2 cores; later starts load them from the cache)...")

    def on_end(self, _event) -> None:
        with self.lock:
            self.compiled += 1


def _print(line: str) -> None:
    print(line, file=sys.stdout, flush=True)


@contextlib.contextmanager
def announce_compilation(prefix: str, write: Callable[[str], None] = _print) -> Iterator[_Announcer]:
    """Print a progress line if numba compiles anything inside the block, and a summary after."""
    from numba.core import event  # noqa: PLC0415

    announcer = _Announcer(prefix, write)

    class Listener(event.Listener):
        def on_start(self, ev) -> None:
            announcer.on_start(ev)

        def on_end(self, ev) -> None:
            announcer.on_end(ev)

    with event.install_listener("numba:compile", Listener()):
        yield announcer
    if announcer.started_s is not None:
        write(f"{prefix}: compiled {announcer.compiled} numba kernel{'' if announcer.compiled == 1 else 's'} in "
              f"{time.perf_counter() - announcer.started_s:.0f} s (cached for the next start)")
