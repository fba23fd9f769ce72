"""An inspect task's settings and a mission's record: the arm's motions, in a form the judge replays, and the
views taken (mm, rad, s).

A mission is what an inspection planner hands the judge instead of a bare tip path. Its motions are the arm's
own: a :class:`JointMotion` holds the base pose (a carriage on rails, a fixed mount) and the joint vector at
sample times, and between two samples every joint and the base move linearly (the base's rotation along the
shortest arc); a :class:`Crawl` is a fed arm inserted along a tip path from the entrance to a depth and retracted
back along it, the follow-the-leader states of reaching. Its views are camera poses at times; the camera rides
the tip, so each view's position must be where the motion puts the tip at that time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from numpy.typing import ArrayLike

from snakeplan import ftl
from snakeplan.geometry.polyline import cumulative_length, point_at, validate_path
from snakeplan.geometry.primitives import Mesh
from snakeplan.mapping.models import DEFAULT_LENGTH_SCALE_MM, DEFAULT_SIGMA_F, CameraModel
from snakeplan.robots import Chain
from snakeplan.scenes import Scene
from snakeplan.world.joint_motion import arm_bodies, interpolate

#: Motion budget of a mission (s), paper 002 §4.
BUDGET_S = 130.0
#: Constant camera (tip) speed (mm/s).
CAMERA_SPEED_MM_S = 1000.0
#: Measurement frequency (Hz).
MEASUREMENT_HZ = 0.5


def _positive(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name}: must be a positive number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class InspectionSettings:
    """How an inspect task is flown and measured: the mission's flight budget (s), the camera's speed (mm/s), the
    measurement frequency (Hz; None: a tip camera that views when the planner stops to look), the camera model, and
    the surface map's prior (Matérn 3/2 amplitude K and length scale mm, constant mean K; None takes the scene's
    nominal temperature, what an operator knows beforehand)."""

    budget_s: float = BUDGET_S
    speed_mm_s: float = CAMERA_SPEED_MM_S
    measurement_hz: float | None = MEASUREMENT_HZ
    camera: CameraModel = field(default_factory=CameraModel)
    sigma_f: float = DEFAULT_SIGMA_F
    length_scale: float = DEFAULT_LENGTH_SCALE_MM
    prior_mean_k: float | None = None

    def __post_init__(self) -> None:
        for name in ("budget_s", "speed_mm_s", "sigma_f", "length_scale"):
            _positive(name, getattr(self, name))
        if self.measurement_hz is not None:
            _positive("measurement_hz", self.measurement_hz)

    @property
    def tip_camera(self) -> bool:
        """Whether views are the tip camera's own, taken when the planner stops to look (no measurement clock),
        looking along the tip: a fed arm's inspection of points of interest."""
        return self.measurement_hz is None

    def ticks(self) -> np.ndarray:
        """Measurement times (s) of the mission clock: 0, 1/f, 2/f, ... up to the budget (none without a clock)."""
        if self.measurement_hz is None:
            return np.zeros(0)
        return np.arange(math.floor(self.budget_s * self.measurement_hz + 1e-9) + 1) / self.measurement_hz

    def prior_mean(self, metadata: dict) -> float:
        """The map's prior mean (K): the setting, else the scene's base temperature, else 0."""
        if self.prior_mean_k is not None:
            return float(self.prior_mean_k)
        return float(metadata.get("parameters", {}).get("base_temperature_k", 0.0))

    def to_dict(self) -> dict:
        return {"budget_s": self.budget_s, "camera_speed_mm_s": self.speed_mm_s,
                "measurement_hz": self.measurement_hz, "sigma_f_k": self.sigma_f,
                "length_scale_mm": self.length_scale, "prior_mean_k": self.prior_mean_k,
                "camera": self.camera.to_dict()}


#: Mission time (s) of a fed arm's inspection when the scene's ``inspect`` block names none: half an hour.
FED_BUDGET_S = 1800.0
#: A fed arm's map prior: amplitude (K) and Matérn length scale (mm), chosen for the seeded hot spots
#: (:func:`snakeplan.scenes.inspect.with_hot_spots`: 15-40 K, 100-250 mm wide) on a tank's walls.
FED_SIGMA_F_K = 20.0
FED_LENGTH_SCALE_MM = 200.0


def default_settings(scene: Scene, robot=None) -> InspectionSettings:
    """The settings an inspect task in ``scene`` is flown under when the problem names none: paper 002's for a
    surface field (the station); else the tip camera of ``robot`` (a :class:`snakeplan.robots.Chain`) at its feed
    speed, views when the planner stops to look, within the scene's ``inspect.budget_s``."""
    if measures_field(scene) or robot is None:
        return InspectionSettings()
    spec = scene.inspect
    budget = FED_BUDGET_S if spec is None or spec.budget_s is None else spec.budget_s
    return InspectionSettings(budget_s=budget, speed_mm_s=robot.limits.feed_speed_mm_s, measurement_hz=None,
                              camera=robot.camera, sigma_f=FED_SIGMA_F_K, length_scale=FED_LENGTH_SCALE_MM)


def points_field(scene: Scene) -> np.ndarray | None:
    """The true field (K) at the scene's points of interest, or None when its inspection maps none."""
    return None if scene.inspect is None else scene.inspect.field


def points_prior(scene: Scene, settings: InspectionSettings):
    """The map's prior over the scene's points of interest (:func:`snakeplan.mapping.gp.point_prior`) under
    ``settings``: mean from the settings or the scene's base temperature."""
    from snakeplan.mapping.gp import point_prior

    p = scene.points_of_interest
    return point_prior(p.points, p.normals, p.obstacle, settings.prior_mean(scene.metadata), settings.sigma_f,
                       settings.length_scale)


def measures_field(scene: Scene) -> bool:
    """Whether an inspect task in ``scene`` maps a surface field (paper 002's station: one mesh, its field on the
    vertices) rather than looking at points of interest."""
    return "field" in scene.metadata


def inspected_surface(scene: Scene) -> tuple[Mesh, np.ndarray]:
    """(the surface an inspect task measures, its true field on the mesh's vertices (K)): the scene's only mesh
    and its ``metadata["field"]``; ValueError naming ``scene`` for a scene that has none."""
    if "field" not in scene.metadata:
        raise ValueError(f"scene: {scene.name} has no surface field to inspect")
    meshes = [o for o in scene.obstacles if isinstance(o, Mesh)]
    if len(meshes) != 1:
        raise ValueError(f"scene: {scene.name} must hold exactly one surface mesh, found {len(meshes)}")
    return meshes[0], np.asarray(scene.metadata["field"]["values"], dtype=float)


def mission_rngs(seed: int) -> tuple[np.random.Generator, np.random.Generator]:
    """(the planner's generator, the measurements' noise generator) of a mission flown from ``seed``: independent
    streams, so the judge draws the same noise as the mission without the planner's draws."""
    planner, noise = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(2))
    return planner, noise


#: How far (per entry) a base pose may be from a rigid transform.
RIGID_TOL = 1e-6


def _array(name: str, value, shape: tuple) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.size == 0 and len(shape) > 1:
        a = a.reshape((0, *(s or 0 for s in shape[1:])))
    if a.ndim != len(shape) or any(s is not None and a.shape[i] != s for i, s in enumerate(shape)):
        raise ValueError(f"{name}: expected shape {tuple('k' if s is None else s for s in shape)}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: must be finite")
    return np.ascontiguousarray(a)


def _times(value) -> np.ndarray:
    """A motion's sample times (k,) s: at least one, nondecreasing."""
    t = _array("times_s", value, (None,))
    if len(t) < 1 or np.any(np.diff(t) < 0):
        raise ValueError("times_s: needs at least one time, nondecreasing")
    return t


class _Timed:
    """A motion sampled at times ``times_s``: it starts at the first and ends at the last."""

    times_s: np.ndarray

    @property
    def start_s(self) -> float:
        return float(self.times_s[0])

    @property
    def end_s(self) -> float:
        return float(self.times_s[-1])


@dataclass(frozen=True)
class JointMotion(_Timed):
    """The arm moved by its joints: at times ``times_s`` (k,) s, nondecreasing, the base poses ``bases`` (k, 4, 4)
    (mm, world) and the joint vectors ``q`` (k, dof) (rad; mm for a feed)."""

    times_s: np.ndarray
    bases: np.ndarray
    q: np.ndarray

    def __post_init__(self) -> None:
        t = _times(self.times_s)
        object.__setattr__(self, "times_s", t)
        bases = _array("bases", self.bases, (len(t), 4, 4))
        R = bases[:, :3, :3]
        rigid = (np.abs(np.einsum("kji,kjl->kil", R, R) - np.eye(3)).max(axis=(1, 2)) <= RIGID_TOL) & (
            np.linalg.det(R) > 0) & np.all(np.abs(bases[:, 3] - [0.0, 0.0, 0.0, 1.0]) <= RIGID_TOL, axis=1)
        if not rigid.all():
            raise ValueError(f"bases[{int(np.argmin(rigid))}]: not a rigid pose (an orthonormal rotation with "
                             f"determinant +1, last row 0 0 0 1)")
        object.__setattr__(self, "bases", bases)
        object.__setattr__(self, "q", _array("q", self.q, (len(t), None)))

    def to_dict(self) -> dict:
        return {"kind": "joints", "times_s": self.times_s.tolist(), "bases": self.bases.tolist(),
                "q": self.q.tolist()}


@dataclass(frozen=True)
class Crawl(_Timed):
    """A fed arm moved by its feed along ``path`` (m, 3) mm from the entrance: at times ``times_s`` (k,) s,
    nondecreasing, the tip is ``depths_mm`` (k,) along the path, and in between the depth moves linearly. The body
    follows the leader: at depth d it lies on the path's stretch behind d. A crawl inserts, holds, retracts, in any
    order; a mission's tree of insertions is a sequence of crawls, each on its branch's path."""

    path: np.ndarray
    depths_mm: np.ndarray
    times_s: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", validate_path(self.path, "path"))
        t = _times(self.times_s)
        d = _array("depths_mm", self.depths_mm, (len(t),))
        length = float(cumulative_length(self.path)[-1])
        if np.any(d < 0) or np.any(d > length + 1e-6):
            raise ValueError(f"depths_mm: must lie in [0, {length:.6g}] mm (the path's length)")
        object.__setattr__(self, "times_s", t)
        object.__setattr__(self, "depths_mm", d)

    def depth_at(self, t: ArrayLike) -> np.ndarray:
        """The tip's depth (mm) at mission times ``t`` (held at the ends outside the crawl)."""
        if len(self.times_s) == 1:
            return np.full(np.shape(t), self.depths_mm[0])
        return np.interp(t, self.times_s, self.depths_mm)

    @property
    def travel_mm(self) -> float:
        """How far the feed moves the arm (mm), in and out."""
        return float(np.abs(np.diff(self.depths_mm)).sum())

    @property
    def retracted_mm(self) -> float:
        """How far the feed draws the arm back (mm)."""
        return float(-np.minimum(np.diff(self.depths_mm), 0.0).sum())

    def to_dict(self) -> dict:
        return {"kind": "crawl", "path": self.path.tolist(), "depths_mm": self.depths_mm.tolist(),
                "times_s": self.times_s.tolist()}


def tip_poses(path: np.ndarray, depths: ArrayLike, lengths: ArrayLike, entrance_direction: ArrayLike
              ) -> tuple[np.ndarray, np.ndarray]:
    """(tip positions (k, 3) mm, unit tip directions (k, 3)) of a fed arm of section ``lengths`` followed onto
    ``path`` at ``depths``: the tip is the path's point at each depth, its direction the last section's axis."""
    joints = ftl.fit_batch(path, lengths, np.atleast_1d(np.asarray(depths, dtype=float)), entrance_direction)
    axis = joints[:, -1] - joints[:, -2]
    return joints[:, -1].copy(), axis / np.linalg.norm(axis, axis=1, keepdims=True)


Motion = JointMotion | Crawl


def tips_at(robot: Chain, motion: Motion, t: ArrayLike) -> np.ndarray:
    """Tip positions (k, 3) mm of ``robot`` in ``motion`` at mission times ``t`` (held at the ends), as the judge
    moves it: a crawl's on its path at its depth then, a joint motion's between its samples as
    :func:`~snakeplan.world.joint_motion.interpolate` moves the base and the joints."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if isinstance(motion, Crawl):
        return point_at(motion.path, motion.depth_at(t))
    times = motion.times_s
    out = np.empty((len(t), 3))
    for k, tk in enumerate(t):
        i = int(np.clip(np.searchsorted(times, tk, side="right") - 1, 0, len(times) - 1))
        if i == len(times) - 1 or times[i + 1] == times[i]:
            bases, q = motion.bases[i:i + 1], motion.q[i:i + 1]
        else:
            bases, q = interpolate(motion.bases, motion.q, i, np.array([(tk - times[i]) / (times[i + 1] - times[i])]))
        out[k] = arm_bodies(robot, bases, q)[0, -1]
    return out


@dataclass(frozen=True)
class Views:
    """Camera poses taken: times (k,) s, positions (k, 3) mm and unit view directions (k, 3), world frame."""

    times_s: np.ndarray
    positions: np.ndarray
    directions: np.ndarray

    def __post_init__(self) -> None:
        t = _array("times_s", self.times_s, (None,))
        object.__setattr__(self, "times_s", t)
        object.__setattr__(self, "positions", _array("positions", self.positions, (len(t), 3)))
        d = _array("directions", self.directions, (len(t), 3))
        n = np.linalg.norm(d, axis=1, keepdims=True)
        if np.any(n == 0):
            raise ValueError("directions: must be non-zero")
        object.__setattr__(self, "directions", d / n)

    def __len__(self) -> int:
        return len(self.times_s)


@dataclass(frozen=True)
class Mission:
    """What an inspection plan did: the arm's motions in time order, the views taken, the inspection settings it
    was flown under, and the seed of the simulated measurements' noise (so the judge measures as the mission did)."""

    motions: tuple[Motion, ...]
    views: Views
    settings: InspectionSettings
    measurement_seed: int

    @classmethod
    def from_dict(cls, d) -> Mission:
        """A mission from the ``mission`` block of a plan document; ValueError naming the field (``mission.views
        .positions``) on a malformed one."""
        def need(obj, key: str, where: str):
            if not isinstance(obj, dict) or key not in obj:
                raise ValueError(f"{where}: missing {key!r}")
            return obj[key]

        def field_of(where: str, build):
            try:
                return build()
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{where}: {str(exc).split(': ', 1)[-1]}") from None

        settings = need(d, "settings", "mission")
        s = field_of("mission.settings", lambda: InspectionSettings(
            float(need(settings, "budget_s", "mission.settings")),
            float(need(settings, "camera_speed_mm_s", "mission.settings")),
            None if need(settings, "measurement_hz", "mission.settings") is None else float(settings["measurement_hz"]),
            CameraModel.from_dict(need(settings, "camera", "mission.settings")),
            float(need(settings, "sigma_f_k", "mission.settings")),
            float(need(settings, "length_scale_mm", "mission.settings")),
            None if settings.get("prior_mean_k") is None else float(settings["prior_mean_k"])))
        v = need(d, "views", "mission")
        views = field_of("mission.views", lambda: Views(need(v, "times_s", "mission.views"),
                                                         need(v, "positions", "mission.views"),
                                                         need(v, "directions", "mission.views")))
        motions = []
        for i, m in enumerate(need(d, "motions", "mission")):
            where = f"mission.motions[{i}]"
            kind = need(m, "kind", where)
            if kind == "joints":
                motions.append(field_of(where, lambda m=m, w=where: JointMotion(
                    need(m, "times_s", w), need(m, "bases", w), need(m, "q", w))))
            elif kind == "crawl":
                motions.append(field_of(where, lambda m=m, w=where: Crawl(
                    need(m, "path", w), need(m, "depths_mm", w), need(m, "times_s", w))))
            else:
                raise ValueError(f"{where}.kind: must be 'joints' or 'crawl', got {kind!r}")
        seed = need(d, "measurement_seed", "mission")
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ValueError(f"mission.measurement_seed: expected a non-negative integer, got {seed!r}")
        return cls(tuple(motions), views, s, seed)

    def to_dict(self) -> dict:
        """The ``mission`` block of ``snakeplan.plan/1`` (docs/ARCHITECTURE.md)."""
        return {"settings": self.settings.to_dict(), "measurement_seed": self.measurement_seed,
                "views": {"times_s": self.views.times_s.tolist(), "positions": self.views.positions.tolist(),
                          "directions": self.views.directions.tolist()},
                "motions": [m.to_dict() for m in self.motions]}
