"""`Scene`: workspace bounds, obstacles, the entrance the arm is fed through, targets, and metadata.

A scene is plain data with a lossless JSON round-trip (schema ``snakeplan.scene/1``, docs/ARCHITECTURE.md) and the
spatial queries every planner and the judge share: signed distance, chain clearance, line of sight.
Lengths in mm.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Obstacle, obstacle_from_dict, vec3

SCHEMA = "snakeplan.scene/1"


def _frozen(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Entrance:
    """Where the arm enters: a point (mm) and the unit feed direction pointing into the scene."""

    position: np.ndarray
    direction: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _frozen(vec3(self.position, "entrance.position")))
        d = vec3(self.direction, "entrance.direction")
        n = np.linalg.norm(d)
        if n < 1e-12:
            raise ValueError("entrance.direction: must be a non-zero vector")
        object.__setattr__(self, "direction", _frozen(d / n))

    def to_dict(self) -> dict:
        return {"position": self.position.tolist(), "direction": self.direction.tolist()}


@dataclass(frozen=True, eq=False)
class Scene:
    """A workspace to plan in. ``targets`` are visited in order; ``metadata`` holds generator facts.

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

    def __post_init__(self) -> None:
        lo, hi = vec3(self.bounds_min, "bounds.min"), vec3(self.bounds_max, "bounds.max")
        if np.any(hi <= lo):
            raise ValueError("bounds: max must exceed min on every axis")
        t = np.array(self.targets, dtype=float).reshape(-1, 3) if len(self.targets) else np.zeros((0, 3))
        if not np.all(np.isfinite(t)):
            raise ValueError("targets: coordinates must be finite")
        for name, value in (("bounds_min", _frozen(lo)), ("bounds_max", _frozen(hi)), ("targets", _frozen(t)),
                            ("obstacles", tuple(self.obstacles))):
            object.__setattr__(self, name, value)

    # --- queries -------------------------------------------------------------------------------------------
    @cached_property
    def obstacle_set(self) -> ObstacleSet:
        """The packed obstacles (built once; a scene is not mutated after construction)."""
        return ObstacleSet(self.obstacles)

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
        return {
            "schema": SCHEMA,
            "name": self.name,
            "seed": self.seed,
            "units": "mm",
            "bounds": {"min": self.bounds_min.tolist(), "max": self.bounds_max.tolist()},
            "entrance": self.entrance.to_dict(),
            "targets": self.targets.tolist(),
            "obstacles": [o.to_dict() for o in self.obstacles],
            "metadata": self.metadata,
        }

    def to_json(self, indent: int | None = None) -> str:
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    @classmethod
    def from_dict(cls, d: Any) -> Scene:
        """Parse a ``snakeplan.scene/1`` object; ValueError names the first bad field."""
        if not isinstance(d, dict):
            raise ValueError("scene: expected a JSON object")
        if d.get("schema", SCHEMA) != SCHEMA:
            raise ValueError(f"schema: expected {SCHEMA!r}, got {d.get('schema')!r}")
        if d.get("units", "mm") != "mm":
            raise ValueError(f"units: only 'mm' is supported, got {d.get('units')!r}")
        for key in ("name", "bounds", "entrance"):
            if key not in d:
                raise ValueError(f"{key}: missing")
        bounds, entrance = d["bounds"], d["entrance"]
        if not isinstance(bounds, dict) or "min" not in bounds or "max" not in bounds:
            raise ValueError("bounds: expected {min: [x, y, z], max: [x, y, z]}")
        if not isinstance(entrance, dict) or "position" not in entrance or "direction" not in entrance:
            raise ValueError("entrance: expected {position: [x, y, z], direction: [dx, dy, dz]}")
        targets = d.get("targets", [])
        if not isinstance(targets, list):
            raise ValueError("targets: expected a list of [x, y, z]")
        parsed_targets = [vec3(t, f"targets[{i}]") for i, t in enumerate(targets)]
        obstacles = d.get("obstacles", [])
        if not isinstance(obstacles, list):
            raise ValueError("obstacles: expected a list")
        seed = d.get("seed")
        if seed is not None and (not isinstance(seed, int) or isinstance(seed, bool)):
            raise ValueError(f"seed: expected an integer or null, got {seed!r}")
        return cls(
            name=str(d["name"]),
            seed=seed,
            bounds_min=bounds["min"],
            bounds_max=bounds["max"],
            entrance=Entrance(entrance["position"], entrance["direction"]),
            targets=np.array(parsed_targets).reshape(-1, 3),
            obstacles=[obstacle_from_dict(o, f"obstacles[{i}]") for i, o in enumerate(obstacles)],
            metadata=dict(d.get("metadata") or {}),
        )

    @classmethod
    def from_json(cls, text: str) -> Scene:
        try:
            data = json.loads(text, parse_constant=_reject_constant)
        except json.JSONDecodeError as exc:
            raise ValueError(f"scene JSON: malformed at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
        return cls.from_dict(data)


def _reject_constant(name: str) -> float:
    raise ValueError(f"JSON: {name} is not a valid number")

