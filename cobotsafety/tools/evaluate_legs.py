"""Measure the leg detectors on real labelled scans: ``python -m cobotsafety.tools.evaluate_legs``.

``python -m cobotsafety.tools.evaluate_legs [--data DIR] [--bags A.bag B.bag ...] [--json]``

Labelled bags (default ``positive_1/2_extracted.bag`` of ``../shared/data/leg_tracker``): a
LaserScan topic and a PoseArray of hand-labelled leg clusters per scan (scan frame). Bags
without labels (default ``negative_2.bag``, nobody in view) count false detections only.

Methods: ``paper`` (``detect_legs(method="paper")``), ``learned`` (the bundled cluster
classifier) and ``learned+tracker`` (the learned legs fed to ``PersonTracker``; the legs of
confirmed persons are the detections, their torsos the torsos). Settings: ``6m_background``
(max range 6 m, per-beam background estimated from the same recording by
``estimate_background``), ``6m`` (no background) and ``1.4m`` (the paper's clip, no background).

Metrics per bag, method and setting:

* ``recall``: share of the labels within range that have a detection within ``HIT_RADIUS_M``;
* ``false_per_scan``: detections farther than ``HIT_RADIUS_M`` from every label, per scan;
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
from cobotsafety.sensors.legs import detect_legs, estimate_background, torsos_from_legs
from cobotsafety.sensors.rosbag_io import read_laser_scans, read_pose_arrays

LABELLED_BAGS = ("positive_1_extracted.bag", "positive_2_extracted.bag")
NOBODY_BAGS = ("negative_2.bag",)
SCAN_TOPIC, LABEL_TOPIC = "/training_scan", "/leg_cluster_positions"
HIT_RADIUS_M = 0.25
ONE_PERSON_M = 0.6
SETTINGS = {"6m_background": (6.0, True), "6m": (6.0, False), "1.4m": (1.4, False)}
METHODS = ("paper", "learned", "learned+tracker")
DEFAULT_DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "leg_tracker"


def _detections(method: str, scans: list[LaserScan], max_range_m: float, background):
    """Per scan: (legs (k, 2), torsos (p, 2)) [m], scanner frame."""
    if method in ("paper", "learned"):
        for scan in scans:
            legs = detect_legs(scan, max_range_m, background, method=method)
            yield legs, torsos_from_legs(legs)
        return
    from cobotsafety.sensors.person_tracker import PersonTracker

    tracker = PersonTracker()
    for scan in scans:
        people = [p for p in tracker.update(scan.stamp_s, detect_legs(scan, max_range_m, background)) if p.confirmed]
        legs = np.concatenate([p.leg_xy_m.reshape(-1, 2) for p in people]) if people else np.zeros((0, 2))
        yield legs, np.array([p.p_xy_m for p in people]).reshape(-1, 2)


def score(method: str, scans: list[LaserScan], labels: list[np.ndarray] | None, max_range_m: float,
          background: np.ndarray | None) -> dict:
    """The module's metrics for one bag (``labels`` None: nobody in view)."""
    labelled = found = false = 0
    torso_errors = []
    for i, (legs, torsos) in enumerate(_detections(method, scans, max_range_m, background)):
        truth = np.zeros((0, 2)) if labels is None else labels[i]
        in_range = truth[np.linalg.norm(truth, axis=1) <= max_range_m]
        labelled += in_range.shape[0]
        if legs.size and truth.size:
            false += int(np.sum(np.linalg.norm(legs[:, None] - truth[None], axis=-1).min(axis=1) > HIT_RADIUS_M))
        else:
            false += legs.shape[0]
        if legs.size and in_range.size:
            found += int(np.sum(np.linalg.norm(in_range[:, None] - legs[None], axis=-1).min(axis=1) <= HIT_RADIUS_M))
        one_person = in_range.shape[0] == 1 or (
            in_range.shape[0] == 2 and np.linalg.norm(in_range[0] - in_range[1]) < ONE_PERSON_M)
        if one_person and torsos.size:
            torso_errors.append(float(np.min(np.linalg.norm(torsos - in_range.mean(axis=0), axis=1))))
    return {
        "scans": len(scans),
        "labelled": labelled,
        "recall": round(found / labelled, 3) if labelled else None,
        "false_per_scan": round(false / len(scans), 3),
        "torso_error_median_m": round(float(np.median(torso_errors)), 3) if torso_errors else None,
        "torso_scans": len(torso_errors),
    }


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
    print("setting | method | bag | scans | labelled | recall | false / scan | torso error median [m] (scans)")
    for setting, methods in result.items():
        for method, bags in methods.items():
            for bag, m in bags.items():
                print(f"{setting} | {method} | {bag} | {m['scans']} | {m['labelled']} | {m['recall']} | "
                      f"{m['false_per_scan']} | {m['torso_error_median_m']} ({m['torso_scans']})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
