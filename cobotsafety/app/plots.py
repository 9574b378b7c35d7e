"""Live uPlot graphs: minimum distance [mm], commanded vs executed speed [mm/s], the worst
joint's acceleration against its limit [%] (3D arms), loop rate [Hz].

``PlotHistory`` keeps the last ``samples`` rows (the server adds one with each status refresh);
``Plots`` pushes them to four ``gui.add_uplot`` handles made once. The acceleration chart shows
the step's largest |q̈_j| / limit_j (``ArmStepReport.joint_acceleration_ratio``) in percent
beside the 100 % limit; values above ``ACCELERATION_RANGE_PCT``'s top are drawn at it (the
title says so): a safety-over-smoothness step. The speed and rate charts
have fixed, labelled y ranges (an empty chart does not read 0-100, small speeds do not read
"0 0 0"); the commanded speed is drawn dashed and wider under the executed one.

The distance chart draws the samples as dots, not a line: uPlot joins the points on either side
of a missing value (a NaN in viser's float arrays is not one of uPlot's gaps), so a line
bridged the time nobody was in view. Dots leave that time empty. It starts with no dot (one
row of NaN: an empty array froze viser's x range) and its y range grows in steps to hold every
distance shown (``distance_range_mm``): nothing is clipped at 1 m.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import viser
import viser.uplot as uplot

from cobotsafety.app.control_loop import LoopSnapshot

DISTANCE_RANGE_MM = (0.0, 1000.0)
"""The distance chart's smallest y range [mm]; it grows in steps of ``DISTANCE_STEP_MM``."""
DISTANCE_STEP_MM = 250.0
SPEED_RANGE_MM_S = (0.0, 300.0)
ACCELERATION_RANGE_PCT = (0.0, 150.0)
DISTANCE_RGB = "#d62728"


def _scales(y_range: tuple[float, float]) -> dict:
    # The x axis is simulated time in seconds, not a date; the y range is fixed.
    return {"x": uplot.Scale(time=False), "y": uplot.Scale(auto=False, range=y_range)}


def _axes(unit: str) -> tuple:
    return (uplot.Axis(label="t [s]", size=36), uplot.Axis(label=unit, size=56, labelSize=18))


def distance_range_mm(distance_mm: np.ndarray) -> tuple[float, float]:
    """The y range [mm] holding every finite value of ``distance_mm``: at least
    ``DISTANCE_RANGE_MM``, widened to the next multiple of ``DISTANCE_STEP_MM`` (below 0 for a
    capsule overlap)."""
    finite = distance_mm[np.isfinite(distance_mm)]
    low, high = DISTANCE_RANGE_MM
    if finite.size:
        low = min(low, math.floor(float(finite.min()) / DISTANCE_STEP_MM) * DISTANCE_STEP_MM)
        high = max(high, math.ceil(float(finite.max()) / DISTANCE_STEP_MM) * DISTANCE_STEP_MM)
    return float(low), float(high)


class PlotHistory:
    """Ring buffers of time [s], minimum distance [m], speeds [m/s] and loop rate [Hz]."""

    def __init__(self, samples: int = 120):
        self.columns = {key: deque(maxlen=samples) for key in
                        ("t_s", "min_distance_m", "speed_commanded_m_s", "speed_executed_m_s", "rate_hz",
                         "joint_acceleration_ratio")}

    def add(self, snapshot: LoopSnapshot, min_distance_m: float | None) -> None:
        times = self.columns["t_s"]
        if times and snapshot.t_s < times[-1]:  # time went back (reset, robot switch): a new trace
            self.clear()
        report = snapshot.report
        commanded = float(np.linalg.norm(report.v_commanded_m_s)) if report is not None else 0.0
        executed = float(np.linalg.norm(report.v_executed_m_s)) if report is not None else 0.0
        row = {"t_s": snapshot.t_s, "min_distance_m": np.nan if min_distance_m is None else min_distance_m,
               "speed_commanded_m_s": commanded, "speed_executed_m_s": executed,
               "rate_hz": snapshot.stats.get("rate_hz", 0.0),
               "joint_acceleration_ratio": getattr(report, "joint_acceleration_ratio", np.nan)}
        for key, value in row.items():
            self.columns[key].append(float(value))

    def array(self, key: str) -> np.ndarray:
        return np.fromiter(self.columns[key], dtype=float)

    def clear(self) -> None:
        for column in self.columns.values():
            column.clear()


class Plots:
    """Four uPlot charts in the current GUI container (the acceleration chart for 3D arms)."""

    def __init__(self, server: viser.ViserServer, rate_hz: float, distance_title: str = "Minimum distance"):
        empty = np.zeros(1)  # one row, not none: viser's chart keeps its x range relative to the data's
        nobody = np.full(1, np.nan)  # extent, which an empty array makes NaN for good (the x axis froze)
        line = lambda label, colour, **kw: uplot.Series(label=label, stroke=colour, **{"width": 2, **kw})  # noqa: E731
        dots = uplot.Series(label="distance [mm]", stroke="rgba(0,0,0,0)", width=0.5,
                            points=uplot.Series_Points(show=True, size=5.0, width=0.0, fill=DISTANCE_RGB,
                                                       stroke=DISTANCE_RGB))
        self.distance_range_mm = DISTANCE_RANGE_MM
        self._server, self._distance_title, self._dots = server, distance_title, dots
        self.distance = server.gui.add_uplot(
            (empty, nobody), (uplot.Series(label="t [s]"), dots),
            title=distance_title, aspect=2.0, padding=(18, 14, 0, 0), scales=_scales(DISTANCE_RANGE_MM), axes=_axes("mm"))
        self.speed = server.gui.add_uplot(
            (empty, empty, empty),
            (uplot.Series(label="t [s]"), line("commanded [mm/s]", "#1f77b4", dash=(8.0, 5.0), width=4),
             line("executed [mm/s]", "#2ca02c")),
            title="End-effector speed", aspect=2.0, padding=(18, 14, 0, 0), scales=_scales(SPEED_RANGE_MM_S), axes=_axes("mm/s"))
        top = ACCELERATION_RANGE_PCT[1]
        self.acceleration = server.gui.add_uplot(
            (empty, empty, empty),
            (uplot.Series(label="t [s]"), line("limit [%]", "#7f7f7f", dash=(6.0, 4.0)),
             line("worst joint [%]", "#ff7f0e")),
            title=f"Joint acceleration / limit (at {top:.0f} %: beyond)", aspect=2.0, padding=(18, 14, 0, 0),
            scales=_scales(ACCELERATION_RANGE_PCT), axes=_axes("%"))
        self.rate = server.gui.add_uplot(
            (empty, empty), (uplot.Series(label="t [s]"), line("loop [Hz]", "#9467bd")),
            title="Control-loop rate", aspect=2.0, padding=(18, 14, 0, 0), scales=_scales((0.0, 1.25 * rate_hz)), axes=_axes("Hz"))

    def push_distance(self, history: PlotHistory) -> None:
        """The distance samples so far; rows without a distance are NaN (drawn as nothing)."""
        t = history.array("t_s")
        if t.size < 2:
            return
        distance_mm = history.array("min_distance_m") * 1e3
        y_range = distance_range_mm(distance_mm)
        if y_range != self.distance_range_mm:  # a new chart in the old one's place (see _regrow)
            self._regrow(y_range, (t, distance_mm))
            return
        self.distance.data = (t, distance_mm)

    def _regrow(self, y_range: tuple[float, float], data: tuple[np.ndarray, np.ndarray]) -> None:
        """Replace the distance chart by one with ``y_range``, at the same place in the panel.

        Assigning new ``scales`` to a live chart makes viser's client rebuild it with a broken
        x range (frozen at a fifth of the data's, read back in the browser), so the chart is
        made anew; it happens only when the range grows or shrinks a step.
        """
        old = self.distance
        self.distance = self._server.gui.add_uplot(
            data, (uplot.Series(label="t [s]"), self._dots), title=self._distance_title, aspect=2.0,
            padding=(18, 14, 0, 0), scales=_scales(y_range), axes=_axes("mm"), order=old.order, visible=old.visible)
        old.remove()
        self.distance_range_mm = y_range

    def push(self, history: PlotHistory, distance: bool = True) -> None:
        """The three charts (``distance=False``: the speed and rate charts only)."""
        if distance:
            self.push_distance(history)
        t = history.array("t_s")
        if t.size < 2:
            return
        self.speed.data = (t, history.array("speed_commanded_m_s") * 1e3, history.array("speed_executed_m_s") * 1e3)
        if self.acceleration.visible:
            percent = np.minimum(history.array("joint_acceleration_ratio") * 100.0, ACCELERATION_RANGE_PCT[1])
            self.acceleration.data = (t, np.full(t.shape, 100.0), percent)
        self.rate.data = (t, history.array("rate_hz") * 1.0)
