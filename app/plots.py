"""Live uPlot graphs: minimum distance, commanded vs executed speed, control-loop rate.

``PlotHistory`` keeps the last ``window_s`` of samples (one per render frame); ``Plots`` pushes
them to three ``gui.add_uplot`` handles made once.
"""

from __future__ import annotations

from collections import deque

import numpy as np
import viser
import viser.uplot as uplot

from cobotsafety.app.control_loop import LoopSnapshot


#: The x axis is simulated time in seconds, not a date.
SCALES = {"x": uplot.Scale(time=False)}


class PlotHistory:
    """Ring buffers of time [s], minimum distance [m], speeds [m/s] and loop rate [Hz]."""

    def __init__(self, samples: int = 300):
        self.columns = {key: deque(maxlen=samples) for key in
                        ("t_s", "min_distance_m", "speed_commanded_m_s", "speed_executed_m_s", "rate_hz")}

    def add(self, snapshot: LoopSnapshot, min_distance_m: float | None) -> None:
        report = snapshot.report
        commanded = float(np.linalg.norm(report.v_commanded_m_s)) if report is not None else 0.0
        executed = float(np.linalg.norm(report.v_executed_m_s)) if report is not None else 0.0
        row = {"t_s": snapshot.t_s, "min_distance_m": np.nan if min_distance_m is None else min_distance_m,
               "speed_commanded_m_s": commanded, "speed_executed_m_s": executed,
               "rate_hz": snapshot.stats.get("rate_hz", 0.0)}
        for key, value in row.items():
            self.columns[key].append(float(value))

    def array(self, key: str) -> np.ndarray:
        return np.fromiter(self.columns[key], dtype=float)

    def clear(self) -> None:
        for column in self.columns.values():
            column.clear()


class Plots:
    """Three uPlot charts in the current GUI container."""

    def __init__(self, server: viser.ViserServer):
        empty = np.zeros(1)
        line = lambda label, colour: uplot.Series(label=label, stroke=colour, width=2)  # noqa: E731
        self.distance = server.gui.add_uplot(
            (empty, empty), (uplot.Series(label="t [s]"), line("min distance [m]", "red")),
            title="Minimum distance", aspect=2.0, scales=SCALES)
        self.speed = server.gui.add_uplot(
            (empty, empty, empty),
            (uplot.Series(label="t [s]"), line("commanded [m/s]", "blue"), line("executed [m/s]", "green")),
            title="End-effector speed", aspect=2.0, scales=SCALES)
        self.rate = server.gui.add_uplot(
            (empty, empty), (uplot.Series(label="t [s]"), line("loop [Hz]", "purple")),
            title="Control-loop rate", aspect=2.0, scales=SCALES)

    def push(self, history: PlotHistory) -> None:
        t = history.array("t_s")
        if t.size < 2:
            return
        self.distance.data = (t, history.array("min_distance_m"))
        self.speed.data = (t, history.array("speed_commanded_m_s"), history.array("speed_executed_m_s"))
        self.rate.data = (t, history.array("rate_hz"))
