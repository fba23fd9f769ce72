"""A hand-built corridor for the picture tests: a plate with a round hole, then a wall across the way.

The arm (sjtu-snake-iii: links of radius 27.5 mm) enters at the origin along +x. The plate's face is at x = 290,
its hole of radius 80 mm centred on the x axis, so a body on the axis clears it by 80 - 27.5 = 52.5 mm. The wall's
face is at x = 700: the tip link's capsule, reaching 27.5 mm past the tip, penetrates it by more than the judge's
0.01 mm once the tip is past x = 672.51, so on the judge's 5 mm grid the first collision is at 675 mm of
insertion, by the tip link (11).
"""

from __future__ import annotations

import numpy as np

from snakeplan.geometry.primitives import Box, Plate
from snakeplan.scenes import Entrance, Scene

HOLE_CLEARANCE_MM = 80.0 - 27.5
COLLISION_DEPTH_MM = 675.0
TIP_LINK = 11


def corridor(target_x: float = 600.0) -> Scene:
    plate = Plate([300.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [500.0, 500.0], 20.0,
                  {"offset": [0.0, 0.0], "semi_axes": [80.0, 80.0]})
    wall = Box([710.0, 0.0, 0.0], [20.0, 500.0, 500.0])
    return Scene("corridor", 0, np.array([-50.0, -300.0, -300.0]), np.array([1000.0, 300.0, 300.0]),
                 Entrance(np.zeros(3), np.array([1.0, 0.0, 0.0])), np.array([[target_x, 0.0, 0.0]]), (plate, wall))


def straight(to_x: float) -> np.ndarray:
    """The tip path along the axis from the entrance to x = ``to_x``."""
    return np.array([[0.0, 0.0, 0.0], [to_x, 0.0, 0.0]])
