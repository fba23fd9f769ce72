"""The sensor's and the map's model parameters (paper 002, §3.1): the camera's field of view, range, incidence limit
and noise, and the surface map's default prior; plain numbers, so that the world and the judge state them without
loading the mapping machinery (mm, rad, K).

Defaults for a 12 m x 20 m station seen from a few metres: a 60 deg lens (30 deg half-angle, a common thermal
camera), 0.5-8 m working range (closer than 0.5 m the arm risks touching the skin, beyond 8 m a pixel covers
more than a mesh triangle), and 60 deg maximum incidence (beyond it the emissivity of a metal skin falls
quickly, so a thermal reading is no longer trusted). The noise is a (1 - exp(-b d)), d in metres (Popovic et al.'s
model, the pair of paper 002).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

#: Prior standard deviation of the field (K): the RMS deviation of station fields (seeds 100-119, not the bench
#: seeds) from their base temperature. Matérn length scale (mm): the best hold-out RMSE among 2-5 m on those
#: seeds (posterior from 10 % and 30 % of the nodes).
DEFAULT_SIGMA_F = 23.5
DEFAULT_LENGTH_SCALE_MM = 3500.0

#: Half-angle (rad) of the circular field of view.
FOV_HALF_ANGLE_RAD = math.radians(30.0)
#: Working range (mm).
D_MIN_MM = 500.0
D_MAX_MM = 8000.0
#: Largest incidence angle (rad) between a node's normal and its line of sight.
INCIDENCE_MAX_RAD = math.radians(60.0)
#: Noise model: variance NOISE_A (K^2) * (1 - exp(-NOISE_B (1/m) * d (m))).
NOISE_A = 0.04
NOISE_B_PER_M = 0.15


@dataclass(frozen=True)
class CameraModel:
    """Field of view (rad), range (mm), largest incidence (rad) and noise pair (K^2, 1/m)."""

    fov_half_angle: float = FOV_HALF_ANGLE_RAD
    d_min: float = D_MIN_MM
    d_max: float = D_MAX_MM
    incidence_max: float = INCIDENCE_MAX_RAD
    noise_a: float = NOISE_A
    noise_b: float = NOISE_B_PER_M

    def noise_variance(self, distance_mm: ArrayLike) -> np.ndarray:
        """Measurement variance (K^2) at camera-to-node distance ``distance_mm``."""
        return self.noise_a * (1.0 - np.exp(-self.noise_b * np.asarray(distance_mm, dtype=float) / 1000.0))
