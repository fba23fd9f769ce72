"""Watertight triangle meshes built from solids with manifold3d: obstacle primitives, sweeps and booleans.

The mesh scene families and the mesh benchmarks build their geometry here: :func:`solid` turns any obstacle
primitive into a manifold solid, :func:`to_mesh` joins solids into one closed :class:`Mesh` and refines it to a
triangle count (refinement splits flat faces, so the shape does not change). manifold3d guarantees the result is
closed and edge-manifold, the condition for the signed distance of :mod:`snakeplan.geometry.mesh_distance`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from snakeplan.geometry.primitives import Box, Cylinder, Mesh, Obstacle, Pipe, Plate, Sphere

#: Segments around a full circle when a curved primitive is meshed.
CIRCLE_SEGMENTS = 96


def _placed(m, rotation: np.ndarray, center: np.ndarray):
    """``m`` (built in a local frame) moved to world: p = rotation @ local + center."""
    return m.transform(np.hstack([np.asarray(rotation, float), np.asarray(center, float)[:, None]]).tolist())


def solid(o: Obstacle, segments: int = CIRCLE_SEGMENTS):
    """The manifold3d solid of an obstacle primitive (curved surfaces as ``segments``-gons)."""
    from manifold3d import Manifold
    from manifold3d import Mesh as MMesh

    if isinstance(o, Box):
        return _placed(Manifold.cube(o.size.tolist(), center=True), o.rotation, o.center)
    if isinstance(o, Sphere):
        return Manifold.sphere(o.radius, segments).translate(o.center.tolist())
    if isinstance(o, Cylinder):
        return _placed(Manifold.cylinder(o.length, o.radius, o.radius, segments, True), o.frame(), o.center)
    if isinstance(o, Pipe):
        outer = Manifold.cylinder(o.length, o.outer_radius, o.outer_radius, segments, True)
        inner = Manifold.cylinder(o.length * 1.01, o.inner_radius, o.inner_radius, segments, True)
        return _placed(outer - inner, o.frame(), o.center)
    if isinstance(o, Plate):
        w, h = o.size
        m = Manifold.cube([o.thickness, w, h], center=True)
        if o.hole is not None:
            (u, v), (a, b) = o.hole["offset"], o.hole["semi_axes"]
            # a unit circle along z, scaled to the ellipse, turned so its axis is local x (the plate's normal)
            hole = Manifold.cylinder(2.0 * o.thickness, 1.0, 1.0, segments, True).scale([a, b, 1.0])
            hole = hole.transform([[0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 0.0, u], [0.0, 1.0, 0.0, v]])
            m = m - hole
        return _placed(m, o.frame(), o.center)
    if isinstance(o, Mesh):
        return Manifold(MMesh(vert_properties=np.asarray(o.vertices, np.float32),
                              tri_verts=np.asarray(o.faces, np.uint32)))
    raise ValueError(f"obstacle: cannot mesh a {o.type}")


def to_mesh(solids: Sequence, triangles: int | None = None) -> Mesh:
    """One closed :class:`Mesh` of the union of manifold3d ``solids``; with ``triangles``, its faces split evenly
    until it has at least that many."""
    from manifold3d import Manifold, OpType

    m = Manifold.batch_boolean(list(solids), OpType.Add)
    if triangles is not None and m.num_tri() < triangles:
        m = m.refine(max(2, math.ceil(math.sqrt(triangles / m.num_tri()))))
    out = m.to_mesh64() if hasattr(m, "to_mesh64") else m.to_mesh()
    return Mesh(np.asarray(out.vert_properties, float)[:, :3], np.asarray(out.tri_verts, np.int64))


def obstacles_mesh(obstacles: Sequence[Obstacle], triangles: int | None = None,
                   segments: int = CIRCLE_SEGMENTS) -> Mesh:
    """The union of ``obstacles`` as one closed mesh (the same scene as primitives, for comparisons)."""
    return to_mesh([solid(o, segments) for o in obstacles], triangles)
