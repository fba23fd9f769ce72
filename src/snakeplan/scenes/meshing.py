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

from snakeplan.geometry.primitives import (
    Box,
    Cylinder,
    Mesh,
    Obstacle,
    Pipe,
    Plate,
    Sphere,
)

#: Segments around a full circle when a curved primitive is meshed.
CIRCLE_SEGMENTS = 96
#: How far (mm) a swept bar's straight parts reach into its bends: end caps that coincide with a bend's would
#: leave a membrane of two coincident faces once vertices are merged (a file round trip); the overlap bulges the
#: surface by about overlap^2 / (2 bend radius), well under a micrometre.
SWEEP_OVERLAP_MM = 0.5


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
    (each edge into n) until it has at least that many."""
    from manifold3d import Manifold, OpType

    m = Manifold.batch_boolean(list(solids), OpType.Add)
    if triangles is not None:
        n = math.ceil(math.sqrt(triangles / m.num_tri()))
        if n >= 2:
            m = m.refine(n)
    out = m.to_mesh64() if hasattr(m, "to_mesh64") else m.to_mesh()
    return Mesh(np.asarray(out.vert_properties, float)[:, :3], np.asarray(out.tri_verts, np.int64))


def obstacles_mesh(obstacles: Sequence[Obstacle], triangles: int | None = None,
                   segments: int = CIRCLE_SEGMENTS) -> Mesh:
    """The union of ``obstacles`` as one closed mesh (the same scene as primitives, for comparisons)."""
    return to_mesh([solid(o, segments) for o in obstacles], triangles)


def _frame_from_z(z: np.ndarray) -> np.ndarray:
    """A rotation whose third column is the unit vector ``z``."""
    from snakeplan.geometry.transforms import any_perpendicular

    x = any_perpendicular(z)
    return np.stack([x, np.cross(z, x), z], axis=1)


def rod(p: np.ndarray, q: np.ndarray, radius: float, segments: int = CIRCLE_SEGMENTS):
    """A solid round bar from p to q (mm)."""
    from manifold3d import Manifold

    d = np.asarray(q, float) - np.asarray(p, float)
    length = float(np.linalg.norm(d))
    bar = Manifold.cylinder(length, radius, radius, segments, False)
    return _placed(bar, _frame_from_z(d / length), np.asarray(p, float))


def swept(points: Sequence, radius: float, bend_radius: float, segments: int = CIRCLE_SEGMENTS):
    """A round bar of ``radius`` swept along a polyline whose corners are rounded into circular arcs of
    ``bend_radius`` (mm; each straight must be long enough for the arcs at its ends)."""
    from manifold3d import CrossSection, Manifold, OpType

    P = np.asarray(points, dtype=float)
    parts = []
    start = P[0]
    for i in range(1, len(P) - 1):
        u = P[i] - P[i - 1]
        v = P[i + 1] - P[i]
        u /= np.linalg.norm(u)
        v /= np.linalg.norm(v)
        theta = math.acos(min(max(float(u @ v), -1.0), 1.0))
        if theta < 1e-9:
            continue
        cut = bend_radius * math.tan(theta / 2.0)
        t1 = P[i] - u * cut
        n = v - (v @ u) * u
        n /= np.linalg.norm(n)
        centre = t1 + bend_radius * n
        parts.append(rod(start, t1 + SWEEP_OVERLAP_MM * u, radius, segments))
        ring = CrossSection.circle(radius, segments).translate([bend_radius, 0.0])
        arc = Manifold.revolve(ring, segments, math.degrees(theta))
        x = -n
        R = np.stack([x, u, np.cross(x, u)], axis=1)
        parts.append(_placed(arc, R, centre))
        start = P[i] + v * (cut - SWEEP_OVERLAP_MM)
    parts.append(rod(start, P[-1], radius, segments))
    return Manifold.batch_boolean(parts, OpType.Add)


def pipe_run(points: Sequence, inner_radius: float, wall: float, bend_radius: float,
             segments: int = CIRCLE_SEGMENTS):
    """A pipe (wall ``wall`` mm around a bore of ``inner_radius``) along a polyline with rounded bends, open at
    both ends."""
    P = np.asarray(points, dtype=float)
    head = (P[0] - P[1]) / np.linalg.norm(P[0] - P[1])
    tail = (P[-1] - P[-2]) / np.linalg.norm(P[-1] - P[-2])
    bore = np.vstack([P[0] + head * wall, P[1:-1], P[-1] + tail * wall])
    return swept(P, inner_radius + wall, bend_radius, segments) - swept(bore, inner_radius, bend_radius, segments)
