"""Episodes: plan a problem, judge the plan, and say it as a ``snakeplan.plan/1`` document, in one place, whatever
the task.

The command line, the benchmarks and training validation all run planning through :func:`run_episode`, so a plan
is judged the same way everywhere and its document is written once. A planner never judges itself: the episode
hands the plan to :func:`snakeplan.evaluation.judge` with the whole scene, whatever the planner knew: a reach
plan's tip path, an inspect plan's mission (the arm's motions and its views).
"""

from __future__ import annotations

from dataclasses import dataclass

from snakeplan.evaluation import MissionReport, Report, SearchReport, judge
from snakeplan.jsonable import jsonable
from snakeplan.planners import Plan, Planner, Problem, get_planner
from snakeplan.robots import Chain
from snakeplan.scenes import Scene, Task

PLAN_SCHEMA = "snakeplan.plan/1"
CHECK_SCHEMA = "snakeplan.check/1"
#: An inspect plan's document keeps the name of the inspection documents before plan/1 held missions: the plan/1
#: fields, the mission, and inspection/1's own top-level fields (docs/ARCHITECTURE.md).
INSPECTION_SCHEMA = "snakeplan.inspection/1"
SCHEMAS = {Task.REACH: PLAN_SCHEMA, Task.INSPECT: INSPECTION_SCHEMA, Task.SEARCH: PLAN_SCHEMA}


@dataclass(frozen=True)
class Episode:
    """A planned and judged problem: the plan, and the judge's report on its path or mission (None without one)."""

    problem: Problem
    plan: Plan
    report: Report | MissionReport | SearchReport | None

    @property
    def success(self) -> bool:
        """The judge's verdict: the plan's path is feasible and reaches every target, or its mission's every motion
        is valid and every view is on the arm."""
        return self.report is not None and self.report.success

    @property
    def reason(self) -> str:
        """The judge's reason, or the plan's status when there is no path to judge."""
        return self.report.reason if self.report is not None else str(self.plan.status)

    def to_dict(self) -> dict:
        """The ``snakeplan.plan/1`` document (docs/ARCHITECTURE.md)."""
        scene, plan = self.problem.scene, self.plan
        doc = {"schema": SCHEMAS[self.problem.task], "task": str(self.problem.task),
               "scene": {"name": scene.name, "seed": scene.seed},
               "robot": self.problem.robot.name, "arm": self.problem.robot.to_dict(), "planner": plan.planner,
               "knowledge": self.problem.knowledge,
               "success": self.success, "reason": self.reason, "status": str(plan.status),
               "why": plan.why,
               "compute_time_s": plan.compute_time_s,
               "path": plan.path.tolist() if plan.path is not None else [],
               "metrics": self.report.metrics() if self.report is not None else None,
               "details": jsonable(plan.details)}
        if plan.mission is not None:
            doc["mission"] = plan.mission.to_dict()
            if self.report is not None and self.problem.task is Task.INSPECT:
                doc.update(self._inspection_fields())
        return jsonable(doc)

    def _inspection_fields(self) -> dict:
        """inspection/1's top-level fields, from the judge's recomputation and the mission's views."""
        m, views, details = self.report.metrics(), self.plan.mission.views, self.plan.details
        return {"path_times_s": details.get("path_times_s", []), "measurement_times_s": m["measurement_times_s"],
                "measurement_poses": views.positions.tolist(), "rmse_k": m["rmse_k"], "trace_k2": m["trace_k2"],
                "final_rmse_k": m["final_rmse_k"], "final_trace_k2": m["final_trace_k2"],
                "compute_cpu_s": details.get("compute_cpu_s"), "plans": details.get("plans")}

    def lines(self) -> list[str]:
        """The judge's verdict as console lines."""
        return self.report.lines() if self.report is not None else []


def run_episode(problem: Problem, planner: Planner | str, seed: int = 0, **options) -> Episode:
    """Plan ``problem`` with ``planner`` (an instance, or a registered name built with ``options``) from ``seed``,
    then judge the plan against the whole scene."""
    if isinstance(planner, str):
        planner = get_planner(planner, **options)
    plan = planner.plan(problem, seed=seed)
    return Episode(problem, plan, judge(problem.scene, problem.robot, plan.path, plan.mission, problem.inspection,
                                        problem.task))


def check_document(scene: Scene, robot: Chain, report: Report) -> dict:
    """The ``snakeplan.check/1`` document: the judge's verdict on a path made elsewhere."""
    return {"schema": CHECK_SCHEMA, "scene": {"name": scene.name, "seed": scene.seed}, "robot": robot.name,
            "success": report.success, "reason": report.reason, "metrics": report.metrics()}
