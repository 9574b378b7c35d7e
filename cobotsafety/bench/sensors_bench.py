"""``cobotsafety bench sensors``: one laser scan (271 beams) + 5 IMU samples -> 5 human capsules.

One timed call = ``HumanTracker.push_scan`` (eq. 1 filter, clipping, leg detection with the
background, scanner pose eq. 10, the person tracker) + five ``push_imu`` + ``capsules_at``
(interpolation, slerp, eqs. 5-12, conservative rules: one compiled call for the fresh
5-capsule human), on scans and IMU samples of the bundled recording while
the human stands at the table with the arm reaching (both legs in view).
``detect_legs_median_us``: the default leg detector alone on those scans, in the same run.
"""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def run(args: argparse.Namespace) -> dict:
    import numpy as np

    from cobotsafety.bench.stopwatch import median_us
    from cobotsafety.human.recording import bundled_recording, load_recording
    from cobotsafety.human.tracker import HumanTracker
    from cobotsafety.sensors.imu import IMU_NAMES
    from cobotsafety.sensors.laser_scan import LaserScan
    from cobotsafety.sensors.legs import detect_legs, estimate_background

    rec = load_recording(bundled_recording())
    g = rec.laser
    window = np.flatnonzero((rec.laser_t_s > 9.0) & (rec.laser_t_s < 13.0))
    scans = [LaserScan(g["angle_min"], g["angle_increment"], g["range_min"], g["range_max"], rec.laser_ranges_m[i])
             for i in range(len(rec.laser_t_s))]
    background = estimate_background(scans)
    tracker = HumanTracker(rec.body, rec.scanner, rec.calibration, background)
    clock = {"k": 0, "t": 100.0}
    samples = {name: rec.imu_q_ref[name][len(rec.imu_q_ref[name]) // 3] for name in IMU_NAMES}

    def step():
        clock["t"] += 0.02  # a fresh stamp each call: streams refuse time going backwards
        t = clock["t"]
        tracker.push_scan(t, scans[window[clock["k"] % len(window)]])
        clock["k"] += 1
        for name in IMU_NAMES:
            tracker.push_imu(t, name, samples[name])
        return tracker.capsules_at(t)

    for _ in range(5):  # the person tracker confirms the human after a few scans
        caps = step()
    assert len(caps.names) == 5, f"bench setup: expected 5 capsules, got {caps.names} ({caps.reason})"
    result = {"name": "sensors_pipeline", "median_us": round(median_us(step, runs=2000, warmup=100), 1),
              "beams": int(g["beams"]), "imus": len(IMU_NAMES), "capsules": len(caps.names)}
    # The leg detector alone (default method) on the same scans, clipped as the tracker clips
    # them, in the same run: its share of the frame.
    clipped = [LaserScan(g["angle_min"], g["angle_increment"], g["range_min"], g["range_max"],
                         np.where(scans[i].valid & (scans[i].ranges < tracker.max_range_m), scans[i].ranges, 0.0))
               for i in window]
    legs_clock = {"k": 0}

    def legs_only():
        legs_clock["k"] += 1
        return detect_legs(clipped[legs_clock["k"] % len(clipped)], tracker.max_range_m, background)

    result["detect_legs_median_us"] = round(median_us(legs_only, runs=2000, warmup=100), 1)
    result["detect_legs_share"] = round(result["detect_legs_median_us"] / result["median_us"], 2)
    return result
