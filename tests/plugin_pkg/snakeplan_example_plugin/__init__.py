"""An example snakeplan plugin package: one planner, one scene family and one robot, named by entry points.

The planner is a bare class found through its entry point; the scene registers itself with its spec as the
module is imported; the robot is a bare factory. Units: mm, rad.
"""

import math

import numpy as np

from snakeplan.geometry.primitives import Box
from snakeplan.planners import Planner
from snakeplan.robots import Chain, Section
from snakeplan.scenes import Entrance, Scene, register_scene


class StraightPlanner(Planner):
    """`example-straight`: the polyline from the entrance through the targets."""

    name = "example-straight"
    needs_full_scene = False

    def _solve(self, problem, rng, deadline):
        return "found", np.vstack([problem.start, problem.goals]), {}


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
