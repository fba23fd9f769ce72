"""Point clouds read from scan files (PLY, PCD, XYZ, NPY, LAS) or fused from depth images (a depth folder,
:mod:`snakeplan.geometry.depth_files`), in a stated unit and pose, cropped and thinned: the points (mm) of which
:mod:`snakeplan.geometry.primitives` makes the :class:`Points` obstacle.

The scene form is ``{"type": "points", "file": "scan.ply", "units": "m", "transform": 4x4, "radius_mm": r,
"crop": [x0, y0, z0, x1, y1, z1], "downsample_mm": v}``: the file is read relative to the scene file's folder, its
coordinates scaled to mm by ``units`` and moved by the rigid ``transform``; then the points outside ``crop`` (mm,
scene frame) are dropped, and ``downsample_mm`` keeps one point per cube of that edge (the mean of the points in
it). The original file stays the source, so the scene says how its cloud was made.

Readers, each a well-kept library or NumPy alone: PLY through trimesh (already read meshes here; a PLY with faces
is taken by its vertices), PCD through pypcd4 (PCL's ASCII, binary and compressed forms; small, pure Python, where
Open3D is hundreds of MB for one reader), LAS through laspy (the ASPRS format of survey scanners, scaled and offset
as stored), XYZ as text (whitespace- or comma-separated, the first three columns x, y, z, the rest colours or
intensities), NPY as an ``(n, 3)`` array. Every problem is a one-line ValueError naming the field.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from snakeplan import inputs
from snakeplan.geometry.depth_files import is_depth_folder, read_depth_folder
from snakeplan.geometry.mesh_files import UNITS_MM, check_span, rigid_transform

#: File name endings read as clouds.
CLOUD_SUFFIXES = (".ply", ".pcd", ".xyz", ".npy", ".las")
#: Largest cloud file (bytes): 10 million points as text is about 400 MB.
MAX_CLOUD_FILE_BYTES = 1024 * 2**20
#: Most points a cloud may keep after cropping and thinning. A million points load in 2.1 s with a peak of 320 MB
#: (101 MB of it Python, NumPy and snakeplan; ``snakeplan bench cloud speed``, 2-core machine), so this many take
#: about 10 s and 1 GB.
MAX_CLOUD_POINTS = 4_000_000


def _shown(path: str | os.PathLike) -> str:
    return str(path) if str(path).isprintable() else repr(str(path))


def _text_columns(path: Path, field: str, shown: str) -> np.ndarray:
    """The first three columns of an XYZ text file (ValueError naming ``field`` for fewer or ragged ones)."""
    with open(path, "rb") as f:
        head = b""
        for line in f:
            if line.strip() and not line.lstrip().startswith(b"#"):
                head = line
                break
    delimiter = "," if b"," in head else None
    try:
        data = np.loadtxt(path, comments="#", delimiter=delimiter, ndmin=2, dtype=float)
    except ValueError as exc:
        raise ValueError(f"{field}: {shown}: not rows of numbers x y z ({str(exc).splitlines()[0]})") from None
    if data.shape[0] and data.shape[1] < 3:
        raise ValueError(f"{field}: {shown}: expected at least 3 columns x y z, got {data.shape[1]}")
    return data[:, :3]


def _read_raw(path: Path, field: str, shown: str) -> np.ndarray:
    """The points of a cloud file in its own units, ``(n, 3)``."""
    suffix = path.suffix.lower()
    if suffix == ".npy":
        try:
            data = np.load(path, allow_pickle=False)
        except (ValueError, OSError) as exc:
            raise ValueError(f"{field}: cannot read {shown} as a NumPy array ({exc.__class__.__name__})") from None
        if data.ndim != 2 or data.shape[1] != 3 or not np.issubdtype(data.dtype, np.number):
            raise ValueError(f"{field}: {shown}: expected an array of n rows x, y, z, got shape {data.shape} "
                             f"of {data.dtype}")
        return np.asarray(data, dtype=float)
    if suffix == ".xyz":
        return _text_columns(path, field, shown)
    if suffix == ".pcd":
        from pypcd4 import PointCloud

        try:
            cloud = PointCloud.from_path(path)
        except Exception as exc:  # pypcd4 raises many kinds for a malformed file
            raise ValueError(f"{field}: cannot read {shown} as a PCD file ({exc.__class__.__name__})") from None
        missing = [c for c in "xyz" if c not in cloud.fields]
        if missing:
            raise ValueError(f"{field}: {shown}: a PCD file needs fields x, y, z; it has {', '.join(cloud.fields)}")
        return np.asarray(cloud.numpy(("x", "y", "z")), dtype=float).reshape(-1, 3)
    if suffix == ".las":
        import laspy

        try:
            las = laspy.read(path)
        except Exception as exc:  # laspy raises many kinds for a malformed file
            raise ValueError(f"{field}: cannot read {shown} as a LAS file ({exc.__class__.__name__})") from None
        return np.column_stack([np.asarray(las.x, dtype=float), np.asarray(las.y, dtype=float),
                                np.asarray(las.z, dtype=float)])
    import trimesh

    try:
        loaded = trimesh.load(str(path), process=False)
    except Exception as exc:  # trimesh raises many kinds for a malformed file
        raise ValueError(f"{field}: cannot read {shown} as a PLY file ({exc.__class__.__name__})") from None
    return np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=float).reshape(-1, 3)


def is_cloud_file(path: str | os.PathLike) -> bool:
    """Whether ``path`` names a cloud: a PCD, XYZ, NPY or LAS file, a PLY file whose header declares no faces (a
    PLY with faces is a mesh), or a depth folder."""
    if is_depth_folder(path):
        return True
    suffix = Path(path).suffix.lower()
    if suffix != ".ply":
        return suffix in CLOUD_SUFFIXES
    try:
        with open(path, "rb") as f:
            header = f.read(4096).split(b"end_header", 1)[0]
    except OSError:
        return False
    for line in header.splitlines():
        words = line.split()
        if len(words) == 3 and words[0] == b"element" and words[1] == b"face":
            return words[2] == b"0"
    return True


def read_cloud_file(path: str | os.PathLike, field: str, units: str = "mm", units_field: str | None = None
                    ) -> np.ndarray:
    """The points (mm) of a cloud file. ValueError (``field: ...``) when it cannot be read, is over
    :data:`MAX_CLOUD_FILE_BYTES` or holds no points or points that are not finite, and (``units_field: ...``,
    default ``field``) when ``units`` makes it implausibly small or large."""
    if units not in UNITS_MM:
        raise ValueError(f"{field}: units must be one of {', '.join(UNITS_MM)}, got {inputs.show(units)}")
    p = Path(path)
    shown = _shown(path)
    if is_depth_folder(p):
        points = read_depth_folder(p, field)
    else:
        if p.suffix.lower() not in CLOUD_SUFFIXES:
            raise ValueError(f"{field}: {shown}: not a point cloud file (known endings: {', '.join(CLOUD_SUFFIXES)}, "
                             f"or a depth folder)")
        try:
            size = p.stat().st_size
        except OSError:
            raise ValueError(f"{field}: file not found: {shown}") from None
        if size > MAX_CLOUD_FILE_BYTES:
            raise ValueError(f"{field}: {shown} is larger than the {MAX_CLOUD_FILE_BYTES // 2**20} MiB limit; thin "
                             f"it first")
        points = _read_raw(p, field, shown)
    if len(points) == 0:
        raise ValueError(f"{field}: {shown} holds no points")
    bad = ~np.isfinite(points).all(axis=1)
    if bad.any():
        raise ValueError(f"{field}: {shown} has {int(bad.sum())} points that are not finite numbers (the first is "
                         f"point {int(np.argmax(bad))}); drop them before import")
    return check_span(points * UNITS_MM[units], units_field or field, units, "cloud")


def crop_box(value: Any, name: str) -> np.ndarray:
    """``[x0, y0, z0, x1, y1, z1]`` (mm) with each low corner below its high one."""
    v = inputs.vector(value, name, 6, shape="[x0, y0, z0, x1, y1, z1]")
    lo, hi = inputs.corners(v[:3], v[3:], name)
    return np.concatenate([lo, hi])


def downsample(points: np.ndarray, voxel_mm: float) -> np.ndarray:
    """One point per cube of edge ``voxel_mm`` (mm; the cubes of the grid through the origin) that holds any: the
    mean of its points (a voxel filter, as PCL's VoxelGrid), in the order of the cubes' first points."""
    keys = np.floor(points / voxel_mm).astype(np.int64)
    _, first, inverse, counts = np.unique(keys, axis=0, return_index=True, return_inverse=True, return_counts=True)
    sums = np.zeros((len(counts), 3))
    np.add.at(sums, inverse.reshape(-1), points)
    means = sums / counts[:, None]
    return means[np.argsort(first)]


def thin(points: np.ndarray, field: str, crop: np.ndarray | None = None, voxel_mm: float | None = None
         ) -> np.ndarray:
    """``points`` (mm) inside ``crop`` (``[x0, y0, z0, x1, y1, z1]``), then :func:`downsample`'d; ValueError naming
    ``field`` when none are left or more than :data:`MAX_CLOUD_POINTS`."""
    if crop is not None:
        points = points[np.all((points >= crop[:3]) & (points <= crop[3:]), axis=1)]
        if len(points) == 0:
            raise ValueError(f"{field}: no point of the cloud lies inside the crop box {crop.tolist()}")
    if voxel_mm is not None:
        points = downsample(points, voxel_mm)
    if len(points) > MAX_CLOUD_POINTS:
        raise ValueError(f"{field}: the cloud keeps {len(points)} points, more than the {MAX_CLOUD_POINTS} limit; "
                         f"thin it (downsample_mm, snakeplan scene import --downsample MM) or crop it")
    return points


def read_cloud_spec(d: dict, where: str, base_dir: str | os.PathLike | None) -> tuple[np.ndarray, dict[str, Any]]:
    """(points in mm, source) of a scene's ``{"type": "points", "file": ...}`` object (see the module): the file
    read, moved, cropped and thinned; ``source`` is the object as written back (the file's absolute path and the
    fields given)."""
    d = inputs.mapping(d, where, required=("type", "file", "units"),
                       allowed=("type", "file", "units", "transform", "radius_mm", "crop", "downsample_mm"))
    file = d["file"]
    if not isinstance(file, str) or not file:
        raise ValueError(f"{where}.file: expected a file name, got {inputs.show(file)}")
    units = d["units"]
    if not isinstance(units, str) or units not in UNITS_MM:
        raise ValueError(f"{where}.units: expected one of {', '.join(UNITS_MM)}, got {inputs.show(units)}")
    T = rigid_transform(d["transform"], f"{where}.transform") if "transform" in d else None
    crop = crop_box(d["crop"], f"{where}.crop") if "crop" in d else None
    voxel = inputs.length(d["downsample_mm"], f"{where}.downsample_mm") if "downsample_mm" in d else None
    radius = inputs.length(d["radius_mm"], f"{where}.radius_mm") if "radius_mm" in d else None
    path = Path(base_dir or ".") / file
    points = read_cloud(path, f"{where}.file", units, f"{where}.units", T, f"{where}.transform", crop, voxel)
    return points, cloud_source(str(path.resolve()), units, T, crop, voxel, radius)


def read_cloud(path: str | os.PathLike, field: str, units: str, units_field: str, transform: np.ndarray | None = None,
               transform_field: str = "transform", crop: np.ndarray | None = None, voxel_mm: float | None = None
               ) -> np.ndarray:
    """The points (mm) of a cloud file read in ``units`` (:func:`read_cloud_file`; implausible units blamed on
    ``units_field``), moved by the rigid ``transform``, cropped and thinned (:func:`thin`): what a scene's cloud and
    ``snakeplan scene import`` both load."""
    points = read_cloud_file(path, field, units, units_field)
    if transform is not None:
        points = points @ transform[:3, :3].T + transform[:3, 3]
        if not np.all(np.abs(points) <= inputs.MAX_MM):
            raise ValueError(f"{transform_field}: moves the cloud beyond {inputs.MAX_MM:g} mm")
    return thin(points, field, crop, voxel_mm)


def cloud_source(file: str, units: str, transform: np.ndarray | None = None, crop: np.ndarray | None = None,
                 voxel_mm: float | None = None, radius_mm: float | None = None) -> dict[str, Any]:
    """A cloud's scene/1 file form: the file, its units and whichever of its transform, crop box, voxel and radius
    were given."""
    source: dict[str, Any] = {"file": file, "units": units}
    for key, value in (("transform", transform), ("crop", crop), ("downsample_mm", voxel_mm),
                       ("radius_mm", radius_mm)):
        if value is not None:
            source[key] = value.tolist() if isinstance(value, np.ndarray) else value
    return source
