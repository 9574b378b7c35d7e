"""``cobotsafety bench sensors``: one laser scan (271 beams) + 5 IMU samples -> 5 human capsules.

One timed call = ``HumanTracker.push_scan`` (eq. 1 filter, clipping, leg detection with the
background, scanner pose eq. 10, the person tracker) + five ``push_imu`` + ``capsules_at``
(interpolation, slerp, eqs. 5-12, conservative rules: one compiled call for the fresh
5-capsule human), on scans and IMU samples of the bundled recording while
the human stands at the table with the arm reaching (both legs in view).
``detect_legs_median_us``: the default leg detector alone on those scans, in the same run.
``detect_legs_dense_ms``: ``detect_legs`` (learned and the paper's rule) on one full-turn scan
of 10^5 and 10^6 beams crafted as the worst case of the learned detector's context: after its
decimation to the trained spacing, a cluster of three returns every six beams (median of 5).
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
    result["detect_legs_dense_ms"] = {f"{method} {beams:.0e}": round(median_us(
        lambda scan=crafted_dense_scan(beams), method=method: detect_legs(scan, 6.0, method=method),
        runs=5, warmup=1) / 1e3, 1) for beams in (10**5, 10**6) for method in ("learned", "paper")}
    return result


def crafted_dense_scan(beams: int):
    """A full turn of ``beams`` beams whose decimation to the trained spacing leaves clusters
    of three returns at 1.0 m between gaps at 1.3 m (~340 clusters of ~1,030 beams)."""
    import math

    import numpy as np

    from cobotsafety.sensors.laser_scan import LaserScan
    from cobotsafety.sensors.legs import FINEST_INCREMENT_RAD

    increment_rad = 2 * math.pi / (beams - 1)
    step = max(1, int(FINEST_INCREMENT_RAD / increment_rad + 1e-9))
    ranges = np.where((np.arange(beams) // step) % 6 < 3, 1.0, 1.3)
    return LaserScan(-math.pi, increment_rad, 0.05, 8.0, ranges)
