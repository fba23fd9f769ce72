"""Exact distances to point clouds whose points are balls of one radius (mm): a scan taken as an obstacle.

A cloud is kept as its points in the leaf order of a bounding-volume hierarchy (:mod:`snakeplan.geometry.bvh`,
:data:`LEAF_POINTS` points a leaf). Chosen over a uniform grid (CAPT-like), which answers a capsule in a few cells
when the bound is small but must search outward cell by cell for the judge's unbounded clearance queries, and over
a distance field, which is not exact: the hierarchy answers both in O(log n) node visits, with the same walks as a
mesh's triangle tree, so a cloud enters the obstacle kernels of :mod:`snakeplan.geometry.distance` beside meshes.

The signed distance of a point is its distance to the nearest cloud point minus the radius: exact outside the
union of the balls; inside, the depth in the nearest ball alone, never deeper than the union's. Its sign is exact
and it is 1-Lipschitz everywhere, which is what the clearance and collision kernels need.
"""

from __future__ import annotations

import math

import numpy as np

from snakeplan.geometry import bvh
from snakeplan.geometry.mesh_distance import _node_gap2, _segment_point2
from snakeplan.jit import kernel, leaf

#: Points a leaf of a cloud's hierarchy holds: more points a leaf, fewer nodes to walk and to store.
LEAF_POINTS = 8


def prepare(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points ``(n, 3)`` in leaf order, nodes, links) of a cloud's hierarchy (n >= 1)."""
    p = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
    order, nodes, links = bvh.build(np.concatenate([p, p], axis=1), LEAF_POINTS)
    return np.ascontiguousarray(p[order]), nodes, links


@leaf
def cloud_nearest2(pts, nodes, links, root, p, bound2, stack, others=False):
    """Squared distance from ``p`` to the nearest point of the cloud whose hierarchy starts at ``root``, when
    less than ``bound2``; else ``bound2``; with ``others``, points at ``p`` itself are passed over. Nearer child
    first, every box no nearer than the best pruned."""
    best = bound2
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
            for j in range(first, first - second):
                dx = pts[j, 0] - p[0]
                dy = pts[j, 1] - p[1]
                dz = pts[j, 2] - p[2]
                d2 = dx * dx + dy * dy + dz * dz
                if d2 < best and not (others and d2 == 0.0):
                    best = d2
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
    return best


@leaf
def cloud_sdf(pts, nodes, links, root, radius, p, stack, reach=np.inf):
    """Distance from ``p`` to the union of the cloud's balls of ``radius`` (negative inside, a lower bound
    there), or ``reach`` when that is less (points farther than ``reach + radius`` are never visited)."""
    bound = reach + radius
    d2 = cloud_nearest2(pts, nodes, links, root, p, bound * bound if bound < np.inf else np.inf, stack)
    if d2 == np.inf:
        return reach
    return min(math.sqrt(d2) - radius, reach)


@leaf
def cloud_segment(pts, nodes, links, root, a, b, bound, stack):
    """Distance between segment ab and the cloud's nearest point when less than ``bound``, else inf (the balls'
    radius not taken off). Allocates nothing."""
    best = bound * bound
    found = False
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
            for j in range(first, first - second):
                d2 = _segment_point2(a, b, pts[j])
                if d2 < best:
                    best = d2
                    found = True
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
    return math.sqrt(best) if found else np.inf


@kernel
def _spacings(pts, nodes, links, which):
    """Each point ``which`` of a prepared cloud's distance to its nearest other point (an exact duplicate
    skipped: it is at the same place, not a neighbour)."""
    stack = np.empty(bvh.STACK_SIZE, dtype=np.int64)
    out = np.empty(which.shape[0])
    for i in range(which.shape[0]):
        out[i] = math.sqrt(cloud_nearest2(pts, nodes, links, 0, pts[which[i]], np.inf, stack, True))
    return out


def spacing(prepared: tuple[np.ndarray, np.ndarray, np.ndarray], sample: int = 10_000, seed: int = 0) -> float:
    """The median distance (mm) from a cloud's points to their nearest others, over ``sample`` points drawn with
    ``seed`` (all of them in a smaller cloud): the cloud's sampling spacing (inf for one point)."""
    pts, nodes, links = prepared
    n = len(pts)
    which = np.arange(n) if n <= sample else np.random.default_rng(seed).choice(n, sample, replace=False)
    d = _spacings(pts, nodes, links, np.sort(which).astype(np.int64))
    d = d[np.isfinite(d)]
    return float(np.median(d)) if d.size else math.inf


@kernel
def _reference_segments(pts, a, b):
    out = np.empty(a.shape[0])
    for i in range(a.shape[0]):
        best = np.inf
        for j in range(pts.shape[0]):
            best = min(best, _segment_point2(a[i], b[i], pts[j]))
        out[i] = math.sqrt(best)
    return out


def reference_segment_distance(points, a, b) -> np.ndarray:
    """Brute-force distance (every point) between segments a->b ``(n, 3)`` and a cloud's points: the reference
    for tests."""
    return _reference_segments(np.ascontiguousarray(points, dtype=float), np.ascontiguousarray(a, dtype=float),
                               np.ascontiguousarray(b, dtype=float))
