"""Episodes: plan a problem, judge the plan, and say it as a ``snakeplan.plan/1`` document, in one place.

The command line, the benchmarks and training validation all run planning through :func:`run_episode`, so a plan
is judged the same way everywhere and its document is written once. A planner never judges itself: the episode
hands the plan to :func:`snakeplan.evaluation.evaluate` with the whole scene, whatever the planner knew.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from snakeplan.evaluation import Report, evaluate
from snakeplan.planners import Plan, Planner, Problem, get_planner
from snakeplan.robots import Chain
from snakeplan.scenes import Scene

PLAN_SCHEMA = "snakeplan.plan/1"
CHECK_SCHEMA = "snakeplan.check/1"


def jsonable(obj: Any) -> Any:
    """Plain JSON of planner details and results: arrays to lists, non-finite floats to None."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


@dataclass(frozen=True)
class Episode:
    """A planned and judged problem: the plan, and the judge's report on its path (None without a path)."""

    problem: Problem
    plan: Plan
    report: Report | None

    @property
    def success(self) -> bool:
        """The judge's verdict: the plan's path is feasible and reaches every target."""
        return self.report is not None and self.report.success

    @property
    def reason(self) -> str:
        """The judge's reason, or the plan's status when there is no path to judge."""
        return self.report.reason if self.report is not None else str(self.plan.status)

    def to_dict(self) -> dict:
        """The ``snakeplan.plan/1`` document (docs/ARCHITECTURE.md)."""
        scene, plan = self.problem.scene, self.plan
        return {"schema": PLAN_SCHEMA, "scene": {"name": scene.name, "seed": scene.seed},
                "robot": self.problem.robot.name, "planner": plan.planner, "knowledge": self.problem.knowledge,
                "success": self.success, "reason": self.reason, "status": str(plan.status),
                "compute_time_s": plan.compute_time_s,
                "path": plan.path.tolist() if plan.path is not None else [],
                "metrics": self.report.metrics() if self.report is not None else None,
                "details": jsonable(plan.details)}


def run_episode(problem: Problem, planner: Planner | str, seed: int = 0, **options) -> Episode:
    """Plan ``problem`` with ``planner`` (an instance, or a registered name built with ``options``) from ``seed``,
    then judge the path against the whole scene."""
    if isinstance(planner, str):
        planner = get_planner(planner, **options)
    plan = planner.plan(problem, seed=seed)
    report = evaluate(problem.scene, problem.robot, plan.path) if plan.path is not None else None
    return Episode(problem, plan, report)


def check_document(scene: Scene, robot: Chain, report: Report) -> dict:
    """The ``snakeplan.check/1`` document: the judge's verdict on a path made elsewhere."""
    return {"schema": CHECK_SCHEMA, "scene": {"name": scene.name, "seed": scene.seed}, "robot": robot.name,
            "success": report.success, "reason": report.reason, "metrics": report.metrics()}
