"""`Scene`: workspace bounds, obstacles, the entrance the arm is fed through, targets, and metadata.

A scene is plain data with a lossless JSON round-trip (schema ``snakeplan.scene/1``, docs/ARCHITECTURE.md) and the
spatial queries every planner and the judge share: signed distance, chain clearance, line of sight.
Lengths in mm. The constructor checks every field (:mod:`snakeplan.inputs`); :meth:`Scene.from_dict`, the one
reader of scene files, also checks the metadata that code reads and where the entrance and targets lie.
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np

from snakeplan import inputs
from snakeplan.geometry.distance import CONTACT_RESOLUTION_MM, ObstacleSet
from snakeplan.geometry.primitives import Mesh, Obstacle, obstacle_from_dict, open_mesh_note
from snakeplan.robots.statics import check_gravity
from snakeplan.scenes.inspect import InspectSpec, points_of_interest
from snakeplan.scenes.task import Task, as_task

SCHEMA = "snakeplan.scene/1"
#: How deep (mm) a scene file's entrance may lie inside an obstacle's surface (it may sit on a wall's port).
ENTRANCE_TOLERANCE_MM = CONTACT_RESOLUTION_MM
#: Most obstacles in a scene file (the generated scenes have at most about 50; `snakeplan show` draws 10,000 in
#: well under a minute).
MAX_OBSTACLES = 10_000
#: Gravity (m/s^2) of a scene that states none: the Earth's, down the scene's -z (every tank and vessel family
#: stands with +z up).
DEFAULT_GRAVITY = (0.0, 0.0, -9.81)



class MeshWarning(UserWarning):
    """A scene's mesh is taken in a way its author may not expect (an open mesh becomes a shell)."""


def _frozen(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Entrance:
    """Where the arm enters: a point (mm) and the unit feed direction pointing into the scene."""

    position: np.ndarray
    direction: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _frozen(inputs.vec3(self.position, "entrance.position")))
        object.__setattr__(self, "direction", _frozen(inputs.unit(self.direction, "entrance.direction")))

    def to_dict(self) -> dict:
        return {"position": self.position.tolist(), "direction": self.direction.tolist()}


@dataclass(frozen=True, eq=False)
class Scene:
    """A workspace to plan in. ``targets`` are visited in order; ``metadata`` holds generator facts.

    ``discovered``: indices of the obstacles that are not known before the job (clutter, debris: a sensed planner
    meets them only through its sensor); every other obstacle is prior (walls, partitions, the CAD structure).
    ``inspect``: what an inspect task looks at (:mod:`snakeplan.scenes.inspect`); None: every surface.
    ``task``: the task a scene file asks for (``"task"``: reach, inspect or search); None: its family's.
    ``gravity``: the gravity vector (m/s^2, scene frame; default :data:`DEFAULT_GRAVITY`, 9.81 down -z; the station
    has none): what the statics of the judge (cable tensions) hold the arm against.

    Immutable: its arrays are read-only and its obstacles a tuple, so the packed obstacles it caches can never go
    stale. Build a changed scene with ``dataclasses.replace``.
    """

    name: str
    seed: int | None
    bounds_min: np.ndarray
    bounds_max: np.ndarray
    entrance: Entrance
    targets: np.ndarray
    obstacles: tuple[Obstacle, ...] = ()
    metadata: dict = field(default_factory=dict)
    discovered: tuple[int, ...] = ()
    inspect: InspectSpec | None = None
    task: Task | None = None
    gravity: np.ndarray | None = None

    def __post_init__(self) -> None:
        lo, hi = inputs.corners(self.bounds_min, self.bounds_max, "bounds")
        if not isinstance(self.entrance, Entrance):
            raise ValueError(f"entrance: expected an Entrance, got {inputs.show(self.entrance)}")
        obstacles = tuple(self.obstacles)
        for i, o in enumerate(obstacles):
            if not isinstance(o, Obstacle):
                raise ValueError(f"obstacles[{i}]: expected an obstacle, got {inputs.show(o)}")
        fields = {"name": inputs.text(self.name, "name"),
                  "seed": None if self.seed is None else inputs.integer(self.seed, "seed", 0, 2**64 - 1),
                  "bounds_min": _frozen(lo), "bounds_max": _frozen(hi),
                  "targets": _frozen(inputs.points(self.targets, "targets")), "obstacles": obstacles,
                  "metadata": inputs.mapping(self.metadata, "metadata"),
                  "discovered": _indices(self.discovered, len(obstacles)),
                  "task": None if self.task is None else as_task(self.task),
                  "gravity": _frozen(check_gravity(DEFAULT_GRAVITY if self.gravity is None else self.gravity))}
        if self.inspect is not None:
            if not isinstance(self.inspect, InspectSpec):
                raise ValueError(f"inspect: expected an InspectSpec, got {inputs.show(self.inspect)}")
            bad = [k for k in self.inspect.surfaces or () if not 0 <= k < len(obstacles)]
            if bad:
                raise ValueError(f"inspect.surfaces: {bad[0]} is not an obstacle index (0 .. {len(obstacles) - 1})")
        for name, value in fields.items():
            object.__setattr__(self, name, value)

    # --- queries -------------------------------------------------------------------------------------------
    @cached_property
    def obstacle_set(self) -> ObstacleSet:
        """The packed obstacles (built once; a scene is not mutated after construction)."""
        return ObstacleSet(self.obstacles)

    def with_targets(self, targets) -> Scene:
        """This scene with other ``targets`` (k, 3) mm, sharing its packed obstacles and points of interest (the
        obstacles are the same, so neither is built again)."""
        other = replace(self, targets=targets)
        for name in ("obstacle_set", "points_of_interest"):
            if name in self.__dict__:
                other.__dict__[name] = self.__dict__[name]
        return other

    @cached_property
    def points_of_interest(self):
        """The points an inspect task must see (:func:`snakeplan.scenes.inspect.points_of_interest`), sampled once."""
        return points_of_interest(self)

    @property
    def prior(self) -> np.ndarray:
        """One flag per obstacle: True where it is known before the job (not in ``discovered``)."""
        flags = np.ones(len(self.obstacles), dtype=bool)
        flags[list(self.discovered)] = False
        return flags

    @property
    def label(self) -> str:
        """The scene's name for titles: "fuel-tank seed 3" for a generated scene, the name alone for one from a
        file (which has no seed)."""
        return self.name if self.seed is None else f"{self.name} seed {self.seed}"

    @property
    def size(self) -> np.ndarray:
        return self.bounds_max - self.bounds_min

    def signed_distance(self, points) -> np.ndarray:
        """Signed distance (mm) from points ``(..., 3)`` to the nearest obstacle."""
        return self.obstacle_set.signed_distance(points)

    def in_bounds(self, points, margin: float = 0.0) -> np.ndarray:
        """True where points lie inside the bounds shrunk by ``margin`` (mm)."""
        p = np.asarray(points, dtype=float)
        return np.all((p >= self.bounds_min + margin) & (p <= self.bounds_max - margin), axis=-1)

    def chain_clearance(self, joints, radii) -> np.ndarray:
        """Minimum clearance (mm) of chains of capsules ``(..., n+1, 3)`` with link ``radii``."""
        return self.obstacle_set.chain_clearance(joints, radii)

    def chain_collides(self, joints, radii) -> np.ndarray:
        """True where a chain of capsules touches an obstacle."""
        return self.obstacle_set.chain_collides(joints, radii)

    def line_of_sight(self, a, b) -> np.ndarray:
        """True where the segment a->b crosses no obstacle."""
        return self.obstacle_set.line_of_sight(a, b)

    # --- JSON ----------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        d = {
            "schema": SCHEMA,
            "name": self.name,
            "seed": self.seed,
            "units": "mm",
            "bounds": {"min": self.bounds_min.tolist(), "max": self.bounds_max.tolist()},
            "entrance": self.entrance.to_dict(),
            "targets": self.targets.tolist(),
            "obstacles": [o.to_dict() if known else {**o.to_dict(), "prior": False}
                          for o, known in zip(self.obstacles, self.prior)],
            "metadata": self.metadata,
        }
        if self.inspect is not None:
            d["inspect"] = self.inspect.to_dict()
        if self.task is not None:
            d["task"] = str(self.task)
        if not np.array_equal(self.gravity, DEFAULT_GRAVITY):
            d["gravity"] = self.gravity.tolist()
        return d

    def to_json(self, indent: int | None = None) -> str:
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    @classmethod
    def from_dict(cls, d: Any, base_dir: str | os.PathLike | None = None) -> Scene:
        """Parse and check a ``snakeplan.scene/1`` object; ValueError names the first bad field's JSON path.
        Mesh files are read relative to ``base_dir`` (the scene file's folder; default the working directory), and
        an open mesh without a ``thickness`` gives a :class:`MeshWarning`.

        Beyond the constructor's checks: at most :data:`MAX_OBSTACLES` obstacles, each object with exactly its
        type's fields; the metadata is plain JSON and the keys code reads are well formed (:func:`check_metadata`);
        the entrance and the targets lie where they may (:func:`check_placement`).
        """
        d = inputs.mapping(d, "scene", what="a JSON object")
        inputs.mapping(d, "", required=("name", "bounds", "entrance"))
        if d.get("schema", SCHEMA) != SCHEMA:
            raise ValueError(f"schema: expected {SCHEMA!r}, got {inputs.show(d['schema'])}")
        if d.get("units", "mm") != "mm":
            raise ValueError(f"units: only 'mm' is supported, got {inputs.show(d['units'])}")
        bounds = inputs.mapping(d["bounds"], "bounds", required=("min", "max"), what="{min: [x, y, z], max: [x, y, z]}")
        entrance = inputs.mapping(d["entrance"], "entrance", required=("position", "direction"),
                                  what="{position: [x, y, z], direction: [dx, dy, dz]}")
        raw = inputs.items(d.get("obstacles", []), "obstacles")
        if len(raw) > MAX_OBSTACLES:
            raise ValueError(f"obstacles: more than {MAX_OBSTACLES} obstacles ({len(raw)}); join small ones into a mesh")
        discovered = []
        for i, o in enumerate(raw):
            if isinstance(o, dict) and "prior" in o:
                if type(o["prior"]) is not bool:
                    raise ValueError(f"obstacles[{i}].prior: expected true or false, got {inputs.show(o['prior'])}")
                if not o["prior"]:
                    discovered.append(i)
        obstacles = [obstacle_from_dict({k: v for k, v in o.items() if k != "prior"} if isinstance(o, dict) else o,
                                        f"obstacles[{i}]", base_dir) for i, o in enumerate(raw)]
        for i, o in enumerate(obstacles):
            note = open_mesh_note(o) if isinstance(o, Mesh) else None
            if note is not None:
                warnings.warn(f"obstacles[{i}]: {note}", MeshWarning, stacklevel=2)
        metadata = d.get("metadata")
        metadata = {} if metadata is None else inputs.mapping(metadata, "metadata")
        inputs.plain_json(metadata, "metadata")
        check_metadata(metadata, obstacles)
        scene = cls(name=d["name"], seed=d.get("seed"), bounds_min=bounds["min"], bounds_max=bounds["max"],
                    entrance=Entrance(entrance["position"], entrance["direction"]), targets=d.get("targets", []),
                    obstacles=obstacles, metadata=metadata, discovered=tuple(discovered),
                    inspect=None if d.get("inspect") is None else InspectSpec.from_dict(d["inspect"], len(obstacles)),
                    task=d.get("task"), gravity=d.get("gravity"))
        check_placement(scene)
        return scene

    @classmethod
    def from_json(cls, text: str, source: str = "scene", base_dir: str | os.PathLike | None = None) -> Scene:
        """Parse scene JSON ``text`` (:func:`snakeplan.inputs.load_json`'s limits; ``source`` names the file in a
        message about the file as a whole; mesh files are read relative to ``base_dir``)."""
        return cls.from_dict(inputs.load_json(text, source), base_dir)


def check_placement(scene: Scene) -> None:
    """The entrance and the targets lie inside the bounds; no target lies inside an obstacle (signed distance
    >= 0) and the entrance lies at most :data:`ENTRANCE_TOLERANCE_MM` deep in one (it may sit in a wall's port)."""
    names = ["entrance.position"] + [f"targets[{i}]" for i in range(len(scene.targets))]
    pts = np.vstack([scene.entrance.position[None], scene.targets])
    inside = scene.in_bounds(pts)
    for name, p, ok in zip(names, pts, inside):
        if not ok:
            raise ValueError(f"{name}: {inputs.point_text(p)} lies outside the bounds {inputs.point_text(scene.bounds_min)} .. "
                             f"{inputs.point_text(scene.bounds_max)}")
    if not scene.obstacles:
        return
    depth = -scene.signed_distance(pts)
    allowed = np.r_[ENTRANCE_TOLERANCE_MM, np.zeros(len(scene.targets))]
    for name, p, dp, limit in zip(names, pts, depth, allowed):
        if dp > limit:
            k = int(np.argmin([o.signed_distance(p) for o in scene.obstacles]))
            what = "the entrance may touch a wall but" if name == "entrance.position" else "a target"
            raise ValueError(f"{name}: {inputs.point_text(p)} lies {dp:.3g} mm deep inside obstacles[{k}]; {what} must lie in "
                             f"free space{_unit_hint(p, scene)}")


def _unit_hint(p: np.ndarray, scene: Scene) -> str:
    """A hint for a point that looks given in metres in a scene of millimetres: every coordinate within +-10 in a
    scene over a metre across."""
    if float(np.max(np.abs(p))) <= 10.0 and float(np.max(scene.size)) > 1000.0:
        return f" (were its coordinates metres? snakeplan's are mm: {inputs.point_text(p * 1000.0)})"
    return ""


def check_metadata(meta: dict, obstacles: list[Obstacle]) -> None:
    """The metadata keys that code reads (docs/ARCHITECTURE.md, ``snakeplan.scene/1``), where present: fuel-tank
    ``chambers`` (with ``holes``), oil-tank ``cells``, the station's ``field``, ``mesh`` and
    ``parameters.base_temperature_k``."""
    if "chambers" in meta:
        n = _rooms(meta["chambers"], "metadata.chambers")
        if "holes" in meta:
            for i, h in enumerate(inputs.items(meta["holes"], "metadata.holes")):
                name = f"metadata.holes[{i}]"
                h = inputs.mapping(h, name, required=("center", "normal", "chambers"))
                inputs.vec3(h["center"], f"{name}.center")
                inputs.unit(h["normal"], f"{name}.normal")
                pair = inputs.items(h["chambers"], f"{name}.chambers", "[a, b]")
                if len(pair) != 2:
                    raise ValueError(f"{name}.chambers: expected [a, b], got {inputs.show(pair)}")
                for j, k in enumerate(pair):
                    inputs.integer(k, f"{name}.chambers[{j}]", 0, n - 1)
    if "cells" in meta:
        _rooms(meta["cells"], "metadata.cells")
    if "field" in meta:
        field_ = inputs.mapping(meta["field"], "metadata.field", required=("values",))
        values = inputs.items(field_["values"], "metadata.field.values")
        for i, v in enumerate(values):
            inputs.real(v, f"metadata.field.values[{i}]")
        meshes = [o for o in obstacles if isinstance(o, Mesh)]
        if len(meshes) != 1:
            raise ValueError(f"metadata.field: lies on the scene's only mesh, but the scene has {len(meshes)} meshes")
        if len(values) != len(meshes[0].vertices):
            raise ValueError(f"metadata.field.values: expected one value per mesh vertex ({len(meshes[0].vertices)}), "
                             f"got {len(values)}")
    if "mesh" in meta:
        mesh = inputs.mapping(meta["mesh"], "metadata.mesh")
        for key in ("radius_mm", "height_mm"):
            if key in mesh:
                inputs.length(mesh[key], f"metadata.mesh.{key}")
        if "axis" in mesh:
            inputs.unit(mesh["axis"], "metadata.mesh.axis")
        if "base_center" in mesh:
            inputs.vec3(mesh["base_center"], "metadata.mesh.base_center")
    if "parameters" in meta:
        parameters = inputs.mapping(meta["parameters"], "metadata.parameters")
        if "base_temperature_k" in parameters:
            inputs.real(parameters["base_temperature_k"], "metadata.parameters.base_temperature_k")


def _rooms(value: Any, name: str) -> int:
    """Check a list of at least one room box ``{min, max}``; return how many."""
    rooms = inputs.items(value, name)
    if not rooms:
        raise ValueError(f"{name}: needs at least one room")
    for i, room in enumerate(rooms):
        room = inputs.mapping(room, f"{name}[{i}]", required=("min", "max"))
        inputs.corners(room["min"], room["max"], f"{name}[{i}]")
    return len(rooms)


def _indices(value: Any, n: int) -> tuple[int, ...]:
    """``discovered`` as sorted unique obstacle indices below ``n``."""
    items = inputs.items(value, "discovered", "[index, ...]")
    out = sorted({inputs.integer(k, f"discovered[{i}]", 0, n - 1) for i, k in enumerate(items)}) if items else []
    return tuple(int(k) for k in out)


