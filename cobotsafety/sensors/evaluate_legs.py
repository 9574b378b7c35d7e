"""Measure ``detect_legs`` on the real labelled scans (../shared/data/leg_tracker).

Run ``python -m cobotsafety.sensors.evaluate_legs [--data DIR] [--json]``.

Metrics, per setting, over every labelled scan of ``positive_1_extracted.bag`` and
``positive_2_extracted.bag`` (labels: hand-marked leg clusters, scan frame):

* ``hit_rate``: share of labelled clusters within the setting's range that have a detection
  within 0.15 m;
* ``false_per_scan``: detections farther than 0.15 m from every label (any range), per scan;
* ``torso_error_m``: median and 90th percentile, over scans whose in-range labels form one
  person (1 label, or 2 labels closer than 0.6 m), of the distance between the labels' mean
  and the nearest torso from ``torsos_from_legs``.

Settings: ``clip_1.4m`` — the paper's detector (clipped at 1.4 m, no background), labels within
1.4 m; ``range_5m_background`` — clipped at 5 m with a background estimated from the same
recording (the farthest valid reading of every beam), labels within 5 m.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from cobotsafety.sensors.legs import detect_legs, estimate_background, torsos_from_legs
from cobotsafety.sensors.rosbag_io import read_laser_scans, read_pose_arrays

BAGS = ("positive_1_extracted.bag", "positive_2_extracted.bag")
HIT_RADIUS_M = 0.15
DEFAULT_DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "leg_tracker"


def evaluate(data_dir: Path, max_range_m: float, use_background: bool) -> dict:
    labelled = found = false = scans = 0
    torso_errors = []
    for name in BAGS:
        path = Path(data_dir) / name
        scan_list = read_laser_scans(path, "/training_scan")
        labels = read_pose_arrays(path, "/leg_cluster_positions")
        background = estimate_background(scan_list) if use_background else None
        for scan, (_, truth) in zip(scan_list, labels):
            scans += 1
            legs = detect_legs(scan, max_range_m=max_range_m, background=background)
            in_range = truth[np.linalg.norm(truth, axis=1) <= max_range_m]
            if legs.size and truth.size:
                nearest_label = np.min(np.linalg.norm(legs[:, None] - truth[None], axis=-1), axis=1)
                false += int(np.sum(nearest_label > HIT_RADIUS_M))
            else:
                false += legs.shape[0]
            labelled += in_range.shape[0]
            if legs.size and in_range.size:
                nearest_det = np.min(np.linalg.norm(in_range[:, None] - legs[None], axis=-1), axis=1)
                found += int(np.sum(nearest_det <= HIT_RADIUS_M))
            one_person = in_range.shape[0] == 1 or (
                in_range.shape[0] == 2 and np.linalg.norm(in_range[0] - in_range[1]) < 0.6)
            if one_person:
                torsos = torsos_from_legs(legs)
                if torsos.size:
                    torso_errors.append(float(np.min(np.linalg.norm(torsos - in_range.mean(axis=0), axis=1))))
    errors = np.array(torso_errors)
    return {
        "scans": scans,
        "labelled_in_range": labelled,
        "hit_rate": round(found / labelled, 3) if labelled else None,
        "false_per_scan": round(false / scans, 3),
        "torso_error_median_m": round(float(np.median(errors)), 3) if errors.size else None,
        "torso_error_p90_m": round(float(np.percentile(errors, 90)), 3) if errors.size else None,
        "torso_scans": int(errors.size),
    }


def evaluate_all(data_dir: Path = DEFAULT_DATA) -> dict:
    return {
        "clip_1.4m": evaluate(data_dir, 1.4, use_background=False),
        "range_5m_background": evaluate(data_dir, 5.0, use_background=True),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder holding the labelled bags")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    result = evaluate_all(args.data)
    if args.json:
        print(json.dumps(result))
    else:
        for setting, figures in result.items():
            print(setting + ": " + ", ".join(f"{k}={v}" for k, v in figures.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
