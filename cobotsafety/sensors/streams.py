"""Time alignment of sensor streams (paper 2, section 5): laser ~50 Hz, IMUs ~300 Hz.

Each stream keeps its own timestamps [s]. ``value_at(t_s)`` interpolates between the two
samples around ``t_s`` (linear for vectors, slerp for orientations) and holds the newest sample
past the end; across a gap longer than the stale threshold it holds the older sample. ``until_s`` hides samples stamped after it, so a replay can be causal (the value
at control time t uses only samples that existed at t). ``age_s(t_s)`` is the time since the
newest visible sample; ``is_stale`` compares it with the stream's threshold.

Garbage (non-finite values, non-unit quaternions, time going backwards) is refused by
``push``: the sample is dropped, counted and described in ``last_rejection``, so a sensor that
returns garbage simply goes stale and the human model turns conservative.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

#: Quaternion norm tolerance for live samples (|norm - 1|).
UNIT_QUATERNION_TOLERANCE = 1e-3


class VectorStream:
    """Timestamped samples of shape (dim,); linear interpolation."""

    def __init__(self, name: str, dim: int, stale_after_s: float, capacity: int = 1024):
        if not stale_after_s > 0:
            raise ValueError(f"stale_after_s must be > 0, got {stale_after_s}")
        self.name = name
        self.dim = int(dim)
        self.stale_after_s = float(stale_after_s)
        self._t = np.empty(capacity)
        self._v = np.empty((capacity, self._width()))
        self._n = 0
        self.rejected = 0
        self.last_rejection = ""

    def _width(self) -> int:
        return self.dim

    def _check(self, value: list[float]) -> str:
        if len(value) != self._width():
            return f"shape ({len(value)},), expected ({self._width()},)"
        if not all(map(math.isfinite, value)):
            return "non-finite value"
        return ""

    def push(self, t_s: float, value) -> bool:
        """Append one sample; returns False (and keeps the stream unchanged) on garbage."""
        # Plain Python floats: numpy's per-call overhead dominated this 4-number check.
        value = np.asarray(value, dtype=float).reshape(-1).tolist()
        problem = self._check(value)
        t_s = float(t_s)
        if not problem and not math.isfinite(t_s):
            problem = f"non-finite time {t_s}"
        if not problem and self._n and t_s <= self._t[self._n - 1]:
            problem = f"time {t_s} not after the previous sample {self._t[self._n - 1]}"
        if problem:
            self.rejected += 1
            self.last_rejection = f"{self.name}: {problem}"
            return False
        if self._n == len(self._t):
            self._t = np.concatenate([self._t, np.empty_like(self._t)])
            self._v = np.concatenate([self._v, np.empty_like(self._v)])
        self._t[self._n] = t_s
        self._v[self._n] = self._normalised_one(value)
        self._n += 1
        return True

    def _normalised_one(self, value: list[float]) -> list[float]:
        return value

    def _normalised(self, value: np.ndarray) -> np.ndarray:
        return value

    @classmethod
    def from_arrays(cls, name: str, t_s: np.ndarray, values: np.ndarray, stale_after_s: float):
        """A stream from already validated arrays: ``t_s`` (n,) increasing, ``values`` (n, dim)."""
        t = np.asarray(t_s, dtype=float)
        values = np.asarray(values, dtype=float).reshape(len(t), -1)
        if len(t) > 1 and not (np.diff(t) > 0).all():
            raise ValueError(f"{name}: timestamps must increase")
        if cls is VectorStream:
            stream = cls(name, values.shape[1], stale_after_s, capacity=max(1, len(t)))
        else:
            stream = cls(name, stale_after_s, capacity=max(1, len(t)))
        stream._t[: len(t)] = t
        stream._v[: len(t)] = stream._normalised(values)
        stream._n = len(t)
        return stream

    @property
    def times_s(self) -> np.ndarray:
        return self._t[: self._n]

    def __len__(self) -> int:
        return self._n

    def _visible(self, until_s: float | None) -> int:
        if until_s is None or (self._n and until_s >= self._t[self._n - 1]):
            return self._n
        # (the array's method: the np.searchsorted wrapper costs a microsecond more, per sample)
        return int(self._t[: self._n].searchsorted(until_s, side="right"))

    def newest_s(self, until_s: float | None = None) -> float:
        """Stamp of the newest visible sample [s]; -inf when there is none."""
        n = self._visible(until_s)
        return float(self._t[n - 1]) if n else -np.inf

    def age_s(self, t_s: float, until_s: float | None = None) -> float:
        """``t_s`` minus the newest visible stamp [s]; inf when empty."""
        return float(t_s - self.newest_s(until_s))

    def is_stale(self, t_s: float, until_s: float | None = None) -> bool:
        return self.age_s(t_s, until_s) > self.stale_after_s

    def _bracket(self, t_s: float, until_s: float | None):
        n = self._visible(until_s)
        if n == 0:
            raise LookupError(f"stream {self.name!r} has no sample at or before {until_s}")
        t = self._t[:n]
        if t_s >= t[n - 1]:
            return n - 1, n - 1, 0.0  # the newest sample held (the live case)
        k = int(t.searchsorted(t_s, side="right"))
        if k == 0:
            return 0, 0, 0.0
        if k == n or t[k] - t[k - 1] > self.stale_after_s:  # never interpolate across a gap
            return k - 1, k - 1, 0.0
        return k - 1, k, float((t_s - t[k - 1]) / (t[k] - t[k - 1]))

    def value_at(self, t_s: float, until_s: float | None = None) -> np.ndarray:
        """Shape (dim,): linear interpolation; first/newest sample held outside the range."""
        i, j, frac = self._bracket(t_s, until_s)
        return (1.0 - frac) * self._v[i] + frac * self._v[j]


class QuaternionStream(VectorStream):
    """Timestamped orientations, scalar-last quaternions ``(x, y, z, w)``; slerp between them."""

    def __init__(self, name: str, stale_after_s: float, capacity: int = 1024):
        super().__init__(name, 4, stale_after_s, capacity)

    def _width(self) -> int:
        return 4

    def _check(self, value: list[float]) -> str:
        problem = super()._check(value)
        norm = math.hypot(*value) if not problem else 1.0
        if abs(norm - 1.0) > UNIT_QUATERNION_TOLERANCE:
            return f"quaternion norm {norm:.6f} not within {UNIT_QUATERNION_TOLERANCE} of 1"
        return problem

    def _normalised(self, value: np.ndarray) -> np.ndarray:
        return value / np.linalg.norm(value, axis=-1, keepdims=True)

    def _normalised_one(self, value: list[float]) -> list[float]:
        norm = math.hypot(*value)
        return [v / norm for v in value]

    def rotation_at(self, t_s: float, until_s: float | None = None) -> Rotation:
        """Slerp between the samples around ``t_s`` (shortest arc); held outside the range."""
        i, j, frac = self._bracket(t_s, until_s)
        r0 = Rotation.from_quat(self._v[i])
        if frac == 0.0:
            return r0
        delta = (r0.inv() * Rotation.from_quat(self._v[j])).as_rotvec()
        return r0 * Rotation.from_rotvec(frac * delta)

    def value_at(self, t_s: float, until_s: float | None = None) -> np.ndarray:
        return self.rotation_at(t_s, until_s).as_quat()


def quaternion_brackets(streams: list[QuaternionStream], t_s: float,
                        until_s: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The samples around ``t_s`` of every stream: ``(q0 (n, 4), q1 (n, 4), frac (n,))``, the
    orientation at ``t_s`` being the slerp from q0 to q1 by ``frac`` (``rotations_at``)."""
    n = len(streams)
    q0, q1, frac = np.empty((n, 4)), np.empty((n, 4)), np.empty(n)
    for k, stream in enumerate(streams):
        i, j, frac[k] = stream._bracket(t_s, until_s)
        q0[k], q1[k] = stream._v[i], stream._v[j]
    return q0, q1, frac


def rotations_at(streams: list[QuaternionStream], t_s: float, until_s: float | None = None) -> Rotation:
    """All streams' orientations at ``t_s`` as one batched ``Rotation`` (one slerp for all)."""
    q0, q1, frac = quaternion_brackets(streams, t_s, until_s)
    r0 = Rotation.from_quat(q0)
    if not frac.any():
        return r0
    delta = (r0.inv() * Rotation.from_quat(q1)).as_rotvec()
    return r0 * Rotation.from_rotvec(frac[:, None] * delta)
