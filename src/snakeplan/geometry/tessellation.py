"""Obstacles as triangle meshes (trimesh, mm, scene frame): what pages draw and where points of interest are
sampled. trimesh (and shapely for a plate's hole) load inside the function."""

from __future__ import annotations

import numpy as np

from snakeplan.geometry.primitives import Box, Cylinder, Mesh, Obstacle, Pipe, Plate, Sphere

#: Segments round a curved outline (cylinders, pipes, holes).
SECTIONS = 48


def _pose(rotation: np.ndarray, center: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = rotation
    T[:3, 3] = center
    return T


def obstacle_mesh(o: Obstacle):
    """The surface of one obstacle as a ``trimesh.Trimesh``; TypeError for an obstacle type it does not know."""
    import trimesh
    from trimesh import creation

    if isinstance(o, Box):
        return creation.box(extents=o.size, transform=_pose(o.rotation, o.center))
    if isinstance(o, Sphere):
        m = creation.icosphere(subdivisions=2, radius=o.radius)
        m.apply_translation(o.center)
        return m
    if isinstance(o, Cylinder):
        return creation.cylinder(radius=o.radius, height=o.length, sections=SECTIONS,
                                 transform=_pose(o.frame(), o.center))
    if isinstance(o, Pipe):
        return creation.annulus(r_min=o.inner_radius, r_max=o.outer_radius, height=o.length, sections=SECTIONS,
                                transform=_pose(o.frame(), o.center))
    if isinstance(o, Plate):
        from shapely.geometry import Polygon, box

        w, h = o.size
        outline = box(-w / 2, -h / 2, w / 2, h / 2)
        if o.hole is not None:
            (u, v), (a, b) = o.hole["offset"], o.hole["semi_axes"]
            t = np.linspace(0.0, 2 * np.pi, SECTIONS, endpoint=False)
            outline = Polygon(outline.exterior.coords, [np.column_stack([u + a * np.cos(t), v + b * np.sin(t)])])
        rotation = np.stack([o.side, o.up, o.normal], axis=1)
        return creation.extrude_polygon(outline, height=o.thickness,
                                        transform=_pose(rotation, o.center - o.normal * o.thickness / 2))
    if isinstance(o, Mesh):
        return trimesh.Trimesh(o.vertices, o.faces, process=False)
    raise TypeError(f"cannot mesh obstacle type {type(o).__name__}")
