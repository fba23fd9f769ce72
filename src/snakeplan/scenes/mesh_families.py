"""Scene families whose geometry is one closed CAD-like mesh, built with manifold3d (mm, rad).

Three snake-arm jobs, each sized for sjtu-snake-iii (2130 mm, 27.5 mm body radius, turn radius about 217 mm):

- ``pipework``: a pipe run (bore radius :data:`PIPE_BORE_MM`) with two rounded bends in 3-D; the arm enters at
  the mouth along the pipe and must reach a point on the axis beyond the bends. The seed picks the turn of each
  bend (one of :data:`PIPE_TURNS`) and the target's depth.
- ``vessel``: a vertical pressure vessel with a top nozzle: the arm enters from above (feed -z), passes the
  nozzle and reaches a point inside the shell beside a dip pipe and above a support ring. The seed draws the
  target.
- ``engine``: an annular engine casing around a hub with a row of guide vanes; the arm enters radially through a
  borescope port on top of the casing (feed -z) and turns into the annulus towards the vanes. The seed draws the
  target in front of the vanes.

Meshes are built once per variant and cached (about 0.1-1 s to build); a scene holds the mesh as an inline
obstacle. Targets are drawn from the seed where the mesh's signed distance is at least :data:`TARGET_CLEARANCE_MM`.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from snakeplan.geometry.primitives import Mesh
from snakeplan.scenes.registry import register_scene
from snakeplan.scenes.scene import Entrance, Scene

#: The families this module registers.
MESH_FAMILIES = ("pipework", "vessel", "engine")
#: Least distance (mm) from a target to the mesh.
TARGET_CLEARANCE_MM = 70.0
#: Draws before a family gives up finding a free target (never reached with these shapes).
MAX_TARGET_DRAWS = 2000
#: Pipework: bore radius, wall, bend radius, leg lengths (mm).
PIPE_BORE_MM = 150.0
PIPE_WALL_MM = 12.0
PIPE_BEND_MM = 400.0
PIPE_LEGS_MM = (600.0, 850.0, 750.0)
#: Pipework: the directions the second and third legs may turn to (unit vectors picked by the seed).
PIPE_TURNS = ((0.0, 1.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0))
#: Vessel: shell inner radius, wall, height; nozzle bore radius and height; dip pipe radius and offset (mm).
VESSEL_RADIUS_MM = 550.0
VESSEL_WALL_MM = 16.0
VESSEL_HEIGHT_MM = 1400.0
NOZZLE_BORE_MM = 120.0
NOZZLE_HEIGHT_MM = 200.0
DIP_PIPE = (45.0, -300.0, 0.0)
#: Engine: casing inner radius, wall, hub radius, axial length; vanes (count, chord, thickness, axial station);
#: port radius and axial station (mm).
CASING_RADIUS_MM = 560.0
CASING_WALL_MM = 14.0
HUB_RADIUS_MM = 150.0
ENGINE_LENGTH_MM = 1100.0
VANES = (10, 140.0, 16.0, 850.0)
PORT = (110.0, 250.0)
#: Circle segments of the built meshes (triangles grow with their square).
SEGMENTS = 128


def _free_target(mesh: Mesh, rng: np.random.Generator, draw) -> np.ndarray:
    """A point from ``draw(rng)`` at least TARGET_CLEARANCE_MM from the mesh (and outside it)."""
    for _ in range(MAX_TARGET_DRAWS):
        p = np.asarray(draw(rng), dtype=float)
        if float(mesh.signed_distance(p)) >= TARGET_CLEARANCE_MM:
            return p
    raise RuntimeError("no free target found")


@lru_cache(maxsize=16)
def _pipework_mesh(turn1: int, turn2: int) -> tuple[Mesh, np.ndarray]:
    from snakeplan.scenes.meshing import pipe_run, to_mesh

    a = np.zeros(3)
    b = a + [PIPE_LEGS_MM[0], 0.0, 0.0]
    u2 = np.array(PIPE_TURNS[turn1])
    c = b + PIPE_LEGS_MM[1] * u2
    u3 = np.array(PIPE_TURNS[turn2])
    if abs(float(u3 @ u2)) > 0.5:  # the third leg turns across the second (never back along it)
        u3 = np.array([1.0, 0.0, 0.0])
    d = c + PIPE_LEGS_MM[2] * u3
    axis = np.array([a, b, c, d])
    return to_mesh([pipe_run(axis, PIPE_BORE_MM, PIPE_WALL_MM, PIPE_BEND_MM, SEGMENTS)]), axis


@register_scene("pipework", robot="sjtu-snake-iii")
def pipework(seed: int) -> Scene:
    """A pipe run with two bends in 3-D, entered at its mouth; the target lies on the axis after the bends."""
    rng = np.random.default_rng(seed)
    turn1 = int(rng.integers(len(PIPE_TURNS)))
    turn2 = int(rng.integers(len(PIPE_TURNS)))
    mesh, axis = _pipework_mesh(turn1, turn2)
    c, d = axis[2], axis[3]
    leg = (d - c) / np.linalg.norm(d - c)
    depth = rng.uniform(PIPE_BEND_MM + 50.0, PIPE_LEGS_MM[2] - 150.0)
    target = c + leg * depth
    lo, hi = mesh.aabb()
    margin = 60.0
    bounds_min = np.minimum(lo - margin, [-300.0, lo[1] - margin, lo[2] - margin])
    return Scene("pipework", seed, bounds_min, hi + margin, Entrance(np.zeros(3), [1.0, 0.0, 0.0]), target[None],
                 (mesh,), {"mesh_family": {"turns": [turn1, turn2], "triangles": len(mesh.faces)}})


@lru_cache(maxsize=1)
def _vessel_mesh() -> Mesh:
    from manifold3d import Manifold

    from snakeplan.scenes.meshing import to_mesh

    R, w, H = VESSEL_RADIUS_MM, VESSEL_WALL_MM, VESSEL_HEIGHT_MM
    shell = Manifold.cylinder(H + 2 * w, R + w, R + w, SEGMENTS) - Manifold.cylinder(H, R, R, SEGMENTS).translate(
        [0.0, 0.0, w])
    nozzle = Manifold.cylinder(NOZZLE_HEIGHT_MM, NOZZLE_BORE_MM + w, NOZZLE_BORE_MM + w, SEGMENTS).translate(
        [0.0, 0.0, H + w])
    bore = Manifold.cylinder(NOZZLE_HEIGHT_MM + 4 * w, NOZZLE_BORE_MM, NOZZLE_BORE_MM, SEGMENTS).translate(
        [0.0, 0.0, H - w])
    r, x, y = DIP_PIPE
    dip = Manifold.cylinder(H * 0.7, r, r, SEGMENTS).translate([x, y, w + H * 0.3])
    ring = (Manifold.cylinder(30.0, R + 1.0, R + 1.0, SEGMENTS)
            - Manifold.cylinder(40.0, R - 70.0, R - 70.0, SEGMENTS).translate([0.0, 0.0, -5.0])).translate(
        [0.0, 0.0, w + 350.0])
    return to_mesh([shell + nozzle - bore, dip, ring])


@register_scene("vessel", robot="sjtu-snake-iii")
def vessel(seed: int) -> Scene:
    """A vertical vessel entered from above through its top nozzle; the target lies inside, above the ring."""
    rng = np.random.default_rng(seed)
    mesh = _vessel_mesh()
    top = VESSEL_WALL_MM + VESSEL_HEIGHT_MM + NOZZLE_HEIGHT_MM

    def draw(g):
        phi = g.uniform(0.0, 2.0 * math.pi)
        rho = g.uniform(100.0, 330.0)
        return [rho * math.cos(phi), rho * math.sin(phi), g.uniform(700.0, 1150.0)]

    target = _free_target(mesh, rng, draw)
    lo, hi = mesh.aabb()
    entrance = Entrance([0.0, 0.0, top], [0.0, 0.0, -1.0])
    return Scene("vessel", seed, lo - 60.0, hi + [60.0, 60.0, 400.0], entrance, target[None], (mesh,),
                 {"mesh_family": {"triangles": len(mesh.faces)}})


@lru_cache(maxsize=1)
def _engine_mesh() -> Mesh:
    from manifold3d import Manifold

    from snakeplan.scenes.meshing import to_mesh

    R, w, L = CASING_RADIUS_MM, CASING_WALL_MM, ENGINE_LENGTH_MM
    along_x = [[0.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.0]]  # z-axis -> x-axis
    casing = (Manifold.cylinder(L, R + w, R + w, SEGMENTS) - Manifold.cylinder(L + 2.0, R, R, SEGMENTS).translate(
        [0.0, 0.0, -1.0])).transform(along_x)
    hub = Manifold.cylinder(L, HUB_RADIUS_MM, HUB_RADIUS_MM, SEGMENTS).transform(along_x)
    port_r, port_x = PORT
    port = Manifold.cylinder(4 * w, port_r, port_r, SEGMENTS).translate([port_x, 0.0, R - w])
    count, chord, thick, station = VANES
    vanes = []
    for k in range(count):
        angle = 360.0 * (k + 0.5) / count
        vane = Manifold.cube([chord, thick, R - HUB_RADIUS_MM + 10.0], center=True).rotate([0.0, 0.0, 20.0])
        vane = vane.translate([station, 0.0, 0.5 * (R + HUB_RADIUS_MM)]).rotate([angle, 0.0, 0.0])
        vanes.append(vane)
    return to_mesh([casing - port, hub, *vanes])


@register_scene("engine", robot="sjtu-snake-iii")
def engine(seed: int) -> Scene:
    """An annular engine casing entered radially through a borescope port on top; the target lies in the annulus
    upstream of the guide vanes."""
    rng = np.random.default_rng(seed)
    mesh = _engine_mesh()
    R = CASING_RADIUS_MM

    def draw(g):
        phi = g.uniform(-0.5, 0.5)  # around the top (+z), rad
        rho = g.uniform(HUB_RADIUS_MM + 110.0, R - 200.0)  # deep enough below the port to turn into
        x = g.uniform(PORT[1] + 350.0, VANES[3] - 150.0)
        return [x, rho * math.sin(phi), rho * math.cos(phi)]

    target = _free_target(mesh, rng, draw)
    lo, hi = mesh.aabb()
    entrance = Entrance([PORT[1], 0.0, R + CASING_WALL_MM], [0.0, 0.0, -1.0])
    return Scene("engine", seed, lo - 60.0, hi + [60.0, 60.0, 400.0], entrance, target[None], (mesh,),
                 {"mesh_family": {"triangles": len(mesh.faces)}})
