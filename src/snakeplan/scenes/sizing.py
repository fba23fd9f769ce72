"""Scenes sized to an arm: a family's scene for another arm than the one its spec names (mm).

The room-scale and pipe generators (fuel-tank, oil-tank, confined, pipe, concentric-pipe) are parametric in the
arm they are made for: they accept a target only where its geodesic tour from the entrance is within
``reach_fraction`` of ``arm_length_mm``, along a free space eroded by ``inflate_mm`` (the arm's body with a
margin). Sized to an arm, a family's scene keeps its rooms and draws its targets for that arm:

- ``arm_length_mm``: the arm's length (the sum of its sections);
- ``inflate_mm``: the family's inflation plus the difference of the arm's thickest radius from that of the
  family's arm (SJTU-Snake III, 27.5 mm, in 30 mm for the tanks: the same 2.5 mm margin for every arm);
- ``target_clearance_mm``: the family's, or the inflation where that is larger (a target lies in free space);
- ``turn_radius_mm``, where the generator takes it (fuel-tank, confined): the arm's smallest turning radius, the
  least on which every section's chord bends at most its limit (:func:`~snakeplan.robots.arm_range.turn_radius_for`
  at the whole limit), so no target lies in the turning circles at the entrance that this arm, rather than the
  family's, cannot reach.

The family's own arm, or any of its length, thickness and turning radius (the generator's defaults), gets the
family's scenes unchanged (the same geometry and targets; the scene's metadata lists the parameters). A family whose
generator takes no ``arm_length_mm`` (meshes, scans, the station) is the same for every arm.
"""

from __future__ import annotations

import inspect
from dataclasses import replace

import numpy as np

from snakeplan.robots import Chain, get_robot
from snakeplan.robots.arm_range import turn_radius_for
from snakeplan.scenes.registry import make_scene, scene_spec
from snakeplan.scenes.scene import Scene

#: The generator parameters that size a family to an arm, and one that does where the generator takes it.
SIZED = ("arm_length_mm", "inflate_mm", "target_clearance_mm")
TURNING = "turn_radius_mm"


def arm_sizing(family: str, robot: Chain | None) -> tuple[tuple[str, float], ...]:
    """The generator parameters (name, value) that size ``family`` to ``robot`` (see the module); empty where
    ``robot`` is None (the family's own arm), the family takes none, or ``robot`` has the length, thickest radius
    and turning radius of the family's own arm."""
    if robot is None:
        return ()
    spec = scene_spec(family)
    params = inspect.signature(spec.generator).parameters
    if not all(k in params for k in SIZED):
        return ()
    own = get_robot(spec.robot)
    length, radius = float(np.sum(robot.lengths)), float(np.max(robot.radii))
    turning = (((TURNING, turn_radius_for(robot, 1.0)),) if TURNING in params else ())
    if np.isclose(length, float(np.sum(own.lengths))) and np.isclose(radius, float(np.max(own.radii))) \
            and all(np.isclose(value, float(params[TURNING].default)) for _, value in turning):
        return ()
    inflate = float(params["inflate_mm"].default) + radius - float(np.max(own.radii))
    clearance = max(float(params["target_clearance_mm"].default), inflate)
    return (("arm_length_mm", round(length, 6)), ("inflate_mm", round(inflate, 6)),
            ("target_clearance_mm", round(clearance, 6))) + turning


def sized_scene(family: str, seed: int, params: tuple[tuple[str, float], ...] = ()) -> Scene:
    """``family``'s scene of ``seed`` made with the sizing ``params`` (:func:`arm_sizing`; empty: the family's own
    arm), which a sized scene records in ``metadata["sizing"]``."""
    scene = make_scene(family, seed, **dict(params))
    return replace(scene, metadata={**scene.metadata, "sizing": dict(params)}) if params else scene


def scene_sizing(scene: Scene) -> tuple[tuple[str, float], ...]:
    """The sizing parameters ``scene`` was made with (:func:`sized_scene`; empty for a family's own arm)."""
    return tuple(scene.metadata.get("sizing", {}).items())
