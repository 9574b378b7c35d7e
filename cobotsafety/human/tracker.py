"""``HumanTracker``: the live pipeline from laser scans and IMU samples to human capsules.

Per scan: paper 2's time filter (eq. 1) and clipping -> ``detect_legs`` (moving average, eq. 2-3,
background removal) -> ``ScannerPose.to_base`` (eq. 10) -> ``PersonTracker`` (legs paired into
people, eq. 4, each a constant-velocity Kalman track in the base frame). The human is the confirmed
person nearest the robot base (the IMU wearer); every other confirmed person whose two legs were
seen lately is a one-capsule person beside them (``others_at``). While the wearer's legs are seen,
the torso stream takes the track's filtered position and velocity (``torso_velocity_at``); a human
seen fresh carries that velocity on every capsule end point (``HumanCapsules.v0_b_m_s``), plus,
with five fresh IMUs, each end point's own motion relative to the torso (a backward difference of
the IMU chain over ``ARM_VELOCITY_WINDOW_S``): the one estimate of the human's motion the
controller uses (a reaching hand is seen coming, not only where it is). Per IMU sample: eq. 6 with
the calibration of eq. 5. ``capsules_at(t_s)``: torso xy interpolated (past its newest sighting:
moved on at the tracked velocity, at most ``StalePolicy.laser_stale_after_s``), IMU orientations
slerped (``sensors.streams``), the chain of eqs. 7-12, then the conservative rules of
``conservative.py`` (fresh IMUs: all of it in one compiled call, ``capsule_kernel``).
``until_s`` hides samples stamped after it (a causal replay passes ``until_s = t_s``).

Absence: a person whose legs are no longer seen (occluded, lost, or gone) keeps the last
pose (moved on at the tracked velocity until the legs count as lost) with a radius growing
with the time since seen (``conservative.py``); only when fresh
scans show no legs and the human, last seen ``age`` seconds ago, could have walked out of the
clipped range since (``could_have_left``), is nobody in range: no capsules. A lost track never
makes the human vanish at once.
"""

from __future__ import annotations

import bisect
import math

import numpy as np
from scipy.spatial.transform import Rotation

from cobotsafety.human.body import BodyDimensions, HumanCapsules
from cobotsafety.human.capsule_kernel import body_vector
from cobotsafety.human.body_capsules import one_capsule
from cobotsafety.human.conservative import (StalePolicy, conservative_capsules, could_have_left, fresh_five_capsules,
                                          laser_margin)
from cobotsafety.sensors.imu import IMU_NAMES, calibrate
from cobotsafety.sensors.laser_filters import TimeFilter
from cobotsafety.sensors.laser_scan import LaserScan
from cobotsafety.sensors.legs import detect_legs
from cobotsafety.sensors.person_tracker import Person, PersonTracker, PersonTrackerParams
from cobotsafety.sensors.scanner_pose import ScannerPose
from cobotsafety.sensors.streams import QuaternionStream, VectorStream, quaternion_brackets, rotations_at

#: Paper 2 clips the ranges at 1400 mm.
MAX_RANGE_M = 1.4
#: Eq. 1 weight of the newest scan.
TIME_FILTER_ALPHA = 0.8
#: The window [s] of the arms' velocity (a backward difference of their IMU poses): the IMUs'
#: staleness threshold (``StalePolicy.imu_stale_after_s``), 15 samples at paper 2's ~300 Hz.
ARM_VELOCITY_WINDOW_S = 0.05
#: Another track whose torso is within this of the wearer's [m] is the wearer tracked twice
#: (two people's torsos are at least a shoulder width, ~0.45 m, apart).
SAME_PERSON_M = 0.45
_NOBODY_ELSE = np.zeros((0, 5))


class HumanTracker:
    """Push scans and IMU samples (any order across streams, increasing within one), query capsules.

    ``imu_calibration``: name -> ``(q_base_imu_init, q_ref_imu_init)`` (xyzw) for the five
    ``IMU_NAMES``, or None for a laser-only, 1-capsule human. ``background``: ranges of the
    empty scene [m], shape (beams,), or None.
    """

    def __init__(self, body: BodyDimensions, scanner: ScannerPose, imu_calibration: dict | None = None,
                 background: np.ndarray | None = None, policy: StalePolicy = StalePolicy(),
                 max_range_m: float = MAX_RANGE_M, time_filter_alpha: float = TIME_FILTER_ALPHA,
                 people: PersonTrackerParams = PersonTrackerParams(), leg_method: str = "learned"):
        self.body, self.scanner, self.policy = body, scanner, policy
        self.leg_method = leg_method
        """``detect_legs``'s method: ``"learned"`` or ``"paper"`` (paper 2's experiments)."""
        self.people = PersonTracker(people)
        self.persons: list[Person] = []
        """The people tracked after the newest scan (base frame)."""
        self.max_range_m = max_range_m
        self.background = background
        self._filter = TimeFilter(time_filter_alpha)
        self._last: np.ndarray | None = None
        self.scans = VectorStream("laser", 1, policy.laser_stale_after_s)
        self.torso = VectorStream("torso", 2, policy.laser_stale_after_s)
        self.torso_velocity = VectorStream("torso_velocity", 2, policy.laser_stale_after_s)
        self._others_t: list[float] = []  # each scan's time and its other people (``_record_others``)
        self._others: list[np.ndarray] = []
        self._paired_s: dict[int, float] = {}  # track id -> when both its legs were last seen
        self.imus: dict[str, QuaternionStream] = {}
        self._r_b_ref: dict[str, Rotation] = {}
        if imu_calibration is not None:
            missing = set(IMU_NAMES) - set(imu_calibration)
            if missing:
                raise ValueError(f"imu_calibration misses {sorted(missing)}; needs {IMU_NAMES}")
            for name in IMU_NAMES:
                q_b_init, q_ref_init = imu_calibration[name]
                self._r_b_ref[name] = calibrate(q_ref_init, q_b_init)  # eq. 5
                self.imus[name] = QuaternionStream(name, policy.imu_stale_after_s)
            self._r_b_ref_all = Rotation.concatenate([self._r_b_ref[n] for n in IMU_NAMES])
            self._r_b_ref_matrices = self._r_b_ref_all.as_matrix()
            self._body_vector = body_vector(body)

    def legs_from_scan(self, scan: LaserScan) -> np.ndarray:
        """Shape (k, 2), the legs in the base frame [m] after the time filter and clipping."""
        # Clip at the monitored range (paper: 1400 mm); a beam without a return this time
        # holds its previous filtered value (a dropout carries no information, it is not "far").
        valid = scan.valid
        clipped = np.where(valid, np.minimum(scan.ranges, self.max_range_m),
                           self.max_range_m if self._last is None else self._last)
        self._last = self._filter.update(clipped)  # eq. 1
        ranges = np.where(self._last < self.max_range_m, self._last, 0.0)  # 0 = no return
        smoothed = LaserScan(scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max, ranges)
        legs = detect_legs(smoothed, self.max_range_m, self.background, method=self.leg_method)
        return self.scanner.to_base(legs) if len(legs) else np.zeros((0, 2))

    def human_from_people(self, persons: list[Person]) -> Person | None:
        """The confirmed person nearest the robot base (the IMU wearer), or None."""
        confirmed = [p for p in persons if p.confirmed]
        if not confirmed:
            return None
        return min(confirmed, key=lambda p: float(p.p_xy_m @ p.p_xy_m))

    def push_scan(self, t_s: float, scan: LaserScan) -> np.ndarray | None:
        """Process one scan stamped ``t_s`` [s]; returns the human's torso xy (base frame) when
        the human's legs are in this scan, else None."""
        if not self.scans.push(t_s, [0.0]):
            return None
        self.persons = self.people.update(t_s, self.legs_from_scan(scan))
        human = self.human_from_people(self.persons)
        self._record_others(t_s, human)
        if human is None or len(human.leg_xy_m) == 0:
            return None  # not seen now: the torso stream ages and the model grows
        self.torso.push(t_s, human.p_xy_m)
        self.torso_velocity.push(t_s, human.v_xy_m_s)
        return human.p_xy_m

    def _record_others(self, t_s: float, human: Person | None) -> None:
        """Every other confirmed person of this scan (not ``human``, nor within ``SAME_PERSON_M``
        of them) with both legs seen within the laser's staleness threshold: rows ``x, y, vx,
        vy, time since seen`` (base frame). A track that has not shown two legs lately is not
        counted as a person: the time filter's tail at the 1.4 m clip leaves one-legged ghost
        tracks there (exp1's synthetic scans, extra capsules over 700 samples with a human: 435
        counting every confirmed track, 118 with the two legs, 93 with both rules)."""
        stale = self.policy.laser_stale_after_s
        # (kept for the tracks of this scan only: a track id is never reused once dropped)
        self._paired_s = {p.track_id: t_s if len(p.leg_xy_m) == 2 else self._paired_s.get(p.track_id, -math.inf)
                          for p in self.persons}
        rows = [[*p.p_xy_m, *p.v_xy_m_s, p.time_since_seen_s] for p in self.persons
                if p.confirmed and (human is None or p.track_id != human.track_id) and p.time_since_seen_s <= stale
                and t_s - self._paired_s.get(p.track_id, -math.inf) <= stale
                and (human is None or np.linalg.norm(p.p_xy_m - human.p_xy_m) > SAME_PERSON_M)]
        self._others_t.append(t_s)
        self._others.append(np.array(rows, dtype=float) if rows else _NOBODY_ELSE)

    def others_at(self, t_s: float, until_s: float | None = None) -> HumanCapsules:
        """The other people at ``t_s`` [s] from the newest scan visible at ``until_s``: one
        capsule each (``one_capsule``: any arm pose; nobody's IMUs are theirs), moved on at the
        track's velocity and grown with the time since seen like the human's (``laser_margin``),
        named ``body 2``, ``body 3``...; the track's velocity on both end points. Absent when
        there is nobody else or the newest scan is older than ``StalePolicy.laser_stale_after_s``
        (then the wearer's rules for a silent laser hold alone)."""
        k = self._others_scan(t_s, until_s)
        return HumanCapsules.absent(t_s) if k is None else self._others_from(k, t_s)

    def _others_from(self, k: int, t_s: float) -> HumanCapsules:
        """``others_at`` from scan ``k`` (``_others_scan``)."""
        held = t_s - self._others_t[k]
        p0, p1, radius, v = [], [], [], []
        for x, y, vx, vy, unseen in self._others[k]:
            xy = np.array([x, y]) + held * np.array([vx, vy])
            one = one_capsule(xy, self.body, t_s)
            growth, _, _ = laser_margin(unseen + held, self.policy)
            p0.append(one.p0_b_m[0])
            p1.append(one.p1_b_m[0])
            radius.append(one.radius_m[0] + growth)
            v.append([vx, vy, 0.0])
        names = tuple(f"body {i + 2}" for i in range(len(p0)))
        return HumanCapsules(np.array(p0), np.array(p1), np.array(radius), names, t_s=t_s,
                             v0_b_m_s=np.array(v), v1_b_m_s=np.array(v))

    def _others_scan(self, t_s: float, until_s: float | None) -> int | None:
        """The newest scan visible at ``until_s`` when it holds other people and is no older
        than ``StalePolicy.laser_stale_after_s`` at ``t_s`` (a silent laser: the wearer's stale
        rules alone, as before), else None."""
        horizon = t_s if until_s is None else min(t_s, until_s)
        k = bisect.bisect_right(self._others_t, horizon) - 1
        if k < 0 or not len(self._others[k]) or t_s - self._others_t[k] > self.policy.laser_stale_after_s:
            return None
        return k

    def torso_velocity_at(self, t_s: float, until_s: float | None = None) -> np.ndarray | None:
        """Shape (2,) [m/s], the tracked torso velocity in the base frame at the newest sighting
        visible at ``until_s``; None when the human was never seen or it is not finite."""
        if not np.isfinite(self.torso_velocity.age_s(t_s, until_s)):
            return None
        velocity = self.torso_velocity.value_at(t_s, until_s)
        return velocity if np.all(np.isfinite(velocity)) else None

    def push_imu(self, t_s: float, name: str, q_ref_imu) -> bool:
        """One IMU reading (xyzw, in its reference frame). False when refused as garbage."""
        if name not in self.imus:
            raise KeyError(f"unknown IMU {name!r}; known: {sorted(self.imus)}")
        return self.imus[name].push(t_s, q_ref_imu)

    def capsules_at(self, t_s: float, until_s: float | None = None) -> HumanCapsules:
        """The human at ``t_s`` [s] from the samples stamped <= ``until_s`` (all when None): the
        IMU wearer (``wearer_at``), then every other person the laser tracks (``others_at``)."""
        wearer, k = self.wearer_at(t_s, until_s), self._others_scan(t_s, until_s)
        return wearer if k is None else joined(wearer, self._others_from(k, t_s))

    def wearer_at(self, t_s: float, until_s: float | None = None) -> HumanCapsules:
        """The IMU wearer (``human_from_people``) at ``t_s`` [s] from the samples
        stamped <= ``until_s`` (all when None)."""
        # Ages count from the newest sample at or before t_s, even when later ones are visible.
        horizon = t_s if until_s is None else min(t_s, until_s)
        scan_age = self.scans.age_s(t_s, horizon)
        torso_age = self.torso.age_s(t_s, horizon)
        laser_alive = scan_age <= self.policy.laser_stale_after_s
        if not np.isfinite(torso_age):
            reason = "nobody in range" if laser_alive else "laser silent: human position unknown"
            return HumanCapsules.absent(t_s, reason, stale=not laser_alive)
        xy = self.torso.value_at(t_s, until_s)
        # Past its newest sighting the torso moves on at the tracked velocity (held there, it
        # stood still between scans while its velocity said it walked: the filter braked for a
        # motion the capsules did not make, then met it as a jump at the next scan), no further
        # than until the legs count as lost; from there the pose is held and grows.
        held_s = self.torso.age_s(t_s, until_s)  # < 0: between two sightings, interpolated
        velocity = self.torso_velocity_at(t_s, until_s)  # (also the capsules' velocity below)
        if velocity is not None and held_s > 0.0:
            xy = xy + velocity * min(held_s, self.policy.laser_stale_after_s)
        if laser_alive and torso_age > self.policy.laser_stale_after_s:
            distance = math.hypot(xy[0] - self.scanner.x_m, xy[1] - self.scanner.y_m)
            if could_have_left(distance, torso_age, self.max_range_m, self.policy):
                return HumanCapsules.absent(t_s, "nobody in range")
        caps, fresh_imus = None, None
        if not self.imus:
            caps = conservative_capsules(t_s, xy, torso_age, self.body, policy=self.policy)
        else:
            streams = [self.imus[name] for name in IMU_NAMES]
            ages = {name: stream.age_s(t_s, horizon) for name, stream in zip(IMU_NAMES, streams)}
            if all(np.isfinite(a) for a in ages.values()):
                q0, q1, frac = quaternion_brackets(streams, t_s, until_s)
                # One compiled call for the fresh 5-capsule human (None: stale or not finite).
                caps = fresh_five_capsules(t_s, xy, torso_age, q0, q1, frac, self._r_b_ref_matrices,
                                           self._body_vector, ages, self.policy)
                if caps is not None:
                    fresh_imus = streams
            if caps is None:  # the readable path: a silent IMU -> 1 capsule
                if all(np.isfinite(a) for a in ages.values()):
                    r_b_imu = self._r_b_ref_all * rotations_at(streams, t_s, until_s)  # eq. 6, batched
                else:
                    r_b_imu = Rotation.identity(len(IMU_NAMES))  # unused: a silent IMU -> 1 capsule
                ages = {k: (v if np.isfinite(v) else 1e9) for k, v in ages.items()}
                caps = conservative_capsules(t_s, xy, torso_age, self.body, r_b_imu, ages, self.policy)
        if not laser_alive:
            caps = HumanCapsules(caps.p0_b_m, caps.p1_b_m, caps.radius_m, caps.names, t_s=t_s, stale=True,
                                 reason=f"laser silent for {scan_age:.2f} s; " + caps.reason, ages_s=caps.ages_s)
        elif caps.present and torso_age <= self.policy.laser_stale_after_s:
            caps = self._with_velocities(caps, velocity, t_s, until_s, fresh_imus, xy)
        return caps

    def _arm_velocities(self, caps: HumanCapsules, streams, xy: np.ndarray, t_s: float,
                        until_s: float | None) -> tuple[np.ndarray, np.ndarray] | None:
        """The end points' velocities relative to the torso (k, 3) x 2 [m/s]: the IMU chain
        (eqs. 6-12) evaluated ``ARM_VELOCITY_WINDOW_S`` earlier with the same torso position, the
        backward difference of the two poses. None when the earlier pose is not available."""
        earlier = t_s - ARM_VELOCITY_WINDOW_S
        q0, q1, frac = quaternion_brackets(streams, earlier, until_s)
        ages = {name: 0.0 for name in IMU_NAMES}
        before = fresh_five_capsules(earlier, xy, 0.0, q0, q1, frac, self._r_b_ref_matrices, self._body_vector,
                                     ages, self.policy)
        if before is None:
            return None
        return ((caps.p0_b_m - before.p0_b_m) / ARM_VELOCITY_WINDOW_S,
                (caps.p1_b_m - before.p1_b_m) / ARM_VELOCITY_WINDOW_S)

    def _with_velocities(self, caps: HumanCapsules, velocity: np.ndarray | None, t_s: float,
                         until_s: float | None, fresh_imus, xy: np.ndarray) -> HumanCapsules:
        """The capsules' end-point velocities: the tracked torso's ``velocity`` (the person
        tracker's Kalman velocity, ``torso_velocity_at``; None: unknown) on every end point, plus,
        with five fresh IMUs (``fresh_imus``: their streams, else None), each end point's own
        motion relative to the torso (``_arm_velocities``). While the torso is not seen, no
        velocity (the stale growth covers it)."""
        if velocity is None:
            return caps
        v0 = np.zeros((len(caps.names), 3))
        v0[:, :2] = velocity
        v1 = v0.copy()
        relative = None if fresh_imus is None else self._arm_velocities(caps, fresh_imus, xy, t_s, until_s)
        if relative is not None:
            v0 += relative[0]
            v1 += relative[1]
        return caps.with_velocities(v0, v1)


def joined(wearer: HumanCapsules, others: HumanCapsules) -> HumanCapsules:
    """The wearer's capsules then the others' in one ``HumanCapsules`` (velocities zero where
    one side has none; staleness and reasons of the wearer, who may be absent)."""
    def velocities(caps):
        zero = np.zeros_like(caps.p0_b_m)
        return (zero, zero) if caps.v0_b_m_s is None else (caps.v0_b_m_s, caps.v1_b_m_s)

    (w0, w1), (o0, o1) = velocities(wearer), velocities(others)
    return HumanCapsules(np.vstack((wearer.p0_b_m, others.p0_b_m)), np.vstack((wearer.p1_b_m, others.p1_b_m)),
                         np.concatenate((wearer.radius_m, others.radius_m)), wearer.names + others.names,
                         t_s=wearer.t_s, stale=wearer.stale, reason=wearer.reason, ages_s=wearer.ages_s,
                         v0_b_m_s=np.vstack((w0, o0)), v1_b_m_s=np.vstack((w1, o1)))
