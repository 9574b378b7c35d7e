"""Synthetic leg scans for training the leg classifier: two ray-cast circles per scan.

The labelled bags hold ~450 leg clusters from two recordings, and one of them has almost no
"both legs in one cluster" examples (3 of 116 in positive_2, 44 of 317 in positive_1): a
forest trained without positive_1 found few of its leg pairs (recall 0.86 with a background).
A leg is, to a laser, a roughly circular arc of 4.5-8 cm radius; a person is two of them, apart
or touching. ``leg_scans`` renders such scenes (``render_circles``: exact ray-circle hits plus
Gaussian range noise) at the bags' scanner geometry, and ``scene_examples`` returns the
features of the clusters the legs and the wall behind make, as extra examples for ``train_legs``. Nothing here is
fitted to the bags: the shapes come from human legs, the ranges from the scanner's.

``walking_examples`` adds what the tracker's input holds besides legs: it time-filters
(eq. 1, ``TimeFilter``) and clips the scans before detecting, so a beam a walking leg has just
left still reads somewhere between the leg and the scene behind it for a few scans. Those
trailing returns can split off as small clusters beside the leg (ghosts); rendered walks
through the same filter and clip give them as non-leg examples, and the filtered legs as leg
examples.

Fixed seed: the same scenes every run.
"""

from __future__ import annotations

import numpy as np

from cobotsafety.sensors.laser_filters import TimeFilter
from cobotsafety.sensors.laser_scan import LaserScan
from cobotsafety.sensors.leg_clusters import segment
from cobotsafety.sensors.leg_features import N_FEATURES, cluster_features

#: The leg_tracker bags' scanner: 768 beams over +-135 deg, 11 m.
BEAMS = 768
ANGLE_INCREMENT_RAD = np.radians(0.352)
RANGE_MAX_M = 11.0
#: Scenes rendered, and their ranges of parameters.
SCENES = 1000
LEG_RADIUS_M = (0.045, 0.08)
PERSON_RANGE_M = (0.5, 5.5)
PERSON_BEARING_RAD = 2.0
#: Gap [m] between the two legs' surfaces (0: touching, one cluster).
LEG_GAP_M = (0.0, 0.3)
RANGE_NOISE_M = (0.003, 0.015)
#: Behind the person, at least BACKDROP_BEHIND_M behind: with BACKDROP_PROBABILITY a backdrop
#: of constant range closes the scene, with WALL_PROBABILITY a straight wall (its normal within
#: WALL_TILT_RAD of the person's bearing); otherwise open space around the legs.
BACKDROP_PROBABILITY = 0.3
WALL_PROBABILITY = 0.35
WALL_TILT_RAD = 0.8
BACKDROP_BEHIND_M = 0.5
#: A cluster whose centroid is this close to a leg centre [m] is a leg example.
NEAR_LEG_M = 0.3
SEED = 14
#: Walks through eq. 1 and a clip: how many, how long, how fast, and the filter's parameters.
WALKS = 60
WALK_DURATION_S = 1.5
WALK_SPEED_M_S = (0.3, 1.3)
SCAN_RATE_HZ = (10.0, 50.0)
STEP_LENGTH_M = 0.6
HIP_HALF_WIDTH_M = (0.08, 0.13)
TIME_FILTER_ALPHA = 0.6
CLIP_RANGE_M = (1.0, 3.0)
#: Clusters farther than this from both current legs [m] are trailing-return ghosts.
GHOST_M = 0.25
#: Filtered clusters within this of a current leg centre [m] are legs.
LEG_MATCH_M = 0.15


def render_circles(circles_m: np.ndarray, noise_m: float, rng: np.random.Generator,
                   backdrop_m: float | None = None, wall: tuple[float, float] | None = None) -> LaserScan:
    """A scan of circles (k, 3) = (x, y, radius) [m] in the scanner frame: the nearest hit per
    beam plus N(0, noise_m) range noise; beams that hit nothing (or beyond ``RANGE_MAX_M``) read
    0 (no return). Behind them optionally a constant range ``backdrop_m`` or a straight
    ``wall`` = (normal's angle [rad], distance [m]): the points p with p . n = distance."""
    angles = -ANGLE_INCREMENT_RAD * (BEAMS - 1) / 2 + ANGLE_INCREMENT_RAD * np.arange(BEAMS)
    ranges = np.full(BEAMS, np.inf if backdrop_m is None else backdrop_m)
    if wall is not None:
        facing = np.cos(angles - wall[0])
        with np.errstate(divide="ignore"):
            hit = np.where(facing > 0, wall[1] / facing, np.inf)
        ranges = np.where(hit <= RANGE_MAX_M, hit, ranges)
    for cx, cy, radius in np.asarray(circles_m, dtype=float).reshape(-1, 3):
        along = np.cos(angles) * cx + np.sin(angles) * cy
        disc = along ** 2 - (cx ** 2 + cy ** 2 - radius ** 2)
        hit = along - np.sqrt(np.abs(disc))
        ranges = np.minimum(ranges, np.where((disc >= 0) & (hit > 0), hit, np.inf))
    ranges = np.where(np.isfinite(ranges), ranges + rng.normal(0.0, noise_m, BEAMS), 0.0)
    return LaserScan(float(angles[0]), float(ANGLE_INCREMENT_RAD), 0.02, RANGE_MAX_M, ranges)


def leg_scans(scenes: int = SCENES, seed: int = SEED) -> list[tuple[LaserScan, np.ndarray]]:
    """[(scan, leg centres (2, 2) [m])]: one person, two legs, per scan."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(scenes):
        radius = rng.uniform(*LEG_RADIUS_M, size=2)
        distance, bearing = rng.uniform(*PERSON_RANGE_M), rng.uniform(-PERSON_BEARING_RAD, PERSON_BEARING_RAD)
        first = distance * np.array([np.cos(bearing), np.sin(bearing)])
        direction = rng.uniform(0.0, 2 * np.pi)
        second = first + (radius.sum() + rng.uniform(*LEG_GAP_M)) * np.array([np.cos(direction), np.sin(direction)])
        behind, kind = rng.uniform(distance + BACKDROP_BEHIND_M, RANGE_MAX_M), rng.random()
        backdrop = behind if kind < BACKDROP_PROBABILITY else None
        wall = None
        if BACKDROP_PROBABILITY <= kind < BACKDROP_PROBABILITY + WALL_PROBABILITY:
            tilt = rng.uniform(-WALL_TILT_RAD, WALL_TILT_RAD)
            wall = (bearing + tilt, behind * np.cos(tilt))  # the wall through the point `behind` the person
        circles = np.array([[*first, radius[0]], [*second, radius[1]]])
        out.append((render_circles(circles, rng.uniform(*RANGE_NOISE_M), rng, backdrop, wall), circles[:, :2]))
    return out


def scene_examples(scan: LaserScan, legs_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Features (c, N_FEATURES) and classes (c,) of the clusters of ``scan``: a leg (1) when its
    centroid is within ``NEAR_LEG_M`` of a leg centre in ``legs_m`` (k, 2), else a piece of the
    backdrop or wall (0; e.g. the wall between the legs' shadows)."""
    clusters = segment(scan)
    if clusters.count == 0:
        return np.zeros((0, N_FEATURES)), np.zeros(0, dtype=int)
    distance = np.linalg.norm(clusters.centroids()[:, None] - legs_m[None], axis=-1).min(axis=1)
    return cluster_features(scan, clusters), (distance < NEAR_LEG_M).astype(int)


def walking_legs(t_s: np.ndarray, start_m: np.ndarray, heading_rad: float, speed_m_s: float,
                 hip_half_width_m: float) -> np.ndarray:
    """Leg centres (n, 2, 2) [m] of a walk from ``start_m`` at times ``t_s`` [s]: each leg in
    turn stands still (stance) while the other swings past it, STEP_LENGTH_M per step."""
    walk = np.array([np.cos(heading_rad), np.sin(heading_rad)])
    side = np.array([-walk[1], walk[0]])
    along = speed_m_s * t_s  # the torso's distance walked
    step_s = STEP_LENGTH_M / 2 / speed_m_s
    phase = (t_s / step_s) % 2.0  # [0, 1): the first leg swings, [1, 2): the second
    swing = phase % 1.0
    first = np.where(phase < 1.0, along - STEP_LENGTH_M / 4 + STEP_LENGTH_M / 2 * swing,
                     along + STEP_LENGTH_M / 4 - STEP_LENGTH_M / 2 * swing)
    second = 2 * along - first  # the torso midway between the feet
    return np.stack([start_m + first[:, None] * walk + hip_half_width_m * side,
                     start_m + second[:, None] * walk - hip_half_width_m * side], axis=1)


def walking_examples(walks: int = WALKS, seed: int = SEED, decimations=(1, 2, 3)) -> tuple[np.ndarray, np.ndarray]:
    """Features (m, N_FEATURES) and classes (m,) (1 = leg) of the clusters of rendered walks
    after eq. 1 and a clip (module docstring); each scan also decimated."""
    rng = np.random.default_rng(seed + 1)
    xs, ys = [], []
    for _ in range(walks):
        rate_hz = rng.uniform(*SCAN_RATE_HZ)
        t_s = np.arange(0.0, WALK_DURATION_S, 1.0 / rate_hz)
        clip_m = rng.uniform(*CLIP_RANGE_M)
        distance, bearing = rng.uniform(0.3, clip_m), rng.uniform(-PERSON_BEARING_RAD, PERSON_BEARING_RAD)
        start = distance * np.array([np.cos(bearing), np.sin(bearing)])
        legs = walking_legs(t_s, start, rng.uniform(0, 2 * np.pi), rng.uniform(*WALK_SPEED_M_S),
                            rng.uniform(*HIP_HALF_WIDTH_M))
        radius, noise = rng.uniform(*LEG_RADIUS_M, size=2), rng.uniform(*RANGE_NOISE_M)
        backdrop = rng.uniform(clip_m, RANGE_MAX_M) if rng.random() < BACKDROP_PROBABILITY else None
        filters = {d: TimeFilter(TIME_FILTER_ALPHA) for d in decimations}
        last = {d: None for d in decimations}
        for k in range(t_s.size):
            raw = render_circles(np.column_stack([legs[k], radius]), noise, rng, backdrop)
            for d in decimations:
                scan = LaserScan(raw.angle_min, raw.angle_increment * d, raw.range_min, raw.range_max, raw.ranges[::d])
                clipped = np.where(scan.valid, np.minimum(scan.ranges, clip_m), clip_m if last[d] is None else last[d])
                last[d] = filters[d].update(clipped)
                if k < 3:
                    continue  # the filter starts from the first scan: no trail yet
                ranges = np.where(last[d] < clip_m, last[d], 0.0)
                filtered = LaserScan(scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max, ranges)
                clusters = segment(filtered)
                if clusters.count == 0:
                    continue
                distance = np.linalg.norm(clusters.centroids()[:, None] - legs[k][None], axis=-1).min(axis=1)
                leg, ghost = distance < LEG_MATCH_M, distance > GHOST_M
                features = cluster_features(filtered, clusters)
                xs.append(features[leg | ghost])
                ys.append(leg[leg | ghost].astype(int))
    return np.concatenate(xs), np.concatenate(ys)
