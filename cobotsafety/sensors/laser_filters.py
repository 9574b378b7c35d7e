"""Paper 2's laser filters (section 2.1.2-2.1.3).

* ``TimeFilter``: eq. 1, ``r_t = alpha r_measured + (1 - alpha) r_{t-dt}`` per beam. The paper
  calls it FIR; it is a first-order exponential (IIR) filter (erratum 8).
* ``moving_average``: eq. 2 along the scan angle, centred (the paper's running form lags by
  n/2 beams, which would shift every leg by half the window).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import uniform_filter1d


def clipped_ranges(ranges: np.ndarray, valid: np.ndarray, max_range_m: float) -> np.ndarray:
    """Ranges clipped to ``max_range_m`` [m]; no-return beams read as ``max_range_m``."""
    return np.where(valid, np.minimum(ranges, max_range_m), max_range_m)


@dataclass
class TimeFilter:
    """Eq. 1 per beam. ``alpha`` in (0, 1]: 1 = no filtering."""

    alpha: float = 0.6
    _state: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        if not 0.0 < self.alpha <= 1.0:
            raise ValueError(f"alpha must be in (0, 1], got {self.alpha}")

    def update(self, ranges_m: np.ndarray) -> np.ndarray:
        ranges_m = np.asarray(ranges_m, dtype=float)
        if self._state is None or self._state.shape != ranges_m.shape:
            self._state = ranges_m.copy()
        else:
            self._state = self.alpha * ranges_m + (1.0 - self.alpha) * self._state
        return self._state.copy()

    def reset(self) -> None:
        self._state = None


def moving_average(ranges_m: np.ndarray, n_beams: int = 3) -> np.ndarray:
    """Eq. 2: mean over ``n_beams`` neighbouring beams (centred; edges repeat the end beam)."""
    if n_beams <= 1:
        return np.asarray(ranges_m, dtype=float).copy()
    return uniform_filter1d(np.asarray(ranges_m, dtype=float), size=int(n_beams), mode="nearest")
