"""Rigid transforms: elementary rotations, homogeneous poses, frames from directions.

All functions accept batched angles/vectors (leading axes broadcast) and return float64.
"""

from __future__ import annotations

import math

import numpy as np

from snakeplan.jit import kernel

#: A heading closer than this (|cos|) to world z takes world x as :func:`frame_into`'s reference.
VERTICAL_COS = 0.9


def rot_x(angle) -> np.ndarray:
    """Rotation matrix about x by ``angle`` (rad); shape ``angle.shape + (3, 3)``."""
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(angle) -> np.ndarray:
    """Rotation matrix about y by ``angle`` (rad)."""
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def rot_z(angle) -> np.ndarray:
    """Rotation matrix about z by ``angle`` (rad)."""
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def pose(rotation=None, translation=None) -> np.ndarray:
    """4x4 homogeneous transform from a 3x3 rotation and a translation (mm)."""
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = rotation
    if translation is not None:
        T[:3, 3] = translation
    return T


def translation(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    """4x4 pure translation (mm)."""
    return pose(translation=[x, y, z])


def normalize(v, eps: float = 1e-12) -> np.ndarray:
    """Unit vectors along the last axis; raises on a zero vector."""
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    if np.any(n < eps):
        raise ValueError("cannot normalise a zero-length vector")
    return v / n


@kernel
def frame_into(d, out):
    """Rows (heading, side, up) of the frame of unit heading ``d`` into ``out (3, 3)``, compiled: side = ref x d,
    ref = world z (world x for a heading within ``VERTICAL_COS`` of vertical), up = d x side, so that up leans to
    world z."""
    x, y, z = d[0], d[1], d[2]
    if abs(z) >= VERTICAL_COS:
        sx, sy, sz = 0.0, -z, y
    else:
        sx, sy, sz = -y, x, 0.0
    n = math.sqrt(sx * sx + sy * sy + sz * sz)
    sx, sy, sz = sx / n, sy / n, sz / n
    out[0, 0], out[0, 1], out[0, 2] = x, y, z
    out[1, 0], out[1, 1], out[1, 2] = sx, sy, sz
    out[2, 0], out[2, 1], out[2, 2] = y * sz - z * sy, z * sx - x * sz, x * sy - y * sx


def any_perpendicular(d) -> np.ndarray:
    """A unit vector perpendicular to unit vector ``d`` (deterministic choice)."""
    d = normalize(d)
    helper = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    return normalize(np.cross(d, helper))


def frame_from_z(direction, up_hint=None) -> np.ndarray:
    """Rotation whose third column (local z) is ``direction``; x is chosen perpendicular to it.

    ``up_hint`` (optional) fixes the roll: local y is as close to it as possible.
    """
    z = normalize(direction)
    if up_hint is None:
        x = any_perpendicular(z)
    else:
        h = np.asarray(up_hint, dtype=float)
        y0 = h - np.dot(h, z) * z
        if np.linalg.norm(y0) < 1e-9:
            x = any_perpendicular(z)
        else:
            x = np.cross(normalize(y0), z)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=-1)


def angle_between(u, v) -> np.ndarray:
    """Angle (rad) between vectors along the last axis, robust near 0 and pi."""
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    cross = np.linalg.norm(np.cross(u, v), axis=-1)
    dot = np.sum(u * v, axis=-1)
    return np.arctan2(cross, dot)
