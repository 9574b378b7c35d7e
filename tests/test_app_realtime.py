"""Real-time scheduling of the control thread: granted or refused, the reported outcome matches
the policy the kernel reports for the thread (``os.sched_getscheduler``)."""

import os
import threading

import pytest

from cobotsafety.app.control_loop import ControlLoop, LoopSettings
from cobotsafety.app.realtime import request_fifo
from cobotsafety.planar.planar_teleop import PlanarTeleop

linux_only = pytest.mark.skipif(not hasattr(os, "sched_getscheduler"), reason="no POSIX scheduling API")


def _in_thread(fn):
    out = {}
    thread = threading.Thread(target=lambda: out.update(result=fn()))
    thread.start()
    thread.join()
    return out["result"]


@linux_only
def test_priority_zero_leaves_the_thread_alone():
    refused, policy = _in_thread(lambda: (request_fifo(0), os.sched_getscheduler(0)))
    assert refused == "not requested"
    assert policy == os.SCHED_OTHER


@linux_only
def test_outcome_matches_the_kernel_policy_and_only_the_calling_thread_changes():
    def ask():
        refused = request_fifo(10)
        return refused, os.sched_getscheduler(0), os.sched_getparam(0).sched_priority

    refused, policy, priority = _in_thread(ask)
    if refused:  # no permission here: the thread kept its policy, and the reason says why
        assert policy == os.SCHED_OTHER and "SCHED_FIFO refused" in refused
    else:
        assert (policy, priority) == (os.SCHED_FIFO, 10)
    assert os.sched_getscheduler(0) == os.SCHED_OTHER  # the caller of the thread is untouched


@linux_only
def test_an_out_of_range_priority_is_refused_with_a_reason():
    refused, policy = _in_thread(lambda: (request_fifo(1000), os.sched_getscheduler(0)))
    assert refused.startswith("SCHED_FIFO refused")
    assert policy == os.SCHED_OTHER


@linux_only
@pytest.mark.parametrize("priority", [0, 10])
def test_the_control_thread_runs_under_the_policy_it_reports(priority):
    loop = ControlLoop(PlanarTeleop(), LoopSettings(fifo_priority=priority))
    seen = []
    ticked = threading.Event()

    def record(_t_s: float) -> None:
        seen.append((os.sched_getscheduler(0), os.sched_getparam(0).sched_priority))
        ticked.set()

    loop.before_step.append(record)
    loop.start()
    try:
        assert ticked.wait(5.0)
    finally:
        loop.stop()
    if priority == 0:
        assert loop.fifo_refused == ""  # nothing asked, nothing refused
    granted = priority > 0 and not loop.fifo_refused
    assert seen[0] == ((os.SCHED_FIFO, priority) if granted else (os.SCHED_OTHER, 0))
