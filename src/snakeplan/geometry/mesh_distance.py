"""Exact signed distance to triangle meshes: a bounding volume hierarchy over the triangles and pseudonormal signs.

The distance is the nearest triangle's, found by a best-first walk of the hierarchy (:mod:`snakeplan.geometry.bvh`)
that skips every box farther than the best triangle so far: exact, and about log(n) triangles per query instead of
all n. The sign of a closed mesh comes from the angle-weighted pseudonormal of the nearest feature (face, edge or
vertex; Baerentzen and Aanaes 2005): for a closed, consistently oriented, edge-manifold surface, the point lies
inside exactly when it lies behind that pseudonormal, so the sign costs nothing beyond the nearest triangle.

An open mesh (sheet metal exported as surfaces) is a shell: the material is every point within half its
``thickness`` of the surface, so its signed distance is ``unsigned distance - thickness / 2``.

Triangle data layout (per triangle, ``(7, 3)`` normals): the face normal, the pseudonormals of edges ab, bc, ca,
then of vertices a, b, c. Distances in mm.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from snakeplan.geometry import bvh

#: Thickness (mm) of the shell an open mesh stands for when its ``thickness`` is not given.
DEFAULT_SHELL_MM = 1.0


def topology(vertices: np.ndarray, faces: np.ndarray, name: str = "mesh") -> tuple[bool, np.ndarray]:
    """(closed, faces oriented outward) of a mesh; ValueError (``name.faces: ...``) for a non-manifold one.

    Closed means every edge is shared by exactly two faces that run along it in opposite directions; such a mesh
    whose signed volume is negative has its faces reversed. An edge shared by more than two faces, or two faces
    that both run along an edge in the same direction on an otherwise closed mesh, is an error."""
    F = np.asarray(faces, dtype=np.int64)
    if np.any((F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2])):
        i = int(np.flatnonzero((F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2]))[0])
        raise ValueError(f"{name}.faces[{i}]: a face repeats a vertex {F[i].tolist()}")
    directed = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)
    lo, hi = directed.min(axis=1), directed.max(axis=1)
    key = lo * (int(F.max()) + 1) + hi
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    if np.any(counts > 2):
        e = int(np.flatnonzero(counts[inverse] > 2)[0])
        raise ValueError(f"{name}.faces: non-manifold: the edge {int(lo[e])}-{int(hi[e])} is shared by "
                         f"{int(counts[inverse[e]])} faces (an edge may border at most two)")
    if np.any(counts == 1):
        return False, F
    forward = directed[:, 0] < directed[:, 1]
    balance = np.bincount(inverse, weights=np.where(forward, 1.0, -1.0))
    if np.any(balance != 0.0):
        e = int(np.flatnonzero(balance[inverse] != 0.0)[0])
        raise ValueError(f"{name}.faces: inconsistently oriented: two faces run along the edge {int(lo[e])}-"
                         f"{int(hi[e])} in the same direction (a closed mesh's faces must all face outward)")
    V = np.asarray(vertices, dtype=float)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    volume = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0
    return True, (F[:, ::-1].copy() if volume < 0.0 else F)


def _normalise(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, n, out=np.zeros_like(v), where=n > 0.0)


def pseudonormals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per face ``(7, 3)``: unit face normal, edge pseudonormals (ab, bc, ca; sum of the two faces' normals) and
    angle-weighted vertex pseudonormals (a, b, c). A face's own edge without a partner gets its own normal."""
    V = np.asarray(vertices, dtype=float)
    F = np.asarray(faces, dtype=np.int64)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    fn = _normalise(np.cross(b - a, c - a))
    out = np.empty((len(F), 7, 3))
    out[:, 0] = fn
    directed = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)
    nv = int(F.max()) + 1
    key = directed[:, 0] * nv + directed[:, 1]
    twin = directed[:, 1] * nv + directed[:, 0]
    sorter = np.argsort(key)
    pos = np.searchsorted(key[sorter], twin)
    pos = np.minimum(pos, len(key) - 1)
    found = key[sorter[pos]] == twin
    partner = np.where(found, sorter[pos] // 3, np.repeat(np.arange(len(F)), 3))
    out[:, 1:4] = (np.repeat(fn, 3, axis=0) + fn[partner]).reshape(-1, 3, 3)
    corners = np.stack([a, b, c], axis=1)
    angles = np.empty((len(F), 3))
    for j in range(3):
        u = _normalise(corners[:, (j + 1) % 3] - corners[:, j])
        w = _normalise(corners[:, (j + 2) % 3] - corners[:, j])
        angles[:, j] = np.arccos(np.clip(np.einsum("ij,ij->i", u, w), -1.0, 1.0))
    vn = np.zeros((len(V), 3))
    for j in range(3):
        np.add.at(vn, F[:, j], angles[:, j, None] * fn)
    out[:, 4:7] = vn[F]
    return out


def prepare(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(triangles ``(T, 3, 3)`` in leaf order, their normals ``(T, 7, 3)``, nodes, links) of a mesh whose faces are
    already oriented (:func:`topology`). Faces of zero area are left out: each of their points lies on a
    neighbour's edge."""
    V = np.asarray(vertices, dtype=float)
    F = np.asarray(faces, dtype=np.int64)
    normals = pseudonormals(V, F)
    tris = V[F]
    area = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    keep = np.flatnonzero(area > 0.0)
    tris, normals = tris[keep], normals[keep]
    boxes = np.concatenate([tris.min(axis=1), tris.max(axis=1)], axis=1)
    order, nodes, links = bvh.build(boxes)
    return np.ascontiguousarray(tris[order]), np.ascontiguousarray(normals[order]), nodes, links


@njit(cache=True)
def closest_on_triangle(p, a, b, c):
    """(squared distance, feature, closest point x, y, z) from p to triangle abc; feature indexes the normals
    layout (0 face, 1-3 edges ab, bc, ca, 4-6 vertices a, b, c). Voronoi regions as in Ericson, Real-Time
    Collision Detection, 5.1.5; scalar arithmetic only, so a query allocates nothing."""
    abx, aby, abz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    acx, acy, acz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    apx, apy, apz = p[0] - a[0], p[1] - a[1], p[2] - a[2]
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return apx * apx + apy * apy + apz * apz, 4, a[0], a[1], a[2]
    bpx, bpy, bpz = p[0] - b[0], p[1] - b[1], p[2] - b[2]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return bpx * bpx + bpy * bpy + bpz * bpz, 5, b[0], b[1], b[2]
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        qx, qy, qz = a[0] + v * abx, a[1] + v * aby, a[2] + v * abz
        rx, ry, rz = qx - p[0], qy - p[1], qz - p[2]
        return rx * rx + ry * ry + rz * rz, 1, qx, qy, qz
    cpx, cpy, cpz = p[0] - c[0], p[1] - c[1], p[2] - c[2]
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return cpx * cpx + cpy * cpy + cpz * cpz, 6, c[0], c[1], c[2]
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        qx, qy, qz = a[0] + w * acx, a[1] + w * acy, a[2] + w * acz
        rx, ry, rz = qx - p[0], qy - p[1], qz - p[2]
        return rx * rx + ry * ry + rz * rz, 3, qx, qy, qz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        qx, qy, qz = b[0] + w * (c[0] - b[0]), b[1] + w * (c[1] - b[1]), b[2] + w * (c[2] - b[2])
        rx, ry, rz = qx - p[0], qy - p[1], qz - p[2]
        return rx * rx + ry * ry + rz * rz, 2, qx, qy, qz
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    qx, qy, qz = a[0] + abx * v + acx * w, a[1] + aby * v + acy * w, a[2] + abz * v + acz * w
    rx, ry, rz = qx - p[0], qy - p[1], qz - p[2]
    return rx * rx + ry * ry + rz * rz, 0, qx, qy, qz


@njit(cache=True)
def mesh_sdf(tris, normals, nodes, links, root, half_thickness, p, stack):
    """Signed distance from p to the mesh whose tree has root node ``root``: a closed solid when
    ``half_thickness`` is 0 (pseudonormal sign), else a shell (unsigned distance - half_thickness).
    ``stack`` is an int64 work array of at least :data:`bvh.STACK_SIZE`."""
    best = np.inf
    tri = -1
    feature = 0
    qx = qy = qz = 0.0
    stack[0] = root
    top = 1
    while top > 0:
        top -= 1
        node = stack[top]
        if bvh.box_distance2(nodes[node], p) >= best:
            continue
        first = links[node, 0]
        second = links[node, 1]
        if second < 0:
            for t in range(first, first - second):
                d2, f, x, y, z = closest_on_triangle(p, tris[t, 0], tris[t, 1], tris[t, 2])
                if d2 < best:
                    best, tri, feature = d2, t, f
                    qx, qy, qz = x, y, z
            continue
        dl = bvh.box_distance2(nodes[first], p)
        dr = bvh.box_distance2(nodes[second], p)
        near, far, dnear, dfar = (first, second, dl, dr) if dl <= dr else (second, first, dr, dl)
        if dfar < best:
            stack[top] = far
            top += 1
        if dnear < best:
            stack[top] = near
            top += 1
    d = math.sqrt(best)
    if half_thickness > 0.0:
        return d - half_thickness
    n = normals[tri, feature]
    behind = (p[0] - qx) * n[0] + (p[1] - qy) * n[1] + (p[2] - qz) * n[2] < 0.0
    return -d if behind else d


@njit(cache=True)
def _solid_angle(p, a, b, c):
    """Signed solid angle of triangle abc seen from p (Van Oosterom and Strackee)."""
    ax, ay, az = a[0] - p[0], a[1] - p[1], a[2] - p[2]
    bx, by, bz = b[0] - p[0], b[1] - p[1], b[2] - p[2]
    cx, cy, cz = c[0] - p[0], c[1] - p[1], c[2] - p[2]
    la = math.sqrt(ax * ax + ay * ay + az * az)
    lb = math.sqrt(bx * bx + by * by + bz * bz)
    lc = math.sqrt(cx * cx + cy * cy + cz * cz)
    det = ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    div = la * lb * lc + (ax * bx + ay * by + az * bz) * lc + (ax * cx + ay * cy + az * cz) * lb
    div += (bx * cx + by * cy + bz * cz) * la
    return 2.0 * math.atan2(det, div)


@njit(cache=True)
def _reference(tris, pts, closed, half_thickness):
    out = np.empty(pts.shape[0])
    for i in range(pts.shape[0]):
        p = pts[i]
        best = np.inf
        winding = 0.0
        for t in range(tris.shape[0]):
            d2 = closest_on_triangle(p, tris[t, 0], tris[t, 1], tris[t, 2])[0]
            best = min(best, d2)
            winding += _solid_angle(p, tris[t, 0], tris[t, 1], tris[t, 2])
        d = math.sqrt(best)
        if closed:
            out[i] = -d if winding > 2.0 * math.pi else d
        else:
            out[i] = d - half_thickness
    return out


def reference_sdf(vertices, faces, points, thickness: float | None = None) -> np.ndarray:
    """Brute-force signed distance (every triangle; sign by winding number > 1/2) from ``points (n, 3)`` to a
    mesh, or ``unsigned - thickness / 2`` with ``thickness``: the independent reference for tests and benchmarks."""
    tris = np.ascontiguousarray(np.asarray(vertices, dtype=float)[np.asarray(faces, dtype=np.int64)])
    pts = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 3))
    half = 0.0 if thickness is None else thickness / 2.0
    return _reference(tris, pts, thickness is None, half)
