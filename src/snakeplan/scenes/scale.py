"""Scale sanity: a scene, or a mesh in it, whose size is implausible against the arm that is to enter it is
most often a unit mistake (a CAD file in metres read as centimetres); say so before planning (mm)."""

from __future__ import annotations

import numpy as np

from snakeplan.geometry.primitives import Mesh, Points
from snakeplan.robots import Chain
from snakeplan.scenes.scene import Scene


def scale_warnings(scene: Scene, robot: Chain) -> list[str]:
    """One line per implausible size: the scene's bounds, or a mesh, spanning less than one of the arm's sections
    (both sizes named, and the mesh's units where it came from a file); and a way in narrower than the arm: every
    section that goes in passes the entrance, so free space there narrower than the arm's thickest section (the
    entrance's clearance from the obstacles) lets only the thinner ones in."""
    section = float(np.max(robot.lengths))
    out = []
    span = float(np.max(scene.size))
    if span < section:
        out.append(f"scene: {scene.name} spans {span:.3g} mm, less than one section of {robot.name} "
                   f"({section:.3g} mm); are its coordinates in mm?")
    for i, o in enumerate(scene.obstacles):
        if isinstance(o, (Mesh, Points)):
            extent = float(np.max(np.ptp(o.vertices if isinstance(o, Mesh) else o.points, axis=0)))
            if extent < section:
                units = (o.source or {}).get("units")
                read = f" (read in {units!r})" if units else ""
                what = "mesh" if isinstance(o, Mesh) else "cloud"
                out.append(f"obstacles[{i}]: the {what} spans {extent:.3g} mm{read}, less than one section of "
                           f"{robot.name} ({section:.3g} mm); are its units right?")
    if scene.obstacles:
        gap = float(scene.signed_distance(scene.entrance.position[None])[0])
        thickest = int(np.argmax(robot.radii))
        if 0.0 <= gap < robot.radii[thickest]:
            thin = int(np.sum(robot.radii <= gap))
            out.append(f"entrance: the free space there is {gap:.3g} mm in radius, narrower than {robot.name}'s "
                       f"thickest section ({robot.radii[thickest]:.3g} mm, section {thickest}): {thin} of its "
                       f"{robot.n_sections} sections fit through; are the scene's units right?")
    return out
