"""``PersonTracker``: legs from successive scans -> tracked people with position and velocity.

Per scan (``update(t_s, legs_xy_m)``):

1. **Legs to tracks**: every live track is predicted to ``t_s`` by its constant-velocity Kalman
   filter (``cobotsafety.estimation.constant_velocity``) and offers two slots, one per leg. The
   cost of leg j in a slot of track i is their squared Mahalanobis distance (the track's
   position variance plus the measurement noise plus the spread of a leg around its torso);
   slots beyond the gate (``gate_chi2``, a chi-square quantile with 2 degrees of freedom) are
   forbidden, and ``scipy.optimize.linear_sum_assignment`` picks the cheapest one-to-one
   assignment, confirmed tracks first, then the tentative ones from the legs left (a
   matching cascade: an uncertain new track must not take a leg from a confirmed person). Associating legs, not ready-made pairs, keeps two people apart when they pass
   close by (a blind pairing would pair one leg of each).
2. **Correction**: a track with legs takes their mean as its measured torso (paper 2, eq. 4;
   a lone leg when the other is hidden or both are seen as one cluster); the others are only
   predicted.
3. **Deaths**: a track not seen for ``delete_after_s`` (``tentative_delete_after_s`` while
   still tentative) is dropped.
4. **Births** (``pair_legs``): the legs left over are paired, closest first, when closer than
   ``leg_pair_distance_m``, a leg left alone being a person too; a lone leg starts a tentative
   track, confirmed after ``confirm_after_hits`` measurements; a pair starts a confirmed one
   (``confirm_pairs_at_birth``: two detections agreeing on one person, where confirmation only
   guards against one stray detection; docs/leg_recall.md, amendment of 2026-12-04).
5. **Legs carried through short misses** (``_carry_legs``): each track keeps two leg slots,
   each a leg's position at its last sighting and the track's velocity then. Two legs of a
   track in a scan fill both slots; one leg fills the slot whose predicted leg (last position
   moved on at that velocity) is nearer (an empty slot costs ``leg_pair_distance_m / 2``); a slot not filled, seen at
   most ``leg_carry_s`` ago, is reported in ``Person.carried_leg_xy_m`` at its predicted leg:
   moved with the torso, the mean of a stance leg (still) and a swing leg (twice as fast).
   The torso's velocity at the last sighting, not the track's since: with one leg seen the
   track is corrected towards that leg (eq. 4, a lone leg), and a leg moved with it drifted
   onto the seen one within ~0.3 s. A missed leg, occluded by the other through a swing phase
   or missed by the detector for a scan or two, is not a missed person. A carried leg is not a
   measurement: it never corrects the track nor resets ``time_since_seen_s``.

The filter's velocity is a model-based estimate (no finite differences of noisy positions);
between sightings a track coasts at its last velocity, and ``time_since_seen_s`` says for how
long, so the human model can grow its margin with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from cobotsafety.estimation.constant_velocity import ConstantVelocityKalman, KalmanNoise
from cobotsafety.sensors.person_kernel import correct_in_place, leg_gate, predict_in_place


#: Shape (0, 2), read-only: no legs (shared by every person with none carried).
_NO_LEGS = np.zeros((0, 2))
_NO_LEGS.flags.writeable = False


@dataclass(frozen=True)
class PersonTrackerParams:
    """Tracker settings (units in the names)."""

    leg_pair_distance_m: float = 0.6
    """Two legs closer than this are one person [m]."""
    gate_chi2: float = 13.8
    """Association gate on the squared Mahalanobis distance (chi-square, 2 dof, 99.9 %)."""
    leg_spread_std_m: float = 0.15
    """Standard deviation of a leg around its torso while walking [m] (hips, stride)."""
    confirm_after_hits: int = 3
    """A tentative track is confirmed after this many measurements (its birth included)."""
    confirm_pairs_at_birth: bool = True
    """A track born from two legs paired in one scan is confirmed at once: confirmation keeps
    one stray detection from becoming a person, and a pair is two detections agreeing on one
    (a phantom pair only slows the robot). False: every track waits ``confirm_after_hits``."""
    delete_after_s: float = 1.0
    """A confirmed track not seen for this long is dropped [s]."""
    tentative_delete_after_s: float = 0.25
    """A tentative track not seen for this long is dropped [s]."""
    leg_carry_s: float = 0.5
    """A leg not seen is carried (``Person.carried_leg_xy_m``) for at most this long after its
    last sighting [s]: a swing phase (~0.4 s of a ~1.1 s gait cycle, when the far leg hides
    behind the near one) plus a scan. 0: never."""
    noise: KalmanNoise = field(default_factory=lambda: KalmanNoise(
        accel_density_m2_s3=2.0, measurement_std_m=0.05, initial_speed_std_m_s=1.0))
    """Kalman noise of a person's torso (the mean of its legs jitters by a few cm as they swing)."""

    def __post_init__(self):
        for name in ("leg_pair_distance_m", "gate_chi2", "leg_spread_std_m", "delete_after_s",
                     "tentative_delete_after_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"PersonTrackerParams.{name} must be finite and > 0, got {value}")
        if not (np.isfinite(self.leg_carry_s) and self.leg_carry_s >= 0):
            raise ValueError(f"PersonTrackerParams.leg_carry_s must be finite and >= 0, got {self.leg_carry_s}")
        if self.tentative_delete_after_s > self.delete_after_s:
            raise ValueError(f"PersonTrackerParams.tentative_delete_after_s ({self.tentative_delete_after_s}) must "
                             f"not exceed delete_after_s ({self.delete_after_s})")
        if not isinstance(self.confirm_pairs_at_birth, (bool, np.bool_)):
            raise ValueError(f"PersonTrackerParams.confirm_pairs_at_birth must be True or False, "
                             f"got {self.confirm_pairs_at_birth!r}")
        if int(self.confirm_after_hits) != self.confirm_after_hits or self.confirm_after_hits < 1:
            raise ValueError(f"PersonTrackerParams.confirm_after_hits must be an integer >= 1, "
                             f"got {self.confirm_after_hits}")


@dataclass(frozen=True)
class Person:
    """One tracked person after a scan (scanner frame of the legs given to the tracker)."""

    track_id: int
    p_xy_m: np.ndarray
    """Shape (2,), filtered torso position [m]."""
    v_xy_m_s: np.ndarray
    """Shape (2,), filtered torso velocity [m/s]."""
    leg_xy_m: np.ndarray
    """Shape (0..2, 2), the legs assigned to this person in this scan [m] (none when unseen)."""
    confirmed: bool
    time_since_seen_s: float
    """Time since the person's last measurement [s] (0 when seen in this scan)."""
    carried_leg_xy_m: np.ndarray = field(default_factory=lambda: _NO_LEGS)
    """Shape (0..2, 2), the legs not seen in this scan but seen within ``leg_carry_s``, moved
    on from their last sighting at the torso's velocity then [m] (module docstring, step 5)."""

    @property
    def all_leg_xy_m(self) -> np.ndarray:
        """Shape (0..2, 2): the legs seen in this scan, then the legs carried [m]."""
        if len(self.carried_leg_xy_m) == 0:
            return self.leg_xy_m
        return np.concatenate([self.leg_xy_m.reshape(-1, 2), self.carried_leg_xy_m])


def pair_legs(legs_xy_m: np.ndarray, leg_pair_distance_m: float) -> list[np.ndarray]:
    """Legs grouped into people: a list of index arrays (1 or 2 legs each), pairs first.

    Pairs are taken closest first among legs closer than ``leg_pair_distance_m``; every leg
    left over is a person alone. ``legs_xy_m``: shape (k, 2) [m].
    """
    k = legs_xy_m.shape[0]
    groups: list[np.ndarray] = []
    if k == 0:
        return groups
    used = np.zeros(k, dtype=bool)
    if k > 1:
        distance = np.linalg.norm(legs_xy_m[:, None] - legs_xy_m[None], axis=-1)
        i_upper, j_upper = np.triu_indices(k, 1)
        d = distance[i_upper, j_upper]
        for flat in np.argsort(d, kind="stable"):
            if d[flat] > leg_pair_distance_m:
                break
            i, j = int(i_upper[flat]), int(j_upper[flat])
            if not used[i] and not used[j]:
                used[i] = used[j] = True
                groups.append(np.array([i, j]))
    groups += [np.array([i]) for i in np.flatnonzero(~used)]
    return groups


def _mean_leg(legs_xy_m: np.ndarray, group: list[int]) -> tuple[float, float]:
    """The mean of one or two legs [m] (plain floats: ``ndarray.mean`` costs more than the sum)."""
    if len(group) == 1:
        x, y = legs_xy_m[group[0]].tolist()
        return x, y
    (x0, y0), (x1, y1) = legs_xy_m[group].tolist()
    return (x0 + x1) / 2, (y0 + y1) / 2


class PersonTracker:
    """Tracks people across scans. Feed it every scan's legs, in time order, even when empty.

    ``packed`` (default): the filter's predict, gate and correction run as compiled loops on its
    arrays (``person_kernel``); False runs ``ConstantVelocityKalman``'s own methods (the
    reference; both give the same tracks).
    """

    def __init__(self, params: PersonTrackerParams = PersonTrackerParams(), *, packed: bool = True):
        self.params = params
        self.packed = bool(packed)
        self._filter: ConstantVelocityKalman | None = None
        self._ids = np.zeros(0, dtype=int)
        self._hits = np.zeros(0, dtype=int)
        self._last_seen_s = np.zeros(0)
        self._empty_slot_cost_m = params.leg_pair_distance_m / 2
        self._leg_slots: list[list[tuple | None]] = []
        """Per track, two leg slots: None (never seen) or the leg's last sighting
        ``(x_m, y_m, track vx_m_s, track vy_m_s, t_s)`` (plain floats: a few per scan)."""
        self._next_id = 1
        self._t_s = -np.inf
        self.births = 0
        """Tracks started so far (confirmed or not)."""

    @property
    def t_s(self) -> float:
        """Stamp of the last update [s] (-inf before the first)."""
        return self._t_s

    def update(self, t_s: float, legs_xy_m: np.ndarray) -> list[Person]:
        """Process the legs (shape (k, 2) [m]) seen at ``t_s`` [s]; returns the live tracks.

        Raises ``ValueError`` for a non-finite time, a time before the previous update, or legs
        that are not a finite (k, 2) array.
        """
        t_s = float(t_s)
        if not np.isfinite(t_s):
            raise ValueError(f"PersonTracker.update: t_s must be finite, got {t_s}")
        if t_s < self._t_s:
            raise ValueError(f"PersonTracker.update: t_s={t_s} is before the previous update {self._t_s}")
        legs = np.asarray(legs_xy_m, dtype=float)
        if legs.size == 0:
            legs = legs.reshape(0, 2)
        if legs.ndim != 2 or legs.shape[1] != 2:
            raise ValueError(f"PersonTracker.update: legs_xy_m must have shape (k, 2), got {legs.shape}")
        if not np.isfinite(legs).all():
            raise ValueError("PersonTracker.update: legs_xy_m must be finite")
        self._t_s = t_s
        n, k = self._ids.size, legs.shape[0]
        carried: list[list[tuple[float, float]]] = []
        if n:
            self._predict(t_s)  # once: the association and the correction share it
        legs_of_track = self._assign_legs(legs) if n and k else [[] for _ in range(n)]
        if n:
            carried = self._carry_legs(t_s, legs, legs_of_track)  # from the predicted torsos
        taken = {leg for group in legs_of_track for leg in group}
        free = [leg for leg in range(k) if leg not in taken]
        new_groups = []
        if free:
            new_groups = [[free[i] for i in group.tolist()]
                          for group in pair_legs(legs[free], self.params.leg_pair_distance_m)]
        if n:
            seen = np.array([len(group) > 0 for group in legs_of_track])
            z = np.full((n, 2), np.nan)
            for i, group in enumerate(legs_of_track):
                if group:
                    z[i] = _mean_leg(legs, group)  # eq. 4: the torso between the legs
            self._correct(t_s, z, seen)
            self._hits[seen] += 1
            self._last_seen_s[seen] = t_s
            keep = self._drop(t_s).tolist()
            legs_of_track = [g for g, kept in zip(legs_of_track, keep) if kept]
            carried = [c for c, kept in zip(carried, keep) if kept]
        if new_groups:
            self._birth(t_s, np.array([_mean_leg(legs, g) for g in new_groups]),
                        [legs[g] for g in new_groups])
        return self._persons(t_s, legs, legs_of_track + new_groups, carried + [[] for _ in new_groups])

    def _assign_legs(self, legs: np.ndarray) -> list[list[int]]:
        """Legs (indices into ``legs``) of each live track: 0, 1 or 2 each.

        Each track (already predicted to this scan) offers two slots; a leg may fill a slot when
        its squared Mahalanobis distance to the predicted torso (covariance: the track's position
        variance, the measurement noise and the leg's spread around the torso) is within the
        gate; the cheapest one-to-one assignment wins. Two legs of one track farther apart than ``leg_pair_distance_m``
        are not one person: the one farther from the prediction is released.
        """
        n, k = self._ids.size, legs.shape[0]
        groups: list[list[int]] = [[] for _ in range(n)]
        f, noise = self._filter, self.params.noise
        extra_variance = noise.measurement_std_m ** 2 + self.params.leg_spread_std_m ** 2
        if self.packed:
            cost = np.empty((n, k))
            unambiguous = leg_gate(f.position, f.covariance, legs, extra_variance, self.params.gate_chi2, cost)
            allowed = cost <= self.params.gate_chi2
        else:
            variance = f.covariance[:, 0, 0] + extra_variance  # position predicted to t_s
            cost = np.sum((f.position[:, None, :] - legs[None]) ** 2, axis=2) / variance[:, None]  # (n, k)
            allowed = cost <= self.params.gate_chi2
            unambiguous = (allowed.sum(axis=0) <= 1).all() and (allowed.sum(axis=1) <= 2).all()
        if unambiguous:
            # Each leg fits one track, no track more than two: every allowed pair is in the
            # optimal assignment, no solver needed.
            pairs = zip(*np.nonzero(allowed))
        else:
            pairs = self._cascade(cost, allowed)
        for track, leg in pairs:
            groups[int(track)].append(int(leg))
        for track, group in enumerate(groups):
            if len(group) == 2:
                (x0, y0), (x1, y1) = legs[group].tolist()
                if math.hypot(x1 - x0, y1 - y0) > self.params.leg_pair_distance_m:
                    groups[track] = [group[int(np.argmin(cost[track, group]))]]
        return groups

    def _cascade(self, cost: np.ndarray, allowed: np.ndarray) -> list[tuple[int, int]]:
        """(track, leg) pairs of the cheapest gated assignment, confirmed tracks first.

        Confirmed tracks share out the legs among themselves; tentative tracks then take from
        the legs left. A tentative track born from one stray detection (a ghost of eq. 1's
        time filter, say) and unseen since has a wide covariance, so a small Mahalanobis
        distance to a leg 0.2 m away: in one assignment with everybody it took a leg from the
        confirmed person beside it, who went on as two one-legged tracks (the replay's torso
        off by the hip half-width for 5 s).
        """
        confirmed = self._hits >= self.params.confirm_after_hits
        free = np.ones(cost.shape[1], dtype=bool)
        pairs = []
        for tracks in (np.flatnonzero(confirmed), np.flatnonzero(~confirmed)):
            legs = np.flatnonzero(free)
            if tracks.size == 0 or legs.size == 0:
                continue
            sub_allowed = allowed[np.ix_(tracks, legs)]
            slots = np.repeat(np.where(sub_allowed, cost[np.ix_(tracks, legs)], 1e6 * self.params.gate_chi2), 2, axis=0)
            rows, cols = linear_sum_assignment(slots)  # (2 slots per track, legs)
            for row, col in zip(rows.tolist(), cols.tolist()):
                if sub_allowed[row // 2, col]:
                    pairs.append((int(tracks[row // 2]), int(legs[col])))
                    free[legs[col]] = False
        return pairs

    def _carry_legs(self, t_s: float, legs: np.ndarray, legs_of_track: list[list[int]]) -> list[list[tuple]]:
        """Fill the leg slots of every track (already predicted to ``t_s``) with its legs of this
        scan; returns, per track, the slots carried (module docstring, step 5) [m]."""
        carry_from_s = t_s - self.params.leg_carry_s
        points = legs.tolist()
        carried = []
        for slots, group, (vx, vy) in zip(self._leg_slots, legs_of_track, self._filter.velocity.tolist()):
            if len(group) == 2:  # both slots (which is which never shows: nothing carried, both restart)
                (x0, y0), (x1, y1) = points[group[0]], points[group[1]]
                slots[0], slots[1] = (x0, y0, vx, vy, t_s), (x1, y1, vx, vy, t_s)
                carried.append([])
                continue
            # Each slot's leg at t_s: its last sighting moved on at the torso's velocity then.
            predicted = [None if slot is None else (slot[0] + slot[2] * (t_s - slot[4]), slot[1] + slot[3] * (t_s - slot[4]))
                         for slot in slots]
            filled = -1
            if group:  # one leg: the nearer slot (an empty one costs half the pairing distance)
                x, y = points[group[0]]
                cost = [self._empty_slot_cost_m if guess is None else math.hypot(x - guess[0], y - guess[1])
                        for guess in predicted]
                filled = 0 if cost[0] <= cost[1] else 1
                slots[filled] = (x, y, vx, vy, t_s)
            carried.append([predicted[k] for k in (0, 1)
                            if k != filled and slots[k] is not None and slots[k][4] >= carry_from_s])
        return carried

    def _predict(self, t_s: float) -> None:
        f = self._filter
        if not self.packed:
            f.predict(t_s)
        elif t_s > f.t_s:
            predict_in_place(f.position, f.velocity, f.covariance, t_s - f.t_s, self.params.noise.accel_density_m2_s3)
            f.t_s = t_s

    def _correct(self, t_s: float, z: np.ndarray, seen: np.ndarray) -> None:
        """Correct the tracks seen (``seen`` (n,) bool) by their measured torsos ``z`` (n, 2)."""
        if self.packed:  # already predicted to t_s
            correct_in_place(self._filter.position, self._filter.velocity, self._filter.covariance, z, seen,
                             self.params.noise.measurement_std_m ** 2)
        else:
            self._filter.update(t_s, z, mask=seen)

    def _drop(self, t_s: float) -> np.ndarray:
        """Drop the tracks unseen for too long; returns the (n,) mask of those kept."""
        unseen_s = t_s - self._last_seen_s
        keep = unseen_s <= self.params.tentative_delete_after_s
        if keep.all():
            return keep  # the common case: every track seen recently
        confirmed = self._hits >= self.params.confirm_after_hits
        keep |= confirmed & (unseen_s <= self.params.delete_after_s)
        f = self._filter
        f.position, f.velocity, f.covariance = f.position[keep], f.velocity[keep], f.covariance[keep]
        self._ids, self._hits, self._last_seen_s = self._ids[keep], self._hits[keep], self._last_seen_s[keep]
        self._leg_slots = [slots for slots, kept in zip(self._leg_slots, keep.tolist()) if kept]
        return keep

    def _birth(self, t_s: float, positions_m: np.ndarray, legs_m: list[np.ndarray]) -> None:
        """New tracks at ``positions_m`` (m, 2), each with its 1 or 2 legs (., 2) in its slots:
        tentative, or confirmed when born from a pair (``confirm_pairs_at_birth``)."""
        m = positions_m.shape[0]
        if m == 0:
            return
        for group in legs_m:  # a new track's velocity is zero
            slots = [(x, y, 0.0, 0.0, t_s) for x, y in group.tolist()]
            self._leg_slots.append(slots + [None] * (2 - len(slots)))
        new = ConstantVelocityKalman(t_s, positions_m, self.params.noise)
        if self._filter is None or self._ids.size == 0:
            self._filter = new
        else:
            f = self._filter
            f.position = np.concatenate([f.position, new.position])
            f.velocity = np.concatenate([f.velocity, new.velocity])
            f.covariance = np.concatenate([f.covariance, new.covariance])
        self._ids = np.concatenate([self._ids, np.arange(self._next_id, self._next_id + m)])
        paired = np.array([len(group) == 2 for group in legs_m]) & self.params.confirm_pairs_at_birth
        self._hits = np.concatenate([self._hits, np.where(paired, self.params.confirm_after_hits, 1)])
        self._last_seen_s = np.concatenate([self._last_seen_s, np.full(m, t_s)])
        self._next_id += m
        self.births += m

    def _persons(self, t_s: float, legs: np.ndarray, legs_of_track: list[list[int]],
                 carried: list[list[tuple]]) -> list[Person]:
        if self._ids.size == 0:
            return []
        f = self._filter
        confirmed = self._hits >= self.params.confirm_after_hits
        return [
            Person(
                track_id=int(self._ids[i]),
                p_xy_m=f.position[i].copy(),
                v_xy_m_s=f.velocity[i].copy(),
                leg_xy_m=legs[group] if group else np.zeros((0, 2)),
                confirmed=bool(confirmed[i]),
                time_since_seen_s=float(t_s - self._last_seen_s[i]),
                carried_leg_xy_m=np.array(kept) if kept else _NO_LEGS,
            )
            for i, (group, kept) in enumerate(zip(legs_of_track, carried))
        ]
