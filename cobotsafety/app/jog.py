"""On-screen jog buttons: a label such as ``"+x"`` -> a velocity along that base axis."""

from __future__ import annotations

import numpy as np

from cobotsafety.errors import CobotSafetyError

AXES = {"x": 0, "y": 1, "z": 2}


def jog_velocity(label: str, speed_m_s: float, dim: int) -> np.ndarray:
    """Shape (dim,) velocity [m/s] for ``label`` (``"+x"``, ``"-y"``, ...)."""
    if len(label) != 2 or label[0] not in "+-" or label[1] not in AXES or AXES[label[1]] >= dim:
        raise CobotSafetyError(f"jog label must be +/- followed by one of {'xyz'[:dim]}, got {label!r}")
    v = np.zeros(dim)
    v[AXES[label[1]]] = speed_m_s if label[0] == "+" else -speed_m_s
    return v
