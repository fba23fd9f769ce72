"""The cable tensions along a crawl: what holds a fed arm up against gravity at every judged insertion depth
(tensions N, depths mm; :mod:`snakeplan.robots.statics` for the model).

Behind the entrance the arm lies straight in its feed guide, which holds it: the joints of a section whose pivot
has not passed the entrance are held by the guide (their torque is its reaction), and the cables hold the joints
inside, each against the weight of the arm beyond it. At depth 0 nothing is inside and no cable pulls; as the arm
goes in, the tensions grow with the weight it carries out from the entrance and with how it is bent.

The judge reports the peak tension, where it is and which section's cable carries it, and whether every depth is
holdable (non-negative tensions exist: force closure); the trajectory carries every cable's tension per sample.
A robot that states no section masses, has no cable routing or no feed has no statics here (None).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from snakeplan import ftl
from snakeplan.robots import Chain
from snakeplan.robots.statics import cable_tensions
from snakeplan.scenes import Scene


@dataclass(frozen=True)
class CrawlStatics:
    """Per crawl state: every cable's least non-negative tension ``tensions_n (T, n_cables)`` (N) and whether it
    holds the arm, ``holdable (T,)``; the depths ``depths_mm (T,)``; the robot's cable names and the section each
    cable drives."""

    depths_mm: np.ndarray
    tensions_n: np.ndarray
    holdable: np.ndarray
    cable_names: tuple[str, ...]
    cable_sections: np.ndarray

    @property
    def peak(self) -> tuple[float, float, int, str]:
        """(the largest tension (N), the depth (mm) where it is, the section whose cable carries it, that cable)."""
        i, c = np.unravel_index(int(np.argmax(self.tensions_n)), self.tensions_n.shape)
        return (float(self.tensions_n[i, c]), float(self.depths_mm[i]), int(self.cable_sections[c]),
                self.cable_names[c])

    @property
    def first_unholdable_mm(self) -> float | None:
        """The first depth (mm) no non-negative tensions hold, or None."""
        bad = np.flatnonzero(~self.holdable)
        return float(self.depths_mm[bad[0]]) if bad.size else None


def has_statics(robot: Chain) -> bool:
    """Whether ``robot`` states what the statics need: section masses, a cable routing, a feed, and sections that
    are two-angle joints (so that its joint angles follow from the body)."""
    if robot.masses is None or robot.cables is None or not robot.has_feed:
        return False
    try:
        robot.universal_joints()
    except ValueError:
        return False
    return True


def crawl_statics(scene: Scene, robot: Chain, states: ftl.FTLBatch) -> CrawlStatics | None:
    """The tensions that hold ``robot`` at each follow-the-leader state of its crawl into ``scene`` under the
    scene's gravity, or None where the robot has no statics (:func:`has_statics`)."""
    if not has_statics(robot) or len(states) == 0:
        return None
    base, q = ftl.fed_joints(robot, scene.entrance.position, scene.entrance.direction, states)
    guided = np.zeros(q.shape, dtype=bool)
    for section, joints in enumerate(robot.universal_joints()):
        guided[:, list(joints)] = (states.joint_arclength[:, section] <= 0.0)[:, None]
    held = cable_tensions(robot.with_base(base), q, scene.gravity, held=guided)
    section, *_ = robot.cables.table()
    return CrawlStatics(np.asarray(states.s, dtype=float), held.tensions_n, held.holdable, robot.cables.names,
                        section)
