"""Obstacle primitives with exact signed distances (mm): box, sphere, cylinder, plate with a hole, pipe, mesh,
point cloud.

Each primitive is a small frozen dataclass that round-trips through the ``snakeplan.scene/1`` JSON of
docs/ARCHITECTURE.md (``to_dict`` / :func:`obstacle_from_dict`) and packs itself into a fixed-width float row
(:meth:`Obstacle.pack`, the layout of :mod:`snakeplan.geometry.distance`) so that its numba kernels can evaluate
whole scenes without Python in the loop. Signed distance is negative inside the material. A mesh given by a CAD
file is read by :mod:`snakeplan.geometry.mesh_files`, a cloud's by :mod:`snakeplan.geometry.cloud_files`.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import MISSING, dataclass, field, fields
from typing import Any, ClassVar

import numpy as np

from snakeplan import inputs
from snakeplan.geometry import cloud_distance, mesh_distance
from snakeplan.geometry.cloud_files import read_cloud_spec
from snakeplan.geometry.distance import (
    _P,
    KIND_BOX,
    KIND_CYLINDER,
    KIND_MESH,
    KIND_PIPE,
    KIND_PLATE,
    KIND_POINTS,
    KIND_SPHERE,
    PACK_WIDTH,
    ObstacleSet,
)
from snakeplan.geometry.mesh_files import read_mesh_spec
from snakeplan.geometry.transforms import any_perpendicular

#: A plate's ``up`` must make an angle with its ``normal`` whose sine is at least this.
MIN_UP_SINE = 1e-6


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
        object.__setattr__(self, "center", inputs.vec3(self.center, "box.center"))
        size = inputs.vec3(self.size, "box.size")
        object.__setattr__(self, "size", np.array([inputs.length(v, f"box.size[{i}]") for i, v in enumerate(size)]))
        object.__setattr__(self, "rotation", inputs.rotation(self.rotation, "box.rotation"))

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
        object.__setattr__(self, "center", inputs.vec3(self.center, "sphere.center"))
        object.__setattr__(self, "radius", inputs.length(self.radius, "sphere.radius"))

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
        object.__setattr__(self, "center", inputs.vec3(self.center, "cylinder.center"))
        object.__setattr__(self, "axis", inputs.unit(self.axis, "cylinder.axis"))
        object.__setattr__(self, "radius", inputs.length(self.radius, "cylinder.radius"))
        object.__setattr__(self, "length", inputs.length(self.length, "cylinder.length"))

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
        object.__setattr__(self, "center", inputs.vec3(self.center, "pipe.center"))
        object.__setattr__(self, "axis", inputs.unit(self.axis, "pipe.axis"))
        object.__setattr__(self, "inner_radius", inputs.length(self.inner_radius, "pipe.inner_radius"))
        object.__setattr__(self, "outer_radius", inputs.length(self.outer_radius, "pipe.outer_radius"))
        object.__setattr__(self, "length", inputs.length(self.length, "pipe.length"))
        if self.outer_radius <= self.inner_radius:
            raise ValueError(f"pipe.outer_radius: must exceed inner_radius {self.inner_radius}, "
                             f"got {self.outer_radius}")

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
        object.__setattr__(self, "center", inputs.vec3(self.center, "plate.center"))
        n = inputs.unit(self.normal, "plate.normal")
        up = inputs.unit(self.up, "plate.up")
        up = up - np.dot(up, n) * n
        if np.linalg.norm(up) < MIN_UP_SINE:
            raise ValueError(f"plate.up: must not be parallel to plate.normal (sine of their angle < {MIN_UP_SINE:g})")
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "up", up / np.linalg.norm(up))
        size = inputs.vector(self.size, "plate.size", 2, shape="[width, height]")
        w, h = (inputs.length(v, f"plate.size[{i}]") for i, v in enumerate(size))
        object.__setattr__(self, "size", (w, h))
        object.__setattr__(self, "thickness", inputs.length(self.thickness, "plate.thickness"))
        if self.hole is not None:
            hole = inputs.mapping(self.hole, "plate.hole", required=("semi_axes",), allowed=("offset", "semi_axes"),
                                  what="null or {offset, semi_axes}")
            off = inputs.vector(hole.get("offset", [0.0, 0.0]), "plate.hole.offset", 2, shape="[u, v]")
            ax = inputs.vector(hole["semi_axes"], "plate.hole.semi_axes", 2, shape="[a, b]")
            ax = [inputs.length(v, f"plate.hole.semi_axes[{i}]") for i, v in enumerate(ax)]
            if abs(off[0]) + ax[0] >= w / 2 or abs(off[1]) + ax[1] >= h / 2:
                raise ValueError(f"plate.hole: must lie strictly inside the plate (|offset| + semi_axes < size / 2 "
                                 f"on each axis; offset {off.tolist()}, semi_axes {ax}, size {[w, h]})")
            object.__setattr__(self, "hole", {"offset": off.tolist(), "semi_axes": ax})

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
    """Triangle mesh (vertices in mm, faces as vertex indices).

    Closed (every edge shared by two faces running along it in opposite directions): a solid, signed distance
    negative inside; its faces are reversed if they face inward. Open (some edge borders one face): a shell, the
    points within ``thickness / 2`` of the surface (``thickness`` default :data:`DEFAULT_SHELL_MM`; a closed mesh
    given a ``thickness`` is a shell too). An edge shared by more than two faces is an error. ``source`` is the
    file form it was loaded from (:mod:`snakeplan.geometry.mesh_files`), written back by :meth:`to_dict`.
    """

    vertices: np.ndarray
    faces: np.ndarray
    thickness: float | None = None
    source: dict | None = field(default=None, compare=False)
    type: ClassVar[str] = "mesh"
    kind: ClassVar[int] = KIND_MESH

    def __post_init__(self) -> None:
        V = inputs.rows(self.vertices, "mesh.vertices", 3, min_rows=4)
        F = inputs.index_rows(self.faces, "mesh.faces", 3, len(V), min_rows=1)
        if self.thickness is not None:
            object.__setattr__(self, "thickness", inputs.length(self.thickness, "mesh.thickness"))
        closed, F = mesh_distance.topology(V, F)
        V.setflags(write=False)
        F.setflags(write=False)
        object.__setattr__(self, "vertices", V)
        object.__setattr__(self, "faces", F)
        object.__setattr__(self, "closed", closed)

    def __getstate__(self) -> dict:
        """Pickled as its defining fields; what is derived from them is rebuilt on loading."""
        return {"vertices": self.vertices, "faces": self.faces, "thickness": self.thickness, "source": self.source}

    def __setstate__(self, state: dict) -> None:
        """Rebuild from the defining fields, so a mesh pickled by an older version (a training checkpoint) gets
        this version's derived data."""
        for name in ("vertices", "faces", "thickness", "source"):
            object.__setattr__(self, name, state.get(name))
        self.__post_init__()

    @property
    def center(self) -> np.ndarray:  # type: ignore[override]
        return (self.vertices.min(axis=0) + self.vertices.max(axis=0)) / 2

    @property
    def shell_thickness(self) -> float | None:
        """Thickness (mm) of the shell this mesh stands for, or None for a solid."""
        if self.thickness is not None:
            return self.thickness
        return None if self.closed else mesh_distance.DEFAULT_SHELL_MM

    def triangles(self) -> np.ndarray:
        """Face corners, shape (F, 3, 3)."""
        return self.vertices[self.faces]

    def fingerprint(self) -> str:
        """A digest of the mesh's defining content (vertices, faces, thickness), made once: equal for equal meshes
        however they were loaded, so what is derived from one mesh can be kept for the next job in it."""
        key = self.__dict__.get("_fingerprint")
        if key is None:
            h = hashlib.sha1(repr((self.vertices.shape, self.vertices.dtype.str, self.faces.shape,
                                   self.faces.dtype.str, self.thickness)).encode())
            h.update(self.vertices.tobytes())
            h.update(self.faces.tobytes())
            key = h.hexdigest()
            object.__setattr__(self, "_fingerprint", key)
        return key

    def distance_data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(triangles in leaf order, normals, nodes, links) of :func:`mesh_distance.prepare`, built once."""
        data = self.__dict__.get("_distance_data")
        if data is None:
            data = mesh_distance.prepare(self.vertices, self.faces)
            object.__setattr__(self, "_distance_data", data)
        return data

    def _pack_params(self, row: np.ndarray) -> None:
        row[_P] = self.bounding_radius()
        shell = self.shell_thickness
        row[_P + 2] = 0.0 if shell is None else shell / 2

    def bounding_radius(self) -> float:
        return float(np.max(np.linalg.norm(self.vertices - self.center, axis=1)))

    def aabb(self) -> tuple[np.ndarray, np.ndarray]:
        grow = 0.0 if self.shell_thickness is None else self.shell_thickness / 2
        return self.vertices.min(axis=0) - grow, self.vertices.max(axis=0) + grow

    def to_dict(self) -> dict:
        if self.source is not None:
            return {"type": "mesh", **self.source}
        out = {"type": "mesh", "vertices": _list(self.vertices), "faces": self.faces.tolist()}
        if self.thickness is not None:
            out["thickness"] = self.thickness
        return out


#: A cloud's points are balls of this many times its spacing (the median distance to the nearest other point) in
#: radius unless ``radius_mm`` says: a ball this size reaches past the middle of the widest gap of a regular grid of
#: that spacing (its diagonal half, 0.71 spacings) with room for range noise of a quarter spacing either way.
DEFAULT_RADIUS_SPACINGS = 1.5


@dataclass(frozen=True, eq=False)
class Points(Obstacle):
    """A point cloud, a scan of a space: every point (mm) a solid ball of one radius. ``radius_mm`` is the
    inflation that covers the scan's noise and the gaps between its points (default
    :data:`DEFAULT_RADIUS_SPACINGS` times its spacing, :func:`cloud_distance.spacing`). ``source`` is the file form
    it was loaded from (:mod:`snakeplan.geometry.cloud_files`), written back by :meth:`to_dict`."""

    points: np.ndarray
    radius_mm: float | None = None
    source: dict | None = field(default=None, compare=False)
    type: ClassVar[str] = "points"
    kind: ClassVar[int] = KIND_POINTS

    def __post_init__(self) -> None:
        P = inputs.rows(self.points, "points.points", 3, min_rows=1)
        P.setflags(write=False)
        object.__setattr__(self, "points", P)
        prepared = cloud_distance.prepare(P)
        object.__setattr__(self, "_distance_data", prepared)
        if self.radius_mm is not None:
            radius = inputs.length(self.radius_mm, "points.radius_mm")
        else:
            spacing = cloud_distance.spacing(prepared)
            if not math.isfinite(spacing):
                raise ValueError("points.radius_mm: a cloud of one place has no spacing to take a radius from; "
                                 "give radius_mm")
            radius = DEFAULT_RADIUS_SPACINGS * spacing
        object.__setattr__(self, "radius", radius)

    def __getstate__(self) -> dict:
        """Pickled as its defining fields; the hierarchy is rebuilt on loading."""
        return {"points": self.points, "radius_mm": self.radius_mm, "source": self.source}

    def __setstate__(self, state: dict) -> None:
        for name in ("points", "radius_mm", "source"):
            object.__setattr__(self, name, state.get(name))
        self.__post_init__()

    @property
    def center(self) -> np.ndarray:  # type: ignore[override]
        return (self.points.min(axis=0) + self.points.max(axis=0)) / 2

    def fingerprint(self) -> str:
        """A digest of the cloud's points and radius (as :meth:`Mesh.fingerprint`)."""
        key = self.__dict__.get("_fingerprint")
        if key is None:
            h = hashlib.sha1(repr((self.points.shape, self.radius)).encode())
            h.update(self.points.tobytes())
            key = h.hexdigest()
            object.__setattr__(self, "_fingerprint", key)
        return key

    def distance_data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(points in leaf order, nodes, links) of :func:`cloud_distance.prepare`."""
        return self.__dict__["_distance_data"]

    def sample(self, most: int) -> np.ndarray:
        """At most ``most`` of the points (mm), every k-th: what a picture or a page draws."""
        return self.points[::max(1, -(-len(self.points) // most))]

    def _pack_params(self, row: np.ndarray) -> None:
        row[_P] = self.radius

    def bounding_radius(self) -> float:
        return float(np.max(np.linalg.norm(self.points - self.center, axis=1))) + self.radius

    def aabb(self) -> tuple[np.ndarray, np.ndarray]:
        return self.points.min(axis=0) - self.radius, self.points.max(axis=0) + self.radius

    def to_dict(self) -> dict:
        if self.source is not None:
            return {"type": "points", **self.source}
        out = {"type": "points", "points": _list(self.points)}
        if self.radius_mm is not None:
            out["radius_mm"] = self.radius_mm
        return out


def open_mesh_note(mesh: Mesh) -> str | None:
    """What the loader warns about a mesh (None for a closed one, or an open one given its ``thickness``)."""
    if mesh.closed or mesh.thickness is not None:
        return None
    return (f"the mesh is open (not watertight); it is taken as a shell {mesh.shell_thickness:g} mm thick "
            f"(give \"thickness\" in mm to choose)")


OBSTACLE_TYPES: dict[str, type[Obstacle]] = {c.type: c for c in (Box, Sphere, Cylinder, Pipe, Plate, Mesh, Points)}


def obstacle_from_dict(d: Any, where: str = "obstacle", base_dir: str | None = None) -> Obstacle:
    """Build an obstacle from its ``snakeplan.scene/1`` dict; ValueError names the bad field's JSON path. A mesh
    or a cloud given by ``file`` is read relative to ``base_dir`` (default: the working directory)."""
    d = inputs.mapping(d, where, required=("type",))
    kind = d["type"]
    if not isinstance(kind, str):
        raise ValueError(f"{where}.type: expected a string, got {inputs.show(kind)}")
    cls = OBSTACLE_TYPES.get(kind)
    if cls is None:
        raise ValueError(f"{where}.type: unknown obstacle type {inputs.show(kind)} "
                         f"(known: {', '.join(OBSTACLE_TYPES)})")
    if cls is Mesh and "file" in d:
        vertices, faces, source = read_mesh_spec(d, where, base_dir)
        try:
            return Mesh(vertices, faces, source.get("thickness"), source=source)
        except ValueError as exc:
            msg = str(exc)
            raise ValueError(f"{where}.file: {msg.split(': ', 1)[1] if ': ' in msg else msg}") from None
    if cls is Points and "file" in d:
        points, source = read_cloud_spec(d, where, base_dir)
        try:
            return Points(points, source.get("radius_mm"), source=source)
        except ValueError as exc:
            msg = str(exc)
            raise ValueError(f"{where}.{msg.split('.', 1)[1] if msg.startswith('points.') else msg}") from None
    names = [f.name for f in fields(cls) if f.name != "source"]
    required = tuple(f.name for f in fields(cls) if f.default is MISSING and f.default_factory is MISSING)
    inputs.mapping(d, where, required=required, allowed=("type", *names))
    try:
        return cls(**{k: v for k, v in d.items() if k != "type"})
    except ValueError as exc:
        msg = str(exc)
        if msg.startswith(f"{kind}."):
            raise ValueError(f"{where}.{msg[len(kind) + 1:]}") from None
        raise ValueError(f"{where}: {msg}") from None
