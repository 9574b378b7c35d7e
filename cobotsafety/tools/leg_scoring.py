"""Scoring leg detections against the hand labels of the leg_tracker bags (``train_legs``'s
cross-validation and ``evaluate_legs`` share it).

Per scan, a *detection* is a leg position [m] in the scanner frame; the labels are the
labelled leg clusters (centroids). leg_tracker labels every leg cluster within
``SECTOR_HALF_ANGLE_RAD`` (15 deg) and ``SECTOR_RANGE_M`` (5 m) of the scanner and nothing
elsewhere (``extract_positive_training_clusters``: ``min_angle``, ``max_angle``,
``max_dist``), so a detection is known to be false only inside that sector; outside it may be
an unlabelled person (positive_2 has several).

Counts over a bag (``score_scans``):

* ``labelled``: labels within the range scored; ``found``: those with a detection within
  ``HIT_RADIUS_M``;
* ``false``: detections farther than ``HIT_RADIUS_M`` from every label; ``false_in_sector``:
  those inside the labelled sector;
* ``torso_errors_m``: over scans whose labels in range form one person (1 label, or 2 closer
  than ``ONE_PERSON_M``), the distance from the labels' mean to the nearest torso;
* ``scans``.

Two sources of detections: ``detector_detections`` (each scan alone; torsos paired by
``torsos_from_legs``) and ``pipeline_detections`` (the detector's legs fed to a
``PersonTracker``: the legs of its *confirmed* people, seen in the scan or carried through a
short miss, and their torsos; what the human model is given).
"""

from __future__ import annotations

from typing import Callable, Iterable, Iterator

import numpy as np

from cobotsafety.sensors.laser_scan import LaserScan
from cobotsafety.sensors.legs import torsos_from_legs
from cobotsafety.sensors.person_tracker import PersonTracker, PersonTrackerParams

HIT_RADIUS_M = 0.25
ONE_PERSON_M = 0.6
SECTOR_HALF_ANGLE_RAD = np.radians(15.0)
SECTOR_RANGE_M = 5.0
COUNTS = ("labelled", "found", "false", "false_in_sector", "scans")

Detections = Iterator[tuple[np.ndarray, np.ndarray]]


def in_sector(xy_m: np.ndarray) -> np.ndarray:
    """Shape (k,) bool: the points (k, 2) [m] inside the labelled sector (bearing and range)."""
    xy_m = np.asarray(xy_m, dtype=float).reshape(-1, 2)
    return ((np.abs(np.arctan2(xy_m[:, 1], xy_m[:, 0])) <= SECTOR_HALF_ANGLE_RAD)
            & (np.hypot(xy_m[:, 0], xy_m[:, 1]) <= SECTOR_RANGE_M))


def detector_detections(scans: Iterable[LaserScan], detect: Callable[[LaserScan], np.ndarray]) -> Detections:
    """Per scan: (``detect(scan)`` (k, 2), the torsos paired from them (p, 2)) [m]."""
    for scan in scans:
        legs = detect(scan)
        yield legs, torsos_from_legs(legs)


def pipeline_detections(scans: Iterable[LaserScan], detect: Callable[[LaserScan], np.ndarray],
                        params: PersonTrackerParams = PersonTrackerParams()) -> Detections:
    """Per scan: the legs (seen and carried) and torsos of the confirmed people of a
    ``PersonTracker(params)`` fed ``detect(scan)`` at the scans' stamps [m]."""
    tracker = PersonTracker(params)
    for scan in scans:
        people = [p for p in tracker.update(scan.stamp_s, detect(scan)) if p.confirmed]
        legs = np.concatenate([p.all_leg_xy_m for p in people]) if people else np.zeros((0, 2))
        yield legs.reshape(-1, 2), np.array([p.p_xy_m for p in people]).reshape(-1, 2)


def score_scans(detections: Iterable[tuple[np.ndarray, np.ndarray]], labels: list[np.ndarray | None],
                max_range_m: float) -> dict:
    """The module's counts for one bag; ``labels[i]`` (k, 2) [m] or None (nobody in view)."""
    counts = dict.fromkeys(COUNTS, 0)
    torso_errors = []
    for (legs, torsos), truth in zip(detections, labels, strict=True):
        truth = np.zeros((0, 2)) if truth is None else truth
        in_range = truth[np.hypot(truth[:, 0], truth[:, 1]) <= max_range_m]
        counts["scans"] += 1
        counts["labelled"] += in_range.shape[0]
        far = np.ones(legs.shape[0], dtype=bool)
        if legs.size and truth.size:
            distance = np.linalg.norm(legs[:, None] - truth[None], axis=-1)
            far = distance.min(axis=1) > HIT_RADIUS_M
        if legs.size and in_range.size:
            counts["found"] += int(np.sum(np.linalg.norm(in_range[:, None] - legs[None], axis=-1).min(axis=1)
                                          <= HIT_RADIUS_M))
        counts["false"] += int(far.sum())
        counts["false_in_sector"] += int(np.sum(far & in_sector(legs)))
        one_person = in_range.shape[0] == 1 or (
            in_range.shape[0] == 2 and np.linalg.norm(in_range[0] - in_range[1]) < ONE_PERSON_M)
        if one_person and torsos.size:
            torso_errors.append(float(np.min(np.linalg.norm(torsos - in_range.mean(axis=0), axis=1))))
    counts["torso_errors_m"] = torso_errors
    return counts


def summary(counts: dict) -> dict:
    """Rates of one bag's counts: recall, false legs per scan (everywhere and in the sector),
    the median torso error [m] and over how many scans."""
    errors = counts["torso_errors_m"]
    return {
        "scans": counts["scans"],
        "labelled": counts["labelled"],
        "recall": round(counts["found"] / counts["labelled"], 3) if counts["labelled"] else None,
        "false_per_scan": round(counts["false"] / counts["scans"], 3),
        "false_in_sector_per_scan": round(counts["false_in_sector"] / counts["scans"], 3),
        "torso_error_median_m": round(float(np.median(errors)), 3) if errors else None,
        "torso_scans": len(errors),
    }
