"""The control loop's schedule: deadlines without drift, catching up, resynchronising; on a
simulated clock (no timing in these tests)."""

import numpy as np
import pytest
from hypothesis import given, strategies as st

from cobotsafety.app.tick_schedule import TickSchedule

PERIOD_S, MAX_LAG_S, MAX_DT_S = 0.001, 0.010, 0.010


def run(durations_s, overshoot_s=0.0, start_s=100.0):
    """Ticks taking ``durations_s`` each, sleeps overshooting by ``overshoot_s``: the ticks and
    their start times."""
    schedule = TickSchedule(PERIOD_S, MAX_LAG_S, MAX_DT_S, start_s)
    now, ticks, starts = start_s, [], []
    for duration in durations_s:
        tick = schedule.start(now)
        ticks.append(tick)
        starts.append(now)
        now += duration
        delay = schedule.finish(now)
        if delay > 0.0:
            now += delay + overshoot_s
    return schedule, ticks, np.array(starts)


def test_on_time_ticks_are_a_period_apart_and_do_not_drift():
    # each sleep wakes 70 us late (timer slack): the deadlines stay on the grid
    schedule, ticks, starts = run([0.0002] * 10_000, overshoot_s=70e-6)
    assert all(t.dt_s == PERIOD_S and not t.overrun for t in ticks)
    assert schedule.due_s == pytest.approx(100.0 + 10_000 * PERIOD_S, abs=1e-9)
    np.testing.assert_allclose(starts - 100.0, np.arange(10_000) * PERIOD_S + np.where(np.arange(10_000) > 0, 70e-6, 0), atol=1e-9)


def test_a_stall_shorter_than_the_lag_bound_is_caught_up_with_nominal_steps():
    durations = [0.0002] * 20 + [0.006] + [0.0002] * 40  # one tick held up 6 ms
    schedule, ticks, starts = run(durations)
    assert all(t.dt_s == PERIOD_S and not t.overrun for t in ticks)
    late = np.array([t.late_s for t in ticks])
    assert late.max() == pytest.approx(0.006 - PERIOD_S)
    # back on schedule: the last ticks start on the grid again, 61 periods after the first
    assert late[-1] == 0.0
    assert starts[-1] - starts[0] == pytest.approx(60 * PERIOD_S)
    # the ticks after the stall ran back to back (200 us apart) until caught up
    assert np.sum(np.isclose(np.diff(starts), 0.0002)) >= 5


def test_a_stall_beyond_the_lag_bound_integrates_the_time_that_passed_and_starts_a_new_grid():
    schedule, ticks, starts = run([0.0002] * 5 + [0.030] + [0.0002] * 5)
    overruns = [i for i, t in enumerate(ticks) if t.overrun]
    assert overruns == [6]
    tick = ticks[6]
    assert tick.late_s == pytest.approx(0.030 - PERIOD_S)
    assert tick.dt_s == MAX_DT_S  # 30 ms passed: capped at 10 ms
    assert all(t.dt_s == PERIOD_S and t.late_s == 0.0 for t in ticks[7:])
    assert starts[7] == pytest.approx(starts[6] + PERIOD_S)  # the new grid starts at the late tick


def test_a_robot_slower_than_the_period_is_integrated_in_real_time_without_catching_up():
    _, ticks, starts = run([0.006] * 200)
    steady = ticks[20:]
    assert all(t.overrun for t in steady)
    dts = np.array([t.dt_s for t in steady])
    np.testing.assert_allclose(dts, 0.006)  # the time that passed between tick starts
    np.testing.assert_allclose(np.diff(starts[20:]), 0.006)


def test_bad_period_is_refused():
    with pytest.raises(ValueError, match="period_s"):
        TickSchedule(0.02, MAX_LAG_S, MAX_DT_S, 0.0)


@given(st.lists(st.sampled_from([0.0001, 0.0003, 0.0009, 0.002, 0.004, 0.012, 0.025]), min_size=1, max_size=400),
       st.floats(0.0, 2e-4))
def test_simulated_time_never_runs_ahead_and_trails_by_at_most_the_lag_bound(durations, overshoot_s):
    schedule, ticks, starts = run(durations, overshoot_s)
    simulated_s, lost_s = 0.0, 0.0
    for tick, start in zip(ticks, starts):
        assert PERIOD_S <= tick.dt_s <= MAX_DT_S
        assert tick.late_s <= MAX_LAG_S or tick.overrun
        lost_s += max(0.0, tick.late_s + PERIOD_S - MAX_DT_S) if tick.overrun else 0.0
        simulated_s += tick.dt_s
        wall_s = start - starts[0] + PERIOD_S  # the tick integrates up to one period ahead
        assert simulated_s <= wall_s + 1e-9
        assert wall_s - simulated_s - lost_s <= MAX_LAG_S + 1e-9


def test_one_stalled_tick_does_not_stop_the_catching_up():
    # a 30 ms tick (resynchronised), then ticks whose sleeps wake 60 us late: caught up, no overrun
    _, ticks, _ = run([0.0002] * 5 + [0.030] + [0.0002] * 50 + [0.004] + [0.0002] * 20, overshoot_s=60e-6)
    assert [i for i, t in enumerate(ticks) if t.overrun] == [6]
    assert all(t.dt_s == PERIOD_S for t in ticks[7:])
