"""One entry to the judge for every plan: a reach plan's tip path by the crawl rules, an inspect plan's mission by
the mission rules (:mod:`snakeplan.evaluation.mission`), a search plan's mission by the same rules and when it saw
and reached each target (:mod:`snakeplan.evaluation.search`); nothing else forks on the task."""

from __future__ import annotations

from snakeplan.evaluation.judge import Report, evaluate
from snakeplan.evaluation.mission import MissionReport, evaluate_mission
from snakeplan.evaluation.search import SearchReport, evaluate_search
from snakeplan.robots import Chain
from snakeplan.scenes import Scene, Task, as_task
from snakeplan.world.mission import InspectionSettings, Mission


def judge(scene: Scene, robot: Chain, path, mission: Mission | None = None,
          settings: InspectionSettings | None = None, task: Task | str | None = None
          ) -> Report | MissionReport | SearchReport | None:
    """The judge's report on a plan's ``path`` (a reach plan) or ``mission`` (an inspect plan, or a search plan when
    ``task`` says so; under the task's ``settings``), against the whole scene; None when the plan has neither."""
    if mission is not None and task is not None and as_task(task) is Task.SEARCH:
        return evaluate_search(scene, robot, mission, settings)
    if mission is not None:
        return evaluate_mission(scene, robot, mission, settings)
    return None if path is None else evaluate(scene, robot, path)
