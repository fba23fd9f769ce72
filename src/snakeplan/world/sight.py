"""What the tip camera sees of a scene's points of interest (mm, rad).

A point of interest is seen from a view when it is in the camera's field of view, within its range, seen at most
the largest incidence off its surface's normal line (either side: :mod:`snakeplan.geometry.surface_points`), and
nothing hides it: an exact ray cast from the camera towards it through the scene's obstacles
(:meth:`snakeplan.geometry.distance.ObstacleSet.raycast`: closed meshes hit exactly, primitives and shells
sphere-traced to :data:`RAY_EPS_MM`) meets no surface before it. The ray may stop up to :data:`OCCLUSION_MM`
short of the point (besides how deep the point lies in its own shell), the point's own surface.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.surface_points import SurfacePoints
from snakeplan.mapping.camera import Sightings, in_view
from snakeplan.mapping.models import CameraModel

#: How far (mm) short of a point of interest the ray may meet a surface and the point still count as seen.
OCCLUSION_MM = 1.0
#: Sphere tracing stops this close (mm) to a primitive's surface.
RAY_EPS_MM = 1e-3


class PoiCamera:
    """The camera model bound to a scene's obstacles (what hides) and its points of interest (what is seen)."""

    def __init__(self, obstacles: ObstacleSet, pois: SurfacePoints, model: CameraModel) -> None:
        self.obstacles = obstacles
        self.pois = pois
        self.model = model

    def visible(self, positions: ArrayLike, directions: ArrayLike) -> Sightings:
        """Sightings (pose, point, distance mm) from cameras at ``positions`` (k, 3) looking along ``directions``
        (k, 3), pose by pose and in point order."""
        s = in_view(self.pois.points, self.pois.normals, positions, directions, self.model, two_sided=True)
        if s.node.size == 0:
            return s
        c = np.asarray(positions, dtype=float).reshape(-1, 3)[s.pose]
        u = (self.pois.points[s.node] - c) / np.maximum(s.distance, 1e-300)[:, None]
        hit = self.obstacles.raycast(c, u, max_distance=float(s.distance.max()) + 1.0, eps=RAY_EPS_MM)
        clear = hit >= s.distance - self.pois.depth[s.node] - OCCLUSION_MM
        return Sightings(s.pose[clear], s.node[clear], s.distance[clear])

    def measure(self, position: ArrayLike, direction: ArrayLike, truth: ArrayLike, rng: np.random.Generator
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A simulated measurement of a field from one view: (points seen, noisy values K, noise variances K^2),
        the camera model's noise at each point's distance, drawn from ``rng``."""
        s = self.visible(np.reshape(position, (1, 3)), np.reshape(direction, (1, 3)))
        r = self.model.noise_variance(s.distance)
        return s.node, np.asarray(truth, dtype=float)[s.node] + rng.normal(0.0, np.sqrt(r)), r

    def first_seen(self, times_s: ArrayLike, positions: ArrayLike, directions: ArrayLike) -> np.ndarray:
        """The mission time (s) at which views at ``times_s`` (k,) first see each point of interest (n,); inf for a
        point no view sees."""
        sight = self.visible(positions, directions)
        first = np.full(len(self.pois), np.inf)
        np.minimum.at(first, sight.node, np.asarray(times_s, dtype=float)[sight.pose])
        return first

    def seen(self, positions: ArrayLike, directions: ArrayLike) -> np.ndarray:
        """Which points of interest (n,) bool any of the views sees."""
        out = np.zeros(len(self.pois), dtype=bool)
        out[self.visible(positions, directions).node] = True
        return out
