"""Depth images with camera poses, fused into one point cloud (mm): a space seen by a depth camera (the arm's own,
or a handheld one) instead of scanned.

A depth folder holds the images and ``camera.json``::

    {"width": 640, "height": 480, "fx": 525.0, "fy": 525.0, "cx": 319.5, "cy": 239.5,
     "depth_scale": 0.0002, "max_depth": 4.0,
     "frames": [{"depth": "0001.png", "pose": [[r, r, r, x], [r, r, r, y], [r, r, r, z], [0, 0, 0, 1]]}, ...]}

- Intrinsics in pixels, the pinhole model with OpenCV's axes: the camera looks along its z, x to the right of the
  image, y down; pixel (u, v) (column, row, from the top left) sees along ((u - cx) / fx, (v - cy) / fy, 1).
- ``depth``: a 16-bit PNG (each value times ``depth_scale`` is the depth; TUM RGB-D's 1/5000 m, a RealSense's
  1/1000 m) or an NPY array of depths (``depth_scale`` does not apply), ``height`` x ``width``. The depth is the
  distance along the camera's z, not along the ray. 0, NaN and values beyond ``max_depth`` (optional) are no
  return.
- ``pose``: the camera's pose in the scene frame (camera to scene, rigid).

Depths, translations and ``max_depth`` are in the scene file's ``units`` (``depth_scale`` turns PNG counts into
them). Every problem is a one-line ValueError naming the field (``FILE: scans/camera.json: frames[3].pose: ...``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from snakeplan import inputs
from snakeplan.geometry.mesh_files import rigid_transform

#: The description file a depth folder holds.
CAMERA_FILE = "camera.json"
#: Most frames and pixels a depth folder may hold (about 30 million returns at most).
MAX_FRAMES = 10_000
MAX_PIXELS = 4096 * 4096


def is_depth_folder(path: str | Path) -> bool:
    """Whether ``path`` is a folder holding :data:`CAMERA_FILE`."""
    return (Path(path) / CAMERA_FILE).is_file()


def _image(path: Path, field: str, shape: tuple[int, int], scale: float) -> np.ndarray:
    """The depths of one frame's image (its units), NaN where there is no return."""
    if not path.is_file():
        raise ValueError(f"{field}: file not found: {path.name}")
    if path.suffix.lower() == ".npy":
        try:
            depth = np.asarray(np.load(path, allow_pickle=False), dtype=float)
        except (ValueError, OSError) as exc:
            raise ValueError(f"{field}: cannot read {path.name} as a NumPy array ({exc.__class__.__name__})") from None
    elif path.suffix.lower() == ".png":
        from PIL import Image

        try:
            with Image.open(path) as im:
                if im.mode not in ("I;16", "I;16B", "I"):
                    raise ValueError(f"{field}: {path.name} is a {im.mode} image; a depth PNG has 16-bit values")
                depth = np.asarray(im, dtype=float) * scale
        except OSError as exc:
            raise ValueError(f"{field}: cannot read {path.name} as a PNG ({exc.__class__.__name__})") from None
    else:
        raise ValueError(f"{field}: {path.name}: a depth image is a 16-bit .png or an .npy array")
    if depth.shape != shape:
        raise ValueError(f"{field}: {path.name} is {depth.shape[1] if depth.ndim == 2 else '?'} x "
                         f"{depth.shape[0]} pixels; camera.json says {shape[1]} x {shape[0]}")
    depth = depth.copy()
    depth[~(depth > 0.0)] = np.nan
    return depth


def read_depth_folder(folder: str | Path, field: str) -> np.ndarray:
    """The points of every frame's returns, in the scene frame (the folder's units): each pixel with a depth
    back-projected through the intrinsics and moved by its frame's pose."""
    folder = Path(folder)
    where = f"{field}: {folder.name}/{CAMERA_FILE}"
    try:
        doc = inputs.load_json((folder / CAMERA_FILE).read_text(), where)
    except OSError as exc:
        raise ValueError(f"{where}: cannot read it ({exc.__class__.__name__})") from None
    doc = inputs.mapping(doc, where, required=("width", "height", "fx", "fy", "cx", "cy", "frames"),
                         allowed=("width", "height", "fx", "fy", "cx", "cy", "depth_scale", "max_depth", "frames"))
    w = inputs.integer(doc["width"], f"{where}: width", 1)
    h = inputs.integer(doc["height"], f"{where}: height", 1)
    if w * h > MAX_PIXELS:
        raise ValueError(f"{where}: width x height: at most {MAX_PIXELS} pixels, got {w} x {h}")
    fx, fy = (inputs.length(doc[k], f"{where}: {k}") for k in ("fx", "fy"))
    cx, cy = (inputs.real(doc[k], f"{where}: {k}") for k in ("cx", "cy"))
    scale = inputs.length(doc.get("depth_scale", 1.0), f"{where}: depth_scale")
    max_depth = inputs.length(doc["max_depth"], f"{where}: max_depth") if "max_depth" in doc else math.inf
    frames = inputs.items(doc["frames"], f"{where}: frames")
    if not frames:
        raise ValueError(f"{where}: frames: give at least one frame")
    if len(frames) > MAX_FRAMES:
        raise ValueError(f"{where}: frames: at most {MAX_FRAMES}, got {len(frames)}")
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    rays = np.stack([(u - cx) / fx, (v - cy) / fy, np.ones_like(u)], axis=-1)
    out = []
    for i, frame in enumerate(frames):
        name = f"{where}: frames[{i}]"
        frame = inputs.mapping(frame, name, required=("depth", "pose"), allowed=("depth", "pose"))
        if not isinstance(frame["depth"], str) or not frame["depth"]:
            raise ValueError(f"{name}.depth: expected a file name, got {inputs.show(frame['depth'])}")
        T = rigid_transform(frame["pose"], f"{name}.pose")
        depth = _image(folder / frame["depth"], f"{name}.depth", (h, w), scale)
        seen = np.isfinite(depth) & (depth <= max_depth)
        local = rays[seen] * depth[seen][:, None]
        out.append(local @ T[:3, :3].T + T[:3, 3])
    return np.concatenate(out)
