"""Meshes read from CAD files (STL, OBJ, PLY, GLB/GLTF, OFF) with trimesh, in a stated unit and pose: vertex
(mm) and face arrays, of which :mod:`snakeplan.geometry.primitives` makes the :class:`Mesh` obstacle.

The scene form is ``{"type": "mesh", "file": "parts/tank.stl", "units": "m", "transform": 4x4, "thickness": t}``:
the file is read relative to the scene file's folder, its coordinates are scaled to mm by ``units``, then moved by
the rigid ``transform`` (rotation and a translation in mm; default identity). Every problem is a one-line
ValueError naming the field (``obstacles[2].file: ...``).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from snakeplan import inputs

#: Millimetres per unit a mesh file may be written in.
UNITS_MM = {"m": 1000.0, "cm": 10.0, "mm": 1.0, "in": 25.4}
#: Largest mesh file (bytes): a binary STL of 2 million triangles is about 100 MB.
MAX_MESH_FILE_BYTES = 512 * 2**20
#: Most triangles a mesh file may hold. Memory: about 1.1 kB per triangle at the peak of loading and about 0.3 kB
#: per triangle once packed (corners, pseudonormals, tree): 1.18 million triangles peaked at 1.3 GB.
MAX_MESH_TRIANGLES = 2_000_000
#: Size range (mm, the box diagonal after scaling) a mesh file must fall in: outside it, the units are wrong.
MESH_SPAN_MM = (10.0, 1e5)
#: File name endings trimesh reads here.
MESH_SUFFIXES = (".stl", ".obj", ".ply", ".glb", ".gltf", ".off")


def read_mesh_file(path: str | os.PathLike, field: str, units: str = "mm", units_field: str | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(vertices in mm, faces) of a mesh file; duplicate vertices merged so shared edges are found. ValueError
    (``field: ...``) when it cannot be read or holds no triangles or too many, and (``units_field: ...``, default
    ``field``) when ``units`` makes it implausibly small or large."""
    import trimesh

    if units not in UNITS_MM:
        raise ValueError(f"{field}: units must be one of {', '.join(UNITS_MM)}, got {inputs.show(units)}")
    p = Path(path)
    shown = str(path) if str(path).isprintable() else repr(str(path))
    if p.suffix.lower() not in MESH_SUFFIXES:
        raise ValueError(f"{field}: {shown}: not a mesh file (known endings: {', '.join(MESH_SUFFIXES)})")
    try:
        size = p.stat().st_size
    except OSError:
        raise ValueError(f"{field}: file not found: {shown}") from None
    if size > MAX_MESH_FILE_BYTES:
        raise ValueError(f"{field}: {shown} is larger than the {MAX_MESH_FILE_BYTES // 2**20} MiB limit")
    try:
        loaded = trimesh.load(str(p), force="mesh", process=True)
    except Exception as exc:  # trimesh raises many kinds for a malformed file
        raise ValueError(f"{field}: cannot read {shown} as a mesh ({exc.__class__.__name__})") from None
    faces = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))), dtype=np.int64).reshape(-1, 3)
    vertices = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=float).reshape(-1, 3)
    if len(faces) == 0:
        raise ValueError(f"{field}: {shown} holds no triangles")
    if len(faces) > MAX_MESH_TRIANGLES:
        raise ValueError(f"{field}: {shown} holds {len(faces)} triangles, more than the {MAX_MESH_TRIANGLES} limit; "
                         f"decimate it in CAD")
    if not np.all(np.isfinite(vertices)):
        raise ValueError(f"{field}: {shown} has vertices that are not finite numbers")
    return check_span(vertices * UNITS_MM[units], units_field or field, units, "mesh"), faces


def check_span(points: np.ndarray, field: str, units: str, what: str) -> np.ndarray:
    """``points`` (mm, read in ``units``), unless their box's diagonal is outside :data:`MESH_SPAN_MM`: then a
    ValueError naming ``field`` that asks whether the units are right."""
    span = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    lo, hi = MESH_SPAN_MM
    if not lo <= span <= hi:
        guess = "m" if span < lo else "mm"
        raise ValueError(f"{field}: in {units!r} the {what} spans {span:.3g} mm, outside {lo:g} mm .. {hi / 1e3:g} m; "
                         f"are its units {guess!r}?")
    return points


def rigid_transform(value: Any, name: str) -> np.ndarray:
    """A 4x4 rigid transform (rotation, translation in mm, last row 0 0 0 1) as an array."""
    T = inputs.rows(value, name, 4, min_rows=4, max_rows=4, shape="[[r, r, r, x], [r, r, r, y], [r, r, r, z], "
                                                                    "[0, 0, 0, 1]]")
    if not np.array_equal(T[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"{name}[3]: the last row of a rigid transform must be [0, 0, 0, 1], got {T[3].tolist()}")
    inputs.rotation(T[:3, :3].tolist(), f"{name} (its rotation part)")
    return T


def read_mesh_spec(d: dict, where: str, base_dir: str | os.PathLike | None
                   ) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """(vertices in mm, faces, source) of a scene's ``{"type": "mesh", "file": ...}`` object (see the module):
    the file read and moved; ``source`` is the object as written back (the file's absolute path, ``units``, and
    ``transform`` and ``thickness`` where given). :func:`snakeplan.geometry.primitives.obstacle_from_dict` makes
    the :class:`Mesh` of them."""
    d = inputs.mapping(d, where, required=("type", "file", "units"),
                       allowed=("type", "file", "units", "transform", "thickness"))
    file = d["file"]
    if not isinstance(file, str) or not file:
        raise ValueError(f"{where}.file: expected a file name, got {inputs.show(file)}")
    units = d["units"]
    if not isinstance(units, str):
        raise ValueError(f"{where}.units: expected one of {', '.join(UNITS_MM)}, got {inputs.show(units)}")
    if units not in UNITS_MM:
        raise ValueError(f"{where}.units: expected one of {', '.join(UNITS_MM)}, got {inputs.show(units)}")
    path = Path(base_dir or ".") / file
    vertices, faces = read_mesh_file(path, f"{where}.file", units, f"{where}.units")
    source = {"file": str(path.resolve()), "units": units}
    if "transform" in d:
        T = rigid_transform(d["transform"], f"{where}.transform")
        vertices = vertices @ T[:3, :3].T + T[:3, 3]
        if not np.all(np.abs(vertices) <= inputs.MAX_MM):
            raise ValueError(f"{where}.transform: moves the mesh beyond {inputs.MAX_MM:g} mm")
        source["transform"] = T.tolist()
    if "thickness" in d:
        source["thickness"] = inputs.length(d["thickness"], f"{where}.thickness")
    return vertices, faces, source
