"""How strictly a crawl is checked: the judge's rules and the planners' stricter working profiles (mm, rad).

Every check of a follow-the-leader crawl in snakeplan, the judge's and every planner's, is one
:class:`~snakeplan.world.validity.ValidityChecker` run under one of these profiles. The planning profiles check a
superset of the judge's crawl depths (their step divides the judge's) with a clearance margin and a fraction of
each bend limit, so a path a planner accepts is a path the judge accepts (``tests/test_validity.py`` checks it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from snakeplan.ftl import ENTRANCE_TOL as ENTRANCE_TOLERANCE_MM  # a path starts this close (mm) to the entrance
from snakeplan.geometry.distance import CONTACT_RESOLUTION_MM

#: The tip within this distance (mm) of a target reaches it: the one reach tolerance of the library.
REACH_TOLERANCE_MM = 10.0
#: Allowance (rad) on bend limits for round-off.
BEND_TOLERANCE_RAD = 1e-9

__all__ = ["BEND_TOLERANCE_RAD", "CONTACT_RESOLUTION_MM", "ENTRANCE_TOLERANCE_MM", "JUDGE", "PLANNING",
           "REACH_TOLERANCE_MM", "ROLLOUT", "Tolerances"]


@dataclass(frozen=True)
class Tolerances:
    """A crawl-check profile: crawl depths every ``step_mm`` (mm), links as capsules of their radius plus
    ``margin_mm`` (mm), bends allowed up to ``bend_fraction`` of each section's limit."""

    step_mm: float
    margin_mm: float = 0.0
    bend_fraction: float = 1.0

    def __post_init__(self) -> None:
        for name, value, ok in (("step_mm", self.step_mm, lambda v: v > 0.0),
                                ("margin_mm", self.margin_mm, lambda v: v >= 0.0),
                                ("bend_fraction", self.bend_fraction, lambda v: 0.0 < v <= 1.0)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or not ok(value):
                raise ValueError(f"tolerances.{name}: out of range, got {value!r}")


#: The library's rules, shared by every benchmark: crawl every 5 mm, bodies exactly their radius, full bend limits.
JUDGE = Tolerances(step_mm=5.0, margin_mm=0.0, bend_fraction=1.0)
#: What planners accept: the judge's depths with 3 mm of clearance and 95 % of each bend limit to spare.
PLANNING = Tolerances(step_mm=5.0, margin_mm=3.0, bend_fraction=0.95)
#: A learned policy's roll-out, step by step (training and sensing): wider clearance, so that a policy trained to
#: keep it clears obstacles between its coarser checks.
ROLLOUT = Tolerances(step_mm=12.0, margin_mm=8.0, bend_fraction=0.97)
