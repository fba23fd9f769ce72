"""Reachable in principle: an any-angle geodesic distance (mm) from a scene's entrance through the free cells of a
grid (:mod:`.grid`).

The distance from the entrance is found by a lazy Theta* search on the 26-connected grid (numba): each cell's
parent is a cell (or the entrance itself) in straight sight through free cells, so in open space the distance is
the straight-line length, not the staircase of plain grid Dijkstra (several per cent longer); around walls it is
the length of a taut polyline through free cells. Scene generators accept a target only when this geodesic
distance is at most a fraction of the arm length; planners reuse the same field as a heuristic and
:meth:`GeodesicField.path_to` as a guide path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from snakeplan.jit import kernel
from snakeplan.scenes.parameters import check_range
from snakeplan.scenes.routes.grid import DEFAULT_CELL_MM, SDF_HORIZON_MM, Grid, free_space
from snakeplan.scenes.scene import Entrance, Scene

#: Inflation radius (mm): SJTU-Snake III's 27.5 mm body radius plus 2.5 mm.
DEFAULT_INFLATE_MM = 30.0
#: Length (mm) of the straight stretch along the feed axis, from the entrance inwards, that counts as free.
DEFAULT_FEED_MM = 100.0

_UNREACHED = -2
_SOURCE = -1
_NEIGHBOURS = np.array(
    [(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1) if (a, b, c) != (0, 0, 0)],
    dtype=np.int64,
)


@dataclass(frozen=True, eq=False)
class GeodesicField:
    """Free cells and the any-angle geodesic distance (mm) from ``source`` through them.

    ``distance`` is inf in blocked or unreachable cells; ``parent`` holds each reached cell's parent as a flat
    cell index (-1: the source point itself). ``sdf`` is the signed distance at the cell centres, clamped to
    [-cap, cap] for the cap it was made with (``inflate_mm + SDF_HORIZON_MM`` by :func:`geodesic_field`).
    """

    grid: Grid
    sdf: np.ndarray
    free: np.ndarray
    distance: np.ndarray
    parent: np.ndarray
    source: np.ndarray
    inflate_mm: float

    def distance_at(self, points) -> np.ndarray:
        """Geodesic distance (mm) from the source to points ``(..., 3)``; inf outside the bounds or unreachable.

        A point in a reached cell gets its cell's parent's distance plus the straight length from that parent
        (exact where the source is in sight); a point in a blocked cell (within the inflation of an obstacle)
        gets the best of its reached neighbour cells. Accurate to about one cell.
        """
        p = np.asarray(points, dtype=float)
        flat = np.require(p.reshape(-1, 3), requirements=["C", "W"])
        g = self.grid
        out = _distance_at(self.distance.reshape(-1), self.parent.reshape(-1), np.array(g.shape, dtype=np.int64),
                           g.origin, g.spacing, self.source, flat)
        return out.reshape(p.shape[:-1])

    def reachable(self, points, max_distance_mm: float) -> np.ndarray:
        """True where the geodesic distance is at most ``max_distance_mm``."""
        return self.distance_at(points) <= max_distance_mm

    def path_to(self, point) -> np.ndarray:
        """The taut polyline ``(k, 3)`` from the source to ``point`` through free space; empty when unreachable."""
        q = np.asarray(point, dtype=float).reshape(3)
        g = self.grid
        k, own = _anchor(self.distance.reshape(-1), np.array(g.shape, dtype=np.int64), g.origin, g.spacing, q)
        if k < 0:
            return np.zeros((0, 3))
        parent = self.parent.reshape(-1)
        chain = [k] if not own else []
        node = int(parent[k])
        while node >= 0:
            chain.append(node)
            node = int(parent[node])
        cells = np.array(np.unravel_index(np.array(chain, dtype=np.int64), g.shape)).T.reshape(-1, 3)
        centres = g.origin + (cells + 0.5) * g.spacing
        return np.vstack([self.source[None], centres[::-1], q[None]])


def geodesic_from_sdf(grid: Grid, sdf: np.ndarray, entrance: Entrance, inflate_mm: float = DEFAULT_INFLATE_MM,
                      feed_mm: float = DEFAULT_FEED_MM, goal=None) -> GeodesicField:
    """Geodesic field from precomputed cell-centre distances ``sdf`` (shape ``grid.shape``, mm).

    Free cells: ``sdf >= inflate_mm``; the entrance cell and the cells along the first ``feed_mm`` of the feed
    axis count as free as long as their centre is not inside material. With a ``goal`` point the search is
    directed at its cell and stops there: only :meth:`GeodesicField.path_to` the goal is meaningful then.
    """
    check_range("inflate_mm", inflate_mm, 0.0)
    check_range("feed_mm", feed_mm, 0.0)
    free = sdf >= inflate_mm
    src = entrance.position
    n_steps = int(math.ceil(feed_mm / (grid.spacing.min() / 4))) + 1
    stretch = src + np.linspace(0.0, feed_mm, n_steps)[:, None] * entrance.direction
    in_box = np.all((stretch >= grid.origin) & (stretch <= grid.origin + grid.spacing * grid.shape), axis=1)
    cells = grid.cell_of(stretch[in_box])
    keep = sdf[cells[:, 0], cells[:, 1], cells[:, 2]] > 0.0
    free[cells[keep, 0], cells[keep, 1], cells[keep, 2]] = True
    start = grid.cell_of(src)
    free[start[0], start[1], start[2]] = True
    start_flat = int(np.ravel_multi_index(tuple(start), grid.shape))
    target = -1 if goal is None else int(np.ravel_multi_index(tuple(grid.cell_of(goal)), grid.shape))
    dist, parent = _lazy_theta(free.reshape(-1), np.array(grid.shape, dtype=np.int64), grid.origin, grid.spacing,
                               src, start_flat, _NEIGHBOURS, target)
    return GeodesicField(grid, sdf, free, dist.reshape(grid.shape), parent.reshape(grid.shape), src.copy(),
                         float(inflate_mm))


def geodesic_field(scene: Scene, inflate_mm: float = DEFAULT_INFLATE_MM, cell_mm: float = DEFAULT_CELL_MM,
                   feed_mm: float = DEFAULT_FEED_MM) -> GeodesicField:
    """Geodesic distance field (mm) from ``scene.entrance`` through space at least ``inflate_mm`` from obstacles."""
    grid = Grid.covering(scene.bounds_min, scene.bounds_max, cell_mm)
    sdf = free_space(scene.obstacle_set, grid, inflate_mm + SDF_HORIZON_MM)
    return geodesic_from_sdf(grid, sdf, scene.entrance, inflate_mm, feed_mm)


# --- numba kernels --------------------------------------------------------------------------------------------


@kernel
def _los(free, shape, ax, ay, az, bx, by, bz):
    """True when every cell the segment a->b (grid units) passes through is free; ties step one axis at a time."""
    nx, ny, nz = shape[0], shape[1], shape[2]
    i = min(max(int(math.floor(ax)), 0), nx - 1)
    j = min(max(int(math.floor(ay)), 0), ny - 1)
    k = min(max(int(math.floor(az)), 0), nz - 1)
    ti = min(max(int(math.floor(bx)), 0), nx - 1)
    tj = min(max(int(math.floor(by)), 0), ny - 1)
    tk = min(max(int(math.floor(bz)), 0), nz - 1)
    dx, dy, dz = bx - ax, by - ay, bz - az
    sx = 1 if dx > 0 else -1
    sy = 1 if dy > 0 else -1
    sz = 1 if dz > 0 else -1
    inf = math.inf
    mx = ((i + (1 if dx > 0 else 0)) - ax) / dx if dx != 0.0 else inf
    my = ((j + (1 if dy > 0 else 0)) - ay) / dy if dy != 0.0 else inf
    mz = ((k + (1 if dz > 0 else 0)) - az) / dz if dz != 0.0 else inf
    ex = 1.0 / abs(dx) if dx != 0.0 else inf
    ey = 1.0 / abs(dy) if dy != 0.0 else inf
    ez = 1.0 / abs(dz) if dz != 0.0 else inf
    for _ in range(3 * (nx + ny + nz) + 3):
        if not free[(i * ny + j) * nz + k]:
            return False
        if i == ti and j == tj and k == tk:
            return True
        t = min(mx, min(my, mz))
        if t > 1.0:
            return True
        tie = t + 1e-12
        if mx <= tie and i != ti:
            i += sx
            mx += ex
            if i < 0 or i >= nx or not free[(i * ny + j) * nz + k]:
                return False
        elif mx <= tie:
            mx += ex
        if my <= tie and j != tj:
            j += sy
            my += ey
            if j < 0 or j >= ny or not free[(i * ny + j) * nz + k]:
                return False
        elif my <= tie:
            my += ey
        if mz <= tie and k != tk:
            k += sz
            mz += ez
            if k < 0 or k >= nz:
                return False
        elif mz <= tie:
            mz += ez
    return free[(i * ny + j) * nz + k]


@kernel
def _sift_up(heap, hpos, key, i):
    node = heap[i]
    while i > 0:
        up = (i - 1) >> 1
        if key[heap[up]] <= key[node]:
            break
        heap[i] = heap[up]
        hpos[heap[i]] = i
        i = up
    heap[i] = node
    hpos[node] = i


@kernel
def _sift_down(heap, hpos, key, i, size):
    node = heap[i]
    while True:
        c = 2 * i + 1
        if c >= size:
            break
        if c + 1 < size and key[heap[c + 1]] < key[heap[c]]:
            c += 1
        if key[heap[c]] >= key[node]:
            break
        heap[i] = heap[c]
        hpos[heap[i]] = i
        i = c
    heap[i] = node
    hpos[node] = i


@kernel
def _lazy_theta(free, shape, origin, spacing, src, start, offsets, goal):
    """Single-source lazy Theta* over the free cells; returns (distance mm, parent flat index). With a ``goal``
    cell (flat index; -1: none) it is A*-ordered by the straight distance to the goal's centre and stops once the
    goal is settled, so only that cell's distance and parents are final; without one every cell's are."""
    nx, ny, nz = shape[0], shape[1], shape[2]
    n = nx * ny * nz
    g = np.full(n, np.inf)
    key = np.full(n, np.inf)
    if goal >= 0:
        gx, gy, gz = goal // (ny * nz) + 0.5, (goal // nz) % ny + 0.5, goal % nz + 0.5
    else:
        gx, gy, gz = 0.0, 0.0, 0.0
    parent = np.full(n, _UNREACHED, dtype=np.int64)
    closed = np.zeros(n, dtype=np.bool_)
    heap = np.empty(n, dtype=np.int64)
    hpos = np.full(n, -1, dtype=np.int64)
    sg = (src - origin) / spacing
    hx, hy, hz = spacing[0], spacing[1], spacing[2]

    si = start // (ny * nz)
    sj = (start // nz) % ny
    sk = start % nz
    g[start] = math.sqrt(((si + 0.5 - sg[0]) * hx) ** 2 + ((sj + 0.5 - sg[1]) * hy) ** 2
                         + ((sk + 0.5 - sg[2]) * hz) ** 2)
    parent[start] = _SOURCE
    key[start] = g[start]
    heap[0] = start
    hpos[start] = 0
    size = 1
    while size > 0:
        u = heap[0]
        hpos[u] = -1
        size -= 1
        if size > 0:
            heap[0] = heap[size]
            hpos[heap[0]] = 0
            _sift_down(heap, hpos, key, 0, size)
        ui = u // (ny * nz)
        uj = (u // nz) % ny
        uk = u % nz
        cx, cy, cz = ui + 0.5, uj + 0.5, uk + 0.5
        p = parent[u]
        if p == _SOURCE:
            px, py, pz = sg[0], sg[1], sg[2]
        else:
            px, py, pz = p // (ny * nz) + 0.5, (p // nz) % ny + 0.5, p % nz + 0.5
        if u != start and not _los(free, shape, px, py, pz, cx, cy, cz):
            best = np.inf
            bp = _UNREACHED
            for o in range(offsets.shape[0]):
                vi, vj, vk = ui + offsets[o, 0], uj + offsets[o, 1], uk + offsets[o, 2]
                if vi < 0 or vi >= nx or vj < 0 or vj >= ny or vk < 0 or vk >= nz:
                    continue
                v = (vi * ny + vj) * nz + vk
                if not closed[v]:
                    continue
                c = g[v] + math.sqrt((offsets[o, 0] * hx) ** 2 + (offsets[o, 1] * hy) ** 2
                                     + (offsets[o, 2] * hz) ** 2)
                if c < best and _los(free, shape, vi + 0.5, vj + 0.5, vk + 0.5, cx, cy, cz):
                    best = c
                    bp = v
            if bp == _UNREACHED:
                g[u] = np.inf
                parent[u] = _UNREACHED
                continue
            g[u] = best
            parent[u] = bp
            p = bp
            px, py, pz = p // (ny * nz) + 0.5, (p // nz) % ny + 0.5, p % nz + 0.5
        closed[u] = True
        if u == goal:
            break
        base = 0.0 if p == _SOURCE else g[p]
        for o in range(offsets.shape[0]):
            vi, vj, vk = ui + offsets[o, 0], uj + offsets[o, 1], uk + offsets[o, 2]
            if vi < 0 or vi >= nx or vj < 0 or vj >= ny or vk < 0 or vk >= nz:
                continue
            v = (vi * ny + vj) * nz + vk
            if closed[v] or not free[v]:
                continue
            c = base + math.sqrt(((vi + 0.5 - px) * hx) ** 2 + ((vj + 0.5 - py) * hy) ** 2
                                 + ((vk + 0.5 - pz) * hz) ** 2)
            if c < g[v]:
                g[v] = c
                key[v] = c
                if goal >= 0:
                    key[v] += math.sqrt(((vi + 0.5 - gx) * hx) ** 2 + ((vj + 0.5 - gy) * hy) ** 2
                                        + ((vk + 0.5 - gz) * hz) ** 2)
                parent[v] = p
                if hpos[v] < 0:
                    heap[size] = v
                    hpos[v] = size
                    size += 1
                _sift_up(heap, hpos, key, hpos[v])
    return g, parent


@kernel
def _anchor(dist, shape, origin, spacing, q):
    """Cell that anchors point q: (its own cell, True) if reached, else (best reached neighbour, False).

    Returns (-1, False) outside the bounds or when nothing around q is reached.
    """
    nx, ny, nz = shape[0], shape[1], shape[2]
    idx = np.empty(3, dtype=np.int64)
    for a in range(3):
        t = (q[a] - origin[a]) / spacing[a]
        if t < -1e-9 or t > shape[a] + 1e-9:
            return -1, False
        idx[a] = min(max(int(math.floor(t)), 0), shape[a] - 1)
    k = (idx[0] * ny + idx[1]) * nz + idx[2]
    if dist[k] < np.inf:
        return k, True
    best = np.inf
    bk = -1
    for a in range(-1, 2):
        for b in range(-1, 2):
            for c in range(-1, 2):
                i, j, l = idx[0] + a, idx[1] + b, idx[2] + c
                if i < 0 or i >= nx or j < 0 or j >= ny or l < 0 or l >= nz:
                    continue
                v = (i * ny + j) * nz + l
                if dist[v] == np.inf:
                    continue
                d = dist[v] + _dist_to_centre(v, shape, origin, spacing, q)
                if d < best:
                    best = d
                    bk = v
    return bk, False


@kernel
def _dist_to_centre(k, shape, origin, spacing, q):
    ny, nz = shape[1], shape[2]
    x = origin[0] + (k // (ny * nz) + 0.5) * spacing[0]
    y = origin[1] + ((k // nz) % ny + 0.5) * spacing[1]
    z = origin[2] + (k % nz + 0.5) * spacing[2]
    return math.sqrt((x - q[0]) ** 2 + (y - q[1]) ** 2 + (z - q[2]) ** 2)


@kernel
def _distance_at(dist, parent, shape, origin, spacing, src, pts):
    out = np.full(pts.shape[0], np.inf)
    for n in range(pts.shape[0]):
        q = pts[n]
        k, own = _anchor(dist, shape, origin, spacing, q)
        if k < 0:
            continue
        if not own:
            out[n] = dist[k] + _dist_to_centre(k, shape, origin, spacing, q)
            continue
        p = parent[k]
        if p == _SOURCE:
            out[n] = math.sqrt((src[0] - q[0]) ** 2 + (src[1] - q[1]) ** 2 + (src[2] - q[2]) ** 2)
        else:
            out[n] = dist[p] + _dist_to_centre(p, shape, origin, spacing, q)
    return out
