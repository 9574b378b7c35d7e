"""Leg detection from one laser scan, and the torso from the legs (paper 2, section 2.1.4).

``detect_legs(..., method="learned")`` (the default) segments the scan into clusters
(``leg_clusters``), computes their geometric features and their context in the scan
(``leg_features``, ``leg_context``) and keeps the clusters the bundled gradient-boosted trees
(``leg_classifier``, trained by ``train_legs`` on the hand-labelled leg_tracker bags) call
legs. Each leg is placed on its axis as eq. 3 places it: one leg
radius behind the cluster's nearest (3-beam averaged) return. (The bags' labels are cluster
centroids, ~pi/4 of a radius in front of the axis; a centroid also drifts backwards with the
trailing returns that eq. 1's time filter leaves behind a walking leg, the nearest return
does not.)
``method="paper"`` is the paper's rule below, kept for the experiments that reproduce it.

The paper mirrors the clipped, filtered range profile and takes its peaks (the range minima)
as legs, each centred one leg radius behind its minimum (eq. 3); the torso is the midpoint of
the two legs (eq. 4). Raw peak picking also fires on table legs, wall corners and noise, so a
minimum counts as a leg only when it is the closest point of a *cluster* of neighbouring returns
(consecutive beams whose ranges differ by less than ``jump_m``) that

* stands out from both neighbours (each is farther by ``jump_m``, or has no return): a peak of
  the mirrored profile with that prominence;
* is as wide as a leg, or two legs together (``min_width_m`` .. ``max_width_m`` chord);
* is not part of the static background (``background``: the empty scene's ranges; beams within
  ``background_margin_m`` of it are ignored).

Never invents a person: no cluster, no leg. No-return readings (0, inf, NaN, out of range)
are never legs.

Bad input fails closed: a non-finite or non-positive ``max_range_m``, a background with NaN
or -inf (``+inf`` means open space), an option that would hide every leg (a NaN margin or
width, a threshold of 1 or more) or a scan covering more than one revolution raise a
``ValueError`` naming the argument; none of them returns "nobody".

Linear time in the beam count: the learned detector's features count returns (its context,
``leg_context``, is quadratic in the returns of one scan), and it was trained at the
leg_tracker bags' beam spacing (``FINEST_INCREMENT_RAD``) and coarser; a finer scan is
decimated to that spacing first (every k-th beam, as the training decimates), so at most
~2,050 beams reach the clustering whatever the scanner gives (10^6 beams: one strided copy).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from cobotsafety.sensors.laser_filters import moving_average
from cobotsafety.sensors.laser_scan import LaserScan
from cobotsafety.sensors.leg_classifier import LegForest, bundled_forest
from cobotsafety.sensors.leg_clusters import MIN_CLUSTER_POINTS, segment
from cobotsafety.sensors.leg_features import cluster_features

#: Leg radius rho_l of eq. 3 [m].
LEG_RADIUS_M = 0.06
#: Widest cluster [m] (end to end) the learned detector considers: two legs side by side are
#: ~0.4 m (the paper's rule: 0.40); the widest labelled leg cluster of the leg_tracker bags is
#: 0.45 m. Wider clusters (walls, tables) are never legs, whatever the classifier says.
MAX_LEG_WIDTH_M = 0.5
#: The finest beam spacing [rad] the classifier was trained at: the leg_tracker bags' 0.352 deg
#: (768 beams over +-135 deg; ``train_legs`` adds every 2nd and 3rd beam). Finer scans are
#: decimated to it (``at_trained_resolution``).
FINEST_INCREMENT_RAD = 0.006135923
#: A scan covers at most one revolution (plus one beam of overlap) [rad].
FULL_TURN_RAD = 2.0 * math.pi


def _require(name: str, value, ok: bool, what: str) -> None:
    if not ok:
        raise ValueError(f"detect_legs: {name} must be {what}, got {value if isinstance(value, str) else repr(value)}")


def _number(name: str, value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"detect_legs: {name} must be a number, got {value!r}") from None


def _finite_at_least(name: str, value, low: float) -> float:
    number = _number(name, value)
    _require(name, value, math.isfinite(number) and number >= low, f"finite and >= {low}")
    return number


def _check_smoothing(smoothing_beams) -> int:
    number = _number("smoothing_beams", smoothing_beams)
    _require("smoothing_beams", smoothing_beams, number.is_integer() and number >= 1, "a whole number >= 1")
    return int(number)


def check_scan_and_range(scan: LaserScan, max_range_m: float, background: np.ndarray | None) -> np.ndarray | None:
    """Refuse what would make the detector blind (module docstring); returns the background as
    a float array. Raises ``ValueError`` naming the argument."""
    number = _number("max_range_m", max_range_m)
    _require("max_range_m", max_range_m, math.isfinite(number) and number > 0.0, "finite and > 0")
    span = abs(scan.angle_increment) * (scan.ranges.size - 1)
    _require("the scan's angular span", f"{span:.6g} rad ({scan.ranges.size} beams of {scan.angle_increment:.6g} rad)",
             span <= FULL_TURN_RAD + abs(scan.angle_increment), "at most one revolution")
    if background is None:
        return None
    background = np.asarray(background, dtype=float)
    if background.shape != scan.ranges.shape:
        raise ValueError(f"detect_legs: background must have the scan's shape {scan.ranges.shape}, "
                         f"got {background.shape}")
    usable = background > -np.inf  # False for NaN and -inf
    if not usable.all():
        beam = int(np.argmin(usable))
        raise ValueError(f"detect_legs: background must be a range or +inf (open space) per beam; beam {beam} "
                         f"is {background[beam]} ({int(np.count_nonzero(~usable))} such beams)")
    return background


def at_trained_resolution(scan: LaserScan, background: np.ndarray | None) -> tuple[LaserScan, np.ndarray | None]:
    """``scan`` (and its background) with every k-th beam, k = the largest whole number of
    beams that fits in ``FINEST_INCREMENT_RAD`` (1: the scan itself, as for every scanner at
    0.176 deg or coarser), keeping at least two beams."""
    step = min(int(FINEST_INCREMENT_RAD / abs(scan.angle_increment) + 1e-9), scan.ranges.size - 1)
    if step <= 1:
        return scan, background
    coarse = LaserScan(scan.angle_min, scan.angle_increment * step, scan.range_min, scan.range_max,
                       scan.ranges[::step], scan.stamp_s)
    return coarse, None if background is None else background[::step]


def foreground_mask(scan: LaserScan, max_range_m: float, background: np.ndarray | None,
                    background_margin_m: float = 0.10) -> np.ndarray:
    """Beams with a usable return within ``max_range_m`` that are in front of the background."""
    mask = scan.valid & (scan.ranges <= max_range_m)
    if background is not None:
        background = np.asarray(background, dtype=float)
        if background.shape != scan.ranges.shape:
            raise ValueError(f"background must have the scan's shape {scan.ranges.shape}, got {background.shape}")
        with np.errstate(invalid="ignore"):
            far = ~np.isfinite(background) | (background <= 0.0)
            mask &= far | (scan.ranges < background - background_margin_m)
    return mask


def detect_legs(scan: LaserScan, max_range_m: float = 1.4, background: np.ndarray | None = None, *,
                method: str = "learned", **options) -> np.ndarray:
    """Leg positions [m] in the scanner frame, shape (k, 2) (k = 0 when nobody is there).

    Args:
        scan: the scan (any beam count and resolution).
        max_range_m: clipping range (paper: 1.4 m); legs beyond it are not reported.
        background: optional ranges of the empty scene, same beams; static objects are ignored.
        method: ``"learned"`` (cluster classifier, ``learned_legs``) or ``"paper"``
            (``paper_legs``); ``options`` go to that function.

    Raises ``ValueError`` (naming the argument) for input that would make it blind: see the
    module docstring.
    """
    if method == "learned":
        return learned_legs(scan, max_range_m, background, **options)
    if method == "paper":
        return paper_legs(scan, max_range_m, background, **options)
    raise ValueError(f"method must be 'learned' or 'paper', got {method!r}")


def learned_legs(scan: LaserScan, max_range_m: float = 1.4, background: np.ndarray | None = None, *,
                 forest: LegForest | None = None, threshold_probability: float | None = None,
                 **options) -> np.ndarray:
    """Leg axes [m], shape (k, 2), of the clusters the classifier calls legs (module docstring):
    the candidates of ``scored_candidates`` (``options`` go there) whose leg probability exceeds
    ``threshold_probability`` (default: the classifier's, chosen by cross-validation, one with
    and one without a background). ``forest``: the tree ensemble, default the bundled one.
    """
    forest = bundled_forest() if forest is None else forest
    if threshold_probability is None:
        threshold_probability = (forest.threshold_probability_no_background if background is None
                                 else forest.threshold_probability)
    number = _number("threshold_probability", threshold_probability)
    _require("threshold_probability", threshold_probability, math.isfinite(number) and number < 1.0,
             "finite and < 1 (at 1 no cluster is a leg)")
    axes_m, probability = scored_candidates(scan, max_range_m, background, forest=forest, **options)
    return axes_m[probability > threshold_probability]


def scored_candidates(scan: LaserScan, max_range_m: float, background: np.ndarray | None, *, forest: LegForest,
                      background_margin_m: float = 0.10, leg_radius_m: float = LEG_RADIUS_M,
                      smoothing_beams: int = 3, max_width_m: float = MAX_LEG_WIDTH_M
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The candidate clusters' leg axes [m] (c, 2) (eq. 3) and leg probabilities (c,).

    Every usable return is clustered (a clip would cut walls into leg-sized stubs); a cluster
    is a candidate when its centroid is within ``max_range_m``, it is at most ``max_width_m``
    wide (first to last return) and, with a ``background``, it has returns in front of the
    background by ``background_margin_m``: at least a cluster's worth (``MIN_CLUSTER_POINTS``)
    or more than half of them. (A leg that passes in front of a spot where someone stood all
    recording long, or brushes past furniture, keeps a few returns in front; requiring half
    lost ~10 % of positive_2's labelled legs.) Features are computed for the candidates only,
    their context among all of the scan's clusters (as in training), on the scan decimated to
    the trained beam spacing (``at_trained_resolution``).
    """
    background = check_scan_and_range(scan, max_range_m, background)
    background_margin_m = _finite_at_least("background_margin_m", background_margin_m, 0.0)
    leg_radius_m = _finite_at_least("leg_radius_m", leg_radius_m, 0.0)
    smoothing_beams = _check_smoothing(smoothing_beams)
    _require("max_width_m", max_width_m, _number("max_width_m", max_width_m) > 0.0, "> 0 (+inf: no limit)")
    scan, background = at_trained_resolution(scan, background)
    clusters = segment(scan)
    if clusters.count == 0:
        return np.zeros((0, 2)), np.zeros(0)
    centroids = clusters.centroids()
    near = (np.hypot(centroids[:, 0], centroids[:, 1]) <= max_range_m) & (clusters.widths() <= max_width_m)
    if background is not None:
        foreground = foreground_mask(scan, np.inf, background, background_margin_m)[clusters.beams]
        in_front = np.concatenate([[0], np.cumsum(foreground)])  # not reduceat: dropped clusters lie between
        count = in_front[clusters.stops] - in_front[clusters.starts]
        near &= (count >= MIN_CLUSTER_POINTS) | (2 * count > clusters.stops - clusters.starts)
    if not near.any():
        return np.zeros((0, 2)), np.zeros(0)
    keep = np.flatnonzero(near)
    probability = forest.predict(cluster_features(scan, clusters, keep))  # context: all clusters
    beam, nearest_m = _nearest_averaged_returns(clusters.ranges_m, clusters.starts[keep], clusters.stops[keep],
                                                smoothing_beams)
    theta = scan.angle_min + scan.angle_increment * clusters.beams[beam]
    rho = nearest_m + leg_radius_m  # eq. 3
    return np.column_stack([rho * np.cos(theta), rho * np.sin(theta)]).reshape(-1, 2), probability


def nearest_averaged_returns_reference(ranges_m: np.ndarray, starts: np.ndarray, stops: np.ndarray,
                                       smoothing_beams: int) -> tuple[np.ndarray, np.ndarray]:
    """Per cluster: the index (into ``ranges_m``) and value [m] of the minimum of its ranges
    averaged over ``smoothing_beams`` (eq. 2, ``moving_average``). Readable version."""
    index, value = [], []
    for start, stop in zip(starts.tolist(), stops.tolist()):
        smoothed = moving_average(ranges_m[start:stop], min(smoothing_beams, stop - start))
        k = int(np.argmin(smoothed))
        index.append(start + k)
        value.append(float(smoothed[k]))
    return np.array(index, dtype=np.int64), np.array(value, dtype=float)


@numba.njit(cache=True)
def _nearest_averaged_returns(ranges_m, starts, stops, smoothing_beams):
    """Compiled ``nearest_averaged_returns_reference`` (a centred window, edges repeated)."""
    index = np.empty(starts.size, dtype=np.int64)
    value = np.empty(starts.size)
    for j in range(starts.size):
        s, e = starts[j], stops[j]
        size = min(smoothing_beams, e - s)
        left = size // 2
        best, best_k = np.inf, s
        for i in range(s, e):
            acc = 0.0
            for w in range(i - left, i - left + size):
                acc += ranges_m[min(max(w, s), e - 1)]
            if acc / size < best:
                best, best_k = acc / size, i
        index[j] = best_k
        value[j] = best
    return index, value


def paper_legs(scan: LaserScan, max_range_m: float = 1.4, background: np.ndarray | None = None, *,
               leg_radius_m: float = LEG_RADIUS_M, jump_m: float = 0.10, min_width_m: float = 0.03,
               max_width_m: float = 0.40, smoothing_beams: int = 3,
               background_margin_m: float = 0.10) -> np.ndarray:
    """Leg centres [m], shape (k, 2), by the paper's rule (module docstring).

    Args:
        scan: the scan (any beam count and resolution).
        max_range_m: clipping range (paper: 1.4 m); returns beyond it are ignored.
        background: optional ranges of the empty scene, same beams; static objects are ignored.
    """
    background = check_scan_and_range(scan, max_range_m, background)
    leg_radius_m = _finite_at_least("leg_radius_m", leg_radius_m, 0.0)
    background_margin_m = _finite_at_least("background_margin_m", background_margin_m, 0.0)
    jump_number = _number("jump_m", jump_m)
    _require("jump_m", jump_m, math.isfinite(jump_number) and jump_number > 0.0, "finite and > 0")
    min_width_m = _finite_at_least("min_width_m", min_width_m, 0.0)
    _require("max_width_m", max_width_m, _number("max_width_m", max_width_m) >= min_width_m,
             f">= min_width_m ({min_width_m}) (+inf: no limit)")
    smoothing_beams = _check_smoothing(smoothing_beams)
    ranges = scan.ranges
    mask = foreground_mask(scan, max_range_m, background, background_margin_m)
    if not np.any(mask):
        return np.zeros((0, 2))
    angles = scan.angles
    n = ranges.size
    idx = np.flatnonzero(mask)
    # Split the foreground beams into clusters at gaps and range jumps.
    breaks = (np.diff(idx) > 1) | (np.abs(np.diff(ranges[idx])) >= jump_m)
    starts = np.concatenate([[0], np.flatnonzero(breaks) + 1])
    ends = np.concatenate([np.flatnonzero(breaks), [idx.size - 1]])
    # Per cluster, scalar work in plain Python floats (a scan has a handful of clusters; numpy's
    # per-call overhead on 2-vectors dominated this loop).
    r_all, a_all, valid = ranges.tolist(), angles.tolist(), scan.valid.tolist()
    legs = []
    for s, e in zip(starts.tolist(), ends.tolist()):
        first, last = int(idx[s]), int(idx[e])
        # Prominence: both neighbours farther by jump_m, or without a usable return.
        prominent = True
        for neighbour, edge_range in ((first - 1, r_all[first]), (last + 1, r_all[last])):
            if 0 <= neighbour < n and valid[neighbour] and r_all[neighbour] < max_range_m + jump_m:
                if r_all[neighbour] - edge_range < jump_m:
                    prominent = False
        if not prominent:
            continue
        width = math.hypot(r_all[last] * math.cos(a_all[last]) - r_all[first] * math.cos(a_all[first]),
                           r_all[last] * math.sin(a_all[last]) - r_all[first] * math.sin(a_all[first]))
        if not min_width_m <= width <= max_width_m:
            continue
        beams = idx[s:e + 1]
        r = ranges[beams]
        smoothed = moving_average(r, min(smoothing_beams, r.size))
        k = int(np.argmin(smoothed))
        theta, rho = a_all[int(beams[k])], float(smoothed[k]) + leg_radius_m  # eq. 3
        legs.append((rho * math.cos(theta), rho * math.sin(theta)))
    return np.array(legs).reshape(-1, 2)


def torsos_from_legs(legs_m: np.ndarray, max_leg_separation_m: float = 0.6) -> np.ndarray:
    """Torso positions [m], shape (p, 2): the midpoint of each pair of legs (eq. 4).

    Legs are paired greedily, closest pairs first, when closer than ``max_leg_separation_m``;
    an unpaired leg (the other hidden, or both legs seen as one cluster) is a torso on its own.
    """
    legs_m = np.asarray(legs_m, dtype=float).reshape(-1, 2)
    k = legs_m.shape[0]
    if k == 0:
        return np.zeros((0, 2))
    distance = np.linalg.norm(legs_m[:, None] - legs_m[None], axis=-1)
    distance[np.arange(k), np.arange(k)] = np.inf
    used = np.zeros(k, dtype=bool)
    torsos = []
    for flat in np.argsort(distance, axis=None):
        i, j = divmod(int(flat), k)
        if distance[i, j] > max_leg_separation_m:
            break
        if i < j and not used[i] and not used[j]:
            used[i] = used[j] = True
            torsos.append((legs_m[i] + legs_m[j]) / 2)
    torsos += [legs_m[i] for i in range(k) if not used[i]]
    return np.array(torsos).reshape(-1, 2)


def estimate_background(scans: list[LaserScan], percentile: float = 100.0,
                        surface_fraction: float = 0.5) -> np.ndarray:
    """The empty scene from a recording with people in it, shape (n,) [m].

    A person occludes a beam only part of the time, so the farthest valid reading of each beam
    (``percentile`` = 100; lower it for noisy scanners) is the static scene behind them. A
    static surface returns whenever nothing stands in front of it, and a person in front of it
    returns too: its beam returns in (nearly) every scan. A beam returning in fewer than
    ``surface_fraction`` of the scans looks into open space and returns only when someone
    passes: inf (its farthest return would be a person's, docs/leg_recall.md, amendment 2).
    A person who never moves stays part of the background.
    """
    if not 0.0 < surface_fraction <= 1.0:
        raise ValueError(f"estimate_background: surface_fraction must be in (0, 1], got {surface_fraction}")
    ranges = np.array([scan.ranges for scan in scans], dtype=float)
    valid = np.array([scan.valid for scan in scans])
    masked = np.where(valid, ranges, np.nan)
    background = np.full(ranges.shape[1], np.inf)
    surface = valid.mean(axis=0) >= surface_fraction
    background[surface] = np.nanpercentile(masked[:, surface], percentile, axis=0)
    return background
