"""Scene generators' parameters, checked: a number within a range (one ValueError that names the parameter), the
reach parameters of the room-scale generators, and the default reach fraction."""

from __future__ import annotations

import math

import numpy as np

#: Targets are accepted when their geodesic distance is at most this fraction of the arm length.
DEFAULT_REACH_FRACTION = 0.85


def check_range(name: str, value, low: float | None = None, high: float | None = None,
                integer: bool = False) -> float:
    """Validate a generator parameter (a finite number in [low, high]); ValueError names it."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: expected a number, got {value!r}")
    if integer and int(value) != value:
        raise ValueError(f"{name}: expected an integer, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or (low is not None and v < low) or (high is not None and v > high):
        raise ValueError(f"{name}: must lie in [{low}, {high}], got {value!r}")
    return v


def tank_parameters(arm_length_mm, reach_fraction, inflate_mm, cell_mm) -> tuple[float, float, float, float]:
    """The reach parameters a room-scale generator takes (fuel-tank, oil-tank, confined), checked: arm length
    (mm, >= 1), reach fraction (0.1-1), inflation (0-100 mm), reach grid cell (5-50 mm)."""
    return (check_range("arm_length_mm", arm_length_mm, 1.0), check_range("reach_fraction", reach_fraction, 0.1, 1.0),
            check_range("inflate_mm", inflate_mm, 0.0, 100.0), check_range("cell_mm", cell_mm, 5.0, 50.0))
