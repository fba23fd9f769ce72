"""`oil-tank`: paper 000's multi-target scene, a 1200 x 600 x 600 mm tank of 300 mm cubic cells (mm, rad).

Fixed structure: 4 x 2 x 2 = 16 cubic cells; every wall between two adjacent cells is a 300 x 300 mm plate with
a centred round hole of 280 mm diameter (28 plates); the outer walls are plates whose inner faces lie on the
bounds. Per seed: the entrance, centred on one cell's face in an end wall (x = 0 or x = 1200; the arm enters that
cell through its own 60 mm-radius port and looks down a row of four cells), and 3 debris targets, one in each
of the next cells of that row, within ``ROW_OFFSET_MM`` of the row's axis, with clearance >= 40 mm and
geodesically reachable (:mod:`snakeplan.scenes.routes.geodesic`).

Why a row: the planners visit targets in order along one follow-the-leader path without retracting (see
:mod:`snakeplan.planners.base`), so the whole tour must fit in one arm and pass the 280 mm holes; a 90 degree turn
inside a 300 mm cell is beyond a 177.5 mm-section arm bending at most 50.7 degrees. The tour is then about
1000 mm long, as the paper's multi-target paths (Table 2). Targets are listed in visiting order, which is also
increasing geodesic distance from the entrance.
"""

from __future__ import annotations

import numpy as np

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Plate
from snakeplan.scenes.fuel_tank import ARM_LENGTH_MM, ARM_RADIUS_MM, DECIMALS, PORT_RADIUS_MM, ROBOT, outer_walls
from snakeplan.scenes.parameters import DEFAULT_REACH_FRACTION, check_range, tank_parameters
from snakeplan.scenes.routes.geodesic import DEFAULT_INFLATE_MM, geodesic_from_sdf
from snakeplan.scenes.routes.grid import SDF_HORIZON_MM, Grid, free_space
from snakeplan.scenes.registry import register_scene
from snakeplan.scenes.scene import Entrance, Scene

#: Cells along x, y, z.
CELLS = (4, 2, 2)
#: Edge (mm) of a cubic cell.
CELL_EDGE_MM = 300.0
#: Radius (mm) of the round hole in every wall between cells (280 mm diameter).
HOLE_RADIUS_MM = 140.0
#: Thickness (mm) of the cell walls and the outer walls.
WALL_THICKNESS_MM = 10.0
#: Number of targets.
TARGET_COUNT = 3
#: Least clearance (mm) from a target to every obstacle.
TARGET_CLEARANCE_MM = 40.0
#: Grid cell (mm) of the reachability check.
REACH_CELL_MM = 20.0
#: Largest distance (mm) of a target from the axis of the entrance's row of cells.
ROW_OFFSET_MM = 70.0
#: Bounded resampling: whole-scene attempts and candidate points per cell.
MAX_ATTEMPTS = 40
CELL_CANDIDATES = 64


def cell_index(ix: int, iy: int, iz: int) -> int:
    """Flat index of cell (ix, iy, iz): ``(iz * CELLS[1] + iy) * CELLS[0] + ix``."""
    return (iz * CELLS[1] + iy) * CELLS[0] + ix


def cell_of(point) -> int:
    """Index of the cell containing ``point`` (clipped into the tank)."""
    idx = [min(max(int(point[a] // CELL_EDGE_MM), 0), CELLS[a] - 1) for a in range(3)]
    return cell_index(*idx)


def cell_walls() -> list[Plate]:
    """The 28 plates between adjacent cells, each with its centred round hole."""
    hole = {"offset": [0.0, 0.0], "semi_axes": [HOLE_RADIUS_MM, HOLE_RADIUS_MM]}
    e = CELL_EDGE_MM
    plates = []
    for axis in range(3):
        up = np.array([0.0, 1.0, 0.0]) if axis == 2 else np.array([0.0, 0.0, 1.0])
        counts = list(CELLS)
        counts[axis] -= 1
        for i in range(counts[0]):
            for j in range(counts[1]):
                for k in range(counts[2]):
                    c = (np.array([i, j, k]) + 0.5) * e
                    c[axis] += e / 2
                    plates.append(Plate(c, np.eye(3)[axis], up, (e, e), WALL_THICKNESS_MM, dict(hole)))
    return plates


def _entrance_faces() -> list[tuple[str, Entrance]]:
    """Every cell face on an end wall (x = 0 or x = max): (wall name, entrance at the face centre, fed inwards)."""
    e = CELL_EDGE_MM
    size = np.array(CELLS) * e
    faces = []
    for axis in (0,):
        for sign, name in ((1.0, "-"), (-1.0, "+")):
            other = 1 - axis
            for a in range(CELLS[other]):
                for k in range(CELLS[2]):
                    p = np.zeros(3)
                    p[axis] = 0.0 if sign > 0 else size[axis]
                    p[other] = (a + 0.5) * e
                    p[2] = (k + 0.5) * e
                    faces.append(("xy"[axis] + name, Entrance(p, sign * np.eye(3)[axis])))
    return faces


# Planned by default with the learned planner whose policy ships for it, as fuel-tank.
@register_scene("oil-tank", robot=ROBOT, planner="sac-per",
                policies={"sac-per": "snakeplan:rl/data/oil-tank-sac-per.npz"})
def oil_tank(seed: int, *, arm_length_mm: float = ARM_LENGTH_MM, reach_fraction: float = DEFAULT_REACH_FRACTION,
             inflate_mm: float = DEFAULT_INFLATE_MM, cell_mm: float = REACH_CELL_MM,
             n_targets: int = TARGET_COUNT, target_clearance_mm: float = TARGET_CLEARANCE_MM) -> Scene:
    """The oil tank for ``seed``: fixed cells and holes, random entrance face and targets."""
    arm_length_mm, reach_fraction, inflate_mm, cell_mm = tank_parameters(arm_length_mm, reach_fraction, inflate_mm,
                                                                         cell_mm)
    n_targets = int(check_range("n_targets", n_targets, 1, CELLS[0] - 1, integer=True))
    target_clearance_mm = check_range("target_clearance_mm", target_clearance_mm, 0.0, 100.0)
    rng = np.random.default_rng(seed)
    bounds_min, bounds_max = np.zeros(3), np.array(CELLS, dtype=float) * CELL_EDGE_MM
    inner = cell_walls()
    grid = Grid.covering(bounds_min, bounds_max, cell_mm)
    limit = reach_fraction * arm_length_mm
    faces = _entrance_faces()
    for attempt in range(1, MAX_ATTEMPTS + 1):
        wall, entrance = faces[int(rng.integers(len(faces)))]
        obstacles = outer_walls(bounds_min, bounds_max, WALL_THICKNESS_MM, wall, entrance.position) + inner
        every = ObstacleSet(obstacles)
        field = geodesic_from_sdf(grid, free_space(every, grid, inflate_mm + SDF_HORIZON_MM), entrance, inflate_mm)
        home = cell_of(entrance.position + entrance.direction)
        found: list[tuple[float, int, np.ndarray]] = []
        step = int(np.sign(entrance.direction[0]))
        row = [cell_of(entrance.position + (k + 0.5) * CELL_EDGE_MM * entrance.direction) for k in range(CELLS[0])]
        for k, c in enumerate(row[1 : n_targets + 1], start=1):
            x0 = entrance.position[0] + step * k * CELL_EDGE_MM
            axial = x0 + step * rng.uniform(target_clearance_mm, CELL_EDGE_MM - target_clearance_mm, CELL_CANDIDATES)
            radius = ROW_OFFSET_MM * np.sqrt(rng.uniform(0.0, 1.0, CELL_CANDIDATES))
            angle = rng.uniform(0.0, 2 * np.pi, CELL_CANDIDATES)
            cand = np.stack([axial, entrance.position[1] + radius * np.cos(angle),
                             entrance.position[2] + radius * np.sin(angle)], axis=1)
            cand = np.round(cand, DECIMALS)
            geo = field.distance_at(cand)
            ok = np.flatnonzero((every.signed_distance(cand) >= target_clearance_mm) & (geo <= limit))
            if len(ok):
                found.append((float(geo[ok[0]]), int(c), cand[ok[0]]))
        if len(found) < n_targets:
            continue
        meta = {
            "generator": "oil-tank",
            "arm_length_mm": arm_length_mm,
            "arm_radius_mm": ARM_RADIUS_MM,
            "cells": [{"index": cell_index(i, j, k),
                       "min": (np.array([i, j, k]) * CELL_EDGE_MM).tolist(),
                       "max": ((np.array([i, j, k]) + 1) * CELL_EDGE_MM).tolist()}
                      for k in range(CELLS[2]) for j in range(CELLS[1]) for i in range(CELLS[0])],
            "hole_radius_mm": HOLE_RADIUS_MM,
            "holes": len(inner),
            "entrance_wall": wall,
            "entrance_cell": home,
            "target_cells": [f[1] for f in found],
            "target_geodesic_mm": [round(f[0], 1) for f in found],
            "target_order": "along the entrance's row of cells (visiting order)",
            "row_offset_mm": ROW_OFFSET_MM,
            "port_radius_mm": PORT_RADIUS_MM,
            "reach_limit_mm": limit,
            "attempts": attempt,
            "parameters": {"reach_fraction": reach_fraction, "inflate_mm": inflate_mm, "cell_mm": cell_mm,
                           "n_targets": n_targets, "target_clearance_mm": target_clearance_mm,
                           "wall_thickness_mm": WALL_THICKNESS_MM},
        }
        targets = np.array([f[2] for f in found])
        return Scene("oil-tank", seed, bounds_min, bounds_max, entrance, targets, obstacles, meta)
    raise RuntimeError(f"oil-tank: no valid scene for seed {seed} in {MAX_ATTEMPTS} attempts")
