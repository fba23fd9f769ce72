"""The viewpoint library of a station mission: candidate camera positions on a shell VIEW_STANDOFF_MM off the
skin, with what each sees and whether the arm holds it (mm).

A (azimuth, height) grid beside the side, 45 deg viewpoints over both rims, rings over both end caps. Every mission
starts at the home viewpoint, VIEW_STANDOFF_MM straight out of the entrance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from snakeplan.scenes.station import StationFrame

#: Stand-off (mm) of the viewpoint library from the skin.
VIEW_STANDOFF_MM = 4000.0
#: Library grid beside the side: azimuth steps, height step (mm); rim viewpoints per rim; cap rings (radius
#: mm, count) over each end cap (the centre included as radius 0).
SIDE_AZIMUTHS = 24
SIDE_HEIGHT_STEP_MM = 2000.0
RIM_AZIMUTHS = 24
CAP_RINGS = ((0.0, 1), (2500.0, 8), (5000.0, 16))


@dataclass(frozen=True)
class ViewpointLibrary:
    """Candidate camera poses: positions (k, 3) mm, view directions (k, 3), reachability, and what each sees
    (node indices and noise variances per viewpoint)."""

    positions: np.ndarray
    directions: np.ndarray
    reachable: np.ndarray
    seen: tuple[np.ndarray, ...]
    noise: tuple[np.ndarray, ...]

    def __len__(self) -> int:
        return len(self.positions)


def library_positions(frame: StationFrame, standoff: float = VIEW_STANDOFF_MM) -> np.ndarray:
    """Viewpoint positions (mm): side grid, 45 deg rim viewpoints, cap rings (see the module constants)."""
    f = frame
    pts = []
    th = np.arange(SIDE_AZIMUTHS) * 2 * math.pi / SIDE_AZIMUTHS
    for z in np.arange(0.0, f.height + 1e-9, SIDE_HEIGHT_STEP_MM):
        pts.append(f.point(f.radius + standoff, th, z))
    th_r = (np.arange(RIM_AZIMUTHS) + 0.5) * 2 * math.pi / RIM_AZIMUTHS
    d = standoff / math.sqrt(2.0)
    for z in (-d, f.height + d):
        pts.append(f.point(f.radius + d, th_r, z))
    for z in (-standoff, f.height + standoff):
        for r, count in CAP_RINGS:
            t = (np.arange(count) + 0.5) * 2 * math.pi / count
            pts.append(f.point(r, t, z))
    return np.concatenate(pts)
