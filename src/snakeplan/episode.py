"""Episodes: plan a problem, judge the plan, and say it as a ``snakeplan.plan/1`` document, in one place (and
inspection missions as ``snakeplan.inspection/1``).

The command line, the benchmarks and training validation all run planning through :func:`run_episode`, so a plan
is judged the same way everywhere and its document is written once. A planner never judges itself: the episode
hands the plan to :func:`snakeplan.evaluation.evaluate` with the whole scene, whatever the planner knew.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from snakeplan.evaluation import Report, evaluate
from snakeplan.jsonable import jsonable
from snakeplan.planners import Plan, Planner, Problem, get_planner
from snakeplan.robots import Chain
from snakeplan.scenes import Scene

if TYPE_CHECKING:
    from snakeplan.planners.inspection import InspectionProblem, InspectionResult

PLAN_SCHEMA = "snakeplan.plan/1"
CHECK_SCHEMA = "snakeplan.check/1"
INSPECTION_SCHEMA = "snakeplan.inspection/1"


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


@dataclass(frozen=True)
class Mission:
    """A flown inspection mission: the problem and what the inspection planner made of it."""

    problem: InspectionProblem
    result: InspectionResult

    def to_dict(self) -> dict:
        """The ``snakeplan.inspection/1`` document (docs/ARCHITECTURE.md)."""
        scene = self.problem.scene
        return jsonable({"schema": INSPECTION_SCHEMA, "scene": {"name": scene.name, "seed": scene.seed},
                         "robot": self.problem.robot.name, **self.result.to_dict()})


def run_mission(problem: InspectionProblem, planner: str, seed: int = 0, on_measure=None) -> Mission:
    """Fly the inspection mission ``problem`` with the registered inspection planner ``planner`` from ``seed``;
    ``on_measure(t, pose, map)`` sees the map after each measurement (see ``InspectionPlanner.plan``)."""
    from snakeplan.planners.inspection import get_inspection_planner

    return Mission(problem, get_inspection_planner(planner).plan(problem, seed=seed, on_measure=on_measure))
