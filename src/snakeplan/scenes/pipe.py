"""`pipe` and `concentric-pipe`: paper 001's hollow-pipe and concentric-pipe experiments (mm, rad).

Paper 001's table of dimensions was lost in extraction; the numbers below are chosen to suit its arms (SSCC-16
and SSCC-24: 1200 mm long, 15 mm body radius) and are documented here as named defaults. Both pipes lie along
+x with their mouth at x = 0; the entrance is the mouth centre, fed along +x; the bounds are a box around the
pipes (PIPE_BOUNDS_MARGIN_MM) extended PIPE_BEHIND_MM behind the mouth, where the arm's feed stage stands.

`pipe`: one open hollow pipe; the target lies inside it. `concentric-pipe`: a wide outer pipe with a narrower
inner pipe on the same axis, its near end recessed behind the outer mouth; the target lies in the annulus
between them, alongside the inner pipe, so the arm must slip past the inner pipe's rim.
"""

from __future__ import annotations

import math

import numpy as np

from snakeplan.geometry.primitives import Pipe
from snakeplan.scenes.parameters import DEFAULT_REACH_FRACTION, check_range
from snakeplan.scenes.routes.geodesic import geodesic_from_sdf
from snakeplan.scenes.routes.grid import SDF_HORIZON_MM, Grid, free_space
from snakeplan.scenes.registry import register_scene
from snakeplan.scenes.scene import Entrance, Scene

#: The robot the pipe scenes are sized for: name, arm length (mm), body radius (mm). Paper 001's two arms share
#: the length and radius; sscc-24 plans here by default, and `snakeplan bench sscc` also runs sscc-16 in the pipe
#: (the paper's first setting).
ROBOT = "sscc-24"
ARM_LENGTH_MM = 1200.0
ARM_RADIUS_MM = 15.0
#: Hollow pipe: inner radius, wall thickness, length (mm).
PIPE_INNER_RADIUS_MM = 100.0
PIPE_WALL_MM = 10.0
PIPE_LENGTH_MM = 800.0
#: Target depth range (mm) along the hollow pipe's axis.
PIPE_TARGET_DEPTH_MM = (250.0, 750.0)
#: Concentric pipes: outer pipe inner radius, wall, length; inner pipe outer radius, inner radius, length (mm).
OUTER_INNER_RADIUS_MM = 150.0
OUTER_WALL_MM = 10.0
OUTER_LENGTH_MM = 900.0
INNER_OUTER_RADIUS_MM = 60.0
INNER_INNER_RADIUS_MM = 50.0
INNER_LENGTH_MM = 500.0
#: Distance (mm) from the outer mouth to the near end of the inner pipe.
INNER_RECESS_MM = 300.0
#: Least clearance (mm) from a target to the pipe walls.
TARGET_CLEARANCE_MM = 40.0
#: Bounds: extension behind the mouth and margin around the pipes (mm).
PIPE_BEHIND_MM = 600.0
PIPE_BOUNDS_MARGIN_MM = 50.0
#: Reachability check: inflation (body radius + 5 mm) and grid cell (mm).
REACH_INFLATE_MM = 20.0
REACH_CELL_MM = 10.0
#: Bounded resampling of the target.
MAX_ATTEMPTS = 64
#: Decimals (mm) every generated coordinate is rounded to.
DECIMALS = 3

_AXIS = np.array([1.0, 0.0, 0.0])


def _bounds(length: float, radius: float) -> tuple[np.ndarray, np.ndarray]:
    r = radius + PIPE_BOUNDS_MARGIN_MM
    return np.array([-PIPE_BEHIND_MM, -r, -r]), np.array([length + PIPE_BOUNDS_MARGIN_MM, r, r])


def _annulus_point(rng: np.random.Generator, r_lo: float, r_hi: float, x_lo: float, x_hi: float) -> np.ndarray:
    """A point uniform in the volume r_lo <= r <= r_hi, x_lo <= x <= x_hi around the x axis."""
    r = math.sqrt(rng.uniform(r_lo**2, r_hi**2))
    phi = rng.uniform(0.0, 2 * math.pi)
    x = rng.uniform(x_lo, x_hi)
    return np.round([x, r * math.cos(phi), r * math.sin(phi)], DECIMALS)


def _finish(name: str, seed: int, obstacles: list[Pipe], bounds: tuple[np.ndarray, np.ndarray], rng,
            draw, limit: float, facts: dict, params: dict) -> Scene:
    """Draw targets with ``draw(rng)`` until one is clear and geodesically reachable; build the scene."""
    entrance = Entrance([0.0, 0.0, 0.0], _AXIS)
    probe = Scene(name, seed, bounds[0], bounds[1], entrance, [], obstacles)
    grid = Grid.covering(bounds[0], bounds[1], params["cell_mm"])
    sdf = free_space(probe.obstacle_set, grid, params["inflate_mm"] + SDF_HORIZON_MM)
    field = geodesic_from_sdf(grid, sdf, entrance, params["inflate_mm"])
    for attempt in range(1, MAX_ATTEMPTS + 1):
        target = draw(rng)
        geo = float(field.distance_at(target))
        if probe.signed_distance(target) >= params["target_clearance_mm"] and geo <= limit:
            meta = {"generator": name, "arm_length_mm": params["arm_length_mm"],
                    "arm_radius_mm": ARM_RADIUS_MM, **facts, "target_geodesic_mm": round(geo, 1),
                    "reach_limit_mm": limit, "attempts": attempt, "parameters": params}
            return Scene(name, seed, bounds[0], bounds[1], entrance, target[None], obstacles, meta)
    raise RuntimeError(f"{name}: no valid target for seed {seed} in {MAX_ATTEMPTS} attempts")


def _params(arm_length_mm, reach_fraction, inflate_mm, cell_mm, target_clearance_mm) -> dict:
    return {"arm_length_mm": check_range("arm_length_mm", arm_length_mm, 1.0),
            "reach_fraction": check_range("reach_fraction", reach_fraction, 0.1, 1.0),
            "inflate_mm": check_range("inflate_mm", inflate_mm, 0.0, 40.0),
            "cell_mm": check_range("cell_mm", cell_mm, 2.0, 20.0),
            "target_clearance_mm": check_range("target_clearance_mm", target_clearance_mm, 0.0, 45.0)}


#: Planned by default with SSCC and the swinging-search agent that ships for the robot.
SSCC_AGENT = {"sscc": f"snakeplan:planners/sscc/data/{ROBOT}.npz"}


@register_scene("pipe", robot=ROBOT, planner="sscc", policies=SSCC_AGENT)
def pipe(seed: int, *, arm_length_mm: float = ARM_LENGTH_MM, reach_fraction: float = DEFAULT_REACH_FRACTION,
         inflate_mm: float = REACH_INFLATE_MM, cell_mm: float = REACH_CELL_MM,
         target_clearance_mm: float = TARGET_CLEARANCE_MM) -> Scene:
    """One hollow pipe along +x, mouth at the entrance; a target inside at a random radius, angle and depth."""
    params = _params(arm_length_mm, reach_fraction, inflate_mm, cell_mm, target_clearance_mm)
    outer = PIPE_INNER_RADIUS_MM + PIPE_WALL_MM
    tube = Pipe([PIPE_LENGTH_MM / 2, 0.0, 0.0], _AXIS, PIPE_INNER_RADIUS_MM, outer, PIPE_LENGTH_MM)
    r_max = PIPE_INNER_RADIUS_MM - params["target_clearance_mm"]
    facts = {"pipe": {"inner_radius_mm": PIPE_INNER_RADIUS_MM, "outer_radius_mm": outer,
                      "length_mm": PIPE_LENGTH_MM, "mouth": [0.0, 0.0, 0.0], "axis": _AXIS.tolist()},
             "target_region": {"radius_mm": [0.0, r_max], "depth_mm": list(PIPE_TARGET_DEPTH_MM)}}
    return _finish("pipe", seed, [tube], _bounds(PIPE_LENGTH_MM, outer), np.random.default_rng(seed),
                   lambda rng: _annulus_point(rng, 0.0, r_max, *PIPE_TARGET_DEPTH_MM),
                   params["reach_fraction"] * params["arm_length_mm"], facts, params)


@register_scene("concentric-pipe", robot=ROBOT, planner="sscc", policies=SSCC_AGENT)
def concentric_pipe(seed: int, *, arm_length_mm: float = ARM_LENGTH_MM,
                    reach_fraction: float = DEFAULT_REACH_FRACTION, inflate_mm: float = REACH_INFLATE_MM,
                    cell_mm: float = REACH_CELL_MM, target_clearance_mm: float = TARGET_CLEARANCE_MM) -> Scene:
    """An outer pipe with a coaxial inner pipe recessed from its mouth; a target in the annulus beside the inner."""
    params = _params(arm_length_mm, reach_fraction, inflate_mm, cell_mm, target_clearance_mm)
    outer_r = OUTER_INNER_RADIUS_MM + OUTER_WALL_MM
    outer = Pipe([OUTER_LENGTH_MM / 2, 0.0, 0.0], _AXIS, OUTER_INNER_RADIUS_MM, outer_r, OUTER_LENGTH_MM)
    inner = Pipe([INNER_RECESS_MM + INNER_LENGTH_MM / 2, 0.0, 0.0], _AXIS, INNER_INNER_RADIUS_MM,
                 INNER_OUTER_RADIUS_MM, INNER_LENGTH_MM)
    c = params["target_clearance_mm"]
    r_lo, r_hi = INNER_OUTER_RADIUS_MM + c, OUTER_INNER_RADIUS_MM - c
    depth = (INNER_RECESS_MM, INNER_RECESS_MM + INNER_LENGTH_MM)
    facts = {"outer_pipe": {"inner_radius_mm": OUTER_INNER_RADIUS_MM, "outer_radius_mm": outer_r,
                            "length_mm": OUTER_LENGTH_MM, "mouth": [0.0, 0.0, 0.0], "axis": _AXIS.tolist()},
             "inner_pipe": {"inner_radius_mm": INNER_INNER_RADIUS_MM, "outer_radius_mm": INNER_OUTER_RADIUS_MM,
                            "length_mm": INNER_LENGTH_MM, "recess_mm": INNER_RECESS_MM},
             "target_region": {"radius_mm": [r_lo, r_hi], "depth_mm": list(depth)}}
    return _finish("concentric-pipe", seed, [outer, inner], _bounds(OUTER_LENGTH_MM, outer_r),
                   np.random.default_rng(seed), lambda rng: _annulus_point(rng, r_lo, r_hi, *depth),
                   params["reach_fraction"] * params["arm_length_mm"], facts, params)
