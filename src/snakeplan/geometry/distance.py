"""Batched distance and ray queries over a set of obstacles, jitted with numba.

The hot path of every planner is "does this body (a chain of capsules) touch anything?". Obstacles are packed
into float rows (:meth:`Obstacle.pack`) and evaluated by exact signed-distance kernels. A segment is cleared
by branch-and-bound on the 1-Lipschitz signed distance: the distance at an interval's midpoint minus the
interval's half-length bounds the whole interval from below, so most links are cleared by one evaluation and
no collision is missed (the bound is exact, not a sampling heuristic). Distances in mm.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit

from snakeplan.geometry.primitives import (
    _P,
    KIND_BOX,
    KIND_CYLINDER,
    KIND_MESH,
    KIND_PIPE,
    KIND_SPHERE,
    Mesh,
    Obstacle,
)

#: Accuracy (mm) of the minimum clearance reported for a segment.
CLEARANCE_TOLERANCE_MM = 0.05
#: Contact resolution (mm): a capsule that penetrates an obstacle by more than this collides; one that only grazes
#: it (tangent contact, or a penetration shallower than this) is a touch. It is also the resolution floor of the
#: branch-and-bound, so a grazing link costs no more than about length / resolution distance evaluations.
CONTACT_RESOLUTION_MM = 0.01


@njit(cache=True)
def _box2(qx: float, qy: float) -> float:
    """Signed distance from a 2-D point given as (|p| - half extents) to a rectangle."""
    ox = max(qx, 0.0)
    oy = max(qy, 0.0)
    return math.sqrt(ox * ox + oy * oy) + min(max(qx, qy), 0.0)


@njit(cache=True)
def _ellipse_distance(px: float, py: float, a: float, b: float) -> float:
    """Signed distance (negative inside) from (px, py) to the ellipse x^2/a^2 + y^2/b^2 = 1."""
    x = abs(px)
    y = abs(py)
    inside = (x / a) ** 2 + (y / b) ** 2 < 1.0
    if abs(a - b) < 1e-12 * max(a, b):
        return math.sqrt(x * x + y * y) - a
    # Work with e0 >= e1 (major axis first).
    if a >= b:
        e0, e1, y0, y1 = a, b, x, y
    else:
        e0, e1, y0, y1 = b, a, y, x
    if y1 > 0.0:
        if y0 > 0.0:
            # Root of F(t) = (e0 y0/(t+e0^2))^2 + (e1 y1/(t+e1^2))^2 - 1 by safeguarded bisection (monotone F).
            z0 = y0 / e0
            z1 = y1 / e1
            r0 = (e0 / e1) ** 2
            s0 = z1 - 1.0
            g = z0 * z0 + z1 * z1 - 1.0
            s1 = 0.0 if g < 0.0 else math.sqrt((r0 * z0) ** 2 + z1 * z1) - 1.0
            s = 0.0
            for _ in range(96):
                s = 0.5 * (s0 + s1)
                if s == s0 or s == s1:
                    break
                ratio0 = r0 * z0 / (s + r0)
                ratio1 = z1 / (s + 1.0)
                gs = ratio0 * ratio0 + ratio1 * ratio1 - 1.0
                if gs > 0.0:
                    s0 = s
                elif gs < 0.0:
                    s1 = s
                else:
                    break
            x0 = r0 * y0 / (s + r0)
            x1 = y1 / (s + 1.0)
            d = math.sqrt((x0 - y0) ** 2 + (x1 - y1) ** 2)
        else:
            d = abs(y1 - e1)
    else:
        numer0 = e0 * y0
        denom0 = e0 * e0 - e1 * e1
        if numer0 < denom0:
            xde0 = numer0 / denom0
            x0 = e0 * xde0
            x1 = e1 * math.sqrt(max(1.0 - xde0 * xde0, 0.0))
            d = math.sqrt((x0 - y0) ** 2 + x1 * x1)
        else:
            d = abs(y0 - e0)
    return -d if inside else d


@njit(cache=True)
def _triangle_distance2(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """Squared distance from point p to triangle abc (closest point by Voronoi regions)."""
    abx, aby, abz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    acx, acy, acz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    apx, apy, apz = p[0] - a[0], p[1] - a[1], p[2] - a[2]
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return apx * apx + apy * apy + apz * apz
    bpx, bpy, bpz = p[0] - b[0], p[1] - b[1], p[2] - b[2]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return bpx * bpx + bpy * bpy + bpz * bpz
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        qx, qy, qz = a[0] + v * abx - p[0], a[1] + v * aby - p[1], a[2] + v * abz - p[2]
        return qx * qx + qy * qy + qz * qz
    cpx, cpy, cpz = p[0] - c[0], p[1] - c[1], p[2] - c[2]
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return cpx * cpx + cpy * cpy + cpz * cpz
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        qx, qy, qz = a[0] + w * acx - p[0], a[1] + w * acy - p[1], a[2] + w * acz - p[2]
        return qx * qx + qy * qy + qz * qz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        qx = b[0] + w * (c[0] - b[0]) - p[0]
        qy = b[1] + w * (c[1] - b[1]) - p[1]
        qz = b[2] + w * (c[2] - b[2]) - p[2]
        return qx * qx + qy * qy + qz * qz
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    qx = a[0] + abx * v + acx * w - p[0]
    qy = a[1] + aby * v + acy * w - p[1]
    qz = a[2] + abz * v + acz * w - p[2]
    return qx * qx + qy * qy + qz * qz


@njit(cache=True)
def _solid_angle(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """Signed solid angle of triangle abc seen from p (Van Oosterom-Strackee)."""
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
def _mesh_sdf(tris: np.ndarray, start: int, stop: int, p: np.ndarray) -> float:
    best = np.inf
    winding = 0.0
    for t in range(start, stop):
        d2 = _triangle_distance2(p, tris[t, 0], tris[t, 1], tris[t, 2])
        if d2 < best:
            best = d2
        winding += _solid_angle(p, tris[t, 0], tris[t, 1], tris[t, 2])
    d = math.sqrt(best)
    return -d if winding > 2.0 * math.pi else d


@njit(cache=True)
def _sdf_row(row: np.ndarray, tris: np.ndarray, ranges: np.ndarray, p: np.ndarray) -> float:
    """Signed distance from p to the obstacle packed in ``row``."""
    kind = int(row[0])
    dx = p[0] - row[1]
    dy = p[1] - row[2]
    dz = p[2] - row[3]
    if kind == KIND_SPHERE:
        return math.sqrt(dx * dx + dy * dy + dz * dz) - row[_P]
    if kind == KIND_MESH:
        k = int(row[_P + 1])
        return _mesh_sdf(tris, ranges[k, 0], ranges[k, 1], p)
    # local = R^T (p - c); R stored row-major at row[4:13]
    lx = row[4] * dx + row[7] * dy + row[10] * dz
    ly = row[5] * dx + row[8] * dy + row[11] * dz
    lz = row[6] * dx + row[9] * dy + row[12] * dz
    if kind == KIND_BOX:
        qx = abs(lx) - row[_P]
        qy = abs(ly) - row[_P + 1]
        qz = abs(lz) - row[_P + 2]
        ox, oy, oz = max(qx, 0.0), max(qy, 0.0), max(qz, 0.0)
        return math.sqrt(ox * ox + oy * oy + oz * oz) + min(max(qx, max(qy, qz)), 0.0)
    rho = math.sqrt(lx * lx + ly * ly)
    if kind == KIND_CYLINDER:
        return _box2(rho - row[_P], abs(lz) - row[_P + 1])
    if kind == KIND_PIPE:
        mid = 0.5 * (row[_P] + row[_P + 1])
        half = 0.5 * (row[_P + 1] - row[_P])
        return _box2(abs(rho - mid) - half, abs(lz) - row[_P + 2])
    # KIND_PLATE: local x = normal, y = side, z = up
    d2 = _box2(abs(ly) - row[_P + 1], abs(lz) - row[_P + 2])
    if row[_P + 3] > 0.0:
        hu = ly - row[_P + 4]
        hv = lz - row[_P + 5]
        a = row[_P + 6]
        b = row[_P + 7]
        # The hole only matters when it can be nearer than the rectangle's boundary.
        if d2 < 0.0 and math.sqrt(hu * hu + hv * hv) - max(a, b) < -d2:
            d2 = max(d2, -_ellipse_distance(hu, hv, a, b))
    dn = abs(lx) - row[_P]
    ox = max(d2, 0.0)
    on = max(dn, 0.0)
    return min(max(d2, dn), 0.0) + math.sqrt(ox * ox + on * on)


@njit(cache=True)
def _scene_sdf(rows: np.ndarray, tris: np.ndarray, ranges: np.ndarray, p: np.ndarray) -> float:
    best = np.inf
    for k in range(rows.shape[0]):
        d = _sdf_row(rows[k], tris, ranges, p)
        if d < best:
            best = d
    return best


@njit(cache=True)
def _sdf_points(rows: np.ndarray, tris: np.ndarray, ranges: np.ndarray, pts: np.ndarray) -> np.ndarray:
    out = np.empty(pts.shape[0])
    for i in range(pts.shape[0]):
        out[i] = _scene_sdf(rows, tris, ranges, pts[i])
    return out


@njit(cache=True)
def _box_distance(box: np.ndarray, p: np.ndarray) -> float:
    """Distance from p to an axis-aligned box [lo(3), hi(3)]: a cheap lower bound on an obstacle's distance."""
    acc = 0.0
    for i in range(3):
        d = max(box[i] - p[i], p[i] - box[i + 3], 0.0)
        acc += d * d
    return math.sqrt(acc)


@njit(cache=True)
def _candidates(rows, boxes, tris, ranges, a, b, cutoff, cand, stats):
    """Obstacles that may come within ``cutoff`` of segment ab; returns their count in ``cand``.

    The bounding-box distance culls far obstacles before their exact distance is evaluated.
    """
    mid = 0.5 * (a + b)
    half = 0.5 * math.sqrt(((b - a) ** 2).sum())
    n = 0
    for k in range(rows.shape[0]):
        outside = _box_distance(boxes[k], mid)  # a lower bound on the distance only outside the box
        if outside > 0.0 and outside - half >= cutoff:
            continue
        stats[0] += 1
        if _sdf_row(rows[k], tris, ranges, mid) - half < cutoff:
            cand[n] = k
            n += 1
    return n


@njit(cache=True)
def _min_over(rows, tris, ranges, cand, n, p, stats):
    stats[0] += n
    best = np.inf
    for j in range(n):
        d = _sdf_row(rows[cand[j]], tris, ranges, p)
        if d < best:
            best = d
    return best


@njit(cache=True)
def _segment_min(rows, boxes, tris, ranges, a, b, cutoff, tol, radius, cand, stack, stats):
    """Minimum signed distance along segment ab (ends included), accurate to ``tol``; values >= ``cutoff`` come
    back as cutoff. Where the minimum may lie below ``radius - CONTACT_RESOLUTION_MM`` while the best found does
    not, the search goes on to the contact resolution, so the sign of the clearance is never decided by ``tol``."""
    n = _candidates(rows, boxes, tris, ranges, a, b, cutoff, cand, stats)
    if n == 0:
        return cutoff
    contact = radius - CONTACT_RESOLUTION_MM
    length = math.sqrt(((b - a) ** 2).sum())
    best = min(cutoff, _min_over(rows, tris, ranges, cand, n, a, stats),
               _min_over(rows, tris, ranges, cand, n, b, stats))
    stack[0, 0] = 0.0
    stack[0, 1] = 1.0
    top = 1
    while top > 0:
        top -= 1
        t0 = stack[top, 0]
        t1 = stack[top, 1]
        tm = 0.5 * (t0 + t1)
        f = _min_over(rows, tris, ranges, cand, n, a + tm * (b - a), stats)
        if f < best:
            best = f
        h = 0.5 * (t1 - t0) * length
        refine = f - h < best - tol or (best >= contact and f - h < contact and h > 0.5 * CONTACT_RESOLUTION_MM)
        if refine and top + 2 <= stack.shape[0]:
            stack[top, 0] = t0
            stack[top, 1] = tm
            stack[top + 1, 0] = tm
            stack[top + 1, 1] = t1
            top += 2
    return best


@njit(cache=True)
def _segment_hits(rows, boxes, tris, ranges, a, b, radius, cand, stack, stats):
    """True when some point of segment ab is closer than ``radius - CONTACT_RESOLUTION_MM`` to an obstacle.

    Intervals are halved only while their bound could hide such a point and they are longer than the contact
    resolution, so a link grazing a surface (tangent contact) costs length / resolution evaluations at most.
    """
    n = _candidates(rows, boxes, tris, ranges, a, b, radius, cand, stats)
    if n == 0:
        return False
    contact = radius - CONTACT_RESOLUTION_MM
    length = math.sqrt(((b - a) ** 2).sum())
    stack[0, 0] = 0.0
    stack[0, 1] = 1.0
    top = 1
    while top > 0:
        top -= 1
        t0 = stack[top, 0]
        t1 = stack[top, 1]
        tm = 0.5 * (t0 + t1)
        f = _min_over(rows, tris, ranges, cand, n, a + tm * (b - a), stats)
        if f < contact:
            return True
        h = 0.5 * (t1 - t0) * length
        if f - h < contact and h > 0.5 * CONTACT_RESOLUTION_MM and top + 2 <= stack.shape[0]:
            stack[top, 0] = t0
            stack[top, 1] = tm
            stack[top + 1, 0] = tm
            stack[top + 1, 1] = t1
            top += 2
    return False


@njit(cache=True)
def _chains_clearance(rows, boxes, tris, ranges, joints, radii, tol, stats):
    B = joints.shape[0]
    n = radii.shape[0]
    out = np.empty(B)
    cand = np.empty(rows.shape[0], dtype=np.int64)
    stack = np.empty((256, 2))
    for i in range(B):
        # Link midpoints give an attained value, an upper bound on the minimum, so every link's search is
        # pruned from the start instead of refining distances to far obstacles.
        best = np.inf
        for k in range(n):
            stats[0] += rows.shape[0]
            d = _scene_sdf(rows, tris, ranges, 0.5 * (joints[i, k] + joints[i, k + 1])) - radii[k]
            if d < best:
                best = d
        if best == np.inf:
            out[i] = best
            continue
        for k in range(n):
            cutoff = best + radii[k]
            d = _segment_min(rows, boxes, tris, ranges, joints[i, k], joints[i, k + 1], cutoff, tol, radii[k], cand,
                             stack, stats)
            d -= radii[k]
            if d < best:
                best = d
        out[i] = best
    return out


@njit(cache=True)
def chain_hit(rows, boxes, tris, ranges, joints, radii, cand, stack, stats):
    """Index of a link of one chain ``(n+1, 3)`` that touches an obstacle (tip first), or -1 (jitted; higher layers'
    kernels call it with :attr:`ObstacleSet.packed`)."""
    # Tip first: in follow-the-leader motion the leading links meet obstacles first, so exits come early.
    for k in range(radii.shape[0] - 1, -1, -1):
        if _segment_hits(rows, boxes, tris, ranges, joints[k], joints[k + 1], radii[k], cand, stack, stats):
            return k
    return -1


@njit(cache=True)
def _chains_collide(rows, boxes, tris, ranges, joints, radii, stats):
    B = joints.shape[0]
    out = np.zeros(B, dtype=np.bool_)
    cand = np.empty(rows.shape[0], dtype=np.int64)
    stack = np.empty((256, 2))
    for i in range(B):
        out[i] = chain_hit(rows, boxes, tris, ranges, joints[i], radii, cand, stack, stats) >= 0
    return out


@njit(cache=True)
def _first_hit(rows, boxes, tris, ranges, joints, radii, stats):
    """(chain, link) of the first chain in order that touches an obstacle, or (-1, -1): the crawl's early exit."""
    cand = np.empty(rows.shape[0], dtype=np.int64)
    stack = np.empty((256, 2))
    for i in range(joints.shape[0]):
        k = chain_hit(rows, boxes, tris, ranges, joints[i], radii, cand, stack, stats)
        if k >= 0:
            return i, k
    return -1, -1


@njit(cache=True)
def _segments_clear(rows, boxes, tris, ranges, a, b, radius, stats):
    out = np.empty(a.shape[0], dtype=np.bool_)
    cand = np.empty(rows.shape[0], dtype=np.int64)
    stack = np.empty((256, 2))
    for i in range(a.shape[0]):
        out[i] = not _segment_hits(rows, boxes, tris, ranges, a[i], b[i], radius, cand, stack, stats)
    return out


@njit(cache=True)
def _ray_meets_box(box, origin, d, max_dist, eps):
    """Whether the ray segment origin + t d, t in [0, max_dist], meets the box [lo(3), hi(3)] grown by eps."""
    t0, t1 = 0.0, max_dist
    for a in range(3):
        lo, hi = box[a] - eps, box[a + 3] + eps
        if abs(d[a]) < 1e-12:
            if origin[a] < lo or origin[a] > hi:
                return False
        else:
            ta, tb = (lo - origin[a]) / d[a], (hi - origin[a]) / d[a]
            t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    return t0 <= t1


@njit(cache=True)
def _raycast(rows, boxes, tris, ranges, origins, dirs, max_dist, eps, stats):
    """Sphere tracing of each ray against only the obstacles whose bounding box (grown by ``eps``) its segment
    [0, max_dist] meets: an obstacle the segment misses can neither stop the ray nor be entered by it, so a ray
    costs a few obstacles' distances per step instead of the whole scene's."""
    out = np.full(origins.shape[0], np.inf)
    cand = np.empty(rows.shape[0], dtype=np.int64)
    for i in range(origins.shape[0]):
        n = 0
        for k in range(rows.shape[0]):
            if _ray_meets_box(boxes[k], origins[i], dirs[i], max_dist, eps):
                cand[n] = k
                n += 1
        t = 0.0
        while n > 0 and t <= max_dist:
            step = _min_over(rows, tris, ranges, cand, n, origins[i] + t * dirs[i], stats)
            if step < eps:
                out[i] = t
                break
            t += step
    return out


class ObstacleSet:
    """A packed, immutable set of obstacles with batched exact queries (mm)."""

    def __init__(self, obstacles: Sequence[Obstacle]):
        self.obstacles = tuple(obstacles)
        rows = [o.pack() for o in self.obstacles]
        tris, ranges, start = [], [], 0
        for o, row in zip(self.obstacles, rows):
            if isinstance(o, Mesh):
                t = o.triangles()
                tris.append(t)
                row[_P + 1] = len(ranges)
                ranges.append((start, start + len(t)))
                start += len(t)
        width = rows[0].shape[0] if rows else 24
        self._rows = np.array(rows, dtype=float).reshape(len(rows), width)
        self._tris = np.concatenate(tris) if tris else np.zeros((0, 3, 3))
        self._ranges = np.array(ranges, dtype=np.int64).reshape(len(ranges), 2)
        self._boxes = np.array([np.concatenate(o.aabb()) for o in self.obstacles], dtype=float).reshape(-1, 6)
        #: Point-to-obstacle distance evaluations made by this set's queries so far (a cost measure for tests and
        #: benchmarks, independent of the machine's speed).
        self.evaluations = np.zeros(1, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.obstacles)

    @property
    def packed(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(rows, boxes, triangles, mesh ranges): the packed arrays jitted kernels take, as :func:`chain_hit`."""
        return self._rows, self._boxes, self._tris, self._ranges

    def signed_distance(self, points) -> np.ndarray:
        """Signed distance (mm) from points ``(..., 3)`` to the nearest obstacle (+inf with no obstacles)."""
        p = np.asarray(points, dtype=float)
        flat = np.ascontiguousarray(p.reshape(-1, 3))
        self.evaluations[0] += flat.shape[0] * len(self.obstacles)
        return _sdf_points(self._rows, self._tris, self._ranges, flat).reshape(p.shape[:-1])

    def chain_clearance(self, joints, radii, tol: float = CLEARANCE_TOLERANCE_MM) -> np.ndarray:
        """Minimum clearance (mm) between obstacles and chains of capsules.

        ``joints`` is ``(..., n+1, 3)``, ``radii`` is ``(n,)``; negative means penetration.
        The value is attained at a point of the chain (link ends included) and exceeds the true clearance by at
        most ``tol``; where the true clearance may be below ``-CONTACT_RESOLUTION_MM``, the search resolves it, so
        a value >= ``-CONTACT_RESOLUTION_MM`` means the chain at most touches (as :meth:`chain_collides` says).
        """
        J = np.asarray(joints, dtype=float)
        r = np.ascontiguousarray(radii, dtype=float)
        flat = np.ascontiguousarray(J.reshape(-1, J.shape[-2], 3))
        return _chains_clearance(self._rows, self._boxes, self._tris, self._ranges, flat, r, tol,
                                 self.evaluations).reshape(J.shape[:-2])

    def chain_collides(self, joints, radii) -> np.ndarray:
        """True where any capsule of a chain ``(..., n+1, 3)`` penetrates an obstacle by more than
        ``CONTACT_RESOLUTION_MM``; exits early per chain."""
        J = np.asarray(joints, dtype=float)
        r = np.ascontiguousarray(radii, dtype=float)
        flat = np.ascontiguousarray(J.reshape(-1, J.shape[-2], 3))
        return _chains_collide(self._rows, self._boxes, self._tris, self._ranges, flat, r,
                               self.evaluations).reshape(J.shape[:-2])

    def first_hit(self, joints, radii) -> tuple[int, int] | None:
        """(chain, link) of the first chain of ``(B, n+1, 3)``, in order, that :meth:`chain_collides`, or None;
        the chains after it are not examined."""
        flat = np.ascontiguousarray(np.asarray(joints, dtype=float).reshape(-1, np.shape(joints)[-2], 3))
        i, k = _first_hit(self._rows, self._boxes, self._tris, self._ranges, flat,
                          np.ascontiguousarray(radii, dtype=float), self.evaluations)
        return None if i < 0 else (int(i), int(k))

    def segments_clear(self, a, b, radius: float = 0.0) -> np.ndarray:
        """True where the capsule of ``radius`` around segment a->b ``(..., 3)`` touches no obstacle."""
        A = np.asarray(a, dtype=float)
        Bp = np.asarray(b, dtype=float)
        A, Bp = np.broadcast_arrays(A, Bp)
        fa = np.ascontiguousarray(A.reshape(-1, 3))
        fb = np.ascontiguousarray(Bp.reshape(-1, 3))
        return _segments_clear(self._rows, self._boxes, self._tris, self._ranges, fa, fb, float(radius),
                               self.evaluations).reshape(A.shape[:-1])

    def line_of_sight(self, a, b) -> np.ndarray:
        """True where the straight segment a->b passes through no obstacle's interior."""
        return self.segments_clear(a, b, 0.0)

    def raycast(self, origins, directions, max_distance: float = 1e9, eps: float = 1e-3) -> np.ndarray:
        """Distance (mm) along unit ``directions`` to the first surface (inf when none within max_distance)."""
        o = np.asarray(origins, dtype=float)
        d = np.asarray(directions, dtype=float)
        o, d = np.broadcast_arrays(o, d)
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        fo = np.ascontiguousarray(o.reshape(-1, 3))
        fd = np.ascontiguousarray(d.reshape(-1, 3))
        return _raycast(self._rows, self._boxes, self._tris, self._ranges, fo, fd, float(max_distance),
                        float(eps), self.evaluations).reshape(o.shape[:-1])


def sampled_chain_clearance(obstacles: ObstacleSet, joints, radii, step: float = 1.0) -> np.ndarray:
    """Reference clearance by dense sampling of every link (NumPy; slow, for tests and as a benchmark baseline).

    Overestimates the true clearance by at most ``step / 2`` (the signed distance is 1-Lipschitz).
    """
    J = np.asarray(joints, dtype=float)
    r = np.asarray(radii, dtype=float)
    a, b = J[..., :-1, :], J[..., 1:, :]
    n = int(np.ceil(np.max(np.linalg.norm(b - a, axis=-1)) / step)) + 1
    t = np.linspace(0.0, 1.0, n)
    pts = a[..., None, :] + t[:, None] * (b - a)[..., None, :]
    d = obstacles.signed_distance(pts) - r[:, None]
    return d.min(axis=(-1, -2))
