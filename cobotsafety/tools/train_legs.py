"""Train the leg classifier on the leg_tracker bags and bundle it: ``python -m cobotsafety.tools.train_legs``.

Training set (``../shared/data/leg_tracker``, BSD-3, angusleigh/leg_tracker):

* ``positive_1/2_extracted.bag``: the clusters whose centroid is within ``MATCH_M`` of a
  hand-labelled leg cluster are legs; clusters farther than ``UNLABELLED_NEAR_M`` from every
  label (walls, furniture of that room) are not; the ones in between (pieces of a leg split in
  two) are left out.
* ``negative_2.bag`` (three scanners, nobody in view): every cluster is not a leg.
* ``synthetic_legs``, in every fold: 1,000 ray-cast pairs of legs (circles of 4.5-8 cm, touching
  or up to 0.3 m apart, 0.5-5.5 m away) as legs (positive_2 holds 3 clusters of two legs
  together; without them a forest trained without positive_1 missed its leg pairs), the
  pieces of the backdrop or straight wall behind them as non-legs (a wall between two legs'
  shadows is a short straight cluster with nearer neighbours on both sides); and the
  ghosts that eq. 1's trailing returns leave beside 60 rendered walks (time-filtered and
  clipped as ``HumanTracker`` does before detecting) as non-legs (the pairs alone made one
  such ghost leg-like, and the replay's tracker paired it).

Each scan also enters decimated (every 2nd and 3rd beam), so the classifier sees the
resolutions of other scanners (0.35 deg here; 1 deg for the bench's TiM-like scanner).

Cross-validation leaves one bag out at a time: a model trained on the others detects legs in
the held-out bag at full resolution (6 m range, with a per-beam background estimated from
that bag and without), scored as ``evaluate_legs`` scores it. Two decision thresholds, one per
setting (``choose_threshold``: the highest threshold that keeps every held-out bag's recall
0.05 above the 0.85 aim with the pooled false detections 30 % under 0.5 per scan, away from
the cliff below; else the best pooled recall under that cap), from the held-out positive bags
pooled (the fold that holds out the negative bag is reported, not used: its model never saw a
chair leg). Fixed seeds: the command writes the same model every run
(``assets/legs/leg_forest.npz``) and prints the table.

The model is gradient-boosted trees of depth 3 (``BOOSTING``) on the clusters' shape and
context (``leg_context``). Held out, without a background, the random forest of depth 6 on
shape alone that it replaces found 51 % of the labelled legs at 2.75 false detections per scan
(positive_1 and positive_2 pooled, threshold 0.7) and 19 % at 0.09; these trees with the
context find 71 % at 0.18 and 82 % at 0.91: five chair and table legs of the labelled room,
leg-shaped and leg-sized, looked like legs in nearly every scan until the classifier saw what
stands around them. Deeper random forests, boosting on shape alone, or the demo bag's
background-subtracted clusters as extra examples were no better held out.
"""

from __future__ import annotations

import argparse
import json
from functools import lru_cache
from pathlib import Path

import numpy as np

from cobotsafety.sensors.laser_scan import LaserScan
from cobotsafety.sensors.leg_classifier import LegForest
from cobotsafety.sensors.leg_clusters import segment
from cobotsafety.sensors.leg_features import cluster_features
from cobotsafety.sensors.legs import estimate_background, scored_candidates, torsos_from_legs
from cobotsafety.sensors.rosbag_io import read_laser_scans, read_pose_arrays
from cobotsafety.tools.synthetic_legs import leg_scans, scene_examples, walking_examples

DEFAULT_DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "leg_tracker"
DEFAULT_OUT = Path(__file__).resolve().parents[1] / "assets" / "legs" / "leg_forest.npz"
POSITIVE_BAGS = ("positive_1_extracted.bag", "positive_2_extracted.bag")
NEGATIVE_BAG, NEGATIVE_TOPICS = "negative_2.bag", ("/left_scan", "/rear_scan", "/right_scan")
#: A cluster whose centroid is this close to a label [m] is a leg.
MATCH_M = 0.10
#: Unlabelled clusters closer than this to a label [m] are ambiguous (left out).
UNLABELLED_NEAR_M = 0.5
#: Beam decimations added to the training set.
DECIMATIONS = (1, 2, 3)
#: Every how many scans of the negative bag to use (consecutive scans are near duplicates).
NEGATIVE_SCAN_STEP = 4
#: Scoring: a label is found when a detection is within this distance [m].
HIT_RADIUS_M = 0.25
CV_RANGE_M = 6.0
MAX_FALSE_PER_SCAN = 0.5
#: Share of MAX_FALSE_PER_SCAN the chosen threshold may use on the held-out bags (a margin
#: for unseen ones).
FALSE_PER_SCAN_MARGIN = 0.7
MIN_RECALL = 0.5
#: The recall the chosen threshold should keep on every held-out bag: the aim, with a margin.
RECALL_AIM = 0.85
RECALL_MARGIN = 0.05
SETTINGS = ("background", "no_background")
THRESHOLDS = (0.02, 0.03, 0.04, 0.05, 0.06, 0.08, 0.1, 0.12, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6, 0.65,
              0.7, 0.75, 0.8, 0.85, 0.9, 0.95, 0.97, 0.99)
SEED = 14
BOOSTING = dict(n_estimators=200, max_depth=3, learning_rate=0.1, subsample=0.8)


def decimate(scan: LaserScan, step: int) -> LaserScan:
    """Every ``step``-th beam of ``scan`` (the first beam kept)."""
    if step == 1:
        return scan
    return LaserScan(scan.angle_min, scan.angle_increment * step, scan.range_min, scan.range_max,
                     scan.ranges[::step], scan.stamp_s)


def labelled_examples(scan: LaserScan, labels_m: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Features (c', F) and classes (c',) (1 = leg) of the usable clusters of one scan.

    ``labels_m``: (k, 2) labelled leg positions, or None when nobody is in view.
    """
    clusters = segment(scan)
    features = cluster_features(scan, clusters)
    if labels_m is None or labels_m.size == 0:
        return features, np.zeros(clusters.count, dtype=int)
    distance = np.linalg.norm(clusters.centroids()[:, None] - labels_m[None], axis=-1).min(axis=1)
    leg, other = distance <= MATCH_M, distance > UNLABELLED_NEAR_M
    return features[leg | other], leg[leg | other].astype(int)


def load_bags(data_dir: Path) -> dict[str, list[tuple[LaserScan, np.ndarray | None]]]:
    """Bag name (a topic suffix for the negative bag) -> [(scan, labels or None)]."""
    bags = {}
    for name in POSITIVE_BAGS:
        scans = read_laser_scans(data_dir / name, "/training_scan")
        labels = read_pose_arrays(data_dir / name, "/leg_cluster_positions")
        bags[name] = [(scan, xy) for scan, (_, xy) in zip(scans, labels)]
    for topic in NEGATIVE_TOPICS:
        bags[f"{NEGATIVE_BAG}{topic}"] = [(scan, None) for scan in read_laser_scans(data_dir / NEGATIVE_BAG, topic)]
    return bags


def group_of(bag: str) -> str:
    return bag.split("/")[0]


def training_set(bags: dict, names: list[str], synthetic: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Features and classes of the bags ``names`` (every scan at every decimation), plus the
    synthetic examples (``synthetic_examples``) unless ``synthetic`` is False."""
    xs, ys = [], []
    for name in names:
        step = NEGATIVE_SCAN_STEP if name.startswith(NEGATIVE_BAG) else 1
        for scan, labels in bags[name][::step]:
            for decimation in DECIMATIONS:
                x, y = labelled_examples(decimate(scan, decimation), labels)
                xs.append(x)
                ys.append(y)
    if synthetic:
        x, y = synthetic_examples()
        xs.append(x)
        ys.append(y)
    return np.concatenate(xs), np.concatenate(ys)


@lru_cache(maxsize=1)
def synthetic_examples() -> tuple[np.ndarray, np.ndarray]:
    """Features and classes of the rendered examples (``synthetic_legs``, computed once): the
    clusters of pairs of legs (legs), and the trailing-return ghosts of walks through eq. 1 and
    a clip (not legs), every scan at every decimation."""
    scenes = [scene_examples(decimate(scan, decimation), legs_m)
              for scan, legs_m in leg_scans() for decimation in DECIMATIONS]
    walk_x, walk_y = walking_examples(decimations=DECIMATIONS)
    ghosts = walk_y == 0
    return (np.concatenate([x for x, _ in scenes] + [walk_x[ghosts]]),
            np.concatenate([y for _, y in scenes] + [walk_y[ghosts]]))


def fit(x: np.ndarray, y: np.ndarray):
    """Gradient-boosted trees (``BOOSTING``), both classes weighted alike (there are ~10x more
    other clusters than legs)."""
    from sklearn.ensemble import GradientBoostingClassifier
    from sklearn.utils.class_weight import compute_sample_weight

    return GradientBoostingClassifier(random_state=SEED, **BOOSTING).fit(
        x, y, sample_weight=compute_sample_weight("balanced", y))


def score_bag(scans: list[tuple[LaserScan, np.ndarray | None]], detect) -> dict:
    """Counts for recall within HIT_RADIUS_M of labels within CV_RANGE_M, false detections per
    scan, and the torso errors [m] of one-person scans (as ``evaluate_legs`` scores them)."""
    labelled = found = false = 0
    torso_errors = []
    for scan, labels in scans:
        legs = detect(scan)
        truth = np.zeros((0, 2)) if labels is None else labels[np.linalg.norm(labels, axis=1) <= CV_RANGE_M]
        labelled += truth.shape[0]
        if legs.size and truth.size:
            d = np.linalg.norm(legs[:, None] - truth[None], axis=-1)
            found += int(np.sum(d.min(axis=0) <= HIT_RADIUS_M))
            false += int(np.sum(d.min(axis=1) > HIT_RADIUS_M))
        else:
            false += legs.shape[0]
        one_person = truth.shape[0] == 1 or (truth.shape[0] == 2 and np.linalg.norm(truth[0] - truth[1]) < 0.6)
        torsos = torsos_from_legs(legs)
        if one_person and torsos.size:
            torso_errors.append(float(np.min(np.linalg.norm(torsos - truth.mean(axis=0), axis=1))))
    return {"labelled": labelled, "found": found, "false": false, "scans": len(scans), "torso_errors_m": torso_errors}


def print_curves(cv: dict, thresholds: np.ndarray) -> None:
    """Recall / false detections per scan of every held-out bag at every threshold."""
    print("threshold | " + " | ".join(f"{n} ({s})" for n, s in cv))
    for i, t in enumerate(thresholds):
        cells = [(f"{c[i]['found'] / c[i]['labelled']:.2f}" if c[i]["labelled"] else "-")
                 + f" / {c[i]['false'] / c[i]['scans']:.2f}" for c in cv.values()]
        print(f"{t} | " + " | ".join(cells))


def cross_validate(bags: dict, thresholds: np.ndarray) -> dict:
    """Leave-one-bag-out: per held-out bag, per background setting, counts per threshold."""
    groups = sorted({group_of(n) for n in bags})
    result = {}
    for held_out in groups:
        train = [n for n in bags if group_of(n) != held_out]
        forest = LegForest.from_sklearn(fit(*training_set(bags, train)), 0.5, 0.5)
        for name in (n for n in bags if group_of(n) == held_out):
            scans = bags[name]
            background = estimate_background([s for s, _ in scans])
            for setting, bg in zip(SETTINGS, (background, None)):
                # Each scan's candidates scored once; a threshold keeps those above it, exactly
                # what learned_legs(..., threshold_probability=t) returns.
                scored = {id(s): scored_candidates(s, CV_RANGE_M, bg, forest=forest) for s, _ in scans}
                result[(name, setting)] = [
                    score_bag(scans, lambda s, t=t: scored[id(s)][0][scored[id(s)][1] > t]) for t in thresholds]
        print(f"  fold {held_out} done", flush=True)
    return result


def pooled_curve(cv: dict, thresholds: np.ndarray, setting: str) -> list[tuple[float, float, float]]:
    """Per threshold: (recall, false detections per scan, F1) over the held-out positive bags pooled."""
    curve = []
    for i in range(thresholds.size):
        rows = [counts[i] for (name, s), counts in cv.items() if s == setting and not name.startswith(NEGATIVE_BAG)]
        found, labelled = sum(r["found"] for r in rows), sum(r["labelled"] for r in rows)
        false, scans = sum(r["false"] for r in rows), sum(r["scans"] for r in rows)
        curve.append((found / labelled, false / scans, 2 * found / (labelled + found + false)))
    return curve


def choose_threshold(cv: dict, thresholds: np.ndarray, setting: str) -> int:
    """Index of the threshold for ``setting``, from the held-out positive bags.

    A threshold t is *safe* when the pooled false detections per scan stay within
    ``FALSE_PER_SCAN_MARGIN`` x ``MAX_FALSE_PER_SCAN`` at t and at every threshold below it
    down to (and including) the first one at which the odds p / (1 - p) are half of t's or less
    (for small t about t / 2): leg probabilities of unseen scans shift, and just below the
    lowest such threshold the false detections jump (a random forest's with-background curve
    once went from 0.17 to 0.79 per scan between 0.04 and 0.02, and 0.03 chosen there let eq.
    1's trailing returns through in the replay). Odds, not probabilities: the boosted model's
    probability is a logistic function, and a shift of its log-odds moves a threshold near 0.5
    much farther in probability than one near 0.02.
    Among the safe thresholds at which *every* held-out bag keeps a recall of ``RECALL_AIM`` +
    ``RECALL_MARGIN``, the highest (fewest false detections, farthest from the cliff); when none
    does, the safe one with the best pooled recall (at least ``MIN_RECALL``); when none is
    safe, the best pooled F1 (a false leg makes the robot careful, a missed one does not).
    False detections are pooled, not per bag: positive_2's are nearly all people outside the
    labelled sector (the bags label every cluster within +-15 deg and 5 m, nobody elsewhere).
    """
    curve = pooled_curve(cv, thresholds, setting)
    cap = FALSE_PER_SCAN_MARGIN * MAX_FALSE_PER_SCAN
    odds = thresholds / (1.0 - thresholds)
    safe = []
    for i in range(thresholds.size):
        below = np.flatnonzero(odds <= odds[i] / 2)
        if below.size and all(curve[k][1] <= cap for k in range(thresholds.size)
                              if thresholds[below.max()] <= thresholds[k] <= thresholds[i]):
            safe.append(i)
    bags = [counts for (name, s), counts in cv.items() if s == setting and not name.startswith(NEGATIVE_BAG)]
    with_margin = [i for i in safe if all(c[i]["found"] >= (RECALL_AIM + RECALL_MARGIN) * c[i]["labelled"] for c in bags)]
    if with_margin:
        return max(with_margin, key=lambda i: thresholds[i])
    feasible = [i for i in safe if curve[i][0] >= MIN_RECALL]
    if feasible:
        return max(feasible, key=lambda i: (curve[i][0], -curve[i][1]))
    return max(range(thresholds.size), key=lambda i: curve[i][2])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--curves", action="store_true", help="print recall / false per scan at every threshold")
    args = parser.parse_args(argv)
    bags = load_bags(args.data)
    thresholds = np.array(THRESHOLDS)
    cv = cross_validate(bags, thresholds)
    if args.curves:
        print_curves(cv, thresholds)
    chosen = {setting: choose_threshold(cv, thresholds, setting) for setting in SETTINGS}
    x, y = training_set(bags, list(bags))
    forest = LegForest.from_sklearn(fit(x, y), float(thresholds[chosen["background"]]),
                                    float(thresholds[chosen["no_background"]]))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    forest.save(args.out)
    table = {f"{name} ({setting})": {
        "scans": c["scans"], "labelled": c["labelled"],
        "recall": round(c["found"] / c["labelled"], 3) if c["labelled"] else None,
        "false_per_scan": round(c["false"] / c["scans"], 3),
        "torso_error_median_m": round(float(np.median(c["torso_errors_m"])), 3) if c["torso_errors_m"] else None}
        for (name, setting), counts in cv.items()
        for c in [counts[chosen[setting]]]}
    report = {"threshold_probability": forest.threshold_probability,
              "threshold_probability_no_background": forest.threshold_probability_no_background,
              "training_clusters": int(y.size),
              "training_legs": int(y.sum()), "nodes": int(forest.feature.size), "trees": int(forest.roots.size),
              "leave_one_bag_out": table}
    if args.json:
        print(json.dumps(report))
    else:
        print(f"thresholds {forest.threshold_probability} (background), "
              f"{forest.threshold_probability_no_background} (none); {y.size} clusters ({y.sum()} legs), "
              f"{forest.roots.size} trees / {forest.feature.size} nodes -> {args.out}")
        print("held-out bag (setting) | scans | labelled | recall | false / scan | torso error median [m]")
        for key, row in table.items():
            print(f"{key} | {row['scans']} | {row['labelled']} | {row['recall']} | {row['false_per_scan']} | "
                  f"{row['torso_error_median_m']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
