"""Planners registered by name: ``get_planner("rrt-star")``.

Built-in planners are lazy ``"module:attr"`` entries (:mod:`snakeplan.registry`): a planner's module, and what it
imports (OMPL, numba kernels, ...), is imported only when that planner is asked for. Plugins add theirs with
``planner.<name>`` entry points; ``@register_planner`` adds a class in code. Which planner a scene uses when none
is named is the scene's spec (:func:`snakeplan.scenes.scene_spec`).
"""

from __future__ import annotations

from snakeplan.planners.base import Planner
from snakeplan.registry import Registry, named_subclass

BUILTIN_PLANNERS = {
    "rrt-star": "snakeplan.planners.rrt_star:RRTStar",
    "sp-rrt": "snakeplan.planners.sp_rrt:SpRRT",
    "as-rrt": "snakeplan.planners.as_rrt:AsRRT",
    "sac": "snakeplan.planners.sac:SacPlanner",
    "sac-her": "snakeplan.planners.sac:SacHerPlanner",
    "sac-per": "snakeplan.planners.sac:SacPerPlanner",
    "sscc": "snakeplan.planners.sscc:SSCCPlanner",
}

PLANNERS: Registry[type[Planner]] = Registry("planner", BUILTIN_PLANNERS, load=named_subclass(Planner))


#: Class decorator: register a planner under its ``name`` (a taken name raises ValueError).
register_planner = PLANNERS.register_class


def planner_names() -> list[str]:
    return PLANNERS.names()


def get_planner(name: str, **options) -> Planner:
    """A new planner instance; KeyError lists the known names for an unknown one."""
    return PLANNERS.get(name)(**options)
