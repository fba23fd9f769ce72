"""What a station mission needs that depends on the station and the arm but not on the field: the surface map's
prior, the camera bound to the surface, the distance field round it, the arm on its carriage and the viewpoint
library (mm, K), built once per station, arm and settings in a process.

The planners' cheap feasibility tests of a camera path live here: the camera keeps KEEP_OUT_MM from the skin
(eq. 16's r) and stays within REACH_RADIUS_MM of a viewpoint the arm holds. They only steer the planners: what is
flown is what the arm follows (:meth:`snakeplan.planners.inspection.arm.StationArm.follow`), and the judge checks
that.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from snakeplan.mapping import SurfaceCamera, SurfacePrior, kalman, surface_prior
from snakeplan.mapping.field import DistanceField
from snakeplan.planners.inspection.arm import StationArm
from snakeplan.planners.inspection.camera_path import CHECK_STEP_MM, CameraPath
from snakeplan.planners.inspection.library import VIEW_STANDOFF_MM, ViewpointLibrary, library_positions
from snakeplan.scenes.station import StationFrame
from snakeplan.world import PLANNING, FullView, ValidityChecker
from snakeplan.world.mission import InspectionSettings, inspected_surface

#: Keep-out distance (mm) of the camera from the skin: eq. 16's r.
KEEP_OUT_MM = 1500.0
#: Camera positions farther than this (mm) from every viewpoint the arm holds count as out of its reach.
REACH_RADIUS_MM = 2500.0


@dataclass
class Survey:
    """The station's frame, the map's prior, the camera, the distance field, the arm (``reach``) and the library."""

    frame: StationFrame
    prior: SurfacePrior
    camera: SurfaceCamera
    field: DistanceField
    reach: StationArm
    library: ViewpointLibrary
    build_time_s: float
    _reachable_tree: cKDTree | None = None

    def home(self) -> np.ndarray:
        """Where every mission starts: VIEW_STANDOFF_MM straight out of the entrance."""
        return self.frame.home(VIEW_STANDOFF_MM)

    def look(self, points: ArrayLike) -> np.ndarray:
        """Camera directions at positions (..., 3): at the closest point of the station."""
        return self.field.look_direction(points)

    def within_reach(self, points: ArrayLike) -> np.ndarray:
        """True where a point is within REACH_RADIUS_MM of a viewpoint the arm holds."""
        if self._reachable_tree is None:
            self._reachable_tree = cKDTree(self.library.positions[self.library.reachable])
        # the search stops at the radius (points farther from every viewpoint come back inf)
        d, _ = self._reachable_tree.query(np.asarray(points, dtype=float).reshape(-1, 3),
                                          distance_upper_bound=REACH_RADIUS_MM + 1.0)
        return (d <= REACH_RADIUS_MM).reshape(np.shape(points)[:-1])

    def clear(self, points: ArrayLike) -> np.ndarray:
        """True where a point keeps KEEP_OUT_MM from the skin (eq. 16)."""
        return self.field.distance(points) >= KEEP_OUT_MM

    def feasible(self, path: CameraPath) -> bool:
        """Clear of the skin and within reach along the whole camera path."""
        s = path.samples()
        return bool(np.all(self.clear(s)) and np.all(self.within_reach(s)))

    def segment_ok(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """For a point ``a`` (3,) and candidates ``b`` (k, 3): the straight segments are feasible."""
        n = max(2, math.ceil(np.max(np.linalg.norm(b - a, axis=1), initial=0.0) / CHECK_STEP_MM) + 1)
        t = np.linspace(0.0, 1.0, n)
        pts = a + t[None, :, None] * (b - a)[:, None, :]
        return np.all(self.clear(pts) & self.within_reach(pts), axis=1)


_SURVEYS: dict[tuple, Survey] = {}


def survey_for(scene, robot, settings: InspectionSettings) -> Survey:
    """The survey of a station scene (cached within the process by obstacles, arm, entrance, camera and prior).
    The station mesh is the surface measured and the only occluder of the camera."""
    mesh, _ = inspected_surface(scene)
    prior_mean = settings.prior_mean(scene.metadata)
    geometry = json.dumps([[o.to_dict() for o in scene.obstacles], robot.to_dict(), scene.entrance.position.tolist()],
                          sort_keys=True)
    key = (hashlib.sha1(geometry.encode()).hexdigest(), settings.camera, float(settings.sigma_f),
           float(settings.length_scale), prior_mean)
    if key not in _SURVEYS:
        t0 = time.perf_counter()
        frame = StationFrame.from_scene(scene)
        prior = surface_prior(mesh.vertices, mesh.faces, prior_mean, settings.sigma_f, settings.length_scale)
        cam = SurfaceCamera(mesh.vertices, mesh.faces, settings.camera)
        dfield = DistanceField(mesh.vertices, mesh.faces)
        arm = StationArm(robot, frame, ValidityChecker(FullView(scene), robot, PLANNING))
        pos = library_positions(frame)
        dirs = dfield.look_direction(pos)
        ok = arm.check(pos).ok
        sight = cam.visible(pos, dirs)
        seen, noise = [], []
        for k in range(len(pos)):
            nodes, dist = sight.of_pose(k)
            seen.append(nodes)
            noise.append(settings.camera.noise_variance(dist))
        lib = ViewpointLibrary(pos, dirs, ok, tuple(seen), tuple(noise))
        kalman.warm_up()  # the planners' gain kernels, before any mission's clock
        _SURVEYS[key] = Survey(frame, prior, cam, dfield, arm, lib, time.perf_counter() - t0)
    return _SURVEYS[key]
