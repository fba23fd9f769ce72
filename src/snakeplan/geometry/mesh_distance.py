"""Exact signed distance to triangle meshes: a bounding volume hierarchy over the triangles and pseudonormal signs.

The distance is the nearest triangle's, found by a best-first walk of the hierarchy (:mod:`snakeplan.geometry.bvh`)
that skips every box farther than the best triangle so far: exact, and about log(n) triangles per query instead of
all n. The sign of a closed mesh comes from the angle-weighted pseudonormal of the nearest feature (face, edge or
vertex; Baerentzen and Aanaes 2005): for a closed, consistently oriented, edge-manifold surface, the point lies
inside exactly when it lies behind that pseudonormal, so the sign costs nothing beyond the nearest triangle. At a
vertex where closed parts touch (its faces form several fans) no one pseudonormal holds, so a point nearest it is
decided by :func:`mesh_inside` (one ray).

An open mesh (sheet metal exported as surfaces) is a shell: the material is every point within half its
``thickness`` of the surface, so its signed distance is ``unsigned distance - thickness / 2``.

Triangle data layout (per triangle, ``(7, 3)`` normals): the face normal, the pseudonormals of edges ab, bc, ca,
then of vertices a, b, c. Distances in mm.
"""

from __future__ import annotations

import math

import numpy as np

from snakeplan.geometry import bvh
from snakeplan.jit import kernel, leaf

#: Thickness (mm) of the shell an open mesh stands for when its ``thickness`` is not given.
DEFAULT_SHELL_MM = 1.0


def topology(vertices: np.ndarray, faces: np.ndarray, name: str = "mesh") -> tuple[bool, np.ndarray]:
    """(closed, faces oriented outward) of a mesh; ValueError (``name.faces: ...``) for a non-manifold one.

    Closed means every edge is shared by faces that run along it in opposite directions, as many each way: two,
    or four or more where closed parts touch along an edge (pinched); such a mesh whose signed volume is negative
    has its faces reversed. An edge shared by an odd number of faces above two, or by more than two faces not
    half each way, is non-manifold; two faces that both run along an edge in the same direction on an otherwise
    closed mesh are inconsistently oriented. Both are errors."""
    F = np.asarray(faces, dtype=np.int64)
    if np.any((F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2])):
        i = int(np.flatnonzero((F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2]))[0])
        raise ValueError(f"{name}.faces[{i}]: a face repeats a vertex {F[i].tolist()}")
    directed = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)
    lo, hi = directed.min(axis=1), directed.max(axis=1)
    key = lo * (int(F.max()) + 1) + hi
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    forward = directed[:, 0] < directed[:, 1]
    balance = np.bincount(inverse, weights=np.where(forward, 1.0, -1.0))
    bad = (counts > 2) & ((counts % 2 == 1) | (balance != 0.0))
    if np.any(bad):
        e = int(np.flatnonzero(bad[inverse])[0])
        raise ValueError(f"{name}.faces: non-manifold: the edge {int(lo[e])}-{int(hi[e])} is shared by "
                         f"{int(counts[inverse[e]])} faces (an edge may border two, or an even number half each way "
                         f"where closed parts touch)")
    if np.any(counts == 1):
        return False, F
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
    _pair_pinched(V, F, directed, partner, fn)
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
    out[:, 4:7][_pinched_corners(F, partner)] = 0.0
    return out


def _pinched_corners(F: np.ndarray, partner: np.ndarray) -> np.ndarray:
    """``(T, 3)`` True at the corners of vertices where closed parts touch: the faces around such a vertex form
    more than one fan (faces joined through the edges at the vertex, across each edge to its ``partner``). Their
    vertex pseudonormal is left zero: one sum over several parts' fans says nothing of a side, so the kernels
    decide a point nearest such a vertex by the inside test instead."""
    return _fans_split(np.ascontiguousarray(F, dtype=np.int64), np.ascontiguousarray(partner, dtype=np.int64),
                       int(F.max()) + 1)


@kernel
def _root(parent, x):
    while parent[x] != x:
        parent[x] = parent[parent[x]]
        x = parent[x]
    return x


@kernel
def _fans_split(F, partner, nv):
    """Union-find over the corners (3 per face, a few bytes each: a 2-million-triangle mesh needs no more)."""
    T = F.shape[0]
    parent = np.arange(3 * T)
    for f in range(T):
        for j in range(3):
            g = partner[3 * f + j]
            if g == f:
                continue
            for end in (j, (j + 1) % 3):
                v = F[f, end]
                k = 0 if F[g, 0] == v else (1 if F[g, 1] == v else 2)
                a = _root(parent, 3 * f + end)
                b = _root(parent, 3 * g + k)
                if a != b:
                    parent[a] = b
    first = np.full(nv, -1, dtype=np.int64)
    split = np.zeros(nv, dtype=np.bool_)
    for c in range(3 * T):
        v = F[c // 3, c % 3]
        r = _root(parent, c)
        if first[v] < 0:
            first[v] = r
        elif first[v] != r:
            split[v] = True
    out = np.empty((T, 3), dtype=np.bool_)
    for f in range(T):
        for j in range(3):
            out[f, j] = split[F[f, j]]
    return out


def _pair_pinched(V, F, directed, partner, fn) -> None:
    """Where closed parts touch along an edge (four or more faces), pair each face with the face across the
    material it bounds (the next face around the edge on its inner side), so the edge's pseudonormal is that
    part's. ``partner`` (per directed edge, the face across it) is corrected in place."""
    nv = int(F.max()) + 1
    undirected = np.minimum(directed[:, 0], directed[:, 1]) * nv + np.maximum(directed[:, 0], directed[:, 1])
    _, inverse, many = np.unique(undirected, return_inverse=True, return_counts=True)
    for group in np.flatnonzero(many > 2):
        rows = np.flatnonzero(inverse == group)
        i, j = directed[rows[0]]
        axis = V[j] - V[i]
        axis /= np.linalg.norm(axis)
        faces = rows // 3
        third = V[F[faces]].sum(axis=1) - V[i] - V[j]
        w = third - V[i]
        w -= np.outer(w @ axis, axis)
        ref = w[0] / np.linalg.norm(w[0])
        angle = np.arctan2(np.cross(ref, w) @ axis, w @ ref)
        order = np.argsort(angle)
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        for r, row in enumerate(rows):
            # the material lies behind the face (-normal): on the side of increasing angle when -n turns that way
            ahead = float(np.cross(axis, w[r]) @ -fn[faces[r]]) > 0.0
            step = 1 if ahead else -1
            partner[row] = faces[order[(rank[r] + step) % len(rows)]]


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


@leaf
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


@leaf
def mesh_sdf(tris, normals, nodes, links, root, half_thickness, p, stack, reach=np.inf):
    """Signed distance from p to the mesh whose tree has root node ``root``: a closed solid when
    ``half_thickness`` is 0 (pseudonormal sign), else a shell (unsigned distance - half_thickness).
    With a finite ``reach`` (mm) only the surface nearer than it is searched, and a point with none that near
    gets NaN (its distance is at least ``reach``; its side is the caller's to settle).
    ``stack`` is an int64 work array of at least :data:`bvh.STACK_SIZE`."""
    best = reach * reach
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
    if tri < 0:
        return np.nan
    d = math.sqrt(best)
    if half_thickness > 0.0:
        return d - half_thickness
    n = normals[tri, feature]
    if n[0] == 0.0 and n[1] == 0.0 and n[2] == 0.0:  # a vertex where closed parts touch
        return -d if mesh_inside(tris, normals, nodes, links, root, p, stack) else d
    behind = (p[0] - qx) * n[0] + (p[1] - qy) * n[1] + (p[2] - qz) * n[2] < 0.0
    return -d if behind else d


@kernel
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


@kernel
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


@kernel(inline="always")
def _segments_closest(ax, ay, az, bx, by, bz, px, py, pz, qx, qy, qz):
    """(squared distance, s, t) of the closest points a + s (b - a) and p + t (q - p) of two segments
    (Ericson, Real-Time Collision Detection, 5.1.9); scalar arithmetic only, so a call allocates nothing."""
    d1x, d1y, d1z = bx - ax, by - ay, bz - az
    d2x, d2y, d2z = qx - px, qy - py, qz - pz
    rx, ry, rz = ax - px, ay - py, az - pz
    aa = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    if aa <= 1e-300 and e <= 1e-300:
        return rx * rx + ry * ry + rz * rz, 0.0, 0.0
    if aa <= 1e-300:
        s = 0.0
        t = min(max(f / e, 0.0), 1.0)
    else:
        c = d1x * rx + d1y * ry + d1z * rz
        if e <= 1e-300:
            t = 0.0
            s = min(max(-c / aa, 0.0), 1.0)
        else:
            bb = d1x * d2x + d1y * d2y + d1z * d2z
            denom = aa * e - bb * bb
            s = min(max((bb * f - c * e) / denom, 0.0), 1.0) if denom > 0.0 else 0.0
            t = (bb * s + f) / e
            if t < 0.0:
                t = 0.0
                s = min(max(-c / aa, 0.0), 1.0)
            elif t > 1.0:
                t = 1.0
                s = min(max((bb - c) / aa, 0.0), 1.0)
    x = rx + s * d1x - t * d2x
    y = ry + s * d1y - t * d2y
    z = rz + s * d1z - t * d2z
    return x * x + y * y + z * z, s, t


@kernel(inline="always")
def _left_of(px, py, pz, qx, qy, qz, x, y, z, nx, ny, nz):
    """Whether (x, y, z) lies on the inner side of the directed edge p -> q of a triangle of normal n."""
    ex, ey, ez = qx - px, qy - py, qz - pz
    wx, wy, wz = x - px, y - py, z - pz
    return nx * (ey * wz - ez * wy) + ny * (ez * wx - ex * wz) + nz * (ex * wy - ey * wx) >= 0.0


@leaf
def segment_triangle(a, b, tris, t):
    """(squared distance, feature, s, closest triangle point x, y, z) between segment a + s (b - a) and triangle
    ``tris[t]`` (features as :func:`closest_on_triangle`; a crossing is distance 0 on the face).

    The closest pair is a crossing, an end of the segment over the face (its foot on the plane inside the
    triangle), or a point of the segment against an edge; so each end costs a plane projection, not a full
    point-triangle search, and the crossing is tested only when the ends lie on both sides of the plane. Scalar
    arithmetic only: a call allocates nothing."""
    ax, ay, az, bx, by, bz = a[0], a[1], a[2], b[0], b[1], b[2]
    x0, y0, z0 = tris[t, 0, 0], tris[t, 0, 1], tris[t, 0, 2]
    x1, y1, z1 = tris[t, 1, 0], tris[t, 1, 1], tris[t, 1, 2]
    x2, y2, z2 = tris[t, 2, 0], tris[t, 2, 1], tris[t, 2, 2]
    e1x, e1y, e1z = x1 - x0, y1 - y0, z1 - z0
    e2x, e2y, e2z = x2 - x0, y2 - y0, z2 - z0
    nx = e1y * e2z - e1z * e2y
    ny = e1z * e2x - e1x * e2z
    nz = e1x * e2y - e1y * e2x
    nn = nx * nx + ny * ny + nz * nz
    best = np.inf
    feature = 0
    s_best = 0.0
    x = y = z = 0.0
    if nn > 0.0:
        da = nx * (ax - x0) + ny * (ay - y0) + nz * (az - z0)
        db = nx * (bx - x0) + ny * (by - y0) + nz * (bz - z0)
        if (da <= 0.0 <= db or db <= 0.0 <= da) and da != db:
            s = da / (da - db)
            cx, cy, cz = ax + s * (bx - ax), ay + s * (by - ay), az + s * (bz - az)
            if (_left_of(x0, y0, z0, x1, y1, z1, cx, cy, cz, nx, ny, nz)
                    and _left_of(x1, y1, z1, x2, y2, z2, cx, cy, cz, nx, ny, nz)
                    and _left_of(x2, y2, z2, x0, y0, z0, cx, cy, cz, nx, ny, nz)):
                return 0.0, 0, s, cx, cy, cz
        for end in range(2):
            px, py, pz, dp = (ax, ay, az, da) if end == 0 else (bx, by, bz, db)
            d2 = dp * dp / nn
            if d2 < best:
                k = dp / nn
                fx, fy, fz = px - k * nx, py - k * ny, pz - k * nz
                if (_left_of(x0, y0, z0, x1, y1, z1, fx, fy, fz, nx, ny, nz)
                        and _left_of(x1, y1, z1, x2, y2, z2, fx, fy, fz, nx, ny, nz)
                        and _left_of(x2, y2, z2, x0, y0, z0, fx, fy, fz, nx, ny, nz)):
                    best, feature, s_best, x, y, z = d2, 0, float(end), fx, fy, fz
    d2, s, u = _segments_closest(ax, ay, az, bx, by, bz, x0, y0, z0, x1, y1, z1)
    if d2 < best:
        best, s_best = d2, s
        feature = 4 if u <= 0.0 else (5 if u >= 1.0 else 1)
        x, y, z = x0 + u * e1x, y0 + u * e1y, z0 + u * e1z
    d2, s, u = _segments_closest(ax, ay, az, bx, by, bz, x1, y1, z1, x2, y2, z2)
    if d2 < best:
        best, s_best = d2, s
        feature = 5 if u <= 0.0 else (6 if u >= 1.0 else 2)
        x, y, z = x1 + u * (x2 - x1), y1 + u * (y2 - y1), z1 + u * (z2 - z1)
    d2, s, u = _segments_closest(ax, ay, az, bx, by, bz, x2, y2, z2, x0, y0, z0)
    if d2 < best:
        best, s_best = d2, s
        feature = 6 if u <= 0.0 else (4 if u >= 1.0 else 3)
        x, y, z = x2 - u * e2x, y2 - u * e2y, z2 - u * e2z
    return best, feature, s_best, x, y, z


@leaf
def ray_triangle(o, d, t0, t1, t2):
    """(t, u, v): distance t >= 0 along the ray o + t d to triangle t0 t1 t2 and the hit's barycentric
    coordinates (t0 + u (t1 - t0) + v (t2 - t0); Moller-Trumbore), or (inf, 0, 0) when it misses."""
    e1x, e1y, e1z = t1[0] - t0[0], t1[1] - t0[1], t1[2] - t0[2]
    e2x, e2y, e2z = t2[0] - t0[0], t2[1] - t0[1], t2[2] - t0[2]
    h0 = d[1] * e2z - d[2] * e2y
    h1 = d[2] * e2x - d[0] * e2z
    h2 = d[0] * e2y - d[1] * e2x
    det = e1x * h0 + e1y * h1 + e1z * h2
    if det == 0.0:
        return np.inf, 0.0, 0.0
    inv = 1.0 / det
    sx, sy, sz = o[0] - t0[0], o[1] - t0[1], o[2] - t0[2]
    u = (sx * h0 + sy * h1 + sz * h2) * inv
    if u < 0.0 or u > 1.0:
        return np.inf, 0.0, 0.0
    qx = sy * e1z - sz * e1y
    qy = sz * e1x - sx * e1z
    qz = sx * e1y - sy * e1x
    v = (d[0] * qx + d[1] * qy + d[2] * qz) * inv
    if v < 0.0 or u + v > 1.0:
        return np.inf, 0.0, 0.0
    t = (e2x * qx + e2y * qy + e2z * qz) * inv
    return (t, u, v) if t >= 0.0 else (np.inf, 0.0, 0.0)


@leaf
def mesh_ray(tris, nodes, links, root, o, d, t_max, stack):
    """(t, triangle, u, v) of the first hit of the ray o + t d, t in [0, t_max], on the mesh whose tree has root
    node ``root`` (u, v: its barycentric coordinates, as :func:`ray_triangle`), or (inf, -1, 0, 0): the tree's
    boxes are entered nearest first and skipped beyond the best hit."""
    best = t_max
    tri = -1
    bu = bv = 0.0
    stack[0] = root
    top = 1
    while top > 0:
        top -= 1
        node = stack[top]
        if bvh.ray_box(nodes[node], o, d, best) == np.inf:
            continue
        first = links[node, 0]
        second = links[node, 1]
        if second < 0:
            for t in range(first, first - second):
                h, u, v = ray_triangle(o, d, tris[t, 0], tris[t, 1], tris[t, 2])
                if h <= best and h < np.inf:
                    best, tri, bu, bv = h, t, u, v
            continue
        tl = bvh.ray_box(nodes[first], o, d, best)
        tr = bvh.ray_box(nodes[second], o, d, best)
        near, far, tnear, tfar = (first, second, tl, tr) if tl <= tr else (second, first, tr, tl)
        if tfar < np.inf:
            stack[top] = far
            top += 1
        if tnear < np.inf:
            stack[top] = near
            top += 1
    return (best, tri, bu, bv) if tri >= 0 else (np.inf, -1, 0.0, 0.0)


#: Directions of the inside test's rays: irrational-looking, so a ray rarely runs along an edge of a CAD mesh.
_INSIDE_RAYS = np.array([[0.5366563146, 0.6260990337, 0.5656854249],
                         [-0.7071067812, 0.3015113446, 0.6396021491],
                         [0.2672612419, -0.8017837257, 0.5345224838],
                         [-0.3713906764, -0.5570860145, -0.7427813527],
                         [0.8164965809, -0.4082482905, -0.4082482905],
                         [-0.2236067977, 0.8944271910, -0.3872983346]])
#: Least barycentric coordinate of a hit that the inside test trusts: nearer a triangle's edge, the ray may cross
#: an edge or a vertex without crossing the surface (a graze), so it is cast again in another direction.
_INSIDE_MARGIN = 1e-6


@leaf
def mesh_inside(tris, normals, nodes, links, root, p, stack):
    """Whether p lies inside the closed mesh whose tree has root node ``root``: a ray from p whose first surface
    it meets inside a face (not at an edge or a vertex, where a ray may graze the surface without crossing it)
    crosses that face outward exactly when p is inside. A ray that meets an edge, a vertex or a face edge-on is
    cast again in another direction. Cost: one ray through the tree, a few dozen boxes, not a distance search."""
    box = nodes[root]
    for a in range(3):
        if p[a] < box[a] or p[a] > box[a + 3]:
            return False
    inside = False
    for r in range(_INSIDE_RAYS.shape[0]):
        d = _INSIDE_RAYS[r]
        t, tri, u, v = mesh_ray(tris, nodes, links, root, p, d, np.inf, stack)
        if tri < 0:
            return False
        n = normals[tri, 0]
        c = d[0] * n[0] + d[1] * n[1] + d[2] * n[2]
        inside = c > 0.0
        if min(u, v, 1.0 - u - v) > _INSIDE_MARGIN and abs(c) > 1e-6:
            return inside
    return inside


def triangle_balls(tris: np.ndarray) -> np.ndarray:
    """Per triangle ``(T, 4)``: a ball (centre, radius) that holds it: the mean of its corners, radius to the
    farthest corner."""
    centre = tris.mean(axis=1)
    radius = np.linalg.norm(tris - centre[:, None, :], axis=2).max(axis=1)
    return np.ascontiguousarray(np.concatenate([centre, radius[:, None]], axis=1))


@leaf
def point_on(a, b, t, out):
    """a + t (b - a) into ``out`` (3,) (mm), without a temporary array (the kernels allocate nothing per call)."""
    out[0] = a[0] + t * (b[0] - a[0])
    out[1] = a[1] + t * (b[1] - a[1])
    out[2] = a[2] + t * (b[2] - a[2])


@leaf
def _segment_point2(a, b, c):
    """Squared distance from point c (its first 3 entries) to segment ab."""
    dx, dy, dz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    wx, wy, wz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    dd = dx * dx + dy * dy + dz * dz
    t = 0.0 if dd <= 0.0 else min(max((wx * dx + wy * dy + wz * dz) / dd, 0.0), 1.0)
    ux, uy, uz = wx - t * dx, wy - t * dy, wz - t * dz
    return ux * ux + uy * uy + uz * uz


@leaf
def _node_gap2(node, a, b):
    """A lower bound on the squared distance between segment ab and anything inside the box ``node`` [lo(3),
    hi(3)]: the larger of the gap between the box and the segment's box and the segment's distance to the box's
    circumscribed ball (tight for small boxes near a slanted segment, where the box gap is loose)."""
    acc = 0.0
    cx = 0.5 * (node[0] + node[3])
    cy = 0.5 * (node[1] + node[4])
    cz = 0.5 * (node[2] + node[5])
    r2 = 0.0
    for k in range(3):
        g = max(node[k] - max(a[k], b[k]), min(a[k], b[k]) - node[k + 3], 0.0)
        acc += g * g
        e = 0.5 * (node[k + 3] - node[k])
        r2 += e * e
    ball = math.sqrt(_segment_point2(a, b, (cx, cy, cz))) - math.sqrt(r2)
    if ball > 0.0 and ball * ball > acc:
        return ball * ball
    return acc


@leaf
def mesh_segment(tris, normals, spheres, nodes, links, root, a, b, bound, stack, point):
    """(distance, outside) between segment ab and the mesh surface when less than ``bound``, else (inf, True).
    ``outside`` says on which side of a closed mesh the segment's closest point lies (pseudonormal of the closest
    surface feature, which is that point's nearest); meaningless when the distance is 0 (the segment crosses).
    ``spheres (T, 4)``: each triangle's bounding ball (:func:`triangle_balls`); ``point (3,)``: scratch (the
    closest point, where an inside test decides). Allocates nothing."""
    best = bound * bound
    tri = -1
    feature = 0
    s_best = 0.0
    qx = qy = qz = 0.0
    stack[0] = root
    top = 1
    while top > 0:
        top -= 1
        node = stack[top]
        if _node_gap2(nodes[node], a, b) >= best:
            continue
        first = links[node, 0]
        second = links[node, 1]
        if second < 0:
            for t in range(first, first - second):
                # the triangle's ball (centre = mean of the corners, radius to the farthest) culls it cheaply
                ball = _segment_point2(a, b, spheres[t])
                if ball > spheres[t, 3] * spheres[t, 3]:
                    gap = math.sqrt(ball) - spheres[t, 3]
                    if gap * gap >= best:
                        continue
                d2, f, s, x, y, z = segment_triangle(a, b, tris, t)
                if d2 < best:
                    best, tri, feature, s_best = d2, t, f, s
                    qx, qy, qz = x, y, z
            continue
        dl = _node_gap2(nodes[first], a, b)
        dr = _node_gap2(nodes[second], a, b)
        near, far, dnear, dfar = (first, second, dl, dr) if dl <= dr else (second, first, dr, dl)
        if dfar < best:
            stack[top] = far
            top += 1
        if dnear < best:
            stack[top] = near
            top += 1
    if tri < 0:
        return np.inf, True
    n = normals[tri, feature]
    if n[0] == 0.0 and n[1] == 0.0 and n[2] == 0.0:  # a vertex where closed parts touch
        point_on(a, b, s_best, point)
        return math.sqrt(best), not mesh_inside(tris, normals, nodes, links, root, point, stack)
    px = a[0] + s_best * (b[0] - a[0]) - qx
    py = a[1] + s_best * (b[1] - a[1]) - qy
    pz = a[2] + s_best * (b[2] - a[2]) - qz
    return math.sqrt(best), px * n[0] + py * n[1] + pz * n[2] >= 0.0


@kernel
def _reference_segments(tris, a, b):
    out = np.empty(a.shape[0])
    for i in range(a.shape[0]):
        best = np.inf
        for t in range(tris.shape[0]):
            best = min(best, segment_triangle(a[i], b[i], tris, t)[0])
        out[i] = math.sqrt(best)
    return out


def reference_segment_distance(vertices, faces, a, b) -> np.ndarray:
    """Brute-force distance (every triangle) between segments a->b ``(n, 3)`` and a mesh's surface: the reference
    for tests."""
    tris = np.ascontiguousarray(np.asarray(vertices, dtype=float)[np.asarray(faces, dtype=np.int64)])
    return _reference_segments(tris, np.ascontiguousarray(a, dtype=float), np.ascontiguousarray(b, dtype=float))
