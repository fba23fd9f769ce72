"""Bounding volume hierarchies (axis-aligned boxes) in flat arrays, built and walked by numba kernels.

One structure serves two broad phases: over a scene's obstacles (so a link only evaluates obstacles near it) and
over a mesh's triangles (so a distance query only visits triangles near the query point). A tree is three arrays:

- ``order (n,)``: item indices in leaf order (each leaf holds a contiguous run of it);
- ``nodes (m, 6)``: each node's box ``[lo(3), hi(3)]``;
- ``links (m, 2)``: an inner node's two children ``(left, right)`` (``right > 0``), or a leaf's
  ``(first, -count)``: items ``order[first:first + count]``.

Node 0 is the root. The tree is built top-down by splitting the items' box centres at the median of the widest
axis, so its depth is about log2(n / LEAF_SIZE) and never more than :data:`MAX_DEPTH`.
"""

from __future__ import annotations

import math

import numpy as np

from snakeplan.jit import kernel, leaf

#: Most items in a leaf.
LEAF_SIZE = 4
#: Deepest tree the walkers' fixed stacks allow (a median split halves the items, so 2^60 items would be needed).
MAX_DEPTH = 60
#: Size of a walker's stack: at most one pending sibling per level, plus the node being expanded.
STACK_SIZE = MAX_DEPTH + 4


@kernel
def _build(boxes: np.ndarray, leaf_size: int):
    n = boxes.shape[0]
    order = np.arange(n)
    cap = max(2 * n, 1)
    nodes = np.empty((cap, 6))
    links = np.empty((cap, 2), dtype=np.int64)
    centres = 0.5 * (boxes[:, :3] + boxes[:, 3:])
    # work items: (node, first, count)
    work = np.empty((cap, 3), dtype=np.int64)
    work[0, 0], work[0, 1], work[0, 2] = 0, 0, n
    top = 1
    used = 1
    while top > 0:
        top -= 1
        node, first, count = work[top, 0], work[top, 1], work[top, 2]
        lo = np.full(3, np.inf)
        hi = np.full(3, -np.inf)
        clo = np.full(3, np.inf)
        chi = np.full(3, -np.inf)
        for j in range(first, first + count):
            i = order[j]
            for a in range(3):
                lo[a] = min(lo[a], boxes[i, a])
                hi[a] = max(hi[a], boxes[i, a + 3])
                clo[a] = min(clo[a], centres[i, a])
                chi[a] = max(chi[a], centres[i, a])
        nodes[node, :3] = lo
        nodes[node, 3:] = hi
        axis = int(np.argmax(chi - clo))
        if count <= leaf_size or chi[axis] - clo[axis] <= 0.0:
            links[node, 0] = first
            links[node, 1] = -count
            continue
        seg = order[first:first + count]
        keys = centres[seg, axis]
        seg = seg[np.argsort(keys, kind="mergesort")]
        order[first:first + count] = seg
        half = count // 2
        left, right = used, used + 1
        used += 2
        links[node, 0] = left
        links[node, 1] = right
        work[top, 0], work[top, 1], work[top, 2] = right, first + half, count - half
        work[top + 1, 0], work[top + 1, 1], work[top + 1, 2] = left, first, half
        top += 2
    return order, nodes[:used].copy(), links[:used].copy()


def build(boxes: np.ndarray, leaf_size: int = LEAF_SIZE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(order, nodes, links) of a hierarchy over items with boxes ``(n, 6)`` ``[lo(3), hi(3)]`` (n >= 1)."""
    b = np.ascontiguousarray(boxes, dtype=float).reshape(-1, 6)
    if b.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 6)), np.zeros((0, 2), dtype=np.int64)
    return _build(b, int(leaf_size))


def shifted(links: np.ndarray, first_node: int, first_item: int) -> np.ndarray:
    """A tree's links (:func:`build`) once its nodes and items are stored after others': inner nodes' children
    moved by ``first_node``, leaves' first items by ``first_item``."""
    out = links.copy()
    inner = out[:, 1] > 0
    out[inner] += first_node
    out[~inner, 0] += first_item
    return out


@leaf
def box_distance2(box: np.ndarray, p: np.ndarray) -> float:
    """Squared distance from p to the box ``[lo(3), hi(3)]`` (0 inside)."""
    acc = 0.0
    for a in range(3):
        d = max(box[a] - p[a], p[a] - box[a + 3], 0.0)
        acc += d * d
    return acc


@leaf
def box_distance(box: np.ndarray, p: np.ndarray) -> float:
    """Distance from p to the box ``[lo(3), hi(3)]`` (0 inside): a lower bound on the distance to what it holds."""
    return math.sqrt(box_distance2(box, p))



@leaf
def ray_box(box: np.ndarray, origin: np.ndarray, d: np.ndarray, t_max: float, eps: float = 0.0) -> float:
    """Where the ray origin + t d, t in [0, t_max], enters the box ``[lo(3), hi(3)]`` grown by ``eps`` (0 when it
    starts inside), or inf when it misses the box (slab test)."""
    t0, t1 = 0.0, t_max
    for a in range(3):
        lo, hi = box[a] - eps, box[a + 3] + eps
        if abs(d[a]) < 1e-12:
            if origin[a] < lo or origin[a] > hi:
                return math.inf
        else:
            ta, tb = (lo - origin[a]) / d[a], (hi - origin[a]) / d[a]
            t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    return t0 if t0 <= t1 else math.inf
