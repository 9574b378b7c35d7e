"""Generate a bundled recording from a scripted human, with its ground truth.

    python -m cobotsafety.tools.generate_recording --scenario exp1|exp2|reach-over \
        --out assets/recordings/NAME.jsonl.gz

writes the recording and ``NAME_truth.npz`` beside it (same stem + ``_truth.npz``).
Deterministic (``--seed``, default 7): the same arguments give the same bytes.

Scene (robot base frame: origin at the robot base, z = 0 the table top, floor at z = -0.75 m):
the laser (SICK TiM-like: 271 beams over 270 deg, 1 deg steps, 8 m, 50 Hz) sits at leg height
where the scenario puts it (``scenario.scanner_xy_m``, ``scanner_yaw_rad``). The human
(``BODY``) follows the scenario's script (``cobotsafety.tools.scripted_people``: where the torso
walks and faces, what the arms reach for; walking swings the arms and alternates the feet).
Five IMUs (~300 Hz, jittered stamps)
read their orientation in their own reference frame (an unknown heading each) with noise and
a slow heading drift; the forearm_left IMU goes silent for ``IMU_GAP_S`` (a dropout the
pipeline must survive). Laser: range noise, single-beam dropouts and whole lost scans.

The truth (``*_truth.npz``) holds, at 50 Hz: ``t_s`` (n,), ``p0_b_m``/``p1_b_m`` (n, 5, 3) and
``radius_m`` (5,) of the 5 capsules, ``names``, ``torso_xy_b_m`` (n, 2), ``legs_xy_b_m``
(n, 2, 2), computed from the true torso and true IMU orientations with ``five_capsules``. A
``Group`` (two people, ``scripted_people``) has 5 capsules per person (the IMU wearer's first)
and ``torso_xy_b_m`` (n, people, 2); the others' legs are in the scans.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from cobotsafety.experiments.approach_truth import truth_path
from cobotsafety.human.body import CAPSULE_NAMES_5, BodyDimensions
from cobotsafety.human.body_capsules import five_capsules
from cobotsafety.human.recording import Recording, write_recording
from cobotsafety.tools.scripted_people import SCENARIOS, Scenario
from cobotsafety.sensors.imu import IMU_NAMES
from cobotsafety.sensors.scanner_pose import ScannerPose

FLOOR_Z_M = -0.75
SCANNER_HEIGHT_ABOVE_FLOOR_M = 0.30
LASER_BEAMS = 271
LASER_FOV_RAD = np.deg2rad(270.0)
LASER_RANGE_M = (0.05, 8.0)
LASER_RATE_HZ = 50.0
LASER_NOISE_M = 0.01
LASER_BEAM_DROPOUT = 0.01
LASER_SCAN_LOSS = 0.02
IMU_RATE_HZ = 300.0
IMU_NOISE_RAD = np.deg2rad(0.3)
IMU_DRIFT_RAD_S = np.deg2rad(3.0) / 60.0  # up to 3 deg/min of heading drift
IMU_GAP_S = (25.0, 25.4)  # forearm_left silent
LEG_RADIUS_M = 0.06
HIP_HALF_WIDTH_M = 0.10
STRIDE_M = 1.2  # one gait cycle
LEG_LOOKBACK_S = 0.01  # a scan's walking direction: the torso 10 ms earlier
ROOM_M = ((-1.5, 4.0), (-2.5, 2.5))  # walls: x range, y range
STOOL_LEGS_XY_M = ((1.05, -1.30), (1.35, -1.30), (1.05, -1.60), (1.35, -1.60))  # static clutter
STOOL_LEG_RADIUS_M = 0.02
BODY = BodyDimensions()


def limb_frame(direction_b: np.ndarray, forward_b: np.ndarray) -> Rotation:
    """IMU orientation with x along the limb and z as close as possible to ``forward_b``."""
    x = direction_b / np.linalg.norm(direction_b, axis=-1, keepdims=True)
    z = forward_b - np.sum(forward_b * x, axis=-1, keepdims=True) * x
    bad = np.linalg.norm(z, axis=-1) < 1e-6
    z[bad] = np.cross(x[bad], [0.0, 0.0, 1.0])
    z /= np.linalg.norm(z, axis=-1, keepdims=True)
    return Rotation.from_matrix(np.stack([x, np.cross(z, x), z], axis=-1))


def body_orientations(scenario: Scenario, t: np.ndarray) -> list[Rotation]:
    """True base-frame orientations of the 5 IMUs (``IMU_NAMES`` order), each n rotations."""
    xy, heading, speed = scenario.torso_path(t)
    fwd = np.stack([np.cos(heading), np.sin(heading), 0 * t], axis=1)
    left = np.stack([-np.sin(heading), np.cos(heading), 0 * t], axis=1)
    up = np.tile([0.0, 0.0, 1.0], (len(t), 1))
    distance = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    swing = np.deg2rad(20.0) * np.clip(speed / 0.8, 0, 1) * np.sin(2 * np.pi * distance / STRIDE_M)
    chest = limb_frame(-up, fwd)
    reaches = scenario.reaches(t, fwd, left, up)
    out = [chest]
    for side, sign in (("left", 1.0), ("right", -1.0)):
        a = sign * swing[:, None]  # arms swing opposite to each other
        upper = -np.cos(a) * up + np.sin(a) * fwd + 0.08 * sign * left
        fore = -np.cos(a + 0.3) * up + np.sin(a + 0.3) * fwd + 0.05 * sign * left
        if side in reaches:
            weight, upper_target, fore_target = reaches[side]
            upper = (1 - weight[:, None]) * upper + weight[:, None] * upper_target
            fore = (1 - weight[:, None]) * fore + weight[:, None] * fore_target
        out += [limb_frame(upper, fwd), limb_frame(fore, fwd)]
    return out


def legs_xy(scenario: Scenario, t: np.ndarray) -> np.ndarray:
    """Leg centres (n, 2, 2) [m] in the base frame: hips apart, feet alternating while walking."""
    xy, heading, speed = scenario.torso_path(t)
    distance = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    direction = np.gradient(xy, axis=0)
    return _legs(xy, heading, speed, distance, direction)


def _legs(xy, heading, speed, distance, direction) -> np.ndarray:
    """Leg centres (n, 2, 2) from the torso (n, 2), heading, speed, walked distance (n,) and the
    walking direction (n, 2) (unnormalised)."""
    norm = np.linalg.norm(direction, axis=1, keepdims=True)
    walk = np.where(norm > 1e-9, direction / np.maximum(norm, 1e-12), np.stack([np.cos(heading), np.sin(heading)], 1))
    side = np.stack([-walk[:, 1], walk[:, 0]], axis=1)
    stride = 0.25 * np.clip(speed / 0.8, 0, 1) * np.sin(2 * np.pi * distance / STRIDE_M)
    left = xy + HIP_HALF_WIDTH_M * side + stride[:, None] * walk
    right = xy - HIP_HALF_WIDTH_M * side - stride[:, None] * walk
    return np.stack([left, right], axis=1)


def scan_legs_xy(scenario: Scenario, t: np.ndarray) -> np.ndarray:
    """The legs the laser sees at each scan time t (n,): (n, 2, 2) [m], base frame, each from
    the torso at ``t - LEG_LOOKBACK_S`` and ``t`` alone (so a scan depends only on its own
    time: the same legs whatever other scans are made). The walked distance of that pair is
    the gait's phase, as the bundled recordings were made (their feet barely alternate in the
    laser: a known simplification; the truth's ``legs_xy`` strides over the whole walk)."""
    xy_a, _, _ = scenario.torso_path(t - LEG_LOOKBACK_S)
    xy_b, heading, _ = scenario.torso_path(t)
    step = xy_b - xy_a
    speed = np.linalg.norm(step / (t - (t - LEG_LOOKBACK_S))[:, None], axis=1)
    return _legs(xy_b, heading, speed, np.linalg.norm(step, axis=1), step)


def ray_circles(origin, directions, centres, radius) -> np.ndarray:
    """Distance along each unit direction (b, 2) to the nearest of circles (c, 2); inf if none."""
    oc = origin - centres  # (c, 2)
    b = directions @ oc.T  # (b, c)
    disc = b * b - (np.sum(oc * oc, axis=1) - radius * radius)
    with np.errstate(invalid="ignore"):
        hit = -b - np.sqrt(disc)
    hit = np.where((disc >= 0) & (hit > 0), hit, np.inf)
    return hit.min(axis=1)


def simulate_scan(scenario: Scenario, t: float, rng: np.random.Generator, legs_b_m: np.ndarray | None = None) -> np.ndarray:
    """Ranges (271,) [m] at time t: legs (``legs_b_m`` (k, 2) [m], default
    ``scan_legs_xy(scenario, [t])``), stool, walls; noise and dropouts (0 = no return)."""
    origin = np.array(scenario.scanner_xy_m)
    angles = scenario.scanner_yaw_rad - LASER_FOV_RAD / 2 + np.arange(LASER_BEAMS) * LASER_FOV_RAD / (LASER_BEAMS - 1)
    d = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    (x0, x1), (y0, y1) = ROOM_M
    with np.errstate(divide="ignore"):
        tx = np.where(d[:, 0] > 0, (x1 - origin[0]) / d[:, 0], (x0 - origin[0]) / d[:, 0])
        ty = np.where(d[:, 1] > 0, (y1 - origin[1]) / d[:, 1], (y0 - origin[1]) / d[:, 1])
    ranges = np.minimum(np.abs(tx), np.abs(ty))
    ranges = np.minimum(ranges, ray_circles(origin, d, np.array(STOOL_LEGS_XY_M), STOOL_LEG_RADIUS_M))
    if legs_b_m is None:
        legs_b_m = scan_legs_xy(scenario, np.array([t]))[0]
    ranges = np.minimum(ranges, ray_circles(origin, d, legs_b_m, LEG_RADIUS_M))
    ranges = ranges + rng.normal(0.0, LASER_NOISE_M, LASER_BEAMS)
    ranges[(ranges > LASER_RANGE_M[1]) | (rng.random(LASER_BEAMS) < LASER_BEAM_DROPOUT)] = 0.0
    return ranges


def generate(scenario: Scenario | str = "reach-over", seed: int = 7) -> tuple[Recording, dict]:
    """The recording and its ground truth (see the module docstring) for ``scenario``."""
    scenario = SCENARIOS[scenario] if isinstance(scenario, str) else scenario
    rng = np.random.default_rng(seed)
    duration_s = scenario.duration_s
    # Laser: 50 Hz, +-0.5 ms jitter, some scans lost.
    laser_t = np.arange(0.0, duration_s, 1 / LASER_RATE_HZ)
    laser_t = laser_t + rng.uniform(-5e-4, 5e-4, laser_t.size)
    laser_t = np.round(laser_t[(rng.random(laser_t.size) >= LASER_SCAN_LOSS) & (laser_t > 0)], 6)
    others = tuple(getattr(scenario, "others", ()))  # a ``Group``: more people, seen by the laser only
    legs = np.concatenate([scan_legs_xy(person, laser_t) for person in (scenario, *others)], axis=1)
    ranges = np.array([simulate_scan(scenario, t, rng, legs[i]) for i, t in enumerate(laser_t)])
    # IMUs: each its own clock phase, reference heading and drift.
    imu_t, imu_q, calibration = {}, {}, {}
    for name in IMU_NAMES:
        t = np.arange(rng.uniform(0, 1 / IMU_RATE_HZ), duration_s, 1 / IMU_RATE_HZ)
        t = np.round(t + rng.uniform(-2e-4, 2e-4, t.size), 6)
        if name == "forearm_left":
            t = t[(t < IMU_GAP_S[0]) | (t > IMU_GAP_S[1])]
        r_ref_b = Rotation.from_euler("z", rng.uniform(-np.pi, np.pi))  # unknown heading of its reference
        drift_rate = rng.uniform(-1, 1) * IMU_DRIFT_RAD_S
        q_b_init = Rotation.from_euler("z", rng.choice([0.0, 90.0, 180.0]), degrees=True)  # jig on the table
        noise0 = Rotation.from_rotvec(rng.normal(0, IMU_NOISE_RAD, 3))
        calibration[name] = (q_b_init.as_quat(), (r_ref_b * q_b_init * noise0).as_quat())
        truth = body_orientations(scenario, t)[IMU_NAMES.index(name)]
        drift = Rotation.from_rotvec(np.outer(drift_rate * t, [0.0, 0.0, 1.0]))
        noise = Rotation.from_rotvec(rng.normal(0, IMU_NOISE_RAD, (t.size, 3)))
        imu_t[name], imu_q[name] = t, (drift * r_ref_b * truth * noise).as_quat()
    recording = Recording(
        body=BODY,
        scanner=ScannerPose(scenario.scanner_xy_m[0], scenario.scanner_xy_m[1], scenario.scanner_yaw_rad),
        scanner_height_m=FLOOR_Z_M + SCANNER_HEIGHT_ABOVE_FLOOR_M,
        laser={"angle_min": -LASER_FOV_RAD / 2, "angle_increment": LASER_FOV_RAD / (LASER_BEAMS - 1),
               "range_min": LASER_RANGE_M[0], "range_max": LASER_RANGE_M[1], "beams": LASER_BEAMS},
        laser_t_s=laser_t, laser_ranges_m=ranges, imu_t_s=imu_t, imu_q_ref=imu_q, calibration=calibration,
        description=f"{scenario.description} (generate_recording, seed {seed})",
    )
    truth_t = np.arange(0.0, duration_s, 1 / LASER_RATE_HZ)
    p0, p1, radius, xy = true_capsules(scenario, truth_t)
    truth = {
        "t_s": truth_t, "names": np.array(CAPSULE_NAMES_5),
        "p0_b_m": p0, "p1_b_m": p1, "radius_m": radius, "torso_xy_b_m": xy, "legs_xy_b_m": legs_xy(scenario, truth_t),
    }
    if others:  # everyone's capsules, the first person's five first
        more = [true_capsules(person, truth_t) for person in others]
        truth["p0_b_m"] = np.concatenate([p0] + [m[0] for m in more], axis=1)
        truth["p1_b_m"] = np.concatenate([p1] + [m[1] for m in more], axis=1)
        truth["radius_m"] = np.concatenate([radius] + [m[2] for m in more])
        truth["names"] = np.array(CAPSULE_NAMES_5 + tuple(f"{n} {i + 2}" for i in range(len(others)) for n in CAPSULE_NAMES_5))
        truth["torso_xy_b_m"] = np.stack([xy] + [m[3] for m in more], axis=1)
    return recording, truth


def true_capsules(person: Scenario, t: np.ndarray):
    """The true five capsules of ``person`` at times t (n,): p0, p1 (n, 5, 3) [m], radius (5,) [m],
    torso xy (n, 2) [m], from the true torso and true limb orientations with ``five_capsules``."""
    rotations = body_orientations(person, t)
    xy, _, _ = person.torso_path(t)
    quats = np.stack([r.as_quat() for r in rotations], axis=1)  # (n, 5, 4), as stored: no renormalising
    caps = [five_capsules(xy[i], Rotation(quats[i], normalize=False, copy=False), BODY) for i in range(t.size)]
    return np.array([c.p0_b_m for c in caps]), np.array([c.p1_b_m for c in caps]), caps[0].radius_m, xy


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="recording path (.jsonl.gz)")
    parser.add_argument("--scenario", choices=list(SCENARIOS), default="reach-over")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args(argv)
    recording, truth = generate(args.scenario, args.seed)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_recording(args.out, recording)
    np.savez_compressed(truth_path(args.out), **truth)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1e6:.2f} MB) and {truth_path(args.out)}")


if __name__ == "__main__":
    main()
