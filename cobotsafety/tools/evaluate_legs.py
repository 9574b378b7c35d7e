"""Measure the leg detectors on real labelled scans: ``python -m cobotsafety.tools.evaluate_legs``.

``python -m cobotsafety.tools.evaluate_legs [--data DIR] [--bags A.bag B.bag ...] [--json]``

Labelled bags (default ``positive_1/2_extracted.bag`` of ``../shared/data/leg_tracker``): a
LaserScan topic and a PoseArray of hand-labelled leg clusters per scan (scan frame). Bags
without labels (default ``negative_2.bag``, nobody in view) count false detections only.

Methods: ``paper`` (``detect_legs(method="paper")``), ``learned`` (the bundled cluster
classifier) and ``learned+tracker`` (the learned legs fed to ``PersonTracker``; the legs of
confirmed persons, seen or carried through a short miss, are the detections, their torsos the
torsos). Scoring: ``leg_scoring``. Settings: ``6m_background``
(max range 6 m, per-beam background estimated from the same recording by
``estimate_background``), ``6m`` (no background) and ``1.4m`` (the paper's clip, no background).

Metrics per bag, method and setting:

* ``recall``: share of the labels within range that have a detection within ``HIT_RADIUS_M``;
* ``false_per_scan``: detections farther than ``HIT_RADIUS_M`` from every label, per scan;
  ``false_in_sector_per_scan``: those inside the labelled sector (+-15 deg, 5 m), where the
  labels are complete;
* ``torso_error_median_m``: over scans whose in-range labels form one person (1 label, or 2
  closer than 0.6 m), the distance from the labels' mean to the nearest torso (a scan with no
  torso is not counted; ``torso_scans`` says how many were).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from cobotsafety.sensors.laser_scan import LaserScan
from cobotsafety.sensors.legs import detect_legs, estimate_background
from cobotsafety.sensors.rosbag_io import read_laser_scans, read_pose_arrays
from cobotsafety.tools.leg_scoring import detector_detections, pipeline_detections, score_scans, summary

LABELLED_BAGS = ("positive_1_extracted.bag", "positive_2_extracted.bag")
NOBODY_BAGS = ("negative_2.bag",)
SCAN_TOPIC, LABEL_TOPIC = "/training_scan", "/leg_cluster_positions"
SETTINGS = {"6m_background": (6.0, True), "6m": (6.0, False), "1.4m": (1.4, False)}
METHODS = ("paper", "learned", "learned+tracker")
DEFAULT_DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "leg_tracker"


def score(method: str, scans: list[LaserScan], labels: list[np.ndarray] | None, max_range_m: float,
          background: np.ndarray | None) -> dict:
    """The module's metrics for one bag (``labels`` None: nobody in view)."""
    if method == "learned+tracker":
        detections = pipeline_detections(scans, lambda scan: detect_legs(scan, max_range_m, background))
    else:
        detections = detector_detections(scans, lambda scan: detect_legs(scan, max_range_m, background, method=method))
    return summary(score_scans(detections, [None] * len(scans) if labels is None else labels, max_range_m))


def load_bag(path: Path, labelled: bool) -> list[tuple[str, list[LaserScan], list[np.ndarray] | None]]:
    """[(name, scans, labels or None)]: one entry per LaserScan topic of an unlabelled bag."""
    if labelled:
        scans = read_laser_scans(path, SCAN_TOPIC)
        labels = [xy for _, xy in read_pose_arrays(path, LABEL_TOPIC)]
        if len(labels) != len(scans):
            raise ValueError(f"{path}: {len(scans)} scans but {len(labels)} label messages")
        return [(path.name, scans, labels)]
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        topics = sorted({c.topic for c in reader.connections if c.msgtype.endswith("LaserScan")})
    return [(f"{path.name}{topic}", read_laser_scans(path, topic), None) for topic in topics]


def evaluate_all(labelled_bags: list[Path], nobody_bags: list[Path] = (), methods=METHODS,
                 settings: dict = SETTINGS) -> dict:
    """``{setting: {method: {bag: metrics}}}``."""
    bags = [entry for path in labelled_bags for entry in load_bag(Path(path), True)]
    bags += [entry for path in nobody_bags for entry in load_bag(Path(path), False)]
    result = {}
    for setting, (max_range_m, use_background) in settings.items():
        result[setting] = {}
        for method in methods:
            result[setting][method] = {}
            for name, scans, labels in bags:
                background = estimate_background(scans) if use_background else None
                result[setting][method][name] = score(method, scans, labels, max_range_m, background)
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of the default bags")
    parser.add_argument("--bags", type=Path, nargs="*", help="labelled bags (default: the two positive bags)")
    parser.add_argument("--nobody", type=Path, nargs="*", help="bags with nobody in view (default: negative_2.bag)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    labelled = args.bags if args.bags is not None else [args.data / b for b in LABELLED_BAGS]
    nobody = args.nobody if args.nobody is not None else [args.data / b for b in NOBODY_BAGS]
    result = evaluate_all(labelled, nobody)
    if args.json:
        print(json.dumps(result))
        return 0
    print("setting | method | bag | scans | labelled | recall | false / scan | in the sector | "
          "torso error median [m] (scans)")
    for setting, methods in result.items():
        for method, bags in methods.items():
            for bag, m in bags.items():
                print(f"{setting} | {method} | {bag} | {m['scans']} | {m['labelled']} | {m['recall']} | "
                      f"{m['false_per_scan']} | {m['false_in_sector_per_scan']} | "
                      f"{m['torso_error_median_m']} ({m['torso_scans']})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
