"""What a planner knows of the obstacles: the whole scene, or only what its tip sensor has revealed (mm).

A planner reaches obstacles only through a knowledge view (``Problem.world``): its ``obstacle_set`` is what is known
now, and its ``raycast`` is the range sensor. Two views:

- :class:`FullView`: every obstacle of the scene.
- :class:`SensedView`: the obstacles known before the job (``prior``; the scene's prior obstacles, see
  :attr:`snakeplan.scenes.Scene.discovered`) plus every obstacle that
  came within ``sensor_range_mm`` of a point the tip has visited. A planner reports the points its tip reaches
  with :meth:`SensedView.sense` (rays sense at their origins); the view reveals an obstacle when the exact distance
  from one of those points to it is at most the range. A retry after a failed check re-plans with what has been
  sensed so far; the judge always uses the whole scene.

:func:`guarded` wraps a scene so that reading its obstacles raises :class:`UnsensedObstacleError`: a planner
handed a guarded scene and a sensed view can only plan honestly.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, fields
from enum import StrEnum
from typing import NamedTuple

import numpy as np

from snakeplan.geometry.bvh import box_distance
from snakeplan.geometry.distance import (
    ObstacleSet,
    obstacle_distance,
    ray_into,
    workspace,
)
from snakeplan.geometry.primitives import Obstacle
from snakeplan.jit import kernel, leaf
from snakeplan.scenes import Scene

#: Default range (mm) of the tip sensor for planners that only know what they have sensed.
DEFAULT_SENSOR_RANGE_MM = 400.0


class Knowledge(StrEnum):
    """What a planner may know of a scene: ``full``, every obstacle; ``sensed``, the prior obstacles and what its
    tip sensor has revealed. A ``str`` so that JSON and the command line hold the plain value."""

    FULL = "full"
    SENSED = "sensed"


def as_knowledge(value, field: str = "knowledge") -> Knowledge:
    """``value`` (a :class:`Knowledge` or its plain value) as Knowledge; ValueError naming ``field`` otherwise."""
    try:
        return Knowledge(value)
    except ValueError:
        raise ValueError(f"{field}: must be 'full' or 'sensed', got {value!r}") from None


class UnsensedObstacleError(RuntimeError):
    """A planner read an obstacle it has not sensed."""


class Sensor(NamedTuple):
    """What a compiled roll-out senses with: the packed obstacles (:attr:`ObstacleSet.packed`), one flag per
    obstacle, True once known (updated in place by :func:`sense_at`), the sensor's range (mm; inf: no limit) and
    the evaluation counter of the packed set. A depth camera (:class:`snakeplan.world.depth.DepthView`) adds its
    frame's unit rays ``(m, 3)`` (none: no camera), its ``params`` (:func:`depth_frame`), the buffer its frames'
    returns go to (``hits (cap, 3)``, mm) and its ``state`` (returns so far, those past ``cap`` included, the last
    frame's position, whether there was one), both updated in place."""

    packed: tuple
    known: np.ndarray
    range_mm: float
    stats: np.ndarray
    frame_rays: np.ndarray = np.zeros((0, 3))
    params: np.ndarray = np.zeros(5)
    hits: np.ndarray = np.zeros((0, 3))
    state: np.ndarray = np.zeros(5)


#: ``Sensor.params`` of a depth camera: range noise (mm, standard deviation), the chance a pixel has no return,
#: the seed of both, the least distance (mm) between frames, and a ray's stopping tolerance (mm).
NOISE, DROPOUT, SEED, SPACING, EPS = range(5)


@leaf
def _uniform(x, y, z, i, seed, k):
    """A number in (0, 1) that depends on a position (to 1 um), an index, a seed and a draw ``k`` alone:
    splitmix64 of their bits, so a camera's noise is the same wherever the same frame is taken (compiled or from
    Python) and needs no random state."""
    h = np.uint64(seed) ^ np.uint64(0x9E3779B97F4A7C15)
    for v in (np.int64(round(x * 1000.0)), np.int64(round(y * 1000.0)), np.int64(round(z * 1000.0)), np.int64(i),
              np.int64(k)):
        h = (h ^ np.uint64(v)) * np.uint64(0xBF58476D1CE4E5B9)
        h ^= h >> np.uint64(31)
        h *= np.uint64(0x94D049BB133111EB)
        h ^= h >> np.uint64(29)
    return (float(h >> np.uint64(11)) + 0.5) / 9007199254740992.0


@leaf
def camera_reading(t, origin, i, params):
    """What a depth camera's pixel ``i`` reads (mm) for an exact range ``t`` from ``origin``: no return (inf) with
    probability ``params[DROPOUT]``, else ``t`` plus Gaussian noise of ``params[NOISE]`` (Box-Muller), never
    negative; inf stays inf."""
    if _uniform(origin[0], origin[1], origin[2], i, params[SEED], 0) < params[DROPOUT] or t == np.inf:
        return np.inf
    u1 = _uniform(origin[0], origin[1], origin[2], i, params[SEED], 1)
    u2 = _uniform(origin[0], origin[1], origin[2], i, params[SEED], 2)
    return max(t + params[NOISE] * math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2), 0.0)


@leaf
def depth_frame(W, known, range_mm, origin, rays, params, hits, state, work, stats) -> None:
    """One depth frame from ``origin``, unless one was taken within ``params[SPACING]`` of it: every ray of
    ``rays`` read (:func:`camera_reading`) against the obstacles flagged in ``known``, each return within range
    written to ``hits`` while there is room and counted in ``state[0]`` (past the room too, so the reader knows how
    many were lost); ``state[1:4]`` the frame's position."""
    if rays.shape[0] == 0:
        return
    if state[4] > 0.0:
        gap = math.sqrt((origin[0] - state[1]) ** 2 + (origin[1] - state[2]) ** 2 + (origin[2] - state[3]) ** 2)
        if gap < params[SPACING]:
            return
    state[1], state[2], state[3], state[4] = origin[0], origin[1], origin[2], 1.0
    for i in range(rays.shape[0]):
        t = camera_reading(ray_into(W, known, origin, rays[i], range_mm, params[EPS], work, stats), origin, i, params)
        c = int(state[0])
        if t <= range_mm:
            if c < hits.shape[0]:
                for a in range(3):
                    hits[c, a] = origin[a] + t * rays[i, a]
            state[0] = c + 1


@leaf
def sense_at(W, known, range_mm, p, walk) -> bool:
    """Reveal every unknown obstacle whose exact distance from ``p`` is at most ``range_mm``; True when one was."""
    new = False
    for k in range(known.shape[0]):
        if known[k] or box_distance(W[1][k], p) > range_mm:
            continue
        if obstacle_distance(W, k, p, walk) <= range_mm:
            known[k] = True
            new = True
    return new


@leaf
def sensor_rays(W, known, range_mm, origin, dirs, max_dist, eps, out, work, stats, frame_rays, params, hits,
                state) -> None:
    """The range sensor at ``origin``: it senses there (:func:`sense_at`), then reads into ``out`` the distance
    (mm) along each unit direction of ``dirs`` to the first known surface, inf when none within ``max_dist`` or
    the sensor's range. With a depth camera (``frame_rays``, :class:`Sensor`), ``dirs`` are pixels of it, read
    with its noise and dropouts, and it takes a frame there (:func:`depth_frame`)."""
    sense_at(W, known, range_mm, origin, work[2])
    reach = min(max_dist, range_mm)
    camera = frame_rays.shape[0] > 0
    for i in range(dirs.shape[0]):
        out[i] = ray_into(W, known, origin, dirs[i], reach, eps, work, stats)
        if camera:
            out[i] = camera_reading(out[i], origin, frame_rays.shape[0] + i, params)
    depth_frame(W, known, range_mm, origin, frame_rays, params, hits, state, work, stats)


@kernel
def _sense_points(W, known, range_mm, points) -> bool:
    walk = workspace(W)[2]
    new = False
    for i in range(points.shape[0]):
        new |= sense_at(W, known, range_mm, points[i], walk)
    return new


class KnowledgeView(ABC):
    """The obstacles a planner may use, with the scene's structure (bounds, entrance, targets)."""

    kind: str = ""

    def __init__(self, scene: Scene):
        self.scene = scene

    @property
    @abstractmethod
    def obstacle_set(self) -> ObstacleSet:
        """The obstacles known now."""

    def sense(self, points) -> bool:
        """Reveal what the tip sensor sees from ``points (..., 3)``; True when something new became known."""
        return False

    def raycast(self, origins, directions, max_distance: float, eps: float = 1e-3) -> np.ndarray:
        """Range readings (mm, inf for none within ``max_distance``) from ``origins`` along unit ``directions``."""
        self.sense(origins)
        return self.obstacle_set.raycast(origins, directions, max_distance, eps)

    def in_bounds(self, points, margin: float = 0.0) -> np.ndarray:
        return self.scene.in_bounds(points, margin)

    @abstractmethod
    def sensor(self) -> Sensor:
        """The view's :class:`Sensor`, for compiled roll-outs (what they reveal is known to the view)."""

    @abstractmethod
    def fresh(self) -> KnowledgeView:
        """The same view before anything was sensed (every plan starts from one)."""

    @abstractmethod
    def over(self, scene: Scene) -> KnowledgeView:
        """This view, fresh, over another structure of the same obstacles (a search's scene with its targets
        hidden)."""

    @abstractmethod
    def for_targets(self, targets) -> KnowledgeView:
        """A view of the same structure with other ``targets`` (k, 3) mm that knows, before anything is sensed, what
        this view knows now: a sub-problem's (a branch of a mission, a reach to a target found), which starts from
        what the mission has sensed so far."""


class FullView(KnowledgeView):
    """Every obstacle of the scene."""

    kind = Knowledge.FULL

    def __init__(self, scene: Scene, obstacles: ObstacleSet | None = None):
        super().__init__(scene)
        self._set = scene.obstacle_set if obstacles is None else obstacles
        self._sensor = Sensor(self._set.packed, np.ones(len(self._set), dtype=bool), np.inf, self._set.evaluations)

    @property
    def obstacle_set(self) -> ObstacleSet:
        return self._set

    def sensor(self) -> Sensor:
        return self._sensor

    def fresh(self) -> FullView:
        return self

    def over(self, scene: Scene) -> FullView:
        return FullView(scene, self._set)

    def for_targets(self, targets) -> FullView:
        return FullView(self.scene.with_targets(targets), self._set)


def prior_flags(prior: Sequence[bool] | None, count: int) -> np.ndarray:
    """One flag per obstacle of a sensed view's truth, True where it is known before the job (``prior``; None:
    none); ValueError naming ``prior`` for the wrong count."""
    flags = np.zeros(count, dtype=bool) if prior is None else np.array(prior, dtype=bool)
    if flags.shape != (count,):
        raise ValueError(f"prior: expected {count} flags, got {flags.shape}")
    return flags


class SensingView(KnowledgeView):
    """What a planner knows of a scene as the tip senses it: the prior obstacles plus what the tip's sensor, which
    sees no further than ``sensor_range_mm``, has revealed. ``truth`` is the scene's obstacle list (read here,
    never handed to the planner); ``prior`` marks the ones known before the job (default: none). The view's
    ``scene`` is the structure alone (:func:`guarded`)."""

    kind = Knowledge.SENSED

    def __init__(self, scene: Scene, truth: Sequence[Obstacle], sensor_range_mm: float,
                 prior: Sequence[bool] | None = None, truth_set: ObstacleSet | None = None):
        super().__init__(scene if isinstance(scene, GuardedScene) else guarded(scene))  # structure only
        self._truth_set = ObstacleSet(truth) if truth_set is None else truth_set
        self.sensor_range_mm = float(sensor_range_mm)
        self._prior = prior_flags(prior, len(self._truth_set))

    def raycast(self, origins, directions, max_distance: float, eps: float = 1e-3) -> np.ndarray:
        """Readings of the tip's sensor: it sees no further than its range."""
        return super().raycast(origins, directions, min(float(max_distance), self.sensor_range_mm), eps)

    def fresh(self) -> SensingView:
        return self.over(self.scene)


class SensedView(SensingView):
    """Prior obstacles plus those revealed, whole and exact, within ``sensor_range_mm`` of the points the tip has
    visited (see :class:`SensingView`)."""

    def __init__(self, scene: Scene, truth: Sequence[Obstacle], sensor_range_mm: float = DEFAULT_SENSOR_RANGE_MM,
                 prior: Sequence[bool] | None = None, truth_set: ObstacleSet | None = None):
        super().__init__(scene, truth, sensor_range_mm, prior, truth_set)
        self.known = self._prior.copy()
        self._set: ObstacleSet | None = None
        self._set_of = self.known.copy()

    @classmethod
    def of(cls, scene: Scene, sensor_range_mm: float = DEFAULT_SENSOR_RANGE_MM, prior: bool = True) -> SensedView:
        """The sensed view of ``scene``: its prior obstacles known before the job (none with ``prior=False``)."""
        return cls(scene, scene.obstacles, sensor_range_mm, scene.prior if prior else None, scene.obstacle_set)

    @property
    def obstacle_set(self) -> ObstacleSet:
        """The known obstacles, packed again whenever more are known than when last packed."""
        if self._set is None or not np.array_equal(self._set_of, self.known):
            self._set = self._truth_set.subset(self.known)
            self._set_of = self.known.copy()
        return self._set

    def sense(self, points) -> bool:
        if self.known.all():
            return False
        pts = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 3))
        return bool(_sense_points(self._truth_set.packed, self.known, self.sensor_range_mm, pts))

    def sensor(self) -> Sensor:
        return Sensor(self._truth_set.packed, self.known, self.sensor_range_mm, self._truth_set.evaluations)

    def over(self, scene: Scene) -> SensedView:
        return SensedView(scene, self._truth_set.obstacles, self.sensor_range_mm, self._prior, self._truth_set)

    def for_targets(self, targets) -> SensedView:
        return SensedView(self.scene.with_targets(targets), self._truth_set.obstacles, self.sensor_range_mm,
                          self.known.copy(), self._truth_set)


def view_for(scene: Scene, knowledge: Knowledge | str, sensor_range_mm: float = DEFAULT_SENSOR_RANGE_MM
             ) -> KnowledgeView:
    """The view a ``knowledge`` mode gives of ``scene``."""
    if as_knowledge(knowledge) is Knowledge.FULL:
        return FullView(scene)
    return SensedView.of(scene, sensor_range_mm)


@dataclass(frozen=True, eq=False)
class GuardedScene(Scene):
    """A scene whose obstacles cannot be read (see :func:`guarded`)."""

    def __getattribute__(self, name: str):
        if name in _OBSTACLE_READS:
            raise UnsensedObstacleError(f"scene.{name}: a planner with sensed knowledge read the whole scene's "
                                        f"obstacles instead of its knowledge view")
        return super().__getattribute__(name)

    def with_targets(self, targets) -> Scene:
        """The structure with other ``targets`` (k, 3) mm, its obstacles still unreadable."""
        return guarded(self, GuardedScene, targets=np.asarray(targets, dtype=float).reshape(-1, 3))


_OBSTACLE_READS = frozenset({"obstacles", "obstacle_set", "signed_distance", "chain_clearance", "chain_collides",
                             "line_of_sight"})


#: The fields of a scene's structure: what a guarded scene keeps (every field but its obstacles).
STRUCTURE = tuple(f.name for f in fields(Scene) if f.name != "obstacles")


def guarded(scene: Scene, kind: type[Scene] | None = None, **replaced) -> Scene:
    """``scene`` with its structure (bounds, entrance, targets, metadata, what to inspect) but obstacles that raise
    when read; ``replaced`` replaces parts of the structure (``targets=``); ``kind``: a subclass of the guarded
    scene."""
    g = object.__new__(kind or GuardedScene)
    for f in STRUCTURE:
        object.__setattr__(g, f, replaced[f] if f in replaced else object.__getattribute__(scene, f))
    object.__setattr__(g, "obstacles", ())
    return g
