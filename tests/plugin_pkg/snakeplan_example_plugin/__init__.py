"""An example snakeplan plugin package: one planner, one scene family and one robot, named by entry points.

The planner is a bare class found through its entry point, registered once for both tasks it does; the scene
registers itself with its spec as the module is imported; the robot is a bare factory. Units: mm, rad.
"""

import math

import numpy as np

from snakeplan.geometry.primitives import Box
from snakeplan.planners.inspection import CameraPath, InspectionPlanner
from snakeplan.robots import Chain, Section
from snakeplan.scenes import Entrance, Scene, Task, register_scene


class StraightPlanner(InspectionPlanner):
    """`example-straight`: to reach, the polyline from the entrance through the targets; to inspect, straight hops
    to the nearest viewpoint the arm holds that it has not visited yet."""

    name = "example-straight"
    tasks = frozenset({Task.REACH, Task.INSPECT})
    needs_full_scene = False

    def _solve(self, problem, rng, deadline):
        if problem.task is Task.REACH:
            return "found", np.vstack([problem.start, problem.goals]), {}
        self.visited = set()
        return super()._solve(problem, rng, deadline)

    def next_path(self, state):
        lib = state.world.library
        far = np.linalg.norm(lib.positions - state.position, axis=1) > 1.0
        free = [k for k in np.flatnonzero(lib.reachable & far) if k not in self.visited]
        ok = np.asarray(free)[state.world.segment_ok(state.position, lib.positions[free])] if free else []
        if len(ok) == 0:
            return None
        k = int(ok[np.argmin(np.linalg.norm(lib.positions[ok] - state.position, axis=1))])
        self.visited.add(k)
        return CameraPath([state.position, lib.positions[k]], state.settings.speed_mm_s, "polyline")


@register_scene("example-corridor", robot="example-arm", planner="example-straight")
def corridor(seed: int) -> Scene:
    """A box fed along +x from the origin, a block beside the way in, one target 200-400 mm straight ahead."""
    depth = float(np.random.default_rng(seed).uniform(200.0, 400.0))
    block = Box([300.0, 120.0, 0.0], [100.0, 60.0, 100.0])
    return Scene("example-corridor", seed, [-100.0, -200.0, -200.0], [600.0, 200.0, 200.0],
                 Entrance([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]), [[depth, 0.0, 0.0]], [block])


def example_arm() -> Chain:
    """Five 100 mm sections of radius 10 mm bending up to 45 deg, fed 0..500 mm."""
    return Chain([Section(100.0, 10.0, math.radians(45.0))] * 5, name="example-arm", feed_range=(0.0, 500.0))
