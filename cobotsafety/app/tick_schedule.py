"""``TickSchedule``: when the control loop's next tick is due, and how much time each tick integrates.

Ticks are due on a fixed grid ``t0 + k * period_s`` (deadlines, not "sleep a period after the
step"), so a late wake-up does not shift every later tick: the schedule has no drift.

* Catching up: a tick that starts late, but at most ``max_lag_s`` behind its deadline, runs at
  once with the nominal ``period_s``, and so do the ticks after it, back to back, until the
  loop is on schedule again. The robot is integrated in nominal steps at the nominal rate and
  the simulated time trails the wall clock by at most ``max_lag_s``. A stall of a few
  milliseconds (another thread holding the interpreter) then costs no ticks.
* Only with headroom: the loop catches up only while its ticks take less than a period
  (running mean of the tick durations, ``TICK_MEAN_WEIGHT``, each counted as at most two
  periods so that one stalled tick does not stop the catching up); a robot whose step is slower
  than the period could never catch up, so each of its late ticks integrates the time that
  passed.
* Resynchronising: a tick that does not catch up integrates the time since its deadline plus
  one period (at most ``max_dt_s``) and starts a new grid at ``now``; it counts as an overrun.

Pure bookkeeping on the times it is given: ``ControlLoop`` feeds it ``time.perf_counter()``.
"""

from __future__ import annotations

from dataclasses import dataclass

MIN_RATE_HZ = 100.0
"""Slowest control rate accepted [Hz]: the filters are tested for steps up to 10 ms."""
MAX_RATE_HZ = 2000.0
"""Fastest control rate accepted [Hz]: one step takes 50-100 us, the loop sleeps between."""

TICK_MEAN_WEIGHT = 0.1
"""Weight of the newest tick in the running mean of tick durations (about the last 10 ticks)."""


@dataclass(frozen=True)
class Tick:
    """One tick as scheduled."""

    dt_s: float
    """Time the tick integrates [s]: ``period_s``, or more (at most ``max_dt_s``) on an overrun."""
    late_s: float
    """How long after its deadline the tick started [s] (0 when on time)."""
    overrun: bool
    """True when the tick dropped the ticks it missed and started a new grid."""


class TickSchedule:
    """Deadlines ``period_s`` apart; catch up within ``max_lag_s``, resynchronise beyond.

    Per tick: ``start(now_s)`` when it begins, ``finish(now_s)`` when its work is done (returns
    how long to sleep before the next one).
    """

    def __init__(self, period_s: float, max_lag_s: float, max_dt_s: float, start_s: float):
        if not 0.0 < period_s <= max_dt_s:
            raise ValueError(f"need 0 < period_s <= max_dt_s, got {period_s!r}, {max_dt_s!r}")
        self.period_s = period_s
        self.max_lag_s = max(0.0, max_lag_s)
        self.max_dt_s = max_dt_s
        self.due_s = start_s
        """Deadline of the next tick [s]."""
        self.tick_mean_s = 0.0
        """Running mean of the tick durations [s] (``finish`` minus ``start``, at most 2 periods)."""
        self._started_s = start_s

    @property
    def can_catch_up(self) -> bool:
        """True while the ticks take less than a period on average."""
        return self.tick_mean_s < self.period_s

    def start(self, now_s: float) -> Tick:
        """The tick starting at ``now_s``; moves the deadline on to the following tick."""
        self._started_s = now_s
        late_s = max(0.0, now_s - self.due_s)
        if late_s > 0.0 and (late_s > self.max_lag_s or not self.can_catch_up):
            self.due_s = now_s + self.period_s
            return Tick(min(late_s + self.period_s, self.max_dt_s), late_s, True)
        self.due_s += self.period_s
        return Tick(self.period_s, late_s, False)

    def finish(self, now_s: float) -> float:
        """The tick's work is done at ``now_s``: how long to sleep until the next deadline [s]."""
        duration_s = min(max(0.0, now_s - self._started_s), 2.0 * self.period_s)
        self.tick_mean_s += TICK_MEAN_WEIGHT * (duration_s - self.tick_mean_s)
        return max(0.0, self.due_s - now_s)
