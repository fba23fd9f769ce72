"""Obstacle primitives with exact signed distances (mm): box, sphere, cylinder, plate with a hole, pipe, mesh.

Each primitive is a small frozen dataclass that round-trips through the ``snakeplan.scene/1`` JSON of
docs/ARCHITECTURE.md (``to_dict`` / :func:`obstacle_from_dict`) and packs itself into a fixed-width float row
(:meth:`Obstacle.pack`) so that the numba kernels in :mod:`snakeplan.geometry.distance` can evaluate whole
scenes without Python in the loop. Signed distance is negative inside the material.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from snakeplan.geometry.transforms import any_perpendicular, normalize

# Packed row layout shared with the numba kernels: [kind, center(3), R row-major(9), params...].
PACK_WIDTH = 24
KIND_BOX, KIND_SPHERE, KIND_CYLINDER, KIND_PLATE, KIND_PIPE, KIND_MESH = range(6)
_P = 13  # first type-specific parameter


def vec3(value: Any, name: str) -> np.ndarray:
    """``value`` as a finite 3-vector; ValueError naming ``name`` otherwise (for input validation)."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected [x, y, z] numbers, got {value!r}") from None
    if arr.shape != (3,):
        raise ValueError(f"{name}: expected [x, y, z], got {value!r}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: coordinates must be finite, got {value!r}")
    return arr


def _positive(value: Any, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{name}: must be a positive finite number, got {value!r}")
    return v


def _unit(value: Any, name: str) -> np.ndarray:
    v = vec3(value, name)
    n = np.linalg.norm(v)
    if n < 1e-12:
        raise ValueError(f"{name}: must be a non-zero vector")
    return v / n


def _list(a: np.ndarray) -> list:
    return np.asarray(a, dtype=float).tolist()


@dataclass(frozen=True, eq=False)
class Obstacle:
    """Base of all obstacles: a world-frame ``center`` (mm) and a local frame ``rotation`` (columns = axes)."""

    type: ClassVar[str] = ""
    kind: ClassVar[int] = -1

    def pack(self) -> np.ndarray:
        """Fixed-width row for the numba kernels."""
        row = np.zeros(PACK_WIDTH)
        row[0] = self.kind
        row[1:4] = self.center
        row[4:13] = self.frame().reshape(-1)
        self._pack_params(row)
        return row

    def frame(self) -> np.ndarray:
        return np.eye(3)

    def _pack_params(self, row: np.ndarray) -> None:
        raise NotImplementedError

    def to_dict(self) -> dict:
        raise NotImplementedError

    def bounding_radius(self) -> float:
        """Radius of a sphere about ``center`` that contains the obstacle (mm)."""
        raise NotImplementedError

    def local_half_extents(self) -> np.ndarray:
        """Half sizes (mm) of a box in the local frame that contains the obstacle."""
        r = self.bounding_radius()
        return np.array([r, r, r])

    def aabb(self) -> tuple[np.ndarray, np.ndarray]:
        """World axis-aligned box (min, max corners, mm) that contains the obstacle."""
        reach = np.abs(self.frame()) @ self.local_half_extents()
        return self.center - reach, self.center + reach

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        """Exact signed distance (mm) from points ``(..., 3)`` to this obstacle."""
        from snakeplan.geometry.distance import ObstacleSet

        return ObstacleSet([self]).signed_distance(points)


@dataclass(frozen=True, eq=False)
class Box(Obstacle):
    """Oriented box: ``size`` full edge lengths (mm) along the columns of ``rotation``."""

    center: np.ndarray
    size: np.ndarray
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    type: ClassVar[str] = "box"
    kind: ClassVar[int] = KIND_BOX

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", vec3(self.center, "box.center"))
        size = vec3(self.size, "box.size")
        if np.any(size <= 0):
            raise ValueError(f"box.size: every edge must be > 0, got {size.tolist()}")
        object.__setattr__(self, "size", size)
        R = np.asarray(self.rotation, dtype=float)
        if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R.T @ R, np.eye(3), atol=1e-6):
            raise ValueError("box.rotation: must be a 3x3 rotation matrix")
        if np.linalg.det(R) < 0:
            raise ValueError("box.rotation: must be a proper rotation (determinant +1)")
        object.__setattr__(self, "rotation", R)

    def frame(self) -> np.ndarray:
        return self.rotation

    def _pack_params(self, row: np.ndarray) -> None:
        row[_P : _P + 3] = self.size / 2

    def local_half_extents(self) -> np.ndarray:
        return self.size / 2

    def bounding_radius(self) -> float:
        return float(np.linalg.norm(self.size) / 2)

    def to_dict(self) -> dict:
        return {"type": "box", "center": _list(self.center), "size": _list(self.size), "rotation": _list(self.rotation)}


@dataclass(frozen=True, eq=False)
class Sphere(Obstacle):
    """Solid ball of ``radius`` (mm)."""

    center: np.ndarray
    radius: float
    type: ClassVar[str] = "sphere"
    kind: ClassVar[int] = KIND_SPHERE

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", vec3(self.center, "sphere.center"))
        object.__setattr__(self, "radius", _positive(self.radius, "sphere.radius"))

    def _pack_params(self, row: np.ndarray) -> None:
        row[_P] = self.radius

    def bounding_radius(self) -> float:
        return self.radius

    def to_dict(self) -> dict:
        return {"type": "sphere", "center": _list(self.center), "radius": self.radius}


@dataclass(frozen=True, eq=False)
class Cylinder(Obstacle):
    """Solid capped cylinder of ``radius``, ``length`` along ``axis``, centred on ``center`` (mm)."""

    center: np.ndarray
    axis: np.ndarray
    radius: float
    length: float
    type: ClassVar[str] = "cylinder"
    kind: ClassVar[int] = KIND_CYLINDER

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", vec3(self.center, "cylinder.center"))
        object.__setattr__(self, "axis", _unit(self.axis, "cylinder.axis"))
        object.__setattr__(self, "radius", _positive(self.radius, "cylinder.radius"))
        object.__setattr__(self, "length", _positive(self.length, "cylinder.length"))

    def frame(self) -> np.ndarray:
        x = any_perpendicular(self.axis)
        return np.stack([x, np.cross(self.axis, x), self.axis], axis=1)

    def _pack_params(self, row: np.ndarray) -> None:
        row[_P] = self.radius
        row[_P + 1] = self.length / 2

    def bounding_radius(self) -> float:
        return math.hypot(self.radius, self.length / 2)

    def local_half_extents(self) -> np.ndarray:
        return np.array([self.radius, self.radius, self.length / 2])

    def to_dict(self) -> dict:
        return {"type": "cylinder", "center": _list(self.center), "axis": _list(self.axis),
                "radius": self.radius, "length": self.length}


@dataclass(frozen=True, eq=False)
class Pipe(Obstacle):
    """Hollow pipe: the wall between ``inner_radius`` and ``outer_radius``, ``length`` along ``axis`` (mm)."""

    center: np.ndarray
    axis: np.ndarray
    inner_radius: float
    outer_radius: float
    length: float
    type: ClassVar[str] = "pipe"
    kind: ClassVar[int] = KIND_PIPE

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", vec3(self.center, "pipe.center"))
        object.__setattr__(self, "axis", _unit(self.axis, "pipe.axis"))
        object.__setattr__(self, "inner_radius", _positive(self.inner_radius, "pipe.inner_radius"))
        object.__setattr__(self, "outer_radius", _positive(self.outer_radius, "pipe.outer_radius"))
        object.__setattr__(self, "length", _positive(self.length, "pipe.length"))
        if self.outer_radius <= self.inner_radius:
            raise ValueError(f"pipe.outer_radius: must exceed inner_radius {self.inner_radius}, got {self.outer_radius}")

    def frame(self) -> np.ndarray:
        x = any_perpendicular(self.axis)
        return np.stack([x, np.cross(self.axis, x), self.axis], axis=1)

    def _pack_params(self, row: np.ndarray) -> None:
        row[_P] = self.inner_radius
        row[_P + 1] = self.outer_radius
        row[_P + 2] = self.length / 2

    def bounding_radius(self) -> float:
        return math.hypot(self.outer_radius, self.length / 2)

    def local_half_extents(self) -> np.ndarray:
        return np.array([self.outer_radius, self.outer_radius, self.length / 2])

    def to_dict(self) -> dict:
        return {"type": "pipe", "center": _list(self.center), "axis": _list(self.axis),
                "inner_radius": self.inner_radius, "outer_radius": self.outer_radius, "length": self.length}


@dataclass(frozen=True, eq=False)
class Plate(Obstacle):
    """Rectangular plate (``size`` = width along side, height along ``up``; ``thickness`` along ``normal``).

    Side = up x normal. An optional elliptical (or round) ``hole`` is given as
    ``{"offset": [u, v], "semi_axes": [a, b]}`` in (side, up) coordinates; it must lie inside the plate.
    """

    center: np.ndarray
    normal: np.ndarray
    up: np.ndarray
    size: tuple[float, float]
    thickness: float
    hole: dict | None = None
    type: ClassVar[str] = "plate"
    kind: ClassVar[int] = KIND_PLATE

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", vec3(self.center, "plate.center"))
        n = _unit(self.normal, "plate.normal")
        up = vec3(self.up, "plate.up")
        up = up - np.dot(up, n) * n
        if np.linalg.norm(up) < 1e-9:
            raise ValueError("plate.up: must not be parallel to plate.normal")
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "up", normalize(up))
        size = np.asarray(self.size, dtype=float)
        if size.shape != (2,) or not np.all(np.isfinite(size)) or np.any(size <= 0):
            raise ValueError(f"plate.size: expected two positive numbers [width, height], got {self.size!r}")
        object.__setattr__(self, "size", (float(size[0]), float(size[1])))
        object.__setattr__(self, "thickness", _positive(self.thickness, "plate.thickness"))
        if self.hole is not None:
            if not isinstance(self.hole, dict):
                raise ValueError("plate.hole: expected null or {offset, semi_axes}")
            off = np.asarray(self.hole.get("offset", [0.0, 0.0]), dtype=float)
            ax = np.asarray(self.hole.get("semi_axes", None) if self.hole.get("semi_axes") is not None else [np.nan], dtype=float)
            if off.shape != (2,) or not np.all(np.isfinite(off)):
                raise ValueError(f"plate.hole.offset: expected two finite numbers, got {self.hole.get('offset')!r}")
            if ax.shape != (2,) or not np.all(np.isfinite(ax)) or np.any(ax <= 0):
                raise ValueError(f"plate.hole.semi_axes: expected two positive numbers, got {self.hole.get('semi_axes')!r}")
            w, h = self.size
            if abs(off[0]) + ax[0] >= w / 2 or abs(off[1]) + ax[1] >= h / 2:
                raise ValueError("plate.hole: the hole must lie strictly inside the plate")
            object.__setattr__(self, "hole", {"offset": off.tolist(), "semi_axes": ax.tolist()})

    @property
    def side(self) -> np.ndarray:
        return np.cross(self.up, self.normal)

    def frame(self) -> np.ndarray:
        return np.stack([self.normal, self.side, self.up], axis=1)

    def _pack_params(self, row: np.ndarray) -> None:
        row[_P] = self.thickness / 2
        row[_P + 1] = self.size[0] / 2
        row[_P + 2] = self.size[1] / 2
        if self.hole is not None:
            row[_P + 3] = 1.0
            row[_P + 4 : _P + 6] = self.hole["offset"]
            row[_P + 6 : _P + 8] = self.hole["semi_axes"]

    def bounding_radius(self) -> float:
        return float(np.linalg.norm([self.thickness, self.size[0], self.size[1]]) / 2)

    def local_half_extents(self) -> np.ndarray:
        return np.array([self.thickness, self.size[0], self.size[1]]) / 2

    def to_dict(self) -> dict:
        return {"type": "plate", "center": _list(self.center), "normal": _list(self.normal), "up": _list(self.up),
                "size": list(self.size), "thickness": self.thickness, "hole": self.hole}


@dataclass(frozen=True, eq=False)
class Mesh(Obstacle):
    """Closed triangle mesh (vertices in mm, faces as vertex indices); inside = winding number > 1/2."""

    vertices: np.ndarray
    faces: np.ndarray
    type: ClassVar[str] = "mesh"
    kind: ClassVar[int] = KIND_MESH

    def __post_init__(self) -> None:
        V = np.asarray(self.vertices, dtype=float)
        F = np.asarray(self.faces)
        if V.ndim != 2 or V.shape[1] != 3 or len(V) < 4 or not np.all(np.isfinite(V)):
            raise ValueError("mesh.vertices: expected at least 4 finite [x, y, z] rows")
        if F.ndim != 2 or F.shape[1] != 3 or len(F) < 4 or not np.issubdtype(F.dtype, np.integer):
            raise ValueError("mesh.faces: expected at least 4 integer [i, j, k] rows")
        if F.min() < 0 or F.max() >= len(V):
            raise ValueError("mesh.faces: vertex index out of range")
        object.__setattr__(self, "vertices", V)
        object.__setattr__(self, "faces", F.astype(np.int64))

    @property
    def center(self) -> np.ndarray:  # type: ignore[override]
        return (self.vertices.min(axis=0) + self.vertices.max(axis=0)) / 2

    def triangles(self) -> np.ndarray:
        """Face corners, shape (F, 3, 3)."""
        return self.vertices[self.faces]

    def _pack_params(self, row: np.ndarray) -> None:
        row[_P] = self.bounding_radius()

    def bounding_radius(self) -> float:
        return float(np.max(np.linalg.norm(self.vertices - self.center, axis=1)))

    def aabb(self) -> tuple[np.ndarray, np.ndarray]:
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    def to_dict(self) -> dict:
        return {"type": "mesh", "vertices": _list(self.vertices), "faces": self.faces.tolist()}


OBSTACLE_TYPES: dict[str, type[Obstacle]] = {c.type: c for c in (Box, Sphere, Cylinder, Pipe, Plate, Mesh)}


def obstacle_from_dict(d: Any, where: str = "obstacle") -> Obstacle:
    """Build an obstacle from its ``snakeplan.scene/1`` dict; ValueError names the bad field."""
    if not isinstance(d, dict):
        raise ValueError(f"{where}: expected an object, got {type(d).__name__}")
    kind = d.get("type")
    cls = OBSTACLE_TYPES.get(kind)  # type: ignore[arg-type]
    if cls is None:
        raise ValueError(f"{where}.type: unknown obstacle type {kind!r} (known: {', '.join(OBSTACLE_TYPES)})")
    kwargs = {k: v for k, v in d.items() if k != "type"}
    try:
        return cls(**kwargs)
    except TypeError as exc:
        raise ValueError(f"{where}: wrong fields for {kind}: {exc}") from None
    except ValueError as exc:
        msg = str(exc)
        if msg.startswith(f"{kind}."):
            raise ValueError(f"{where}.{msg[len(kind) + 1:]}") from None
        raise ValueError(f"{where}: {msg}") from None
