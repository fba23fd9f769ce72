"""A sensed view through a simulated tip depth camera: what the planner knows is the points the camera returned,
noisy and with dropouts, kept as point clouds (mm).

:class:`~snakeplan.world.knowledge.SensedView` reveals a whole obstacle, exactly, once the tip comes within range
of it. A real tip sensor returns depth images. Here the tip carries a depth camera of six faces (a cube map,
:func:`camera_rays`: the views' sensing calls give the tip's position, not its orientation, so it sees every way,
as a ring of cameras or a spinning scanner does) of ``pixels`` x ``pixels`` rays each, reading to ``range_mm``:

- each pixel reads the exact distance to the scene along its ray with Gaussian range noise of ``noise_mm`` and no
  return with probability ``dropout`` (:func:`~snakeplan.world.knowledge.camera_reading`, seeded by ``seed`` and a
  hash of the pose, so a frame is the same wherever it is taken from the same place);
- a frame is taken when the tip senses at least ``spacing_mm`` from the last frame (a camera's frame rate);
- the returns are thinned to one point per ``voxel_mm`` cube already seen (the first return in it kept), and the
  new ones become a :class:`~snakeplan.geometry.primitives.Points` obstacle of balls of ``radius_mm`` (the voxel's
  half diagonal plus twice the noise, by default), merged into one cloud every :data:`MERGE_CHUNKS` chunks.

The known obstacles are the scene's prior ones (exact, as in a sensed view) and these clouds. Compiled roll-outs
sense through the same camera (:class:`~snakeplan.world.knowledge.Sensor`): their own rays are pixels of it, and
their frames go to the view's buffer, read in when the view's obstacles are next asked for. The judge always uses
the whole scene.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from snakeplan import inputs
from snakeplan.geometry.distance import ObstacleSet, workspace
from snakeplan.geometry.primitives import Obstacle, Points
from snakeplan.jit import kernel
from snakeplan.scenes import Scene
from snakeplan.world.knowledge import (
    DEFAULT_SENSOR_RANGE_MM,
    EPS,
    NOISE,
    DROPOUT,
    SEED,
    SPACING,
    Sensor,
    SensingView,
    depth_frame,
)

#: Returns a view's buffer holds between readings at first: a frame of 24 x 24 x 6 pixels returns at most 3,456, a
#: roll-out of the whole 2.1 m SJTU-Snake III takes at most 43 frames (148,608); the finest camera's frame (256
#: pixels a face) returns at most 393,216. A compiled roll-out that returns more (a finer camera, a longer arm)
#: loses the rest: the view warns (:class:`DepthBufferWarning`) and grows its buffer to hold them next time.
BUFFER_POINTS = 400_000
#: Clouds of new returns kept apart before they are merged into one.
MERGE_CHUNKS = 16
#: Stopping tolerance (mm) of the camera's rays.
RAY_EPS_MM = 1e-3


class DepthBufferWarning(UserWarning):
    """A compiled roll-out's depth frames returned more points than the view's buffer held: the rest were lost."""


@dataclass(frozen=True)
class DepthCamera:
    """The tip's depth camera (mm): pixels per face edge (six faces), range, noise, dropout rate, seed, the least
    distance between frames, the voxel its returns are thinned to, and the radius of their balls (None: the
    voxel's half diagonal plus twice the noise)."""

    pixels: int = 24
    range_mm: float = DEFAULT_SENSOR_RANGE_MM
    noise_mm: float = 2.0
    dropout: float = 0.05
    seed: int = 0
    spacing_mm: float = 50.0
    voxel_mm: float = 5.0
    radius_mm: float | None = None

    def __post_init__(self) -> None:
        inputs.integer(self.pixels, "camera.pixels", 1, 256)
        inputs.length(self.range_mm, "camera.range_mm")
        if not (math.isfinite(self.noise_mm) and self.noise_mm >= 0.0):
            raise ValueError(f"camera.noise_mm: must be a finite number >= 0, got {self.noise_mm!r}")
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError(f"camera.dropout: must be in [0, 1), got {self.dropout!r}")
        inputs.integer(self.seed, "camera.seed", 0, 2**53)
        inputs.length(self.spacing_mm, "camera.spacing_mm")
        inputs.length(self.voxel_mm, "camera.voxel_mm")
        if self.radius_mm is not None:
            inputs.length(self.radius_mm, "camera.radius_mm")

    @property
    def radius(self) -> float:
        """The balls' radius (mm)."""
        if self.radius_mm is not None:
            return self.radius_mm
        return 0.5 * math.sqrt(3.0) * self.voxel_mm + 2.0 * self.noise_mm

    def params(self) -> np.ndarray:
        """``Sensor.params`` (:data:`snakeplan.world.knowledge.NOISE` ...)."""
        out = np.zeros(5)
        out[NOISE], out[DROPOUT], out[SEED], out[SPACING], out[EPS] = (self.noise_mm, self.dropout, self.seed,
                                                                       self.spacing_mm, RAY_EPS_MM)
        return out


def camera_rays(pixels: int) -> np.ndarray:
    """Unit rays ``(6 pixels^2, 3)`` through the pixel centres of a cube map: six square faces, one along each
    axis direction, each 90 degrees across."""
    c = (np.arange(pixels) + 0.5) / pixels * 2.0 - 1.0
    a, b = (g.ravel() for g in np.meshgrid(c, c))
    one = np.ones_like(a)
    faces = [np.column_stack(f) for f in ((one, a, b), (-one, a, b), (a, one, b), (a, -one, b), (a, b, one),
                                          (a, b, -one))]
    rays = np.concatenate(faces)
    return np.ascontiguousarray(rays / np.linalg.norm(rays, axis=1)[:, None])


@kernel
def _frames(W, known, range_mm, points, rays, params, hits, state, stats):
    work = workspace(W)
    for i in range(points.shape[0]):
        depth_frame(W, known, range_mm, points[i], rays, params, hits, state, work, stats)


class DepthView(SensingView):
    """Prior obstacles plus the clouds of the tip depth camera's returns (see the module and
    :class:`~snakeplan.world.knowledge.SensingView`; the camera's range is the sensor's); ``buffer_points``: the
    returns its buffer holds at first (default :data:`BUFFER_POINTS`, at least a frame's; the views made from this
    one keep what it grew to)."""

    def __init__(self, scene: Scene, truth: Sequence[Obstacle], camera: DepthCamera = DepthCamera(),
                 prior: Sequence[bool] | None = None, truth_set: ObstacleSet | None = None,
                 seen: tuple[np.ndarray, list] | None = None, buffer_points: int | None = None):
        super().__init__(scene, truth, camera.range_mm, prior, truth_set)
        self.camera = camera
        count = len(self._truth_set)
        self._rays = camera_rays(camera.pixels)
        self._params = camera.params()
        self._all = np.ones(count, dtype=bool)
        self._hits = np.zeros((max(buffer_points or BUFFER_POINTS, len(self._rays)), 3))  # a frame at least
        self._state = np.zeros(5)
        self._keys, self._clouds = (np.zeros(0, dtype=np.int64), []) if seen is None else (seen[0].copy(),
                                                                                           list(seen[1]))
        self._set: ObstacleSet | None = None

    @classmethod
    def of(cls, scene: Scene, camera: DepthCamera = DepthCamera()) -> DepthView:
        """The depth view of ``scene``: its prior obstacles known before the job."""
        return cls(scene, scene.obstacles, camera, scene.prior, scene.obstacle_set)

    @property
    def points(self) -> np.ndarray:
        """Every return kept so far (mm), after reading the buffer."""
        self._read()
        return np.concatenate([c.points for c in self._clouds]) if self._clouds else np.zeros((0, 3))

    def _read(self) -> bool:
        """Take the buffer's returns in: those in a voxel not seen before become a new cloud; True when any
        did."""
        n = int(self._state[0])
        if n == 0:
            return False
        cap = len(self._hits)
        pts = self._hits[:min(n, cap)].copy()
        self._state[0] = 0.0
        if n > cap:
            self._hits = np.zeros((cap << int(math.ceil(math.log2(n / cap))), 3))
            warnings.warn(f"depth camera: {n - cap} of {n} returns since the last reading fell past the buffer of "
                          f"{cap} and were lost; it now holds {len(self._hits)}", DepthBufferWarning, stacklevel=3)
        cells = np.floor(pts / self.camera.voxel_mm).astype(np.int64) + (1 << 20)
        keys = (cells[:, 0] << 42) | (cells[:, 1] << 21) | cells[:, 2]
        keys, first = np.unique(keys, return_index=True)
        new = ~np.isin(keys, self._keys, assume_unique=True)
        if not new.any():
            return False
        self._keys = np.union1d(self._keys, keys[new])
        fresh = Points(pts[np.sort(first[new])], radius_mm=self.camera.radius)
        if len(self._clouds) >= MERGE_CHUNKS:
            merged = np.concatenate([c.points for c in self._clouds] + [fresh.points])
            self._clouds = [Points(merged, radius_mm=self.camera.radius)]
        else:
            self._clouds.append(fresh)
        self._set = None
        return True

    @property
    def obstacle_set(self) -> ObstacleSet:
        """The prior obstacles and the clouds of returns, packed again when new returns came in."""
        self._read()
        if self._set is None:
            prior = [o for o, k in zip(self._truth_set.obstacles, self._prior) if k]
            self._set = ObstacleSet(prior + self._clouds)
        return self._set

    def sense(self, points) -> bool:
        """Frames from ``points (..., 3)`` (each at least the camera's spacing from the last), read in as often as
        the buffer fills, so none is lost; True when a return fell in a voxel not seen before."""
        pts = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 3))
        new = self._read()
        per = len(self._hits) // len(self._rays)
        for start in range(0, len(pts), per):
            _frames(self._truth_set.packed, self._all, self.camera.range_mm, pts[start:start + per], self._rays,
                    self._params, self._hits, self._state, self._truth_set.evaluations)
            new = self._read() or new
        return new

    def sensor(self) -> Sensor:
        return Sensor(self._truth_set.packed, self._all, self.camera.range_mm, self._truth_set.evaluations,
                      self._rays, self._params, self._hits, self._state)

    def over(self, scene: Scene) -> DepthView:
        return DepthView(scene, self._truth_set.obstacles, self.camera, self._prior, self._truth_set,
                         buffer_points=len(self._hits))

    def for_targets(self, targets) -> DepthView:
        self._read()
        view = DepthView(self.scene.with_targets(targets), self._truth_set.obstacles, self.camera, self._prior,
                         self._truth_set, (self._keys, self._clouds), len(self._hits))
        view._state[1:] = self._state[1:]
        return view
