"""`fuel-tank`: paper 000's multi-obstacle scene, an 1800 x 1400 x 400 mm tank of six chambers (mm, rad).

Fixed structure: a 3 (x) x 2 (y) grid of 600 x 700 mm chambers; one partition plate per pair of adjacent
chambers, each with a centred 500 x 300 mm oval hole (7 holes); outer walls as plates whose inner faces lie on the
bounds; a support frame of boxes (pillars at the partition crossings, half pillars where partitions meet the outer
walls, corner posts, stiffener beams along the top and bottom edges of every partition and outer side wall) that
never covers a hole. The operator knows the coarse structure alone (paper 000 §4.1: "overall dimensions,
compartment structure, and passage locations"): the outer walls and the partitions with their holes; the frame is
clutter to them as much as the debris is. Per seed (unknown to the operator): the entrance (a
point on an outer side wall, fed along the inward normal, through a round port cut in that wall), 3-6 clutter
obstacles resting on the floor, and one debris target one or two oval holes away from the entrance chamber, with
clearance and geodesic reach checked by :mod:`snakeplan.scenes.routes.geodesic`: its geodesic distance from the
entrance lies between ``MIN_TARGET_GEODESIC_MM`` and the reach limit, so paths are as long as the paper's (Table 2:
1.5-1.8 m), and it lies outside the region a tip that starts along the feed axis cannot reach when it turns no
tighter than the arm's bend limits allow (``turn_radius_mm``, the SJTU-Snake III's ``TURN_RADIUS_MM`` by default; see
:func:`outside_turning_region`).

Obstacles are listed as: the six outer walls (x-, x+, y-, y+, floor, ceiling), the seven partitions, the frame
boxes, then the clutter (the last ``metadata["clutter"]`` obstacles). The frame and the clutter are ``discovered``
(unknown before the job); the outer walls and the partitions are prior.
"""

from __future__ import annotations

import math

import numpy as np

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Box, Cylinder, Obstacle, Plate, Sphere
from snakeplan.scenes.parameters import DEFAULT_REACH_FRACTION, check_range, tank_parameters
from snakeplan.scenes.routes.geodesic import DEFAULT_INFLATE_MM, geodesic_from_sdf
from snakeplan.scenes.routes.grid import SDF_HORIZON_MM, Grid, free_space
from snakeplan.scenes.registry import register_scene
from snakeplan.scenes.scene import Entrance, Scene

#: Interior size of the tank (mm), x by y by z.
TANK_SIZE_MM = (1800.0, 1400.0, 400.0)
#: Chambers along x and along y.
CHAMBERS_X, CHAMBERS_Y = 3, 2
#: Thickness (mm) of the partitions and outer walls.
WALL_THICKNESS_MM = 10.0
#: Semi-axes (mm) of the oval holes: along the partition's horizontal side, and vertical.
HOLE_SEMI_AXES_MM = (250.0, 150.0)
#: Radius (mm) of the round entrance port in the outer wall.
PORT_RADIUS_MM = 60.0
#: Square section (mm) of the pillars at partition crossings; half pillars and corner posts use it too.
PILLAR_MM = 60.0
#: Depth (mm) of the half pillars and corner posts standing against the outer walls.
WALL_POST_DEPTH_MM = 30.0
#: Section of the stiffener beams (mm): width across the wall, height.
BEAM_WIDTH_MM, BEAM_HEIGHT_MM = 40.0, 30.0
#: Least distance (mm) of the entrance from partitions, corners, floor and ceiling.
ENTRANCE_MARGIN_MM = 120.0
#: Number of clutter obstacles, inclusive range.
CLUTTER_COUNT = (3, 6)
#: Extent (mm) of a clutter obstacle: box edges, sphere and cylinder diameters, cylinder lengths.
CLUTTER_SIZE_MM = (60.0, 200.0)
#: Least distance (mm) from the entrance to any clutter.
CLUTTER_ENTRANCE_GAP_MM = 250.0
#: Least gap (mm) between clutter and the structure or other clutter.
CLUTTER_GAP_MM = 10.0
#: Clutter stays out of a box around every hole: this deep (mm) on each side of the partition ...
HOLE_KEEPOUT_DEPTH_MM = 100.0
#: ... and this much (mm) wider and taller than the hole.
HOLE_KEEPOUT_MARGIN_MM = 20.0
#: Spacing (mm) of the points that sample a clutter obstacle for the overlap tests.
CLUTTER_SAMPLE_MM = 20.0
#: Least clearance (mm) from the target to every obstacle.
TARGET_CLEARANCE_MM = 60.0
#: Least geodesic distance (mm) from the entrance to the target.
MIN_TARGET_GEODESIC_MM = 1000.0
#: Holes (chamber steps) between the entrance chamber and the target chamber.
TARGET_HOLES = (1, 2)
#: Smallest turning radius (mm) of sjtu-snake-iii: chords of 177.5 mm bending 50.7 deg, 177.5 / (2 sin 25.35 deg).
TURN_RADIUS_MM = 207.3
#: The robot the scene is sized for (paper 000): name, arm length (mm), body radius (mm).
ROBOT = "sjtu-snake-iii"
ARM_LENGTH_MM = 2130.0
ARM_RADIUS_MM = 27.5
#: Grid cell (mm) of the reachability check.
REACH_CELL_MM = 20.0
#: Bounded resampling: whole-scene attempts, draws per clutter obstacle, target candidates per attempt.
MAX_ATTEMPTS = 40
CLUTTER_TRIES = 60
TARGET_CANDIDATES = 256
#: Decimals (mm) every generated coordinate is rounded to, so the JSON is identical on every machine.
DECIMALS = 3
#: Decimals of rotation-matrix entries.
ROTATION_DECIMALS = 12

_SIDE_WALLS = ("x-", "x+", "y-", "y+")


def outer_walls(bounds_min, bounds_max, thickness: float, port_wall: str | None = None, port_centre=None,
                port_radius: float = PORT_RADIUS_MM) -> list[Plate]:
    """Six plates just outside the box (inner faces on the bounds); ``port_wall`` ("x-", ..., "z+") gets a port.

    Side walls span the height; floor and ceiling overhang by ``thickness`` to close the edges.
    """
    lo = np.asarray(bounds_min, dtype=float)
    hi = np.asarray(bounds_max, dtype=float)
    mid = (lo + hi) / 2
    ext = hi - lo
    walls = []
    for axis, sign in ((0, -1), (0, 1), (1, -1), (1, 1), (2, -1), (2, 1)):
        name = "xyz"[axis] + ("-" if sign < 0 else "+")
        centre = mid.copy()
        centre[axis] = (lo[axis] - thickness / 2) if sign < 0 else (hi[axis] + thickness / 2)
        normal = np.eye(3)[axis]
        if axis == 2:
            up = np.array([0.0, 1.0, 0.0])
            size = (ext[0] + 2 * thickness, ext[1] + 2 * thickness)
        else:
            up = np.array([0.0, 0.0, 1.0])
            size = (ext[1 - axis] + 2 * thickness, ext[2])
        hole = None
        if name == port_wall:
            rel = np.asarray(port_centre, dtype=float) - centre
            side = np.cross(up, normal)
            hole = {"offset": [float(np.dot(rel, side)), float(np.dot(rel, up))],
                    "semi_axes": [port_radius, port_radius]}
        walls.append(Plate(centre, normal, up, size, thickness, hole))
    return walls


def yaw_matrix(yaw: float) -> np.ndarray:
    """Rotation about z by ``yaw`` (rad), entries rounded for byte-stable JSON."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.round(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), ROTATION_DECIMALS)


def chamber_boxes() -> list[tuple[np.ndarray, np.ndarray]]:
    """(min, max) corners (mm) of the six chambers, indexed ``iy * CHAMBERS_X + ix``."""
    sx, sy, sz = TANK_SIZE_MM
    dx, dy = sx / CHAMBERS_X, sy / CHAMBERS_Y
    return [(np.array([ix * dx, iy * dy, 0.0]), np.array([(ix + 1) * dx, (iy + 1) * dy, sz]))
            for iy in range(CHAMBERS_Y) for ix in range(CHAMBERS_X)]


def chamber_of(point) -> int:
    """Index of the chamber containing ``point`` (clipped into the tank)."""
    sx, sy, _ = TANK_SIZE_MM
    ix = min(max(int(point[0] // (sx / CHAMBERS_X)), 0), CHAMBERS_X - 1)
    iy = min(max(int(point[1] // (sy / CHAMBERS_Y)), 0), CHAMBERS_Y - 1)
    return iy * CHAMBERS_X + ix


def outside_turning_region(entrance: Entrance, points: np.ndarray, radius: float = TURN_RADIUS_MM) -> np.ndarray:
    """True where a point can be reached by a tip that leaves the entrance along the feed axis and turns with
    radius >= ``radius``: in the plane through the feed axis, the unreachable points fill the turning circles
    tangent to the axis at the entrance, x^2 + (rho - R)^2 < R^2 (x along the axis, rho off it)."""
    rel = np.asarray(points, dtype=float) - entrance.position
    x = rel @ entrance.direction
    rho = np.linalg.norm(rel - np.outer(x, entrance.direction), axis=1)
    return x * x + (rho - radius) ** 2 >= radius * radius


def chamber_steps(holes: list[dict], home: int) -> dict[int, int]:
    """Number of holes (chamber-graph distance) from chamber ``home`` to every chamber."""
    steps, frontier = {home: 0}, [home]
    while frontier:
        nxt = []
        for c in frontier:
            for h in holes:
                if c in h["chambers"]:
                    for o in h["chambers"]:
                        if o not in steps:
                            steps[o] = steps[c] + 1
                            nxt.append(o)
        frontier = nxt
    return steps


def partitions() -> tuple[list[Plate], list[dict]]:
    """The seven partition plates, each with its centred oval hole, and the hole facts for the metadata."""
    sx, sy, sz = TANK_SIZE_MM
    dx, dy = sx / CHAMBERS_X, sy / CHAMBERS_Y
    hole = {"offset": [0.0, 0.0], "semi_axes": list(HOLE_SEMI_AXES_MM)}
    z = np.array([0.0, 0.0, 1.0])
    plates, holes = [], []
    for ix in range(1, CHAMBERS_X):
        for iy in range(CHAMBERS_Y):
            c = np.array([ix * dx, (iy + 0.5) * dy, sz / 2])
            plates.append(Plate(c, [1.0, 0.0, 0.0], z, (dy, sz), WALL_THICKNESS_MM, dict(hole)))
            holes.append({"center": c.tolist(), "normal": [1.0, 0.0, 0.0], "semi_axes": list(HOLE_SEMI_AXES_MM),
                          "chambers": [iy * CHAMBERS_X + ix - 1, iy * CHAMBERS_X + ix]})
    for iy in range(1, CHAMBERS_Y):
        for ix in range(CHAMBERS_X):
            c = np.array([(ix + 0.5) * dx, iy * dy, sz / 2])
            plates.append(Plate(c, [0.0, 1.0, 0.0], z, (dx, sz), WALL_THICKNESS_MM, dict(hole)))
            holes.append({"center": c.tolist(), "normal": [0.0, 1.0, 0.0], "semi_axes": list(HOLE_SEMI_AXES_MM),
                          "chambers": [(iy - 1) * CHAMBERS_X + ix, iy * CHAMBERS_X + ix]})
    return plates, holes


def frame() -> list[Box]:
    """The support frame: pillars, half pillars, corner posts and stiffener beams (none covers a hole)."""
    sx, sy, sz = TANK_SIZE_MM
    dx, dy = sx / CHAMBERS_X, sy / CHAMBERS_Y
    p, d, bw, bh = PILLAR_MM, WALL_POST_DEPTH_MM, BEAM_WIDTH_MM, BEAM_HEIGHT_MM
    boxes = []
    for ix in range(1, CHAMBERS_X):
        for iy in range(1, CHAMBERS_Y):
            boxes.append(Box([ix * dx, iy * dy, sz / 2], [p, p, sz]))
        for y in (d / 2, sy - d / 2):
            boxes.append(Box([ix * dx, y, sz / 2], [p, d, sz]))
    for iy in range(1, CHAMBERS_Y):
        for x in (d / 2, sx - d / 2):
            boxes.append(Box([x, iy * dy, sz / 2], [d, p, sz]))
    for x in (d / 2, sx - d / 2):
        for y in (d / 2, sy - d / 2):
            boxes.append(Box([x, y, sz / 2], [d, d, sz]))
    for z in (bh / 2, sz - bh / 2):
        for ix in range(1, CHAMBERS_X):
            for iy in range(CHAMBERS_Y):
                boxes.append(Box([ix * dx, (iy + 0.5) * dy, z], [bw, dy, bh]))
        for iy in range(1, CHAMBERS_Y):
            for ix in range(CHAMBERS_X):
                boxes.append(Box([(ix + 0.5) * dx, iy * dy, z], [dx, bw, bh]))
        for x in (bw / 2, sx - bw / 2):
            boxes.append(Box([x, sy / 2, z], [bw, sy, bh]))
        for y in (bw / 2, sy - bw / 2):
            boxes.append(Box([sx / 2, y, z], [sx, bw, bh]))
    return boxes


def _draw_entrance(rng: np.random.Generator) -> tuple[str, Entrance]:
    """A random side wall and a point on it at least ENTRANCE_MARGIN_MM from partitions, corners, floor, ceiling."""
    sx, sy, sz = TANK_SIZE_MM
    wall = _SIDE_WALLS[int(rng.integers(len(_SIDE_WALLS)))]
    along, cells = (sy, CHAMBERS_Y) if wall[0] == "x" else (sx, CHAMBERS_X)
    width = along / cells
    span = width - 2 * ENTRANCE_MARGIN_MM
    t = float(rng.uniform(0.0, cells * span))
    cell = min(int(t // span), cells - 1)
    u = round(cell * width + ENTRANCE_MARGIN_MM + (t - cell * span), DECIMALS)
    z = round(float(rng.uniform(ENTRANCE_MARGIN_MM, sz - ENTRANCE_MARGIN_MM)), DECIMALS)
    if wall[0] == "x":
        x = 0.0 if wall[1] == "-" else sx
        return wall, Entrance([x, u, z], [1.0 if wall[1] == "-" else -1.0, 0.0, 0.0])
    y = 0.0 if wall[1] == "-" else sy
    return wall, Entrance([u, y, z], [0.0, 1.0 if wall[1] == "-" else -1.0, 0.0])


def _draw_clutter(rng: np.random.Generator) -> Obstacle:
    """One floor-resting clutter obstacle (box, sphere or cylinder) in a random chamber."""
    lo, hi = chamber_boxes()[int(rng.integers(CHAMBERS_X * CHAMBERS_Y))]
    a, b = CLUTTER_SIZE_MM
    xy = np.round(rng.uniform(lo[:2], hi[:2]), DECIMALS)
    kind = int(rng.integers(3))
    yaw = float(rng.uniform(0.0, math.pi))
    if kind == 0:
        size = np.round(rng.uniform(a, b, 3), DECIMALS)
        return Box([xy[0], xy[1], size[2] / 2], size, yaw_matrix(yaw))
    radius = round(float(rng.uniform(a, b)) / 2, DECIMALS)
    if kind == 1:
        return Sphere([xy[0], xy[1], radius], radius)
    length = round(float(rng.uniform(a, b)), DECIMALS)
    if rng.uniform() < 0.5:
        return Cylinder([xy[0], xy[1], length / 2], [0.0, 0.0, 1.0], radius, length)
    axis = np.round([math.cos(yaw), math.sin(yaw), 0.0], ROTATION_DECIMALS)
    return Cylinder([xy[0], xy[1], radius], axis, radius, length)


def _sample_points(obstacle: Obstacle) -> np.ndarray:
    """Grid points within CLUTTER_SAMPLE_MM * sqrt(3)/2 of the obstacle: every point of it is that near one."""
    h = CLUTTER_SAMPLE_MM
    r = obstacle.bounding_radius()
    n = int(math.ceil(2 * r / h)) + 1
    axis = np.linspace(-r, r, n)
    pts = obstacle.center + np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), -1).reshape(-1, 3)
    return pts[obstacle.signed_distance(pts) <= h * math.sqrt(3) / 2]


def _keepouts(holes: list[dict]) -> list[Box]:
    """Boxes around the holes that clutter must not enter (the floor is left out: clutter rests on it)."""
    boxes = []
    for hole in holes:
        a, b = hole["semi_axes"]
        across = 2 * (a + HOLE_KEEPOUT_MARGIN_MM)
        depth = 2 * HOLE_KEEPOUT_DEPTH_MM
        size = [depth, across] if hole["normal"][0] else [across, depth]
        boxes.append(Box(hole["center"], size + [2 * (b + HOLE_KEEPOUT_MARGIN_MM)]))
    return boxes


class _Blockers:
    """Obstacles clutter must keep clear of, each with its bounding box, so a test only evaluates nearby ones."""

    def __init__(self, obstacles: list[Obstacle]):
        self.items = [(*o.aabb(), ObstacleSet([o])) for o in obstacles]

    def clear(self, points: np.ndarray, gap: float) -> bool:
        """True when every point is at least ``gap`` from every obstacle."""
        lo, hi = points.min(axis=0) - gap, points.max(axis=0) + gap
        for a, b, obstacle in self.items:
            if np.all(a <= hi) and np.all(b >= lo) and np.any(obstacle.signed_distance(points) < gap):
                return False
        return True


def _fits(item: Obstacle, blockers: _Blockers, entrance: Entrance) -> bool:
    """True when ``item`` keeps CLUTTER_GAP_MM from the blockers and CLUTTER_ENTRANCE_GAP_MM from the entrance."""
    if item.signed_distance(entrance.position) < CLUTTER_ENTRANCE_GAP_MM:
        return False
    return blockers.clear(_sample_points(item), CLUTTER_SAMPLE_MM * math.sqrt(3) / 2 + CLUTTER_GAP_MM)


# Planned by default with the learned planner whose policy ships for it (milliseconds per plan and the smoothest
# paths in the Table 2 run, see README).
@register_scene("fuel-tank", robot=ROBOT, planner="sac-her",
                policies={"sac-her": "snakeplan:rl/data/fuel-tank-sac-her.npz"})
def fuel_tank(seed: int, *, arm_length_mm: float = ARM_LENGTH_MM, reach_fraction: float = DEFAULT_REACH_FRACTION,
              inflate_mm: float = DEFAULT_INFLATE_MM, cell_mm: float = REACH_CELL_MM,
              min_clutter: int = CLUTTER_COUNT[0], max_clutter: int = CLUTTER_COUNT[1],
              target_clearance_mm: float = TARGET_CLEARANCE_MM, turn_radius_mm: float = TURN_RADIUS_MM) -> Scene:
    """The fuel tank for ``seed``: fixed chambers and holes, random entrance, clutter and debris target."""
    arm_length_mm, reach_fraction, inflate_mm, cell_mm = tank_parameters(arm_length_mm, reach_fraction, inflate_mm,
                                                                         cell_mm)
    turn_radius_mm = check_range("turn_radius_mm", turn_radius_mm, 1.0, arm_length_mm)
    min_clutter = int(check_range("min_clutter", min_clutter, 0, 12, integer=True))
    max_clutter = int(check_range("max_clutter", max_clutter, min_clutter, 12, integer=True))
    target_clearance_mm = check_range("target_clearance_mm", target_clearance_mm, inflate_mm, 120.0)
    rng = np.random.default_rng(seed)
    bounds_min, bounds_max = np.zeros(3), np.array(TANK_SIZE_MM)
    plates, holes = partitions()
    structure = plates + frame()
    keepout = _keepouts(holes)
    grid = Grid.covering(bounds_min, bounds_max, cell_mm)
    limit = reach_fraction * arm_length_mm
    chambers = chamber_boxes()
    for attempt in range(1, MAX_ATTEMPTS + 1):
        wall, entrance = _draw_entrance(rng)
        walls = outer_walls(bounds_min, bounds_max, WALL_THICKNESS_MM, wall, entrance.position)
        fixed = walls + structure
        clutter: list[Obstacle] = []
        blockers = _Blockers(walls[:4] + walls[5:] + structure + keepout)
        for _ in range(int(rng.integers(min_clutter, max_clutter + 1))):
            for _ in range(CLUTTER_TRIES):
                item = _draw_clutter(rng)
                if _fits(item, blockers, entrance):
                    clutter.append(item)
                    blockers.items.append((*item.aabb(), ObstacleSet([item])))
                    break
            else:
                break
        else:
            obstacles = fixed + clutter
            every = ObstacleSet(obstacles)
            field = geodesic_from_sdf(grid, free_space(every, grid, inflate_mm + SDF_HORIZON_MM), entrance, inflate_mm)
            home = chamber_of(entrance.position + entrance.direction)
            steps = chamber_steps(holes, home)
            options = sorted(c for c, k in steps.items() if TARGET_HOLES[0] <= k <= TARGET_HOLES[1])
            goal = options[int(rng.integers(len(options)))]
            lo, hi = chambers[goal]
            cand = np.round(rng.uniform(lo + target_clearance_mm, hi - target_clearance_mm,
                                        (TARGET_CANDIDATES, 3)), DECIMALS)
            geo = field.distance_at(cand)
            ok = np.flatnonzero((every.signed_distance(cand) >= target_clearance_mm) & (geo <= limit)
                                & (geo >= MIN_TARGET_GEODESIC_MM) & outside_turning_region(entrance, cand,
                                                                                              turn_radius_mm))
            if len(ok):
                target = cand[ok[0]]
                meta = {
                    "generator": "fuel-tank",
                    "arm_length_mm": arm_length_mm,
                    "arm_radius_mm": ARM_RADIUS_MM,
                    "chambers": [{"index": i, "min": c[0].tolist(), "max": c[1].tolist()}
                                 for i, c in enumerate(chambers)],
                    "holes": holes,
                    "entrance_wall": wall,
                    "entrance_chamber": home,
                    "target_chamber": goal,
                    "target_holes": steps[goal],
                    "port_radius_mm": PORT_RADIUS_MM,
                    "clutter": len(clutter),
                    "target_geodesic_mm": round(float(geo[ok[0]]), 1),
                    "reach_limit_mm": limit,
                    "attempts": attempt,
                    "parameters": {"reach_fraction": reach_fraction, "inflate_mm": inflate_mm, "cell_mm": cell_mm,
                                   "min_clutter": min_clutter, "max_clutter": max_clutter,
                                   "target_clearance_mm": target_clearance_mm, "turn_radius_mm": turn_radius_mm,
                                   "wall_thickness_mm": WALL_THICKNESS_MM},
                }
                return Scene("fuel-tank", seed, bounds_min, bounds_max, entrance, target[None], obstacles, meta,
                             discovered=tuple(range(len(walls) + len(plates), len(obstacles))))
    raise RuntimeError(f"fuel-tank: no valid scene for seed {seed} in {MAX_ATTEMPTS} attempts")


#: Mission time (s) of a thermal tank's inspection.
THERMAL_BUDGET_S = 600.0


@register_scene("thermal-tank", robot=ROBOT, planner="informative", task="inspect")
def thermal_tank(seed: int) -> Scene:
    """The fuel tank of ``seed`` with a seeded temperature-like field on its walls, baffles and clutter (hot spots
    at its points of interest, :func:`snakeplan.scenes.inspect.with_hot_spots`), to be mapped by the tip camera
    within :data:`THERMAL_BUDGET_S`."""
    from dataclasses import replace

    from snakeplan.scenes.inspect import InspectSpec, with_hot_spots

    tank = replace(fuel_tank(seed), name="thermal-tank")
    return with_hot_spots(tank, seed, InspectSpec(budget_s=THERMAL_BUDGET_S))
