"""Points of interest on obstacle surfaces: area-uniform samples, each on its obstacle's exact surface, with the
surface's normal line there and the obstacle it lies on (mm).

Samples are drawn on the obstacles' tessellations (:func:`snakeplan.geometry.tessellation.obstacle_mesh`), faces
chosen in proportion to their area and points uniform within a face, so the density per mm² is the same on every
surface. A primitive's sample is then moved onto its exact surface (Newton steps on the obstacle's own signed
distance) and takes that distance's gradient as its normal; a mesh's sample is on its triangle already and takes
the triangle's normal. A normal is a line, not a side: a camera may see a surface from either side (an open
shell's, a CAD mesh whose faces are wound either way); which side faces the camera is the ray cast's to say.

A sample lying deeper than ``BURIED_MM`` inside another obstacle (a box face flush inside a plate) is no surface
anyone can look at and is dropped. ``depth`` says how deep a sample lies inside its own obstacle's material: 0 on
an exact surface, half the thickness on the mid-surface of a shell (an open mesh); a ray cast towards it stops
that much short.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Mesh, Obstacle, Points

#: How deep (mm) a sample may lie inside another obstacle and still count as surface.
BURIED_MM = 1.0
#: Newton steps that move a primitive's sample onto its exact surface, and the gradient's difference step (mm).
PROJECTION_STEPS = 3
GRADIENT_STEP_MM = 1e-3
#: Most samples drawn before the region is applied (a spacing far too fine for the surfaces is refused).
MAX_DRAWN = 400_000


@dataclass(frozen=True)
class SurfacePoints:
    """Points (n, 3) mm on obstacle surfaces, unit normals (n, 3) (a line: either sign), the index of the
    obstacle each lies on (n,), how deep each lies in its own obstacle's material (n,) mm, and the spacing (mm)
    they were drawn at (one point per spacing² of area on average)."""

    points: np.ndarray
    normals: np.ndarray
    obstacle: np.ndarray
    depth: np.ndarray
    spacing_mm: float

    def __len__(self) -> int:
        return len(self.points)

    def subset(self, keep: np.ndarray) -> SurfacePoints:
        return SurfacePoints(self.points[keep], self.normals[keep], self.obstacle[keep], self.depth[keep],
                             self.spacing_mm)


#: Most points of a cloud whose splats :func:`surface_triangles` gives.
SPLAT_POINTS = 20_000


def surface_triangles(obstacle: Obstacle) -> np.ndarray:
    """The triangles (t, 3, 3) mm of an obstacle's surface: a mesh's own, a primitive's tessellation; a cloud's,
    one splat per point (at most :data:`SPLAT_POINTS`): a triangle about the point, its corners a radius away."""
    if isinstance(obstacle, Mesh):
        return obstacle.triangles()
    if isinstance(obstacle, Points):
        corners = obstacle.radius * (np.eye(3) - 1.0 / 3.0) * math.sqrt(1.5)
        return obstacle.sample(SPLAT_POINTS)[:, None, :] + corners[None]
    from snakeplan.geometry.tessellation import obstacle_mesh

    return np.asarray(obstacle_mesh(obstacle).triangles, dtype=float)


def surface_area(obstacles: Sequence[Obstacle], which: Sequence[int]) -> float:
    """Total surface area (mm²) of the obstacles ``which``, as their triangles have it."""
    return float(sum(_areas(surface_triangles(obstacles[k])).sum() for k in which))


def _areas(tri: np.ndarray) -> np.ndarray:
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)


def _gradient(obstacle: Obstacle, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(signed distance (m,), its central-difference gradient (m, 3)) of ``obstacle`` at points ``p`` (m, 3)."""
    h = GRADIENT_STEP_MM
    offsets = np.vstack([np.zeros(3), h * np.eye(3), -h * np.eye(3)])
    d = obstacle.signed_distance(p[:, None, :] + offsets[None]).reshape(len(p), 7)
    return d[:, 0], (d[:, 1:4] - d[:, 4:7]) / (2 * h)


def sample_surfaces(obstacles: Sequence[Obstacle], which: Sequence[int], spacing_mm: float,
                    region: tuple[np.ndarray, np.ndarray], seed: int = 0, most: int = MAX_DRAWN) -> SurfacePoints:
    """Area-uniform points of interest on the surfaces of ``obstacles[k]`` for k in ``which``, one per
    ``spacing_mm``² of area on average, inside the box ``region`` (lo, hi) mm; see the module. The same inputs give
    the same points. ValueError naming ``spacing_mm`` for a spacing that would draw over ``most`` points."""
    tris = [surface_triangles(obstacles[k]) for k in which]
    areas = [_areas(t) for t in tris]
    total = float(sum(a.sum() for a in areas))
    drawn = math.ceil(total / spacing_mm**2) if total > 0 else 0
    if drawn > most:
        raise ValueError(f"spacing_mm: {spacing_mm:g} mm draws {drawn} points on {total / 1e6:.3g} m² of surface "
                         f"(at most {most}); use at least {math.sqrt(total / most):.3g} mm")
    empty = SurfacePoints(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, dtype=np.int64), np.zeros(0), spacing_mm)
    if drawn == 0:
        return empty
    rng = np.random.default_rng(seed)
    tri = np.concatenate(tris)
    area = np.concatenate(areas)
    owner = np.concatenate([np.full(len(t), k, dtype=np.int64) for k, t in zip(which, tris)])
    face = rng.choice(len(tri), size=drawn, p=area / area.sum())
    r1, r2 = np.sqrt(rng.random(drawn)), rng.random(drawn)
    t = tri[face]
    points = (1 - r1)[:, None] * t[:, 0] + (r1 * (1 - r2))[:, None] * t[:, 1] + (r1 * r2)[:, None] * t[:, 2]
    normals = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    depth = np.zeros(drawn)
    obstacle = owner[face]
    for k in np.unique(obstacle):
        sel = np.flatnonzero(obstacle == k)
        o = obstacles[k]
        if isinstance(o, Mesh):
            depth[sel] = np.maximum(-o.signed_distance(points[sel]), 0.0)
            continue
        p = points[sel]
        for _ in range(PROJECTION_STEPS):
            d, g = _gradient(o, p)
            p = p - d[:, None] * g / np.maximum(np.einsum("ij,ij->i", g, g), 1e-300)[:, None]
        d, g = _gradient(o, p)
        points[sel], normals[sel], depth[sel] = p, g, np.maximum(-d, 0.0)
    normals /= np.maximum(np.linalg.norm(normals, axis=1), 1e-300)[:, None]
    lo, hi = (np.asarray(b, dtype=float) for b in region)
    keep = np.all((points >= lo) & (points <= hi), axis=1)
    if keep.any():
        exposed = ObstacleSet(obstacles).signed_distance(points[keep]) >= -(depth[keep] + BURIED_MM)
        keep[np.flatnonzero(keep)[~exposed]] = False
    return SurfacePoints(points, normals, obstacle, depth, spacing_mm).subset(keep)
