"""`confined`: a procedural family of confined spaces to train and test generalist planners on (mm, rad).

A seed draws a grid of rooms (1-3 along x and y, 1-2 storeys), each column and row its own width: most are rooms
(``ROOM_SPAN_MM``), some narrow (``DUCT_SPAN_MM``), so runs of narrow cells form ducts that bend where a narrow
row meets a narrow column. Each wall between two neighbouring rooms is open (the two rooms make one bay),
solid, or a 10 mm plate with an opening: an oval hole of random semi-axes and offset, or a rectangular cut. The
openings of a random spanning tree of the rooms are never solid, so every room can be reached. Some rooms get a
baffle, a plate standing part-way up from the floor across the room, which makes bays. Clutter (spheres, boxes,
cylinders) rests on the floors away from the openings and the entrance.

The entrance is a 60 mm port in any of the six outer walls, side walls, floor or ceiling (the arm may be fed
vertically), fed along the inward normal, with no baffle near the first stretch of the feed axis (the feed and a
turn). One to three targets are drawn in order: each clear of everything by ``TARGET_CLEARANCE_MM``, outside the
circles a tip leaving the entrance along the feed axis cannot reach when it turns no tighter than the arm allows
(``turn_radius_mm``), and onward from the one before (its geodesic distance from the entrance grows by at least
``MIN_TARGET_STEP_MM``, and the geodesic leg from the one before is at most ``MAX_DETOUR`` times that growth); the
whole tour, entrance to last target along geodesics, is within the reach limit.

Obstacles are listed as: the six outer walls (x-, x+, y-, y+, floor, ceiling), the inner walls (plates and the
boxes of rectangular cuts), the baffles, then the clutter. The clutter is ``discovered``; the rest is prior.
``metadata`` records the rooms, the openings (centre, normal, kind, the rooms they join) and the tour.
"""

from __future__ import annotations

import numpy as np

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Box, Cylinder, Obstacle, Plate, Sphere
from snakeplan.scenes.fuel_tank import (
    ARM_LENGTH_MM,
    ARM_RADIUS_MM,
    DECIMALS,
    PORT_RADIUS_MM,
    ROBOT,
    TURN_RADIUS_MM,
    outer_walls,
    outside_turning_region,
)
from snakeplan.scenes.parameters import DEFAULT_REACH_FRACTION, check_range, tank_parameters
from snakeplan.scenes.routes.geodesic import DEFAULT_FEED_MM, DEFAULT_INFLATE_MM, geodesic_from_sdf
from snakeplan.scenes.routes.grid import SDF_HORIZON_MM, Grid, free_space
from snakeplan.scenes.registry import register_scene
from snakeplan.scenes.scene import Entrance, Scene

#: Rooms along x, y and z (inclusive ranges).
ROOMS = ((1, 3), (1, 3), (1, 2))
#: Width (mm) of a room column or row, of a narrow (duct) one, and the chance that one is narrow.
ROOM_SPAN_MM = (420.0, 760.0)
DUCT_SPAN_MM = (300.0, 360.0)
DUCT_CHANCE = 0.25
#: Height (mm) of a storey.
STOREY_MM = (380.0, 620.0)
#: Wall and baffle thickness (mm).
WALL_THICKNESS_MM = 10.0
#: Chances of a wall outside the spanning tree being solid or open (else it has an opening); a tree wall is
#: open with ``OPEN_CHANCE`` and otherwise has an opening.
SOLID_CHANCE = 0.45
OPEN_CHANCE = 0.15
#: Chance that an opening is a rectangular cut (else an oval hole).
RECT_CHANCE = 0.4
#: Least half-size (mm) of an opening, and the least rim (mm) left around it.
MIN_HALF_OPENING_MM = 110.0
RIM_MM = 15.0
#: Chance that a room gets a baffle, and the baffle's height as a fraction of the storey.
BAFFLE_CHANCE = 0.2
BAFFLE_HEIGHT = (0.3, 0.5)
#: Clutter: count (inclusive), extent (mm), and gaps (mm) kept to the structure, the openings and the entrance.
CLUTTER_COUNT = (0, 4)
CLUTTER_SIZE_MM = (50.0, 150.0)
CLUTTER_GAP_MM = 15.0
OPENING_KEEPOUT_MM = 150.0
ENTRANCE_KEEPOUT_MM = 250.0
CLUTTER_TRIES = 30
#: Least distance (mm) of the entrance port's centre from the edges of its room's face.
ENTRANCE_MARGIN_MM = 120.0
#: Targets: count (inclusive), clearance (mm), least geodesic distance of the first (mm), least growth of the
#: geodesic distance from one target to the next (mm), and how much longer than that growth a leg may be.
TARGET_COUNT = (1, 3)
TARGET_CLEARANCE_MM = 60.0
MIN_FIRST_GEODESIC_MM = 500.0
MIN_TARGET_STEP_MM = 250.0
MAX_DETOUR = 1.3
TARGET_CANDIDATES = 256
#: Grid cell (mm) of the reach check.
REACH_CELL_MM = 25.0
MAX_ATTEMPTS = 60


def _spans(rng: np.random.Generator, count: int, span: tuple[float, float], narrow: bool) -> np.ndarray:
    """Edges (mm, from 0) of ``count`` columns; with ``narrow`` some are ducts."""
    widths = [rng.uniform(*DUCT_SPAN_MM) if narrow and count > 1 and rng.uniform() < DUCT_CHANCE
              else rng.uniform(*span) for _ in range(count)]
    return np.round(np.concatenate([[0.0], np.cumsum(widths)]), DECIMALS)


def _room_box(edges, index) -> tuple[np.ndarray, np.ndarray]:
    lo = np.array([edges[a][index[a]] for a in range(3)])
    hi = np.array([edges[a][index[a] + 1] for a in range(3)])
    return lo, hi


def _tree(rng: np.random.Generator, shape: tuple[int, int, int]) -> set[tuple[tuple, tuple]]:
    """The walls of a random spanning tree of the room grid (randomised depth-first search)."""
    start = tuple(int(rng.integers(n)) for n in shape)
    seen, stack, tree = {start}, [start], set()
    while stack:
        room = stack[-1]
        options = []
        for a in range(3):
            for step in (-1, 1):
                other = list(room)
                other[a] += step
                other = tuple(other)
                if 0 <= other[a] < shape[a] and other not in seen:
                    options.append(other)
        if not options:
            stack.pop()
            continue
        other = options[int(rng.integers(len(options)))]
        seen.add(other)
        stack.append(other)
        tree.add((min(room, other), max(room, other)))
    return tree


def _wall_axes(axis: int) -> tuple[np.ndarray, np.ndarray]:
    """(normal, up) of a wall across ``axis``: up is world z for upright walls, world y for floors."""
    return np.eye(3)[axis], (np.array([0.0, 1.0, 0.0]) if axis == 2 else np.array([0.0, 0.0, 1.0]))


def _opening(rng: np.random.Generator, axis: int, lo: np.ndarray, hi: np.ndarray, at: float
             ) -> tuple[list[Obstacle], dict] | None:
    """A wall across ``axis`` at coordinate ``at`` over the face ``lo..hi`` with an oval hole or a rectangular cut:
    (its obstacles, the opening's facts), or None when the face is too small for an opening."""
    normal, up = _wall_axes(axis)
    side = np.cross(up, normal)
    centre = (lo + hi) / 2
    centre[axis] = at
    ext = hi - lo
    w, h = float(ext @ np.abs(side)), float(ext @ np.abs(up))
    room = np.array([w / 2 - RIM_MM, h / 2 - RIM_MM])
    if np.any(room < MIN_HALF_OPENING_MM):
        return None
    half = np.round(rng.uniform(MIN_HALF_OPENING_MM, room), DECIMALS)
    offset = np.round(rng.uniform(-(room - half), room - half), DECIMALS)
    hole_centre = centre + offset[0] * side + offset[1] * up
    facts = {"center": np.round(hole_centre, DECIMALS).tolist(), "normal": normal.tolist(),
             "half_size_mm": half.tolist()}
    t = WALL_THICKNESS_MM
    if rng.uniform() >= RECT_CHANCE:
        hole = {"offset": offset.tolist(), "semi_axes": half.tolist()}
        return [Plate(centre, normal, up, (w, h), t, hole)], {**facts, "kind": "oval"}
    boxes = []
    u0, u1 = offset[0] - half[0], offset[0] + half[0]
    v0, v1 = offset[1] - half[1], offset[1] + half[1]
    for (a, b), (c, d) in (((-w / 2, u0), (-h / 2, h / 2)), ((u1, w / 2), (-h / 2, h / 2)),
                           ((u0, u1), (-h / 2, v0)), ((u0, u1), (v1, h / 2))):
        if b - a > 1e-6 and d - c > 1e-6:
            mid = centre + (a + b) / 2 * side + (c + d) / 2 * up
            size = t * np.abs(normal) + (b - a) * np.abs(side) + (d - c) * np.abs(up)
            boxes.append(Box(np.round(mid, DECIMALS), np.round(size, DECIMALS)))
    return boxes, {**facts, "kind": "rectangle"}


def _structure(rng: np.random.Generator, edges, shape) -> tuple[list[Obstacle], list[dict], list[dict]]:
    """Inner walls and baffles: (obstacles, openings, baffles' facts)."""
    tree = _tree(rng, shape)
    walls: list[Obstacle] = []
    openings: list[dict] = []
    rooms = [(i, j, k) for k in range(shape[2]) for j in range(shape[1]) for i in range(shape[0])]
    for room in rooms:
        for axis in range(3):
            other = list(room)
            other[axis] += 1
            other = tuple(other)
            if other[axis] >= shape[axis]:
                continue
            in_tree = (room, other) in tree
            draw = rng.uniform()
            if draw < OPEN_CHANCE:
                openings.append({"kind": "open", "rooms": [rooms.index(room), rooms.index(other)]})
                continue
            if not in_tree and draw < OPEN_CHANCE + SOLID_CHANCE:
                lo, hi = _room_box(edges, room)
                normal, up = _wall_axes(axis)
                centre = (lo + hi) / 2
                centre[axis] = hi[axis]
                ext = hi - lo
                walls.append(Plate(centre, normal, up, (float(ext @ np.abs(np.cross(up, normal))),
                                                       float(ext @ np.abs(up))), WALL_THICKNESS_MM))
                continue
            lo, hi = _room_box(edges, room)
            made = _opening(rng, axis, lo, hi, float(hi[axis]))
            if made is None:  # too small a face for an opening: leave it open
                openings.append({"kind": "open", "rooms": [rooms.index(room), rooms.index(other)]})
                continue
            walls += made[0]
            openings.append({**made[1], "rooms": [rooms.index(room), rooms.index(other)]})
    baffles, facts = [], []
    for room in rooms:
        if rng.uniform() >= BAFFLE_CHANCE:
            continue
        lo, hi = _room_box(edges, room)
        axis = int(rng.integers(2))
        at = float(rng.uniform(lo[axis] + 0.35 * (hi[axis] - lo[axis]), lo[axis] + 0.65 * (hi[axis] - lo[axis])))
        height = float(rng.uniform(*BAFFLE_HEIGHT)) * (hi[2] - lo[2])
        normal, up = _wall_axes(axis)
        centre = (lo + hi) / 2
        centre[axis], centre[2] = at, lo[2] + height / 2
        width = float((hi - lo)[1 - axis])
        baffles.append(Plate(np.round(centre, DECIMALS), normal, up, (width, round(height, DECIMALS)),
                             WALL_THICKNESS_MM))
        facts.append({"room": rooms.index(room), "axis": "xy"[axis], "at": round(at, DECIMALS),
                      "height_mm": round(height, DECIMALS)})
    return walls + baffles, openings, facts


def _entrance(rng: np.random.Generator, edges, shape) -> tuple[str, Entrance]:
    """A port on a random outer face (any of six), inside one room's face by ``ENTRANCE_MARGIN_MM``."""
    names = ("x-", "x+", "y-", "y+", "z-", "z+")
    for _ in range(64):
        face = int(rng.integers(6))
        axis, sign = face // 2, (-1 if face % 2 == 0 else 1)
        index = [int(rng.integers(n)) for n in shape]
        index[axis] = 0 if sign < 0 else shape[axis] - 1
        lo, hi = _room_box(edges, index)
        span_lo, span_hi = lo + ENTRANCE_MARGIN_MM, hi - ENTRANCE_MARGIN_MM
        others = [a for a in range(3) if a != axis]
        if any(span_lo[a] > span_hi[a] for a in others):
            continue
        p = np.empty(3)
        for a in others:
            p[a] = rng.uniform(span_lo[a], span_hi[a])
        p[axis] = lo[axis] if sign < 0 else hi[axis]
        direction = np.zeros(3)
        direction[axis] = -sign
        return names[face], Entrance(np.round(p, DECIMALS), direction)
    raise RuntimeError("confined: no room face is wide enough for the entrance port")


def _feed_clear(entrance: Entrance, baffles: list[Obstacle], inflate_mm: float, turn_radius_mm: float) -> bool:
    """Whether the first ``DEFAULT_FEED_MM + turn_radius_mm`` of the feed axis keep ``inflate_mm`` from the baffles
    (an arm fed in along it can turn no sooner)."""
    s = np.linspace(0.0, DEFAULT_FEED_MM + turn_radius_mm, 32)
    axis = entrance.position + s[:, None] * entrance.direction
    return bool(np.min(ObstacleSet(baffles).signed_distance(axis)) >= inflate_mm)


def _clutter(rng: np.random.Generator, edges, shape, baffles: list[Obstacle], keep: np.ndarray,
             keep_radius: np.ndarray, count: int) -> list[Obstacle]:
    """Floor-resting clutter in random rooms: clear of the room's walls and baffles by ``CLUTTER_GAP_MM``, and of
    each ``keep`` point (the entrance, the openings' centres) by its ``keep_radius`` (mm)."""
    walls = ObstacleSet(baffles) if baffles else None
    items: list[Obstacle] = []
    for _ in range(count):
        for _ in range(CLUTTER_TRIES):
            lo, hi = _room_box(edges, [int(rng.integers(n)) for n in shape])
            size = float(rng.uniform(*CLUTTER_SIZE_MM))
            kind = int(rng.integers(3))
            r = round(size / 2, DECIMALS)
            if kind == 0:
                item: Obstacle = Sphere([0.0, 0.0, lo[2] + r], r)
            elif kind == 1:
                dims = np.round(rng.uniform(*CLUTTER_SIZE_MM, 3), DECIMALS)
                item = Box([0.0, 0.0, lo[2] + dims[2] / 2], dims)
            else:
                item = Cylinder([0.0, 0.0, lo[2] + r], [0.0, 0.0, 1.0], r, round(size, DECIMALS))
            reach = item.bounding_radius()
            margin = reach + CLUTTER_GAP_MM + WALL_THICKNESS_MM / 2
            if np.any(hi[:2] - lo[:2] <= 2 * margin):
                continue
            xy = np.round(rng.uniform(lo[:2] + margin, hi[:2] - margin), DECIMALS)
            floor_top = lo[2] + (WALL_THICKNESS_MM / 2 if lo[2] > 0.0 else 0.0)  # an inner floor's plate, or z = 0
            centre = np.array([xy[0], xy[1], item.center[2] - lo[2] + floor_top])
            item = (Sphere(centre, r) if kind == 0 else Box(centre, dims) if kind == 1
                    else Cylinder(centre, [0.0, 0.0, 1.0], r, round(size, DECIMALS)))
            if walls is not None and float(walls.signed_distance(centre)) < reach + CLUTTER_GAP_MM:
                continue
            if np.any(np.linalg.norm(keep - centre, axis=1) < keep_radius + reach):
                continue
            if any(np.linalg.norm(o.center - centre) < o.bounding_radius() + reach + CLUTTER_GAP_MM for o in items):
                continue
            items.append(item)
            break
    return items


@register_scene("confined", robot=ROBOT, planner="as-rrt")
def confined(seed: int, *, arm_length_mm: float = ARM_LENGTH_MM, reach_fraction: float = DEFAULT_REACH_FRACTION,
             inflate_mm: float = DEFAULT_INFLATE_MM, cell_mm: float = REACH_CELL_MM,
             min_targets: int = TARGET_COUNT[0], max_targets: int = TARGET_COUNT[1],
             target_clearance_mm: float = TARGET_CLEARANCE_MM, turn_radius_mm: float = TURN_RADIUS_MM) -> Scene:
    """A confined space for ``seed``: rooms, ducts, bays, openings, clutter, an entrance on any side, 1-3 targets."""
    arm_length_mm, reach_fraction, inflate_mm, cell_mm = tank_parameters(arm_length_mm, reach_fraction, inflate_mm,
                                                                         cell_mm)
    turn_radius_mm = check_range("turn_radius_mm", turn_radius_mm, 1.0, arm_length_mm)
    min_targets = int(check_range("min_targets", min_targets, 1, 5, integer=True))
    max_targets = int(check_range("max_targets", max_targets, min_targets, 5, integer=True))
    target_clearance_mm = check_range("target_clearance_mm", target_clearance_mm, inflate_mm, 120.0)
    rng = np.random.default_rng(seed)
    limit = reach_fraction * arm_length_mm
    for attempt in range(1, MAX_ATTEMPTS + 1):
        shape = tuple(int(rng.integers(a, b + 1)) for a, b in ROOMS)
        edges = [_spans(rng, shape[0], ROOM_SPAN_MM, True), _spans(rng, shape[1], ROOM_SPAN_MM, True),
                 _spans(rng, shape[2], STOREY_MM, False)]
        bounds_min, bounds_max = np.zeros(3), np.array([e[-1] for e in edges])
        inner, openings, baffles = _structure(rng, edges, shape)
        wall, entrance = _entrance(rng, edges, shape)
        fixed = outer_walls(bounds_min, bounds_max, WALL_THICKNESS_MM, wall, entrance.position) + inner
        holes = [o for o in openings if "center" in o]
        keep = np.array([entrance.position] + [o["center"] for o in holes]).reshape(-1, 3)
        keep_radius = np.array([ENTRANCE_KEEPOUT_MM] + [max(o["half_size_mm"]) + OPENING_KEEPOUT_MM for o in holes])
        baffle_plates = inner[len(inner) - len(baffles):]
        if baffle_plates and not _feed_clear(entrance, baffle_plates, inflate_mm, turn_radius_mm):
            continue
        clutter = _clutter(rng, edges, shape, baffle_plates, keep, keep_radius,
                           int(rng.integers(CLUTTER_COUNT[0], CLUTTER_COUNT[1] + 1)))
        obstacles = fixed + clutter
        every = ObstacleSet(obstacles)
        grid = Grid.covering(bounds_min, bounds_max, cell_mm)
        sdf = free_space(every, grid, inflate_mm + SDF_HORIZON_MM)
        field = geodesic_from_sdf(grid, sdf, entrance, inflate_mm)
        n_targets = int(rng.integers(min_targets, max_targets + 1))
        targets, geodesic, tour = [], [], 0.0
        previous, prev_geo = None, 0.0
        for _ in range(n_targets):
            cand = np.round(rng.uniform(bounds_min + target_clearance_mm, bounds_max - target_clearance_mm,
                                        (TARGET_CANDIDATES, 3)), DECIMALS)
            geo = field.distance_at(cand)
            ok = (every.signed_distance(cand) >= target_clearance_mm) & outside_turning_region(entrance, cand,
                                                                                               turn_radius_mm)
            if previous is None:
                ok &= (geo >= MIN_FIRST_GEODESIC_MM) & (geo <= limit)
                leg = geo
            else:
                leg = previous.distance_at(cand)
                ok &= (geo - prev_geo >= MIN_TARGET_STEP_MM) & (leg <= MAX_DETOUR * (geo - prev_geo))
                ok &= tour + leg <= limit
            hits = np.flatnonzero(ok)
            if not len(hits):
                break
            k = hits[0]
            targets.append(cand[k])
            geodesic.append(round(float(geo[k]), 1))
            tour += float(leg[k])
            prev_geo = float(geo[k])
            previous = geodesic_from_sdf(grid, sdf, Entrance(cand[k], entrance.direction), inflate_mm, 0.0)
        if len(targets) < n_targets:
            continue
        rooms = [_room_box(edges, (i, j, k)) for k in range(shape[2]) for j in range(shape[1])
                 for i in range(shape[0])]
        meta = {
            "generator": "confined",
            "arm_length_mm": arm_length_mm,
            "arm_radius_mm": ARM_RADIUS_MM,
            "rooms": [{"index": i, "min": lo.tolist(), "max": hi.tolist()} for i, (lo, hi) in enumerate(rooms)],
            "grid": list(shape),
            "openings": openings,
            "baffles": baffles,
            "entrance_wall": wall,
            "port_radius_mm": PORT_RADIUS_MM,
            "clutter": len(clutter),
            "target_geodesic_mm": geodesic,
            "tour_mm": round(tour, 1),
            "reach_limit_mm": limit,
            "attempts": attempt,
            "parameters": {"reach_fraction": reach_fraction, "inflate_mm": inflate_mm, "cell_mm": cell_mm,
                           "min_targets": min_targets, "max_targets": max_targets,
                           "target_clearance_mm": target_clearance_mm, "turn_radius_mm": turn_radius_mm,
                           "wall_thickness_mm": WALL_THICKNESS_MM},
        }
        return Scene("confined", seed, bounds_min, bounds_max, entrance, np.array(targets), obstacles, meta,
                     discovered=tuple(range(len(fixed), len(obstacles))))
    raise RuntimeError(f"confined: no valid scene for seed {seed} in {MAX_ATTEMPTS} attempts")
