"""Reachable in principle: a free-space grid and an any-angle geodesic distance from a scene's entrance (mm).

The workspace bounds are cut into cells of at most ``cell_mm``; a cell is free when the signed distance at its
centre is at least ``inflate_mm`` (the arm's radius plus a margin), so a free path of cell centres keeps a body
of that radius clear of every obstacle (to within half a cell). The distance from the entrance is found by a
lazy Theta* search on the 26-connected grid (numba): each cell's parent is a cell (or the entrance itself) in
straight sight through free cells, so in open space the distance is the straight-line length, not the staircase
of plain grid Dijkstra (several per cent longer); around walls it is the length of a taut polyline through free
cells. Scene generators accept a target only when this
geodesic distance is at most a fraction of the arm length; planners reuse the same field as a heuristic and
:meth:`GeodesicField.path_to` as a guide path.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.polyline import densify
from snakeplan.jit import kernel
from snakeplan.scenes.scene import Entrance, Scene

#: Grid cell edge (mm): small enough for the 120 mm half-height of a fuel-tank hole shrunk by the inflation.
DEFAULT_CELL_MM = 20.0
#: Inflation radius (mm): SJTU-Snake III's 27.5 mm body radius plus 2.5 mm.
DEFAULT_INFLATE_MM = 30.0
#: Length (mm) of the straight stretch along the feed axis, from the entrance inwards, that counts as free.
DEFAULT_FEED_MM = 100.0
#: A field made for one inflation keeps exact cell-centre distances up to the inflation plus this much (mm);
#: farther ones are clamped (to minus this much inside material).
SDF_HORIZON_MM = 40.0
#: Largest grid (cells) a field may use, about 100 MB of working memory.
MAX_CELLS = 8_000_000
#: Targets are accepted when their geodesic distance is at most this fraction of the arm length.
DEFAULT_REACH_FRACTION = 0.85

_UNREACHED = -2
_SOURCE = -1
_NEIGHBOURS = np.array(
    [(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1) if (a, b, c) != (0, 0, 0)],
    dtype=np.int64,
)


def check_range(name: str, value, low: float | None = None, high: float | None = None,
                integer: bool = False) -> float:
    """Validate a generator parameter (a finite number in [low, high]); ValueError names it."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: expected a number, got {value!r}")
    if integer and int(value) != value:
        raise ValueError(f"{name}: expected an integer, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or (low is not None and v < low) or (high is not None and v > high):
        raise ValueError(f"{name}: must lie in [{low}, {high}], got {value!r}")
    return v


def tank_parameters(arm_length_mm, reach_fraction, inflate_mm, cell_mm) -> tuple[float, float, float, float]:
    """The reach parameters a room-scale generator takes (fuel-tank, oil-tank, confined), checked: arm length
    (mm, >= 1), reach fraction (0.1-1), inflation (0-100 mm), reach grid cell (5-50 mm)."""
    return (check_range("arm_length_mm", arm_length_mm, 1.0), check_range("reach_fraction", reach_fraction, 0.1, 1.0),
            check_range("inflate_mm", inflate_mm, 0.0, 100.0), check_range("cell_mm", cell_mm, 5.0, 50.0))


@dataclass(frozen=True, eq=False)
class Grid:
    """A regular grid of ``shape`` cells tiling the box from ``origin`` with edge lengths ``spacing`` (mm)."""

    origin: np.ndarray
    spacing: np.ndarray
    shape: tuple[int, int, int]

    @classmethod
    def covering(cls, bounds_min, bounds_max, cell_mm: float = DEFAULT_CELL_MM) -> Grid:
        """The grid whose cells (edges <= ``cell_mm``) tile the bounds exactly."""
        lo = np.array(bounds_min, dtype=float)  # a writable copy: the kernels see one array type, whatever the bounds
        hi = np.array(bounds_max, dtype=float)
        check_range("cell_mm", cell_mm, 1e-3)
        n = np.maximum(1, np.ceil((hi - lo) / cell_mm - 1e-9)).astype(np.int64)
        if np.prod(n.astype(float)) > MAX_CELLS:
            raise ValueError(f"cell_mm: {cell_mm} gives {int(np.prod(n.astype(float)))} cells, more than {MAX_CELLS}")
        return cls(lo, (hi - lo) / n, (int(n[0]), int(n[1]), int(n[2])))

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    def centres(self) -> np.ndarray:
        """Cell centres, shape ``shape + (3,)``."""
        axes = [self.origin[k] + (np.arange(self.shape[k]) + 0.5) * self.spacing[k] for k in range(3)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)

    def cell_of(self, points) -> np.ndarray:
        """Integer cell indices ``(..., 3)`` of points, clipped into the grid."""
        p = np.asarray(points, dtype=float)
        idx = np.floor((p - self.origin) / self.spacing).astype(np.int64)
        return np.clip(idx, 0, np.array(self.shape) - 1)


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


class FieldDeadline(Exception):
    """:func:`free_space` ran past its deadline (a planner's budget ran out while it built its field)."""


#: Cells evaluated between two looks at :func:`free_space`'s deadline.
DEADLINE_CHUNK_CELLS = 4096


def free_space(obstacles: ObstacleSet, grid: Grid, horizon_mm: float = math.inf,
               deadline: float | None = None) -> np.ndarray:
    """Signed distance (mm) at every cell centre, shape ``grid.shape``, clamped to [-``horizon_mm``,
    ``horizon_mm``] (its users compare it with an inflation at most the horizon, and with 0).

    A finite horizon evaluates each obstacle only at the cells within the horizon of its box
    (:meth:`ObstacleSet.grid_distance`), so a cell far from everything costs nothing. With a ``deadline`` (a
    perf_counter value) it raises :class:`FieldDeadline` once past it, so a planner's setup never outlasts its
    budget by more than one chunk of cells.
    """
    out = np.empty(grid.shape)
    if math.isfinite(horizon_mm):
        layers = max(1, DEADLINE_CHUNK_CELLS // max(1, grid.shape[0] * grid.shape[1]))
        for k0 in range(0, grid.shape[2], layers):
            if deadline is not None and time.perf_counter() >= deadline:
                raise FieldDeadline
            k1 = min(k0 + layers, grid.shape[2])
            out[:, :, k0:k1] = obstacles.grid_distance(grid.origin, grid.spacing, grid.shape, horizon_mm, (k0, k1))
        return out
    flat = grid.centres().reshape(-1, 3)
    out = out.reshape(-1)
    for start in range(0, len(flat), DEADLINE_CHUNK_CELLS):
        if deadline is not None and time.perf_counter() >= deadline:
            raise FieldDeadline
        stop = start + DEADLINE_CHUNK_CELLS
        out[start:stop] = obstacles.signed_distance(flat[start:stop], horizon_mm)
    return out.reshape(grid.shape)


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


#: Grid cell (mm) of a route guide: coarse, so that a guide costs milliseconds; the openings a guide must pass
#: (a fuel-tank hole, an oil-tank hole: 110 mm free radius once inflated) span several cells.
GUIDE_CELL_MM = 40.0
#: Spacing (mm) of a route guide's points.
GUIDE_STEP_MM = 10.0


@dataclass(frozen=True, eq=False)
class RouteGuide:
    """A coarse route from the entrance through every target in order (mm): ``points (n, 3)`` every
    ``GUIDE_STEP_MM`` or less along it, their arc lengths ``arc (n,)``, and each target's arc length
    ``target_arc (T,)``. Each leg is the taut geodesic through the free cells of the known obstacles, inflated by
    the arm's radius; a leg the coarse grid cannot find is a straight segment (``complete`` is then False)."""

    points: np.ndarray
    arc: np.ndarray
    target_arc: np.ndarray
    complete: bool = True

    def at(self, s) -> np.ndarray:
        """Points (mm) at arc lengths ``s`` (clipped to the guide)."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.arc[-1])
        return np.stack([np.interp(s, self.arc, self.points[:, k]) for k in range(3)], axis=-1)

    def progress(self, tip, s_from: float, s_to: float) -> float:
        """Arc length (mm) of the guide point nearest ``tip`` among those between ``s_from`` and ``s_to``."""
        return nearest_on_guide(self.points, self.arc, np.asarray(tip, dtype=float), float(s_from), float(s_to))


@dataclass(frozen=True, eq=False)
class FreeSpace:
    """:func:`free_space` of ``obstacles`` on ``grid``, capped at ``cap_mm``: the route guide's free cells for any
    inflation up to the cap. :meth:`including` a superset of its obstacles evaluates only the added ones (the
    field of a union is the least of the parts' fields), so a guide made again after sensing costs the newly
    known obstacles, not the structure again."""

    grid: Grid
    cap_mm: float
    sdf: np.ndarray
    obstacles: ObstacleSet

    def __post_init__(self) -> None:
        self.sdf.setflags(write=False)  # shared by the spaces extended from it and the fields routed through it

    @classmethod
    def of(cls, obstacles: ObstacleSet, grid: Grid, cap_mm: float, deadline: float | None = None) -> FreeSpace:
        """The field of ``obstacles`` (:class:`FieldDeadline` past ``deadline``)."""
        return cls(grid, float(cap_mm), free_space(obstacles, grid, cap_mm, deadline), obstacles)

    def including(self, obstacles: ObstacleSet, deadline: float | None = None) -> FreeSpace:
        """The field of ``obstacles``: only those not in this field's set are evaluated when they are a superset
        of it (the same obstacle objects; a sensed view's known set grows so), else all of them."""
        held = {id(o) for o in self.obstacles.obstacles}
        given = [id(o) for o in obstacles.obstacles]
        if not held.issubset(given):
            return FreeSpace.of(obstacles, self.grid, self.cap_mm, deadline)
        added = np.array([k not in held for k in given], dtype=bool)
        if not added.any():
            return FreeSpace(self.grid, self.cap_mm, self.sdf, obstacles)
        extra = free_space(obstacles.subset(added), self.grid, self.cap_mm, deadline)
        return FreeSpace(self.grid, self.cap_mm, np.minimum(self.sdf, extra), obstacles)


def route_guide(obstacles: ObstacleSet, bounds_min, bounds_max, entrance: Entrance, targets,
                inflate_mm: float = DEFAULT_INFLATE_MM, cell_mm: float = GUIDE_CELL_MM,
                deadline: float | None = None) -> RouteGuide:
    """The :class:`RouteGuide` through ``obstacles`` (a planner passes what it knows before the job: its knowledge
    view's obstacles) from ``entrance`` through ``targets`` in order; :class:`FieldDeadline` past ``deadline``
    (a perf_counter value) while its free space is computed."""
    space = FreeSpace.of(obstacles, Grid.covering(bounds_min, bounds_max, cell_mm), inflate_mm + SDF_HORIZON_MM,
                         deadline)
    return route_through(space, entrance, targets, inflate_mm)


def route_through(space: FreeSpace, entrance: Entrance, targets, inflate_mm: float) -> RouteGuide:
    """:func:`route_guide` through the cells of ``space`` at least ``inflate_mm`` (at most its cap) from its
    obstacles."""
    if inflate_mm > space.cap_mm:
        raise ValueError(f"inflate_mm: at most the field's cap {space.cap_mm:g} mm, got {inflate_mm:g}")
    grid, sdf = space.grid, space.sdf
    source, pieces, ends, complete = entrance, [entrance.position[None]], [], True
    for k, target in enumerate(np.asarray(targets, dtype=float).reshape(-1, 3)):
        feed = DEFAULT_FEED_MM if k == 0 else 0.0
        leg = geodesic_from_sdf(grid, sdf, source, inflate_mm, feed, goal=target).path_to(target)
        if len(leg) < 2:
            leg, complete = np.vstack([source.position, target]), False
        pieces.append(densify(leg, GUIDE_STEP_MM)[1:])
        ends.append(sum(len(p) for p in pieces) - 1)
        source = Entrance(target, entrance.direction)
    points = np.vstack(pieces)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    return RouteGuide(points, arc, arc[ends], complete)


# --- numba kernels --------------------------------------------------------------------------------------------


@kernel
def nearest_on_guide(points, arc, tip, s_from, s_to):
    """:meth:`RouteGuide.progress`: the arc length of the point nearest ``tip`` with arc in [s_from, s_to] (the
    first point at or after ``s_from`` at least)."""
    i = min(np.searchsorted(arc, s_from), arc.shape[0] - 1)
    j = max(np.searchsorted(arc, s_to, side="right"), i + 1)
    best, arg = np.inf, i
    for k in range(i, j):
        d = (points[k, 0] - tip[0]) ** 2 + (points[k, 1] - tip[1]) ** 2 + (points[k, 2] - tip[2]) ** 2
        if d < best:
            best, arg = d, k
    return arc[arg]


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
