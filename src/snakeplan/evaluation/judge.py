"""The one judge of every plan: feasibility of the follow-the-leader crawl and the path's quality metrics.

A plan is a tip path that starts at the scene's entrance. The judge crawls the arm along it (follow-the-leader,
:mod:`snakeplan.ftl`) and checks, at every crawl step, that the body (links as capsules) touches no obstacle,
that every bend stays within its section's limit, and that the arm is long enough; it checks that the tip path
stays inside the scene's bounds and passes the targets in order. Planners never judge themselves.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from enum import StrEnum

import numpy as np

from snakeplan.evaluation.metrics import curvature_profile, path_length, smoothness_index
from snakeplan.evaluation.statics import CrawlStatics, crawl_statics
from snakeplan.geometry.polyline import validate_path
from snakeplan.robots import Chain
from snakeplan.scenes import Scene
from snakeplan.world import (
    ENTRANCE_TOLERANCE_MM,
    JUDGE,
    REACH_TOLERANCE_MM,
    FullView,
    Tolerances,
    ValidityChecker,
    targets_reached,
)

#: Arc-length step (mm) between judged crawl configurations.
CRAWL_STEP_MM = JUDGE.step_mm


class Reason(StrEnum):
    """The judge's verdict (:attr:`Report.reason`): the kind of the first failure in depth (a
    :class:`~snakeplan.world.FailureKind`), else ``not_holdable`` where the settings require every depth holdable
    by non-negative cable tensions and one is not, else ``reached`` when every target was reached, else
    ``not_reached``. A ``str`` so that JSON and printed output hold the plain value, and it compares equal to it."""

    REACHED = "reached"
    COLLISION = "collision"
    BEND_LIMIT = "bend_limit"
    INSERTION = "insertion"
    OUT_OF_BOUNDS = "out_of_bounds"
    NOT_REACHED = "not_reached"
    NOT_HOLDABLE = "not_holdable"


@dataclass(frozen=True)
class JudgeSettings:
    """How strictly to judge; the defaults are the library's rules, shared by every benchmark."""

    reach_tolerance_mm: float = REACH_TOLERANCE_MM
    crawl_step_mm: float = CRAWL_STEP_MM
    curvature_step_mm: float | None = None  # None: the robot's mean section length (docs/ARCHITECTURE.md)
    #: Whether a depth that no non-negative cable tensions hold (force closure lost) fails the plan. Off in the
    #: library's rules: the papers judge geometry, and the tensions are reported beside it.
    require_holdable: bool = False


@dataclass
class Report:
    """The judge's verdict on one tip path; ``metrics()`` is the ``snakeplan.plan/1`` metrics block."""

    success: bool
    reason: Reason
    reached: bool
    targets_reached: int
    collision_free: bool
    bend_limits_ok: bool
    insertion_ok: bool
    in_bounds: bool
    path_length_mm: float
    max_curvature_per_mm: float
    mean_curvature_per_mm: float
    smoothness_index: float
    min_clearance_mm: float
    max_deviation_mm: float
    mean_deviation_mm: float
    max_bend_rad: float
    first_failure_depth_mm: float | None
    crawl_steps: int
    curvature_s: np.ndarray = field(repr=False)
    curvature: np.ndarray = field(repr=False)
    #: The body at the last judged depth: joints ``(n+1, 3)`` (mm), base first.
    body_mm: np.ndarray = field(repr=False)
    #: Statics (None for a robot without masses, cables or feed): the largest least cable tension over the crawl
    #: (N), its depth (mm) and the section whose cable carries it; whether every depth is holdable, and the first
    #: that is not.
    peak_tension_n: float | None = None
    peak_tension_depth_mm: float | None = None
    peak_tension_section: int | None = None
    holdable: bool | None = None
    first_unholdable_depth_mm: float | None = None
    #: Every crawl state's tensions (:class:`~snakeplan.evaluation.statics.CrawlStatics`), or None.
    statics: CrawlStatics | None = field(default=None, repr=False)

    def lines(self) -> list[str]:
        """The verdict and the metrics as console lines, one per metric."""
        lines = [f"verdict: {'feasible' if self.success else 'infeasible'} ({self.reason})"]
        for key, value in self.metrics().items():
            lines.append(f"  {key:24s} {value:.6g}" if isinstance(value, float) else f"  {key:24s} {value}")
        return lines

    def metrics(self) -> dict:
        """JSON-ready metrics (finite floats, or None where undefined)."""
        skip = ("curvature_s", "curvature", "body_mm", "success", "reason", "statics")
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in skip}
        for k, v in out.items():
            if isinstance(v, float) and not np.isfinite(v):
                out[k] = None
        return out


def evaluate(scene: Scene, robot: Chain, path, settings: JudgeSettings = JudgeSettings()) -> Report:
    """Judge tip ``path (m, 3)`` (mm) for ``robot`` in ``scene``; ValueError for a malformed path."""
    p = validate_path(path)
    gap = float(np.linalg.norm(p[0] - scene.entrance.position))
    if gap > ENTRANCE_TOLERANCE_MM:
        raise ValueError(f"path: must start at the entrance {scene.entrance.position.tolist()}, starts {gap:.3g} mm away")
    h = settings.curvature_step_mm or float(np.mean(robot.lengths))
    checker = ValidityChecker(FullView(scene), robot, Tolerances(settings.crawl_step_mm))
    check = checker.crawl(p)
    states = check.states
    reached_count = targets_reached(p, scene.targets, settings.reach_tolerance_mm)
    reached = reached_count == len(scene.targets)
    failure = check.failure
    held = crawl_statics(scene, robot, states)
    unholdable = None if held is None else held.first_unholdable_mm
    if failure is not None:
        reason = Reason(failure.kind)
    elif settings.require_holdable and unholdable is not None:
        reason = Reason.NOT_HOLDABLE
    else:
        reason = Reason.REACHED if reached else Reason.NOT_REACHED
    peak = (None, None, None, None) if held is None else held.peak

    s_k, kappa = curvature_profile(p, h)
    k_max = float(kappa.max()) if kappa.size else 0.0
    k_mean = float(kappa.mean()) if kappa.size else 0.0
    inserted = states.joint_arclength[:, 1:] > 0.0  # links whose tip end is past the entrance
    deviation = states.deviation[inserted] if inserted.any() else np.zeros(1)
    return Report(
        success=reason is Reason.REACHED,
        reason=reason,
        reached=reached,
        targets_reached=reached_count,
        collision_free=not bool(check.collides.any()),
        bend_limits_ok=not bool(check.bend_bad.any()),
        insertion_ok=not bool(check.insertion_bad.any()),
        in_bounds=check.in_bounds,
        path_length_mm=path_length(p),
        max_curvature_per_mm=k_max,
        mean_curvature_per_mm=k_mean,
        smoothness_index=smoothness_index(k_max, k_mean, robot.k_ul),
        min_clearance_mm=check.min_clearance,
        max_deviation_mm=float(deviation.max()),
        mean_deviation_mm=float(deviation.mean()),
        max_bend_rad=float(states.bend_angles.max()),
        first_failure_depth_mm=failure.depth_mm if failure is not None else None,
        crawl_steps=len(states),
        peak_tension_n=peak[0],
        peak_tension_depth_mm=peak[1],
        peak_tension_section=peak[2],
        holdable=None if held is None else unholdable is None,
        first_unholdable_depth_mm=unholdable,
        statics=held,
        curvature_s=s_k,
        curvature=kappa,
        body_mm=states.joints[-1],
    )
