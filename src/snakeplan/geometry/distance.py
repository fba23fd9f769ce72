"""Batched distance and ray queries over a set of obstacles, jitted with numba.

The hot path of every planner is "does this body (a chain of capsules) touch anything?". Obstacles are packed
into float rows (:meth:`Obstacle.pack`) and evaluated by exact signed-distance kernels. A segment is cleared
by branch-and-bound on the 1-Lipschitz signed distance: the distance at an interval's midpoint minus the
interval's half-length bounds the whole interval from below, so most links are cleared by one evaluation and
no collision is missed (the bound is exact, not a sampling heuristic). Distances in mm.

The packed row layout is defined here, next to the kernels that read it; obstacles are used only through their
rows and methods (:class:`Packable`), so this module imports no obstacle class and
:mod:`snakeplan.geometry.primitives` builds on it (:meth:`Obstacle.signed_distance`).
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from snakeplan.geometry import bvh
from snakeplan.geometry.cloud_distance import cloud_sdf, cloud_segment
from snakeplan.geometry.mesh_distance import (
    mesh_inside,
    mesh_ray,
    mesh_sdf,
    mesh_segment,
    point_on,
    triangle_balls,
)
from snakeplan.jit import inlined, kernel, leaf

#: The packed row of an obstacle (:meth:`Obstacle.pack` writes it, the kernels below read it):
#: ``[kind, center(3), R row-major(9), params...]``, its kinds, and where the type-specific parameters start.
PACK_WIDTH = 24
KIND_BOX, KIND_SPHERE, KIND_CYLINDER, KIND_PLATE, KIND_PIPE, KIND_MESH, KIND_POINTS = range(7)
_P = 13

#: Accuracy (mm) of the minimum clearance reported for a segment.
CLEARANCE_TOLERANCE_MM = 0.05
#: Contact resolution (mm): a capsule that penetrates an obstacle by more than this collides; one that only grazes
#: it (tangent contact, or a penetration shallower than this) is a touch. It is also the resolution floor of the
#: branch-and-bound, so a grazing link costs no more than about length / resolution distance evaluations.
CONTACT_RESOLUTION_MM = 0.01


@leaf
def _box2(qx: float, qy: float) -> float:
    """Signed distance from a 2-D point given as (|p| - half extents) to a rectangle."""
    ox = max(qx, 0.0)
    oy = max(qy, 0.0)
    return math.sqrt(ox * ox + oy * oy) + min(max(qx, qy), 0.0)


@leaf
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
    # A coordinate below 1e-12 of its semi-axis is taken as on the axis (the distance moves by less than that):
    # the root below would otherwise be sought among subnormal numbers.
    if y1 > 1e-12 * e1:
        if y0 > 1e-12 * e0:
            # Root of F(u) = (r0 z0/(u + r0 - 1))^2 + (z1/u)^2 - 1 (u = s + 1 of Eberly's F(s), so that a root
            # next to the pole at u = 0, as for a point near the major axis, keeps its digits) in [u0, u1], where
            # F >= 0 >= F. F falls and is convex there: Newton's steps from the left approach the root without
            # passing it, and a step from the right lands left of it. A step that leaves the bracket is replaced
            # by its middle, geometric while its ends differ in scale. About 8 steps instead of ~50 halvings.
            z0 = y0 / e0
            z1 = y1 / e1
            r0 = (e0 / e1) ** 2
            u0 = z1
            g = z0 * z0 + z1 * z1 - 1.0
            u1 = 1.0 if g < 0.0 else math.sqrt((r0 * z0) ** 2 + z1 * z1)
            u = math.sqrt(u0) * math.sqrt(u1)
            for _ in range(200):
                ratio0 = r0 * z0 / (u + r0 - 1.0)
                ratio1 = z1 / u
                gu = ratio0 * ratio0 + ratio1 * ratio1 - 1.0
                if gu > 0.0:
                    u0 = u
                elif gu < 0.0:
                    u1 = u
                else:
                    break
                slope = -2.0 * (ratio0 * ratio0 / (u + r0 - 1.0) + ratio1 * ratio1 / u)
                step = u - gu / slope
                if not u0 < step < u1:
                    step = math.sqrt(u0) * math.sqrt(u1) if u1 > 4.0 * u0 else 0.5 * (u0 + u1)
                if step == u or step == u0 or step == u1:
                    break
                u = step
            x0 = r0 * y0 / (u + r0 - 1.0)
            x1 = y1 / u
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


@inlined
def _sdf_row(row, W, p, walk):
    """Signed distance from p to the obstacle packed in ``row`` (W: the packed set, walk: tree stacks)."""
    kind = int(row[0])
    dx = p[0] - row[1]
    dy = p[1] - row[2]
    dz = p[2] - row[3]
    if kind == KIND_SPHERE:
        return math.sqrt(dx * dx + dy * dy + dz * dz) - row[_P]
    if kind == KIND_MESH:
        k = int(row[_P + 1])
        return mesh_sdf(W[2], W[4], W[5], W[6], W[3][k, 2], row[_P + 2], p, walk[1])
    if kind == KIND_POINTS:
        return cloud_sdf(W[11], W[12], W[13], W[14][int(row[_P + 1]), 2], row[_P], p, walk[1])
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


@leaf
def obstacle_distance(W, k, p, walk):
    """Signed distance (mm) from p to obstacle ``k`` of the packed set W alone."""
    return _sdf_row(W[0][k], W, p, walk)


@kernel
def workspace(W):
    """Scratch arrays of the kernels for the packed set W: (candidates, interval stack, tree stacks, a point).
    The kernels below allocate nothing per call: an array temporary costs about 60 ns, several times a box
    test."""
    return (np.empty(W[0].shape[0], dtype=np.int64), np.empty((256, 2)),
            np.empty((2, bvh.STACK_SIZE), dtype=np.int64), np.empty(3))


@leaf
def _length(a, b):
    """|b - a| (mm) of two points (3,)."""
    return math.sqrt((b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2 + (b[2] - a[2]) ** 2)


@leaf
def _scene_sdf(W, p, walk, stats, cap=np.inf):
    """Signed distance from p to the nearest obstacle, or ``cap`` when that is less: a best-first walk of the
    obstacle tree that skips every box p lies outside of and farther than the best so far (outside its box, an
    obstacle is at least as far as the box), so a finite cap skips every obstacle beyond it."""
    rows, nodes, links, order = W[0], W[7], W[8], W[9]
    best = cap
    if rows.shape[0] == 0:
        return best
    st = walk[0]
    st[0] = 0
    top = 1
    while top > 0:
        top -= 1
        node = st[top]
        out = bvh.box_distance(nodes[node], p)
        if out > 0.0 and out >= best:
            continue
        first = links[node, 0]
        second = links[node, 1]
        if second < 0:
            for j in range(first, first - second):
                k = order[j]
                out = bvh.box_distance(W[1][k], p)
                if out > 0.0 and out >= best:
                    continue
                stats[0] += 1
                d = _sdf_row(rows[k], W, p, walk)
                if d < best:
                    best = d
            continue
        dl = bvh.box_distance(nodes[first], p)
        dr = bvh.box_distance(nodes[second], p)
        if dl <= dr:
            st[top] = second
            st[top + 1] = first
        else:
            st[top] = first
            st[top + 1] = second
        top += 2
    return best


@kernel
def _sdf_points(W, pts, cap, stats):
    walk = workspace(W)[2]
    out = np.empty(pts.shape[0])
    for i in range(pts.shape[0]):
        out[i] = _scene_sdf(W, pts[i], walk, stats, cap)
    return out


@kernel
def _grid_sdf(W, which, origin, spacing, nx, ny, k0, k1, cap, out, stats):
    """``out[i, j, k - k0]`` lowered to the signed distance at the centre of grid cell (i, j, k) to the obstacles
    ``which``, clamped to [-cap, cap], for k0 <= k < k1 (``out`` holds at most ``cap`` on entry), obstacle by
    obstacle: only the cells within an obstacle's box grown by ``cap`` evaluate it (outside that box it is farther
    than ``cap``), and of those only the ones its box is nearer to than the least value so far, so a finite cap
    costs the cells near each obstacle, not cells times tree walks.
    A mesh is searched only near each cell (:func:`mesh_sdf`'s ``reach``): within ``cap`` of it, and for a closed
    mesh at least a little beyond the z spacing. A cell with no surface that near lies on the same side of a closed
    mesh as the cell before it in z (the segment between them cannot cross a surface farther than the spacing);
    the first cell of a column takes its side from a ray (:func:`mesh_inside`). The same values as
    :func:`_scene_sdf` with ``cap`` at the centres, clamped below at ``-cap`` (for a closed mesh whose surface
    does not cross itself: there the two ways of telling a side may disagree)."""
    walk = workspace(W)[2]
    rows, boxes, ranges = W[0], W[1], W[3]
    p = np.empty(3)
    side_reach = max(cap, spacing[2] * (1.0 + 1e-9))  # beyond the step from the cell before
    for o in which:
        row = rows[o]
        mesh = int(row[0]) == KIND_MESH
        i0 = max(0, math.ceil((boxes[o, 0] - cap - origin[0]) / spacing[0] - 0.5))
        i1 = min(nx - 1, math.floor((boxes[o, 3] + cap - origin[0]) / spacing[0] - 0.5))
        j0 = max(0, math.ceil((boxes[o, 1] - cap - origin[1]) / spacing[1] - 0.5))
        j1 = min(ny - 1, math.floor((boxes[o, 4] + cap - origin[1]) / spacing[1] - 0.5))
        z0 = max(k0, math.ceil((boxes[o, 2] - cap - origin[2]) / spacing[2] - 0.5))
        z1 = min(k1 - 1, math.floor((boxes[o, 5] + cap - origin[2]) / spacing[2] - 0.5))
        for i in range(i0, i1 + 1):
            p[0] = origin[0] + (i + 0.5) * spacing[0]
            for j in range(j0, j1 + 1):
                p[1] = origin[1] + (j + 0.5) * spacing[1]
                side = 0.0  # the side of the mesh the cell before lies on (0: not known)
                for k in range(z0, z1 + 1):
                    p[2] = origin[2] + (k + 0.5) * spacing[2]
                    outside = bvh.box_distance(boxes[o], p)
                    if outside > 0.0 and outside >= out[i, j, k - k0]:
                        side = 0.0
                        continue  # outside its box, the obstacle is at least as far as the box
                    stats[0] += 1
                    if int(row[0]) == KIND_POINTS:
                        d = cloud_sdf(W[11], W[12], W[13], W[14][int(row[_P + 1]), 2], row[_P], p, walk[1], cap)
                    elif mesh:
                        root, half = ranges[int(row[_P + 1]), 2], row[_P + 2]
                        reach = cap + half if half > 0.0 else side_reach
                        d = mesh_sdf(W[2], W[4], W[5], W[6], root, half, p, walk[1], reach)
                        if math.isnan(d):
                            if half > 0.0 or side > 0.0:
                                d = cap
                            elif side < 0.0:
                                d = -cap
                            else:
                                d = -cap if mesh_inside(W[2], W[4], W[5], W[6], root, p, walk[1]) else cap
                        side = 1.0 if d >= 0.0 else -1.0
                    else:
                        d = _sdf_row(row, W, p, walk)
                    out[i, j, k - k0] = min(out[i, j, k - k0], max(d, -cap))


@leaf
def _candidates(W, a, b, cutoff, work, stats):
    """Obstacles that may come within ``cutoff`` of segment ab; returns their count in ``work[0]``. A primitive
    is evaluated at the midpoint and kept when that value allows; a mesh or a cloud whose box is near enough is a
    candidate without a distance evaluation (its exact segment search, :func:`_meshes_exact`, decides).

    The obstacle tree culls every box that the segment's bounding ball lies outside of and farther than
    ``cutoff`` from, so a link only evaluates obstacles near it, whatever the size of the scene.
    """
    rows, boxes, nodes, links, order = W[0], W[1], W[7], W[8], W[9]
    cand, _, walk, mid = work
    if rows.shape[0] == 0:
        return 0
    point_on(a, b, 0.5, mid)
    half = 0.5 * _length(a, b)
    n = 0
    st = walk[0]
    st[0] = 0
    top = 1
    while top > 0:
        top -= 1
        node = st[top]
        outside = bvh.box_distance(nodes[node], mid)  # a lower bound on the distance only outside the box
        if outside > 0.0 and outside - half >= cutoff:
            continue
        first = links[node, 0]
        second = links[node, 1]
        if second >= 0:
            st[top] = first
            st[top + 1] = second
            top += 2
            continue
        for j in range(first, first - second):
            k = order[j]
            outside = bvh.box_distance(boxes[k], mid)
            if outside > 0.0 and outside - half >= cutoff:
                continue
            if int(rows[k, 0]) >= KIND_MESH:
                cand[n] = k
                n += 1
                continue
            stats[0] += 1
            d = _sdf_row(rows[k], W, mid, walk)
            if d - half < cutoff:
                cand[n] = k
                n += 1
    return n


@leaf
def _meshes_exact(W, a, b, n, bound, work, stats):
    """Settle the mesh candidates of segment ab exactly, by segment-to-surface distance: returns (the least
    signed distance along ab among the settled meshes, or ``bound`` when none comes nearer, and how many
    candidates remain), moving the rest (primitives, and closed meshes the segment lies in or crosses) to the
    front of the candidate list. A segment that does not touch a closed mesh's surface lies wholly on one side:
    outside when its closest surface point says so, or, with no surface within ``bound``, when the inside test
    of one of its points says so; then its least distance is the exact one (or >= ``bound``). A shell is always
    settled (unsigned distance - half thickness), and so is a cloud (distance to its nearest point - radius)."""
    rows, ranges = W[0], W[3]
    cand, _, walk, point = work
    best = bound
    keep = 0
    for j in range(n):
        k = cand[j]
        row = rows[k]
        if int(row[0]) == KIND_POINTS:
            stats[0] += 1
            radius = row[_P]
            d = cloud_segment(W[11], W[12], W[13], W[14][int(row[_P + 1]), 2], a, b, max(best + radius, 1e-9),
                              walk[1])
            best = min(best, d - radius)
            continue
        if int(row[0]) != KIND_MESH:
            cand[keep] = k
            keep += 1
            continue
        stats[0] += 1
        half = row[_P + 2]
        m = int(row[_P + 1])
        # a bound above 0, so a link that crosses the surface is always found (distance 0) before the inside
        # test of one end decides a link that meets no surface
        d, outside = mesh_segment(W[2], W[4], W[10], W[5], W[6], ranges[m, 2], a, b, max(best + half, 1e-9),
                                  walk[1], point)
        if half > 0.0:
            best = min(best, d - half)
            continue
        if d == np.inf:  # no surface within the bound: wholly outside, or inside and kept
            settled = not mesh_inside(W[2], W[4], W[5], W[6], ranges[m, 2], a, walk[1])
        else:
            settled = d > 0.0 and outside
            if settled:
                best = min(best, d)
        if not settled:
            cand[keep] = k
            keep += 1
    return best, keep


@inlined
def _min_over(W, cand, n, p, walk, stats):
    stats[0] += n
    best = np.inf
    for j in range(n):
        d = _sdf_row(W[0][cand[j]], W, p, walk)
        if d < best:
            best = d
    return best


@leaf
def _segment_min(W, a, b, cutoff, tol, radius, work, stats):
    """Minimum signed distance along segment ab (ends included), accurate to ``tol``; values >= ``cutoff`` come
    back as cutoff. Where the minimum may lie below ``radius - CONTACT_RESOLUTION_MM`` while the best found does
    not, the search goes on to the contact resolution, so the sign of the clearance is never decided by ``tol``."""
    n = _candidates(W, a, b, cutoff, work, stats)
    if n == 0:
        return cutoff
    best, n = _meshes_exact(W, a, b, n, cutoff, work, stats)
    if n == 0:
        return best
    cand, stack, walk, point = work
    contact = radius - CONTACT_RESOLUTION_MM
    length = _length(a, b)
    best = min(best, _min_over(W, cand, n, a, walk, stats), _min_over(W, cand, n, b, walk, stats))
    stack[0, 0] = 0.0
    stack[0, 1] = 1.0
    top = 1
    while top > 0:
        top -= 1
        t0 = stack[top, 0]
        t1 = stack[top, 1]
        tm = 0.5 * (t0 + t1)
        point_on(a, b, tm, point)
        f = _min_over(W, cand, n, point, walk, stats)
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


@leaf
def _segment_hits(W, a, b, radius, work, stats):
    """True when some point of segment ab is closer than ``radius - CONTACT_RESOLUTION_MM`` to an obstacle.

    Intervals are halved only while their bound could hide such a point and they are longer than the contact
    resolution, so a link grazing a surface (tangent contact) costs length / resolution evaluations at most.
    """
    n = _candidates(W, a, b, radius, work, stats)
    if n == 0:
        return False
    contact = radius - CONTACT_RESOLUTION_MM
    nearest, n = _meshes_exact(W, a, b, n, contact, work, stats)
    if nearest < contact:
        return True
    if n == 0:
        return False
    cand, stack, walk, point = work
    length = _length(a, b)
    stack[0, 0] = 0.0
    stack[0, 1] = 1.0
    top = 1
    while top > 0:
        top -= 1
        t0 = stack[top, 0]
        t1 = stack[top, 1]
        tm = 0.5 * (t0 + t1)
        point_on(a, b, tm, point)
        f = _min_over(W, cand, n, point, walk, stats)
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


@kernel
def _midpoint_clearances(W, chain, radii, work, stats):
    """Each link's clearance at its midpoint: attained values, the first chain's link order and bounds."""
    out = np.empty(radii.shape[0])
    for k in range(radii.shape[0]):
        point_on(chain[k], chain[k + 1], 0.5, work[3])
        out[k] = _scene_sdf(W, work[3], work[2], stats) - radii[k]
    return out


@kernel
def _chains_clearance(W, joints, radii, tol, stats):
    """Each chain's clearance. Links are taken nearest first (in the order of their clearances in the previous
    chain; the first chain's by midpoint distance), and each link's search is cut off at the least found so far.
    The search starts from an attained bound: a link's value in the previous chain plus the farthest its ends
    moved (the signed distance is 1-Lipschitz, so the least over a segment moves no more than its ends), so in
    a crawl of nearby chains even the nearest link's search is pruned from the start."""
    B = joints.shape[0]
    n = radii.shape[0]
    out = np.empty(B)
    work = workspace(W)
    if B == 0:
        return out
    last = _midpoint_clearances(W, joints[0], radii, work, stats)
    attained = np.ones(n, dtype=np.bool_)
    for i in range(B):
        prev = joints[max(i - 1, 0)]
        best = np.inf
        for k in range(n):
            if attained[k]:
                moved = max(_length(joints[i, k], prev[k]), _length(joints[i, k + 1], prev[k + 1]))
                best = min(best, last[k] + moved)
        for k in np.argsort(last):
            cutoff = best + radii[k]
            d = _segment_min(W, joints[i, k], joints[i, k + 1], cutoff, tol, radii[k], work, stats)
            attained[k] = d < cutoff
            d -= radii[k]
            last[k] = d
            if d < best:
                best = d
        out[i] = best
    return out


@kernel
def _least_clearance(W, joints, radii, tol, stats):
    """(least clearance over chains ``(B, n+1, 3)``, its chain): each link's search is cut off at the least found
    so far, so chains and links farther than it cost a pruned search; the links of each chain are taken in the
    order of their clearances in the previous chain (nearest first), the first chain's by midpoint distance."""
    B = joints.shape[0]
    work = workspace(W)
    last = _midpoint_clearances(W, joints[0], radii, work, stats)
    best = np.inf
    arg = -1
    for i in range(B):
        for k in np.argsort(last):
            d = _segment_min(W, joints[i, k], joints[i, k + 1], best + radii[k], tol, radii[k], work, stats)
            d -= radii[k]
            last[k] = d
            if d < best:
                best = d
                arg = i
    return best, arg


@leaf
def chain_hit(W, joints, radii, work, stats):
    """Index of a link of one chain ``(n+1, 3)`` that touches an obstacle (tip first), or -1 (jitted; higher layers'
    kernels call it with :attr:`ObstacleSet.packed` and a :func:`workspace` of it)."""
    # Tip first: in follow-the-leader motion the leading links meet obstacles first, so exits come early.
    for k in range(radii.shape[0] - 1, -1, -1):
        if _segment_hits(W, joints[k], joints[k + 1], radii[k], work, stats):
            return k
    return -1


@kernel
def _chains_collide(W, joints, radii, stats):
    B = joints.shape[0]
    out = np.zeros(B, dtype=np.bool_)
    work = workspace(W)
    for i in range(B):
        out[i] = chain_hit(W, joints[i], radii, work, stats) >= 0
    return out


@kernel
def _first_hit(W, joints, radii, stats):
    """(chain, link) of the first chain in order that touches an obstacle, or (-1, -1): the crawl's early exit."""
    work = workspace(W)
    for i in range(joints.shape[0]):
        k = chain_hit(W, joints[i], radii, work, stats)
        if k >= 0:
            return i, k
    return -1, -1


@kernel
def _segments_clear(W, a, b, radius, stats):
    out = np.empty(a.shape[0], dtype=np.bool_)
    work = workspace(W)
    for i in range(a.shape[0]):
        out[i] = not _segment_hits(W, a[i], b[i], radius, work, stats)
    return out


@kernel
def _raycast(W, origins, dirs, max_dist, eps, stats):
    """First surface along each ray (:func:`ray_into` with every obstacle seen), as an array."""
    out = np.empty(origins.shape[0])
    seen = np.ones(W[0].shape[0], dtype=np.bool_)
    work = workspace(W)
    for i in range(origins.shape[0]):
        out[i] = ray_into(W, seen, origins[i], dirs[i], max_dist, eps, work, stats)
    return out


@leaf
def ray_into(W, seen, o, d, max_dist, eps, work, stats):
    """Distance (mm) along unit ``d`` from ``o`` to the first surface of an obstacle flagged in ``seen`` (inf when
    none within ``max_dist``), against only the obstacles whose bounding box (grown by ``eps``) its segment
    [0, max_dist] meets, found by walking the obstacle tree: an obstacle the segment misses can neither stop the
    ray nor be entered by it, so the search grows with the obstacles along the ray, not with the scene. A closed
    mesh is hit exactly (the first triangle along the ray, through the mesh's tree; 0 when the ray starts
    inside); primitives and shells are sphere traced (stopped within ``eps`` of the surface) up to that hit."""
    rows, boxes, nodes, links, order = W[0], W[1], W[7], W[8], W[9]
    ranges = W[3]
    if rows.shape[0] == 0:
        return np.inf
    cand, _, walk, point = work
    st = walk[0]
    n = 0
    meshes = np.inf  # the nearest closed mesh's hit
    st[0] = 0
    top = 1
    while top > 0:
        top -= 1
        node = st[top]
        if bvh.ray_box(nodes[node], o, d, max_dist, eps) > max_dist:
            continue
        first = links[node, 0]
        second = links[node, 1]
        if second >= 0:
            st[top] = first
            st[top + 1] = second
            top += 2
            continue
        for j in range(first, first - second):
            k = order[j]
            if not seen[k] or bvh.ray_box(boxes[k], o, d, max_dist, eps) > max_dist:
                continue
            if int(rows[k, 0]) == KIND_MESH and rows[k, _P + 2] == 0.0:
                stats[0] += 1
                m = int(rows[k, _P + 1])
                root = ranges[m, 2]
                if mesh_inside(W[2], W[4], W[5], W[6], root, o, walk[1]):
                    meshes = 0.0
                else:
                    meshes = min(meshes, mesh_ray(W[2], W[5], W[6], root, o, d, min(meshes, max_dist),
                                                  walk[1])[0])
                continue
            cand[n] = k
            n += 1
    limit = min(meshes, max_dist)
    t = 0.0
    while n > 0 and t <= limit:
        for c in range(3):
            point[c] = o[c] + t * d[c]
        step = _min_over(W, cand, n, point, walk, stats)
        if step < eps:
            return min(t, meshes)
        t += step
    return meshes


def _kernel_array(x) -> np.ndarray:
    """x as a C-contiguous, writable float64 array: one type per kernel argument, so a kernel warmed on a scene's
    read-only arrays is not compiled again for a planner's own arrays (inside its timed region)."""
    return np.require(np.asarray(x, dtype=float), requirements=["C", "W"])


#: Grid fields of meshes kept by :func:`_mesh_grid`, newest last, the most cells they may hold in all, and the
#: lock that keeps the store whole when planners run in threads.
_MESH_GRIDS: OrderedDict = OrderedDict()
MESH_GRID_CELLS = 4_000_000
_MESH_GRIDS_LOCK = threading.Lock()


class Packable(Protocol):
    """What an :class:`ObstacleSet` uses of an obstacle (:class:`~snakeplan.geometry.primitives.Obstacle`): its
    kind, its packed row and its world box; a mesh (``KIND_MESH``) also its triangles' data and a digest, a cloud
    (``KIND_POINTS``) its points' hierarchy and a digest."""

    kind: int

    def pack(self) -> np.ndarray: ...

    def aabb(self) -> tuple[np.ndarray, np.ndarray]: ...

    def distance_data(self) -> tuple[np.ndarray, ...]: ...

    def fingerprint(self) -> str: ...


def _split_meshes(obstacles: Sequence[Packable]) -> tuple[np.ndarray, np.ndarray]:
    """(the indices of the meshes and clouds among ``obstacles``, the indices of the rest)."""
    is_mesh = np.array([o.kind in (KIND_MESH, KIND_POINTS) for o in obstacles], dtype=bool)
    return np.flatnonzero(is_mesh), np.flatnonzero(~is_mesh)


def _mesh_grid(obstacles: ObstacleSet, meshes: np.ndarray, query: tuple) -> np.ndarray:
    """The clamped grid field (:meth:`ObstacleSet.grid_distance`) of the meshes and clouds ``meshes`` of
    ``obstacles`` alone,
    read-only, kept per the meshes' content (:meth:`Mesh.fingerprint`) and the grid, the least recently used
    dropped past :data:`MESH_GRID_CELLS` cells in all: a later job in the same structure reuses it."""
    origin, spacing, nx, ny, k0, k1, cap = query
    key = (tuple(obstacles.obstacles[k].fingerprint() for k in meshes), origin.tobytes(), spacing.tobytes(),
           nx, ny, k0, k1, cap)
    with _MESH_GRIDS_LOCK:
        field = _MESH_GRIDS.get(key)
        if field is not None:
            _MESH_GRIDS.move_to_end(key)
            return field
    field = np.full((nx, ny, k1 - k0), cap)
    _grid_sdf(obstacles.packed, meshes, *query, field, obstacles.evaluations)
    field.setflags(write=False)
    with _MESH_GRIDS_LOCK:
        _MESH_GRIDS[key] = field
        while sum(f.size for f in _MESH_GRIDS.values()) > MESH_GRID_CELLS and len(_MESH_GRIDS) > 1:
            _MESH_GRIDS.popitem(last=False)
    return field


class ObstacleSet:
    """A packed, immutable set of obstacles with batched exact queries (mm).

    The packed form (:attr:`packed`) is a tuple of arrays the jitted kernels take as one argument: obstacle rows
    and boxes, mesh triangles and their trees, and a tree over the obstacles' boxes (the broad phase).
    """

    def __init__(self, obstacles: Sequence[Packable]):
        self.obstacles = tuple(obstacles)
        rows = [o.pack() for o in self.obstacles]
        tris, normals, nodes, links, ranges = [], [], [], [], []
        cloud_pts, cloud_nodes, cloud_links, cloud_ranges = [], [], [], []
        tri_start = node_start = point_start = cloud_node_start = 0
        for o, row in zip(self.obstacles, rows):
            if o.kind == KIND_POINTS:
                pts, nd, lk = o.distance_data()
                row[_P + 1] = len(cloud_ranges)
                cloud_ranges.append((point_start, point_start + len(pts), cloud_node_start))
                cloud_pts.append(pts)
                cloud_nodes.append(nd)
                cloud_links.append(bvh.shifted(lk, cloud_node_start, point_start))
                point_start += len(pts)
                cloud_node_start += len(nd)
            if o.kind == KIND_MESH:
                t, nrm, nd, lk = o.distance_data()
                row[_P + 1] = len(ranges)
                ranges.append((tri_start, tri_start + len(t), node_start))
                tris.append(t)
                normals.append(nrm)
                nodes.append(nd)
                links.append(bvh.shifted(lk, node_start, tri_start))
                tri_start += len(t)
                node_start += len(nd)
        width = rows[0].shape[0] if rows else PACK_WIDTH
        self._rows = np.array(rows, dtype=float).reshape(len(rows), width)
        self._boxes = np.array([np.concatenate(o.aabb()) for o in self.obstacles], dtype=float).reshape(-1, 6)
        order, onodes, olinks = bvh.build(self._boxes)
        all_tris = np.concatenate(tris) if tris else np.zeros((0, 3, 3))
        self._packed = (self._rows, self._boxes, all_tris,
                        np.array(ranges, dtype=np.int64).reshape(len(ranges), 3),
                        np.concatenate(normals) if normals else np.zeros((0, 7, 3)),
                        np.concatenate(nodes) if nodes else np.zeros((0, 6)),
                        np.concatenate(links) if links else np.zeros((0, 2), dtype=np.int64),
                        onodes, olinks, order, triangle_balls(all_tris),
                        np.concatenate(cloud_pts) if cloud_pts else np.zeros((0, 3)),
                        np.concatenate(cloud_nodes) if cloud_nodes else np.zeros((0, 6)),
                        np.concatenate(cloud_links) if cloud_links else np.zeros((0, 2), dtype=np.int64),
                        np.array(cloud_ranges, dtype=np.int64).reshape(len(cloud_ranges), 3))
        self._split = _split_meshes(self.obstacles)
        #: Point-to-obstacle distance evaluations made by this set's queries so far (a cost measure for tests and
        #: benchmarks, independent of the machine's speed; a kept mesh grid field costs none).
        self.evaluations = np.zeros(1, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.obstacles)

    def subset(self, flags) -> ObstacleSet:
        """The set of the obstacles flagged in ``flags`` (one bool per obstacle), sharing this set's packed rows
        and mesh data: only the tree over their boxes is built (a sensed view's known set, made again as it
        grows, costs no repacking)."""
        keep = np.flatnonzero(np.asarray(flags, dtype=bool))
        out = object.__new__(ObstacleSet)
        out.obstacles = tuple(self.obstacles[k] for k in keep)
        out._rows = np.ascontiguousarray(self._rows[keep])
        out._boxes = np.ascontiguousarray(self._boxes[keep])
        order, onodes, olinks = bvh.build(out._boxes)
        W = self._packed
        out._packed = (out._rows, out._boxes, *W[2:7], onodes, olinks, order, *W[10:])
        out._split = _split_meshes(out.obstacles)
        out.evaluations = np.zeros(1, dtype=np.int64)
        return out

    def __getstate__(self) -> dict:
        """Pickled as its obstacles alone: the packed arrays are derived, and rebuilt on loading."""
        return {"obstacles": self.obstacles}

    def __setstate__(self, state: dict) -> None:
        """Rebuild from the obstacles, so a checkpoint written by an older version (whose pickled state held
        that version's derived arrays) loads into this version's packed form."""
        self.__init__(state["obstacles"])

    @property
    def packed(self) -> tuple[np.ndarray, ...]:
        """The packed arrays jitted kernels take as one argument, as :func:`chain_hit` (with a :func:`workspace`):
        (rows, boxes, triangles, mesh ranges (first triangle, stop, root node), triangle normals, triangle tree
        nodes and links, obstacle tree nodes, links and order, triangle balls, cloud points, cloud tree nodes and
        links, cloud ranges (first point, stop, root node))."""
        return self._packed

    def signed_distance(self, points, cap: float = math.inf) -> np.ndarray:
        """Signed distance (mm) from points ``(..., 3)`` to the nearest obstacle (+inf with no obstacles), or
        ``cap`` where that is less: obstacles farther than a finite cap are never evaluated."""
        p = np.asarray(points, dtype=float)
        flat = _kernel_array(p.reshape(-1, 3))
        return _sdf_points(self._packed, flat, float(cap), self.evaluations).reshape(p.shape[:-1])

    def grid_distance(self, origin, spacing, shape: tuple[int, int, int], cap: float,
                      layers: tuple[int, int] | None = None) -> np.ndarray:
        """:meth:`signed_distance` with a finite ``cap`` at the centres ``origin + (index + 0.5) * spacing`` (mm) of
        a grid of ``shape`` cells (the z layers ``layers = (k0, k1)`` only; default all), clamped below at
        ``-cap``; shape ``(nx, ny, k1 - k0)``. Each obstacle is evaluated only at the cells within ``cap`` of its
        box. The part the meshes make is kept (:func:`_mesh_grid`): a mesh is usually the fixed structure of
        many jobs, and its part costs far more than the primitives'."""
        if not (math.isfinite(cap) and cap > 0.0):
            raise ValueError(f"cap: a grid query needs a finite positive cap (mm), got {cap}")
        k0, k1 = layers if layers is not None else (0, shape[2])
        origin = np.asarray(origin, dtype=float)
        spacing = np.asarray(spacing, dtype=float)
        query = (origin, spacing, int(shape[0]), int(shape[1]), int(k0), int(k1), float(cap))
        meshes, others = self._split
        if len(meshes):
            out = _mesh_grid(self, meshes, query).copy()
        else:
            out = np.full((shape[0], shape[1], k1 - k0), float(cap))
        if len(others):
            _grid_sdf(self._packed, others, *query, out, self.evaluations)
        return out

    def chain_clearance(self, joints, radii, tol: float = CLEARANCE_TOLERANCE_MM) -> np.ndarray:
        """Minimum clearance (mm) between obstacles and chains of capsules.

        ``joints`` is ``(..., n+1, 3)``, ``radii`` is ``(n,)``; negative means penetration.
        The value is attained at a point of the chain (link ends included) and exceeds the true clearance by at
        most ``tol``; where the true clearance may be below ``-CONTACT_RESOLUTION_MM``, the search resolves it, so
        a value >= ``-CONTACT_RESOLUTION_MM`` means the chain at most touches (as :meth:`chain_collides` says).
        """
        J = np.asarray(joints, dtype=float)
        r = _kernel_array(radii)
        flat = _kernel_array(J.reshape(-1, J.shape[-2], 3))
        return _chains_clearance(self._packed, flat, r, tol, self.evaluations).reshape(J.shape[:-2])

    def chain_collides(self, joints, radii) -> np.ndarray:
        """True where any capsule of a chain ``(..., n+1, 3)`` penetrates an obstacle by more than
        ``CONTACT_RESOLUTION_MM``; exits early per chain."""
        J = np.asarray(joints, dtype=float)
        r = _kernel_array(radii)
        flat = _kernel_array(J.reshape(-1, J.shape[-2], 3))
        return _chains_collide(self._packed, flat, r, self.evaluations).reshape(J.shape[:-2])

    def least_clearance(self, joints, radii, tol: float = CLEARANCE_TOLERANCE_MM) -> tuple[float, int]:
        """(the least :meth:`chain_clearance` over chains ``(B, n+1, 3)``, the first chain that has it): the
        same value, found without settling each chain's own clearance exactly ((inf, -1) with no obstacles)."""
        flat = _kernel_array(np.asarray(joints, dtype=float).reshape(-1, np.shape(joints)[-2], 3))
        if len(self.obstacles) == 0 or flat.shape[0] == 0:
            return math.inf, -1
        best, i = _least_clearance(self._packed, flat, _kernel_array(radii), float(tol),
                                   self.evaluations)
        return float(best), int(i)

    def first_hit(self, joints, radii) -> tuple[int, int] | None:
        """(chain, link) of the first chain of ``(B, n+1, 3)``, in order, that :meth:`chain_collides`, or None;
        the chains after it are not examined."""
        flat = _kernel_array(np.asarray(joints, dtype=float).reshape(-1, np.shape(joints)[-2], 3))
        i, k = _first_hit(self._packed, flat, _kernel_array(radii), self.evaluations)
        return None if i < 0 else (int(i), int(k))

    def segments_clear(self, a, b, radius: float = 0.0) -> np.ndarray:
        """True where the capsule of ``radius`` around segment a->b ``(..., 3)`` touches no obstacle."""
        A = np.asarray(a, dtype=float)
        Bp = np.asarray(b, dtype=float)
        A, Bp = np.broadcast_arrays(A, Bp)
        fa = _kernel_array(A.reshape(-1, 3))
        fb = _kernel_array(Bp.reshape(-1, 3))
        return _segments_clear(self._packed, fa, fb, float(radius), self.evaluations).reshape(A.shape[:-1])

    def line_of_sight(self, a, b) -> np.ndarray:
        """True where the straight segment a->b passes through no obstacle's interior."""
        return self.segments_clear(a, b, 0.0)

    def raycast(self, origins, directions, max_distance: float = 1e9, eps: float = 1e-3) -> np.ndarray:
        """Distance (mm) along unit ``directions`` to the first surface (inf when none within max_distance)."""
        o = np.asarray(origins, dtype=float)
        d = np.asarray(directions, dtype=float)
        shape = np.broadcast_shapes(o.shape, d.shape)
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        fo = _kernel_array(np.broadcast_to(o, shape).reshape(-1, 3))
        fd = _kernel_array(np.broadcast_to(d, shape).reshape(-1, 3))
        return _raycast(self._packed, fo, fd, float(max_distance), float(eps), self.evaluations).reshape(shape[:-1])


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
