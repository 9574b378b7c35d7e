"""Body dimensions (paper 2, section 2.2.3) and the capsule container the pipeline hands out.

Frames: everything is in the robot base frame ``b`` (z up, z = 0 the table top / robot base
plane). The chest point sits ``chest_height_m`` (the paper's ``l``) above that plane.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

import numpy as np

#: Capsule order of the 5-capsule human (paper Fig. 1b).
CAPSULE_NAMES_5 = ("torso", "upper_arm_left", "forearm_left", "upper_arm_right", "forearm_right")
#: The 1-capsule human (paper Fig. 1a): torso with both arms inside the radius.
CAPSULE_NAMES_1 = ("body",)


@dataclass(frozen=True)
class BodyDimensions:
    """A co-worker's dimensions [m]; names follow the paper (d1..d4, l).

    * ``d1_m``: chest point up to shoulder height, vertically.
    * ``d2_m``: half the shoulder width.
    * ``d3_m``: upper arm, shoulder to elbow.
    * ``d4_m``: forearm, elbow to wrist.
    * ``chest_height_m``: ``l``, chest point above the base xy plane (not above the floor).
    * ``torso_below_chest_m`` / ``head_above_chest_m``: the torso+head capsule axis runs
      vertically from ``l - torso_below_chest_m`` to ``l + head_above_chest_m``.
    * ``torso_radius_m``, ``upper_arm_radius_m``, ``forearm_radius_m``: capsule radii.
    """

    d1_m: float = 0.20
    d2_m: float = 0.20
    d3_m: float = 0.30
    d4_m: float = 0.28
    chest_height_m: float = 0.60
    torso_below_chest_m: float = 0.55
    head_above_chest_m: float = 0.25
    torso_radius_m: float = 0.18
    upper_arm_radius_m: float = 0.06
    forearm_radius_m: float = 0.06

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if not np.isfinite(value):
                raise ValueError(f"BodyDimensions.{f.name} must be finite, got {value}")
            if f.name != "chest_height_m" and value < 0.0:
                raise ValueError(f"BodyDimensions.{f.name} must be >= 0, got {value}")

    @property
    def one_capsule_radius_m(self) -> float:
        """Radius of the 1-capsule human [m]: contains every arm pose of an upright torso.

        Every arm point lies within ``d3 + d4`` of a shoulder, each shoulder within ``d2`` of the
        capsule's top axis point (shoulder height), plus the arm radius.
        """
        arm = self.d2_m + self.d3_m + self.d4_m + max(self.upper_arm_radius_m, self.forearm_radius_m)
        return max(self.torso_radius_m, arm)

    def to_dict(self) -> dict:
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}

    @classmethod
    def from_dict(cls, values: dict) -> "BodyDimensions":
        """Raises ``KeyError``/``TypeError`` on missing or unknown keys (callers add context)."""
        names = {f.name for f in fields(cls)}
        unknown = set(values) - names
        if unknown:
            raise TypeError(f"unknown body dimension(s) {sorted(unknown)}")
        missing = names - set(values)
        if missing:
            raise KeyError(f"missing body dimension(s) {sorted(missing)}")
        return cls(**{k: float(v) for k, v in values.items()})


@dataclass(frozen=True)
class HumanCapsules:
    """k capsules of one human, in the robot base frame.

    ``p0_b_m``, ``p1_b_m``: shape (k, 3) [m], capsule axis end points. ``radius_m``: shape (k,)
    [m]. ``names``: k names (``CAPSULE_NAMES_5``, ``CAPSULE_NAMES_1`` or ``()`` when nobody is
    in range). ``stale``: True when a sensor stream is older than its threshold and the model
    was made more conservative; ``reason``: a sentence for the app ("" when all is fresh).
    ``t_s``: the time the capsules describe. ``v0_b_m_s``, ``v1_b_m_s``: shape (k, 3) [m/s],
    the end points' estimated velocities, or None when not estimated (``HumanTracker`` gives
    every end point the tracked torso's velocity while the torso is seen fresh).
    """

    p0_b_m: np.ndarray
    p1_b_m: np.ndarray
    radius_m: np.ndarray
    names: tuple[str, ...]
    t_s: float = 0.0
    stale: bool = False
    reason: str = ""
    ages_s: dict = field(default_factory=dict)
    v0_b_m_s: np.ndarray | None = None
    v1_b_m_s: np.ndarray | None = None

    def __post_init__(self):
        p0 = np.asarray(self.p0_b_m, dtype=float).reshape(-1, 3)
        p1 = np.asarray(self.p1_b_m, dtype=float).reshape(-1, 3)
        radius = np.asarray(self.radius_m, dtype=float).reshape(-1)
        k = len(self.names)
        if p0.shape != (k, 3) or p1.shape != (k, 3) or radius.shape != (k,):
            raise ValueError(
                f"HumanCapsules: {k} names but p0 {p0.shape}, p1 {p1.shape}, radius {radius.shape}"
            )
        if not (np.isfinite(p0).all() and np.isfinite(p1).all() and np.isfinite(radius).all()):
            raise ValueError("HumanCapsules: non-finite end point or radius")
        if (radius < 0).any():
            raise ValueError(f"HumanCapsules: negative radius {radius}")
        object.__setattr__(self, "p0_b_m", p0)
        object.__setattr__(self, "p1_b_m", p1)
        object.__setattr__(self, "radius_m", radius)
        object.__setattr__(self, "names", tuple(self.names))
        if (self.v0_b_m_s is None) != (self.v1_b_m_s is None):
            raise ValueError("HumanCapsules: give both end-point velocities or neither")
        if self.v0_b_m_s is not None:
            v0 = np.asarray(self.v0_b_m_s, dtype=float).reshape(-1, 3)
            v1 = np.asarray(self.v1_b_m_s, dtype=float).reshape(-1, 3)
            if v0.shape != (k, 3) or v1.shape != (k, 3):
                raise ValueError(f"HumanCapsules: {k} names but velocities {v0.shape}, {v1.shape}")
            if not (np.isfinite(v0).all() and np.isfinite(v1).all()):
                raise ValueError("HumanCapsules: non-finite end-point velocity")
            object.__setattr__(self, "v0_b_m_s", v0)
            object.__setattr__(self, "v1_b_m_s", v1)

    def with_velocities(self, v0_b_m_s: np.ndarray, v1_b_m_s: np.ndarray) -> "HumanCapsules":
        """The same capsules with these end-point velocities (k, 3) [m/s]."""
        return replace(self, v0_b_m_s=v0_b_m_s, v1_b_m_s=v1_b_m_s)

    @classmethod
    def trusted(cls, p0_b_m: np.ndarray, p1_b_m: np.ndarray, radius_m: np.ndarray, names: tuple[str, ...],
                t_s: float = 0.0, stale: bool = False, reason: str = "", ages_s: dict | None = None
                ) -> "HumanCapsules":
        """Capsules the pipeline built itself, without re-validation: float64 arrays of shapes
        (k, 3), (k, 3), (k,), finite, radii >= 0, ``names`` a k-tuple. Only for callers that
        have checked that (``human/capsule_kernel.py`` does, in its kernel)."""
        caps = object.__new__(cls)
        for name, value in (("p0_b_m", p0_b_m), ("p1_b_m", p1_b_m), ("radius_m", radius_m), ("names", names),
                            ("t_s", t_s), ("stale", stale), ("reason", reason), ("ages_s", ages_s or {})):
            object.__setattr__(caps, name, value)
        return caps

    @property
    def present(self) -> bool:
        """False when no human is in range (zero capsules)."""
        return len(self.names) > 0

    @classmethod
    def absent(cls, t_s: float = 0.0, reason: str = "", stale: bool = False) -> "HumanCapsules":
        """No human in the monitored range (``stale``: nor can the sensors tell)."""
        return cls(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), (), t_s=t_s, stale=stale, reason=reason)

    def by_name(self, name: str) -> tuple[np.ndarray, np.ndarray, float]:
        """``(p0, p1, radius)`` of the capsule called ``name``."""
        i = self.names.index(name)
        return self.p0_b_m[i], self.p1_b_m[i], float(self.radius_m[i])
