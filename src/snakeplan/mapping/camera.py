"""Camera visibility and noise model (paper 002, §3.1) over the nodes of a surface mesh.

A node x (unit normal n) is measured by a camera at c looking along unit v when
(1) it lies in the field of view: the angle between v and x - c is at most the half-angle (a circular cone);
(2) its distance d = |x - c| is in [d_min, d_max];
(3) its incidence, the angle between n and c - x, is at most alpha_max;
(4) nothing hides it: a ray from the node towards the camera (trimesh + embree) hits no occluder before c.
The measurement is the true value plus Gaussian noise of variance a (1 - exp(-b d)), d in metres, a = 0.04 K^2,
b = 0.15 /m (Popovic et al.'s model, the pair of paper 002).

The model's parameters and defaults: :mod:`snakeplan.mapping.models`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from snakeplan.jit import kernel
from snakeplan.mapping.models import CameraModel

#: A ray starts this far (mm) from its node, so the node's own faces do not hide it.
OCCLUSION_EPS_MM = 1.0


@dataclass(frozen=True)
class Sightings:
    """Nodes seen from a batch of camera poses, flat: pose index, node index and distance (mm) per sighting."""

    pose: np.ndarray
    node: np.ndarray
    distance: np.ndarray

    def of_pose(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(nodes, distances) seen from pose ``k``."""
        sel = self.pose == k
        return self.node[sel], self.distance[sel]


class SurfaceCamera:
    """The camera model bound to a surface mesh (the measured nodes) and the meshes that can hide them.

    ``occluders`` are extra (vertices, faces) meshes (mm); the surface itself always occludes.
    """

    def __init__(self, vertices: ArrayLike, faces: ArrayLike, model: CameraModel | None = None,
                 occluders: Sequence[tuple[ArrayLike, ArrayLike]] = ()) -> None:
        import trimesh  # the ray caster, only where a camera is bound to a surface

        from snakeplan.mapping.gp import vertex_normals

        self.model = model or CameraModel()
        self.nodes = np.asarray(vertices, dtype=float)
        F = np.asarray(faces, dtype=np.int64)
        self.normals = vertex_normals(self.nodes, F)
        parts = [trimesh.Trimesh(self.nodes, F, process=False)]
        parts += [trimesh.Trimesh(np.asarray(v, dtype=float), np.asarray(f, dtype=np.int64), process=False)
                  for v, f in occluders]
        scene = trimesh.util.concatenate(parts)
        self._tri = np.asarray(scene.triangles)
        self._tri_normals = np.asarray(scene.face_normals)
        self._rays = scene.ray

    def candidates(self, positions: ArrayLike, directions: ArrayLike) -> Sightings:
        """Sightings that pass conditions (1)-(3) (no occlusion test)."""
        return in_view(self.nodes, self.normals, positions, directions, self.model)

    def visible(self, positions: ArrayLike, directions: ArrayLike) -> Sightings:
        """Sightings from each pose (positions (k, 3) mm, view directions (k, 3)) that pass all four tests."""
        s = self.candidates(positions, directions)
        if s.node.size == 0:
            return s
        c = np.asarray(positions, dtype=float).reshape(-1, 3)[s.pose]
        x = self.nodes[s.node]
        u = (c - x) / s.distance[:, None]
        origin = x + OCCLUSION_EPS_MM * u
        hit = self._rays.intersects_first(origin, u)
        clear = hit < 0
        h = np.flatnonzero(~clear)
        if h.size:
            tri, n = self._tri[hit[h]], self._tri_normals[hit[h]]
            denom = np.einsum("ij,ij->i", u[h], n)
            t = np.einsum("ij,ij->i", tri[:, 0] - origin[h], n) / np.where(np.abs(denom) > 1e-12, denom, 1e-12)
            clear[h] = t >= s.distance[h] - OCCLUSION_EPS_MM
        return Sightings(s.pose[clear], s.node[clear], s.distance[clear])

    def measure(self, position: ArrayLike, direction: ArrayLike, truth: ArrayLike, rng: np.random.Generator
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Simulated measurement from one pose: (nodes, noisy values K, noise variances K^2)."""
        s = self.visible(position, direction)
        r = self.model.noise_variance(s.distance)
        y = np.asarray(truth, dtype=float)[s.node] + rng.normal(0.0, np.sqrt(r))
        return s.node, y, r


def in_view(nodes: ArrayLike, normals: ArrayLike, positions: ArrayLike, directions: ArrayLike, model: CameraModel,
            two_sided: bool = False) -> Sightings:
    """Sightings of ``nodes`` (n, 3) mm with unit ``normals`` from cameras at ``positions`` (k, 3) mm looking along
    ``directions`` (k, 3) that pass tests (1)-(3) of the module (no occlusion test); ``two_sided``: a normal is a
    line, and the incidence is measured from whichever side faces the camera."""
    c = np.ascontiguousarray(np.asarray(positions, dtype=float).reshape(-1, 3))
    v = np.asarray(directions, dtype=float).reshape(-1, 3)
    v = np.ascontiguousarray(v / np.linalg.norm(v, axis=1, keepdims=True))
    pose, node, d = _sightings(np.ascontiguousarray(nodes, dtype=float), np.ascontiguousarray(normals, dtype=float),
                               c, v, model.d_min, model.d_max, math.cos(model.fov_half_angle),
                               math.cos(model.incidence_max), bool(two_sided))
    return Sightings(pose, node, d)


@kernel
def _sightings(nodes, normals, c, v, d_min, d_max, cos_fov, cos_incidence, two_sided):
    """(pose, node, distance) of every node within [d_min, d_max] of a pose, inside its field of view and
    facing it within the incidence limit, pose by pose and in node order: one pass, no (poses, nodes, 3)
    differences. A NaN pose or direction sees nothing (every test must hold, as a comparison with NaN does not)."""
    count = 0
    pose = np.empty(c.shape[0] * nodes.shape[0], dtype=np.int64)
    node = np.empty_like(pose)
    dist = np.empty(pose.shape[0])
    for k in range(c.shape[0]):
        for n in range(nodes.shape[0]):
            dx, dy, dz = nodes[n, 0] - c[k, 0], nodes[n, 1] - c[k, 1], nodes[n, 2] - c[k, 2]
            d = math.sqrt(dx * dx + dy * dy + dz * dz)
            if not (d >= d_min and d <= d_max):
                continue
            if not (dx * v[k, 0] + dy * v[k, 1] + dz * v[k, 2] >= cos_fov * d):
                continue
            facing = -(dx * normals[n, 0] + dy * normals[n, 1] + dz * normals[n, 2])
            if two_sided:
                facing = abs(facing)
            if not (facing >= cos_incidence * d):
                continue
            pose[count], node[count], dist[count] = k, n, d
            count += 1
    return pose[:count].copy(), node[:count].copy(), dist[:count].copy()
