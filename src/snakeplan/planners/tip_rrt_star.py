"""A compiled RRT* in tip space: OMPL's ``RRTstar`` with its defaults, in numba, motion checks in the same loop.

OMPL's RRT* calls back into Python for every motion check, and on these scenes its own iteration costs about
0.1 ms besides (measured with no Python callback at all), so a plan of a few thousand iterations cannot take
less than a few tenths of a second through it. This is the same algorithm with the same defaults, compiled
whole (mm):

* sample the goal with probability ``goal_bias``, else uniformly in the bounds; steer from the nearest vertex
  by at most ``range_mm``; keep the new state when the swept tip ball clears the obstacles
  (:func:`snakeplan.world.validity.motion_free`, the kernel behind :meth:`ValidityChecker.motion_check`);
* neighbours: the k nearest vertices, k = ceil(1.1 e (1 + 1/3) ln(n + 1)) (OMPL's ``useKNearest`` with rewire
  factor 1.1); the parent is the neighbour of least cost-to-come through it whose motion is free, tried in
  order of that cost (OMPL's delayed collision checking), neighbours farther than ``range_mm`` being refused;
* rewiring: every other neighbour whose cost-to-come drops through the new vertex is re-parented when its
  motion is free (reusing the checks already made), and its subtree's costs are updated;
* the goal is reached when the goal state itself joins the tree; the best goal vertex is kept.

Nearest and k-nearest searches use a uniform grid over the bounds (a vertex list per cell, half a range wide,
wider in large scenes): the nearest vertex by shells of cells around the sample, the k nearest among the cells
within a range of it. Only neighbours within the range can become parents or be rewired, so the k nearest within
the range are all the brute-force search over the whole tree would use; ties go to the older vertex as they
would there. The tree is therefore the one a brute-force search grows: the two queries are tested against brute
force, and grown trees kept their sizes and distance evaluations when the grid replaced it. The random stream is
numba's, seeded per plan; the trees therefore differ from OMPL's for the same seed, and
:mod:`snakeplan.bench.speed` compares the two on the same problems.
"""

from __future__ import annotations

import math
import time

import numpy as np

from snakeplan.geometry.distance import workspace
from snakeplan.jit import kernel, leaf
from snakeplan.world import ValidityChecker
from snakeplan.world.validity import motion_free

#: OMPL RRTstar's rewire factor; k_rrt = factor * e * (1 + 1 / dimension).
REWIRE_FACTOR = 1.1
#: Iterations per compiled call between deadline checks.
CHUNK = 256
#: Vertices allocated at first (the arrays double when full).
CAPACITY = 4096
#: Grid cells per range, and the most cells along one axis of the bounds (cells grow in larger scenes; the
#: k-nearest search looks as many cells each way as a range spans).
GRID_CELLS_PER_RANGE = 2
MAX_GRID_SIDE = 128

# indices into the integer state of a search: vertices, iterations, iteration of the first solution (-1: none yet),
# best goal vertex (-1: none), goal vertices
_N, _ITER, _FOUND_AT, _BEST, _GOALS = 0, 1, 2, 3, 4


@kernel(seeds=True)
def seed_stream(seed):
    """Seed numba's random stream (process-wide, like OMPL's: plan from one thread at a time)."""
    np.random.seed(seed)


@leaf
def _insert_k(kd, ki, m, k, d, j):
    """Insert (d, j) into the list kd/ki of length m, ascending by (distance, index), at most k kept; return the
    new length."""
    if m == k and (d > kd[m - 1] or (d == kd[m - 1] and j > ki[m - 1])):
        return m
    pos = m if m < k else k - 1
    while pos > 0 and (kd[pos - 1] > d or (kd[pos - 1] == d and ki[pos - 1] > j)):
        kd[pos] = kd[pos - 1]
        ki[pos] = ki[pos - 1]
        pos -= 1
    kd[pos] = d
    ki[pos] = j
    return m + 1 if m < k else m


@leaf
def _cell(dims, cell, lo, x, a):
    """The grid index of coordinate ``a`` of point x (clamped to the grid)."""
    return min(max(int((x[a] - lo[a]) / cell), 0), dims[a] - 1)


@leaf
def grid_add(head, nxt, dims, cell, lo, pos, v):
    """Put vertex v (at ``pos[v]``) on its cell's list."""
    c = (_cell(dims, cell, lo, pos[v], 0) * dims[1] + _cell(dims, cell, lo, pos[v], 1)) * dims[2] \
        + _cell(dims, cell, lo, pos[v], 2)
    nxt[v] = head[c]
    head[c] = v


@leaf
def nearest(pos, head, nxt, dims, cell, lo, x):
    """(the vertex nearest to x, its squared distance), the older vertex on a tie: cells are searched in rings
    around x's cell until every cell not yet searched is farther than the best found."""
    ci, cj, ck = _cell(dims, cell, lo, x, 0), _cell(dims, cell, lo, x, 1), _cell(dims, cell, lo, x, 2)
    best, dn = -1, np.inf
    for r in range(max(dims[0], max(dims[1], dims[2]))):
        for i in range(max(ci - r, 0), min(ci + r, dims[0] - 1) + 1):
            for j in range(max(cj - r, 0), min(cj + r, dims[1] - 1) + 1):
                # the ring's shell only: every k on its faces across i or j, else its two ends along k
                if abs(i - ci) == r or abs(j - cj) == r:
                    k, last, step = max(ck - r, 0), min(ck + r, dims[2] - 1), 1
                else:
                    k, last, step = ck - r, ck + r, 2 * r
                while k <= last:
                    v = head[(i * dims[1] + j) * dims[2] + k] if 0 <= k < dims[2] else -1
                    while v >= 0:
                        d = (pos[v, 0] - x[0]) ** 2 + (pos[v, 1] - x[1]) ** 2 + (pos[v, 2] - x[2]) ** 2
                        if d < dn or (d == dn and v < best):
                            best, dn = v, d
                        v = nxt[v]
                    k += step
        # a vertex outside rings 0..r is at least r cells from x along some axis
        if best >= 0 and dn < (r * cell) ** 2:
            break
    return best, dn


@leaf
def near_k(pos, head, nxt, dims, cell, lo, x, k, radius, kd, ki):
    """The k vertices nearest to x among those within ``radius`` into kd/ki, ascending by (distance, index);
    returns their count. Only the cells that reach within ``radius`` of x's cell are searched, and a vertex
    farther than the k-th so far is dropped on its squared distance."""
    ci, cj, ck = _cell(dims, cell, lo, x, 0), _cell(dims, cell, lo, x, 1), _cell(dims, cell, lo, x, 2)
    reach = math.ceil(radius / cell)
    r2 = radius * radius
    m = 0
    for i in range(max(ci - reach, 0), min(ci + reach, dims[0] - 1) + 1):
        for j in range(max(cj - reach, 0), min(cj + reach, dims[1] - 1) + 1):
            for c in range(max(ck - reach, 0), min(ck + reach, dims[2] - 1) + 1):
                v = head[(i * dims[1] + j) * dims[2] + c]
                while v >= 0:
                    d2 = (pos[v, 0] - x[0]) ** 2 + (pos[v, 1] - x[1]) ** 2 + (pos[v, 2] - x[2]) ** 2
                    if d2 <= r2 and (m < k or d2 <= kd[m - 1] * kd[m - 1] * (1.0 + 1e-12)):
                        m = _insert_k(kd, ki, m, k, math.sqrt(d2), v)
                    v = nxt[v]
    return m


@leaf
def _detach(child, sibling, parent_of, v):
    """Remove vertex v from its parent's list of children."""
    p = parent_of[v]
    if child[p] == v:
        child[p] = sibling[v]
    else:
        c = child[p]
        while sibling[c] != v:
            c = sibling[c]
        sibling[c] = sibling[v]
    sibling[v] = -1


@kernel
def grow(pos, parent, cost, inc, child, sibling, goals, state, head, nxt, dims, cell, goal, lo, hi, range_mm,
         goal_bias, k_rrt, improve, iterations, W, radius, stats):
    """Run up to ``iterations`` RRT* iterations on the tree (arrays with room for that many more vertices, and
    its grid: cell lists ``head``/``nxt`` of ``dims`` cells ``cell`` mm wide from ``lo``); True when the search
    is done (``improve`` iterations after the first solution)."""
    cap = pos.shape[0]
    joints = np.empty((2, 3))
    radii = np.empty(1)
    work = workspace(W)
    kmax = int(math.ceil(k_rrt * math.log(cap + 1.0))) + 1
    kd = np.empty(kmax)
    ki = np.empty(kmax, dtype=np.int64)
    valid = np.empty(kmax, dtype=np.int8)
    through = np.empty(kmax)
    order = np.empty(kmax, dtype=np.int64)
    todo = np.empty(cap, dtype=np.int64)
    x = np.empty(3)
    for _ in range(iterations):
        if state[_FOUND_AT] >= 0 and state[_ITER] >= state[_FOUND_AT] + improve:
            return True
        state[_ITER] += 1
        n = state[_N]
        if np.random.random() < goal_bias:
            x[:] = goal
        else:
            for a in range(3):
                x[a] = lo[a] + np.random.random() * (hi[a] - lo[a])
        near, dn = nearest(pos, head, nxt, dims, cell, lo, x)
        dn = math.sqrt(dn)
        if dn > range_mm:
            for a in range(3):
                x[a] = pos[near, a] + (x[a] - pos[near, a]) * (range_mm / dn)
        if not motion_free(W, lo, hi, pos[near, 0], pos[near, 1], pos[near, 2], x[0], x[1],
                           x[2], radius, joints, radii, work, stats):
            continue
        k = min(int(math.ceil(k_rrt * math.log(n + 1.0))), kmax)
        # the steered x is within the range of its nearest vertex, so the candidates within the range include it
        m = near_k(pos, head, nxt, dims, cell, lo, x, k, range_mm * (1.0 + 1e-12), kd, ki)
        for i in range(m):
            through[i] = cost[ki[i]] + kd[i]
            valid[i] = 0
        order[:m] = np.argsort(through[:m], kind="mergesort")
        par = -1
        for o in range(m):
            i = order[o]
            j = ki[i]
            if j == near or (kd[i] < range_mm and motion_free(W, lo, hi, pos[j, 0], pos[j, 1],
                                                              pos[j, 2], x[0], x[1], x[2], radius, joints, radii,
                                                              work, stats)):
                valid[i] = 1
                par = i
                break
            valid[i] = -1
        v = n
        pos[v] = x
        if par >= 0:
            parent[v] = ki[par]
            inc[v] = kd[par]
        else:
            parent[v] = near
            inc[v] = dn if dn <= range_mm else range_mm
        cost[v] = cost[parent[v]] + inc[v]
        child[v] = -1
        sibling[v] = child[parent[v]]
        child[parent[v]] = v
        state[_N] = n + 1
        grid_add(head, nxt, dims, cell, lo, pos, v)
        improved = False
        for i in range(m):
            j = ki[i]
            if j == parent[v]:
                continue
            new_cost = cost[v] + kd[i]
            if new_cost < cost[j]:
                ok = valid[i] == 1
                if valid[i] == 0:
                    ok = kd[i] < range_mm and motion_free(W, lo, hi, x[0], x[1], x[2],
                                                          pos[j, 0], pos[j, 1], pos[j, 2], radius, joints, radii,
                                                          work, stats)
                if ok:
                    _detach(child, sibling, parent, j)
                    parent[j] = v
                    inc[j] = kd[i]
                    cost[j] = new_cost
                    sibling[j] = child[v]
                    child[v] = j
                    top = 0
                    c = child[j]
                    while c >= 0:
                        todo[top] = c
                        top += 1
                        c = sibling[c]
                    while top > 0:
                        top -= 1
                        u = todo[top]
                        cost[u] = cost[parent[u]] + inc[u]
                        c = child[u]
                        while c >= 0:
                            todo[top] = c
                            top += 1
                            c = sibling[c]
                    improved = True
        if x[0] == goal[0] and x[1] == goal[1] and x[2] == goal[2]:
            goals[state[_GOALS]] = v
            state[_GOALS] += 1
            improved = True
        if improved and state[_GOALS] > 0:
            best = goals[0]
            for g in range(1, state[_GOALS]):
                if cost[goals[g]] < cost[best]:
                    best = goals[g]
            state[_BEST] = best
        if state[_BEST] >= 0 and state[_FOUND_AT] < 0:
            state[_FOUND_AT] = state[_ITER]
    return False


class _Tree:
    """The arrays of one search (vertices in insertion order; the root is vertex 0) and its grid over the bounds
    ``lo``-``hi`` (mm): cells ``range_mm / GRID_CELLS_PER_RANGE`` wide, at most ``MAX_GRID_SIDE`` along an axis."""

    def __init__(self, root: np.ndarray, lo: np.ndarray, hi: np.ndarray, range_mm: float,
                 capacity: int = CAPACITY) -> None:
        self.pos = np.zeros((capacity, 3))
        self.parent = np.full(capacity, -1, dtype=np.int64)
        self.cost = np.zeros(capacity)
        self.inc = np.zeros(capacity)
        self.child = np.full(capacity, -1, dtype=np.int64)
        self.sibling = np.full(capacity, -1, dtype=np.int64)
        self.goals = np.zeros(capacity, dtype=np.int64)
        self.nxt = np.full(capacity, -1, dtype=np.int64)
        self.state = np.array([1, 0, -1, -1, 0], dtype=np.int64)
        self.lo = np.asarray(lo, dtype=float)
        self.hi = np.asarray(hi, dtype=float)
        extent = np.maximum(self.hi - self.lo, 1e-9)
        self.cell = float(max(range_mm / GRID_CELLS_PER_RANGE, float(extent.max()) / MAX_GRID_SIDE))
        self.dims = np.maximum(np.ceil(extent / self.cell), 1).astype(np.int64)
        self.head = np.full(int(np.prod(self.dims)), -1, dtype=np.int64)
        self.pos[0] = root
        grid_add(self.head, self.nxt, self.dims, self.cell, self.lo, self.pos, 0)

    def reserve(self, extra: int) -> None:
        """Room for ``extra`` more vertices (the arrays double as needed)."""
        need = int(self.state[_N]) + extra
        cap = self.pos.shape[0]
        if need <= cap:
            return
        new = max(need, 2 * cap)
        for name, fill in (("pos", 0.0), ("parent", -1), ("cost", 0.0), ("inc", 0.0), ("child", -1),
                           ("sibling", -1), ("goals", 0), ("nxt", -1)):
            old = getattr(self, name)
            grown = np.full((new, *old.shape[1:]), fill, dtype=old.dtype)
            grown[:cap] = old
            setattr(self, name, grown)

    def grow(self, goal: np.ndarray, range_mm: float, goal_bias: float, k_rrt: float, improve: int,
             iterations: int, W: tuple, radius: float, stats: np.ndarray) -> bool:
        """Up to ``iterations`` more iterations (room for them is made first); True when the search is done."""
        self.reserve(iterations)
        return grow(self.pos, self.parent, self.cost, self.inc, self.child, self.sibling, self.goals, self.state,
                    self.head, self.nxt, self.dims, self.cell, goal, self.lo, self.hi, float(range_mm),
                    float(goal_bias), float(k_rrt), int(improve), int(iterations), W, float(radius), stats)

    def path(self) -> np.ndarray | None:
        """Vertices from the root to the best goal vertex (mm), or None."""
        v = int(self.state[_BEST])
        if v < 0:
            return None
        chain = []
        while v >= 0:
            chain.append(v)
            v = int(self.parent[v])
        return self.pos[chain[::-1]].copy()


def warm_up(arm: ValidityChecker, start: np.ndarray, goal: np.ndarray) -> None:
    """Load the kernels (numba's cache) with a few iterations of a throw-away search; the random stream is
    seeded again by the plan that follows."""
    seed_stream(0)
    plan_leg(arm, start, goal, arm.tip_radius, math.inf, 200.0, 0.05, 0, iterations=4)


def plan_leg(arm: ValidityChecker, start: np.ndarray, goal: np.ndarray, radius: float, deadline: float,
             range_mm: float, goal_bias: float, improve: int, iterations: int | None = None
             ) -> tuple[np.ndarray | None, int]:
    """RRT* from ``start`` to ``goal`` (mm) with tip clearance ``radius`` (mm) until ``deadline`` (a perf_counter
    value) or ``improve`` iterations after the first solution (or after ``iterations`` in all, when given);
    (waypoints or None, tree size). Seed the stream (:func:`seed_stream`) before a plan's first leg."""
    obstacles = arm.obstacles
    scene = arm.world.scene
    k_rrt = REWIRE_FACTOR * math.e * (1.0 + 1.0 / 3.0)
    tree = _Tree(np.asarray(start, dtype=float), scene.bounds_min, scene.bounds_max, range_mm)
    g = np.asarray(goal, dtype=float)
    left = math.inf if iterations is None else int(iterations)
    while time.perf_counter() < deadline and left > 0:
        chunk = int(min(CHUNK, left))
        left -= chunk
        if tree.grow(g, range_mm, goal_bias, k_rrt, improve, chunk, obstacles.packed, radius, obstacles.evaluations):
            break
    pts = tree.path()
    if pts is not None:
        pts[0], pts[-1] = start, goal
    return pts, int(tree.state[_N])
