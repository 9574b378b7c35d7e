"""Real-time scheduling (Linux ``SCHED_FIFO``) for the calling thread, when the OS allows it.

Why the control thread asks for it: under the normal policy it is one runnable thread among
many, and a browser on the same machine takes the cores for tens of milliseconds at a time
(headless Chromium's GPU process drawing the scene in software GL used ~1.2 cores at nice -8,
in an autogroup of its own). Measured with the panda, the replayed human and Chromium attached
(``/proc/<pid>/task/<tid>/schedstat`` of the control thread across each gap over 30 ms): in
most gaps the thread was *runnable* nearly the whole gap (e.g. 404.7 ms of a 406 ms gap, 107
of 108, 249 of 250), waiting in the run queue, not blocked on the GIL.
A ``SCHED_FIFO`` thread runs as soon as it wakes, ahead of every normal thread; the control
thread sleeps most of each period, and the kernel's RT throttling (``sched_rt_runtime_us``)
bounds it if it ever does not.

Without the permission (a user without ``CAP_SYS_NICE`` and with ``RLIMIT_RTPRIO`` 0) or off
Linux, nothing changes and the reason is returned.
"""

from __future__ import annotations

import os


def request_fifo(priority: int) -> str:
    """Put the calling thread under ``SCHED_FIFO`` at ``priority`` (1-99; 0 = leave it alone).

    Returns "" on success, else why not (the thread keeps its policy).
    """
    if priority <= 0:
        return "not requested"
    if not hasattr(os, "sched_setscheduler"):
        return "SCHED_FIFO is not available on this platform"
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))  # 0: the calling thread
    except OSError as error:  # EPERM without CAP_SYS_NICE / RLIMIT_RTPRIO, EINVAL out of range
        return f"SCHED_FIFO refused: {error}"
    return ""
