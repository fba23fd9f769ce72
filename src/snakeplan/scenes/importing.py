"""A scene from CAD mesh files and scans (point clouds): the meshes and clouds, where the arm enters, the targets
and the bounds (``snakeplan scene import``).

The written scene refers to the files by their path relative to the scene file (scene/1 ``file`` form), so the
scene and its parts move together; a cloud's crop box and voxel size are written beside its file, so the scene
says how its cloud was thinned. Every check names the command-line option it is about.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from snakeplan import inputs
from snakeplan.geometry.cloud_files import cloud_source, crop_box, is_cloud_file, read_cloud
from snakeplan.geometry.mesh_files import read_mesh_file
from snakeplan.geometry.primitives import Mesh, Points, obstacle_from_dict
from snakeplan.scenes.scene import Entrance, Scene, check_placement

#: Margin (mm) added around the meshes, entrance and targets by ``--bounds auto``.
AUTO_BOUNDS_MARGIN_MM = 50.0


def parse_triple(text: str, field: str) -> np.ndarray:
    """``"X,Y,Z"`` as a 3-vector (mm)."""
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"{field}: expected X,Y,Z numbers, got {text!r}") from None
    return inputs.vector(values, field, 3, shape="X,Y,Z")


def parse_bounds(text: str) -> tuple[np.ndarray, np.ndarray] | None:
    """``auto`` (None) or ``X0,Y0,Z0,X1,Y1,Z1`` (mm)."""
    if text == "auto":
        return None
    try:
        values = [float(p) for p in text.split(",")]
    except ValueError:
        raise ValueError(f"--bounds: expected auto or X0,Y0,Z0,X1,Y1,Z1, got {text!r}") from None
    v = inputs.vector(values, "--bounds", 6, shape="X0,Y0,Z0,X1,Y1,Z1")
    return inputs.corners(v[:3], v[3:], "--bounds")


def _cloud(file: str, field: str, units: str, here: Path, crop: np.ndarray | None, voxel: float | None,
           radius: float | None) -> Points:
    """The :class:`Points` of a cloud file, cropped and thinned, its source relative to ``here``."""
    points = read_cloud(file, field, units, f"--units: {file}", crop=crop, voxel_mm=voxel)
    source = cloud_source(os.path.relpath(Path(file).resolve(), here), units, None, crop, voxel, radius)
    try:
        return Points(points, radius, source=source)
    except ValueError as exc:
        raise ValueError(f"{field}: {file}: {str(exc).split(': ', 1)[-1]}") from None


def parse_crop(text: str) -> np.ndarray:
    """``X0,Y0,Z0,X1,Y1,Z1`` (mm) as a crop box."""
    try:
        values = [float(p) for p in text.split(",")]
    except ValueError:
        raise ValueError(f"--crop: expected X0,Y0,Z0,X1,Y1,Z1, got {text!r}") from None
    return crop_box(values, "--crop")


def import_scene(files: Sequence[str], units: str, entrance: np.ndarray, direction: np.ndarray,
                 targets: Sequence[np.ndarray], out: str | os.PathLike, bounds: tuple | None = None,
                 name: str | None = None, thickness: float | None = None,
                 primitives: Sequence[dict] = (), crop: np.ndarray | None = None, downsample_mm: float | None = None,
                 radius_mm: float | None = None) -> Scene:
    """The scene of mesh and cloud files (read in ``units``; a cloud cropped to ``crop``, ``[x0, y0, z0, x1, y1,
    z1]`` mm, and thinned to one point per ``downsample_mm`` cube, its points balls of ``radius_mm``), entrance
    (mm), unit feed ``direction`` and ``targets`` (mm), inside ``bounds`` (default: around everything with
    :data:`AUTO_BOUNDS_MARGIN_MM`), whose file references are relative to ``out``'s folder, with ``primitives``
    beside them (scene/1 obstacle objects, mm: a floor, a fixture the CAD lacks). ValueError names the option:
    ``FILE``, ``--entrance``, ``--target[i]``, ``--obstacle[i]``..."""
    if not files:
        raise ValueError("FILE: give at least one mesh or cloud file")
    here = Path(out).resolve().parent
    obstacles: list = []
    for i, file in enumerate(files):
        field = "FILE" if len(files) == 1 else f"FILE[{i}]"
        if is_cloud_file(file):
            obstacles.append(_cloud(file, field, units, here, crop, downsample_mm, radius_mm))
            continue
        vertices, faces = read_mesh_file(file, field, units, f"--units: {file}")
        source = {"file": os.path.relpath(Path(file).resolve(), here), "units": units}
        if thickness is not None:
            source["thickness"] = thickness
        try:
            obstacles.append(Mesh(vertices, faces, thickness, source=source))
        except ValueError as exc:
            raise ValueError(f"{field}: {file}: {str(exc).split(': ', 1)[-1]}") from None
    obstacles += [obstacle_from_dict(d, f"--obstacle[{i}]") for i, d in enumerate(primitives)]
    targets = np.asarray(targets, dtype=float).reshape(-1, 3)
    if bounds is None:
        pts = np.vstack([*(np.vstack(o.aabb()) for o in obstacles), entrance[None], targets])
        bounds = (pts.min(axis=0) - AUTO_BOUNDS_MARGIN_MM, pts.max(axis=0) + AUTO_BOUNDS_MARGIN_MM)
    scene = Scene(name=name or Path(files[0]).stem or "imported", seed=None, bounds_min=bounds[0],
                  bounds_max=bounds[1], entrance=Entrance(entrance, direction), targets=targets,
                  obstacles=tuple(obstacles), metadata={"source": "snakeplan scene import"})
    try:
        check_placement(scene)
    except ValueError as exc:
        msg = str(exc)
        if msg.startswith("entrance.position"):
            raise ValueError("--entrance" + msg[len("entrance.position"):]) from None
        if msg.startswith("targets["):
            raise ValueError("--target[" + msg[len("targets["):]) from None
        raise
    return scene
