"""``PersonTracker``: legs from successive scans -> tracked people with position and velocity.

Per scan (``update(t_s, legs_xy_m)``):

1. **Pairing** (``pair_legs``): two legs closer than ``leg_pair_distance_m`` are one person
   (closest pairs first); a leg left alone is a person too (the other leg hidden, or both legs
   seen as one cluster). The person's measured position is the mean of its legs (paper 2,
   eq. 4).
2. **Association**: every live track is predicted to ``t_s`` by its constant-velocity Kalman
   filter (``cobotsafety.estimation.constant_velocity``); the cost of giving measurement j to
   track i is their squared Mahalanobis distance, pairs beyond the gate (``gate_chi2``, a
   chi-square quantile with 2 degrees of freedom) are forbidden, and
   ``scipy.optimize.linear_sum_assignment`` picks the cheapest one-to-one assignment.
3. **Correction**: assigned tracks take their measurement; the others are only predicted.
4. **Deaths**: a track not seen for ``delete_after_s`` (``tentative_delete_after_s`` while
   still tentative) is dropped.
5. **Births**: every measurement left unassigned starts a tentative track; it is confirmed after
   ``confirm_after_hits`` measurements.

The filter's velocity is a model-based estimate (no finite differences of noisy positions);
between sightings a track coasts at its last velocity, and ``time_since_seen_s`` says for how
long, so the human model can grow its margin with it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from cobotsafety.estimation.constant_velocity import ConstantVelocityKalman, KalmanNoise


@dataclass(frozen=True)
class PersonTrackerParams:
    """Tracker settings (units in the names)."""

    leg_pair_distance_m: float = 0.6
    """Two legs closer than this are one person [m]."""
    gate_chi2: float = 13.8
    """Association gate on the squared Mahalanobis distance (chi-square, 2 dof, 99.9 %)."""
    confirm_after_hits: int = 3
    """A tentative track is confirmed after this many measurements (its birth included)."""
    delete_after_s: float = 1.0
    """A confirmed track not seen for this long is dropped [s]."""
    tentative_delete_after_s: float = 0.25
    """A tentative track not seen for this long is dropped [s]."""
    noise: KalmanNoise = field(default_factory=lambda: KalmanNoise(
        accel_density_m2_s3=2.0, measurement_std_m=0.05, initial_speed_std_m_s=1.0))
    """Kalman noise of a person's torso (the mean of its legs jitters by a few cm as they swing)."""

    def __post_init__(self):
        for name in ("leg_pair_distance_m", "gate_chi2", "delete_after_s", "tentative_delete_after_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"PersonTrackerParams.{name} must be finite and > 0, got {value}")
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


class PersonTracker:
    """Tracks people across scans. Feed it every scan's legs, in time order, even when empty."""

    def __init__(self, params: PersonTrackerParams = PersonTrackerParams()):
        self.params = params
        self._filter: ConstantVelocityKalman | None = None
        self._ids = np.zeros(0, dtype=int)
        self._hits = np.zeros(0, dtype=int)
        self._last_seen_s = np.zeros(0)
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
        groups = pair_legs(legs, self.params.leg_pair_distance_m)
        measured = np.array([legs[g].mean(axis=0) for g in groups]).reshape(-1, 2)
        n = self._ids.size
        assigned_group = np.full(n, -1)
        if n and measured.shape[0]:
            cost = self._filter.mahalanobis2(t_s, measured)
            allowed = cost <= self.params.gate_chi2
            if allowed.any():
                rows, cols = linear_sum_assignment(np.where(allowed, cost, 1e6 * self.params.gate_chi2))
                ok = allowed[rows, cols]
                assigned_group[rows[ok]] = cols[ok]
        if n:
            seen = assigned_group >= 0
            z = np.full((n, 2), np.nan)
            z[seen] = measured[assigned_group[seen]]
            self._filter.update(t_s, z, mask=seen)
            self._hits[seen] += 1
            self._last_seen_s[seen] = t_s
            assigned_group = assigned_group[self._drop(t_s)]
        unassigned = np.setdiff1d(np.arange(measured.shape[0]), assigned_group)
        self._birth(t_s, measured[unassigned])
        assigned_group = np.concatenate([assigned_group, unassigned])
        return self._persons(t_s, legs, groups, assigned_group)

    def _drop(self, t_s: float) -> np.ndarray:
        """Drop the tracks unseen for too long; returns the (n,) mask of those kept."""
        confirmed = self._hits >= self.params.confirm_after_hits
        timeout = np.where(confirmed, self.params.delete_after_s, self.params.tentative_delete_after_s)
        keep = (t_s - self._last_seen_s) <= timeout
        if keep.all():
            return keep
        f = self._filter
        f.position, f.velocity, f.covariance = f.position[keep], f.velocity[keep], f.covariance[keep]
        self._ids, self._hits, self._last_seen_s = self._ids[keep], self._hits[keep], self._last_seen_s[keep]
        return keep

    def _birth(self, t_s: float, positions_m: np.ndarray) -> None:
        m = positions_m.shape[0]
        if m == 0:
            return
        new = ConstantVelocityKalman(t_s, positions_m, self.params.noise)
        if self._filter is None or self._ids.size == 0:
            self._filter = new
        else:
            f = self._filter
            f.position = np.concatenate([f.position, new.position])
            f.velocity = np.concatenate([f.velocity, new.velocity])
            f.covariance = np.concatenate([f.covariance, new.covariance])
        self._ids = np.concatenate([self._ids, np.arange(self._next_id, self._next_id + m)])
        self._hits = np.concatenate([self._hits, np.ones(m, dtype=int)])
        self._last_seen_s = np.concatenate([self._last_seen_s, np.full(m, t_s)])
        self._next_id += m
        self.births += m

    def _persons(self, t_s: float, legs: np.ndarray, groups: list[np.ndarray],
                 assigned_group: np.ndarray) -> list[Person]:
        if self._ids.size == 0:
            return []
        f = self._filter
        confirmed = self._hits >= self.params.confirm_after_hits
        return [
            Person(
                track_id=int(self._ids[i]),
                p_xy_m=f.position[i].copy(),
                v_xy_m_s=f.velocity[i].copy(),
                leg_xy_m=legs[groups[g]] if g >= 0 else np.zeros((0, 2)),
                confirmed=bool(confirmed[i]),
                time_since_seen_s=float(t_s - self._last_seen_s[i]),
            )
            for i, g in enumerate(assigned_group.tolist())
        ]
