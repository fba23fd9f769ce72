"""Planners registered by name: ``get_planner("rrt-star")``.

Built-in planners are lazy ``"module:attr"`` entries (:mod:`snakeplan.registry`): a planner's module, and what it
imports (OMPL, numba kernels, ...), is imported only when that planner is asked for. Plugins add theirs with
``planner.<name>`` entry points; ``@register_planner`` adds a class in code. Which planner a scene uses when none
is named is the scene's spec (:func:`snakeplan.scenes.scene_spec`).
"""

from __future__ import annotations

from snakeplan.optimize import as_level
from snakeplan.planners.base import Planner
from snakeplan.registry import Registry, named_subclass
from snakeplan.scenes import Task, as_task

BUILTIN_PLANNERS = {
    "rrt-star": "snakeplan.planners.rrt_star:RRTStar",
    "sp-rrt": "snakeplan.planners.sp_rrt:SpRRT",
    "as-rrt": "snakeplan.planners.as_rrt:AsRRT",
    "sac": "snakeplan.planners.sac:SacPlanner",
    "sac-her": "snakeplan.planners.sac:SacHerPlanner",
    "sac-per": "snakeplan.planners.sac:SacPerPlanner",
    "sscc": "snakeplan.planners.sscc:SSCCPlanner",
    "informative": "snakeplan.planners.informative:InformativePlanner",
    "coverage": "snakeplan.planners.coverage:CoveragePlanner",
    "random": "snakeplan.planners.random_views:RandomPlanner",
    "iris": "snakeplan.planners.iris:IrisPlanner",
    "explore-reach": "snakeplan.planners.search.explore_reach:ExploreReach",
    "frontier": "snakeplan.planners.search.frontier:Frontier",
}

PLANNERS: Registry[type[Planner]] = Registry("planner", BUILTIN_PLANNERS, load=named_subclass(Planner))


#: Class decorator: register a planner under its ``name`` (a taken name raises ValueError).
register_planner = PLANNERS.register_class


def planner_names(task: Task | str | None = None) -> list[str]:
    """Names of the registered planners, or of those that do ``task`` (which imports each planner's module)."""
    if task is None:
        return PLANNERS.names()
    task = as_task(task)
    return [n for n in PLANNERS.names() if task in PLANNERS.get(n).tasks]


def get_planner(name: str, task: Task | str | None = None, optimize: str | None = None, **options) -> Planner:
    """A new planner instance made with ``options``, its path optimiser at ``optimize`` (every planner takes it:
    :data:`snakeplan.optimize.LEVELS`; None: the planner's ``default_optimize``); KeyError lists the known names
    (of the planners that do ``task``, when given) for an unknown one, ValueError names ``optimize``."""
    if task is not None and name not in PLANNERS:
        known = planner_names(task)
        raise KeyError(f"unknown {as_task(task)} planner {name!r} (known: {', '.join(known)})")
    planner = PLANNERS.get(name)(**options)
    if optimize is not None:
        planner.optimize = as_level(optimize)
    return planner
