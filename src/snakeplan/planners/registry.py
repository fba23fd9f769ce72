"""Planners registered by name: ``get_planner("rrt-star")``.

Built-in planners are lazy ``"module:attr"`` entries (:mod:`snakeplan.registry`): a planner's module, and what it
imports (OMPL, numba kernels, ...), is imported only when that planner is asked for. Plugins add theirs with
``planner.<name>`` entry points; ``@register_planner`` adds a class in code.
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


def register_planner(cls: type[Planner]) -> type[Planner]:
    """Class decorator: register a planner under its ``name`` (a taken name raises ValueError)."""
    if not cls.name:
        raise ValueError(f"{cls.__name__} has no name")
    return PLANNERS.register(cls.name, cls)


def planner_names() -> list[str]:
    return PLANNERS.names()


def get_planner(name: str, **options) -> Planner:
    """A new planner instance; KeyError lists the known names for an unknown one."""
    return PLANNERS.get(name)(**options)


#: The planner per scene used when none is named: the learned planner with its shipped policy where one ships
#: (milliseconds, smoothest paths in Table 2; see README), SSCC in pipes.
DEFAULT_PLANNER_BY_SCENE = {"fuel-tank": "sac-her", "oil-tank": "sac-per", "pipe": "sscc", "concentric-pipe": "sscc"}


def default_planner(scene_name: str) -> str:
    """The planner `snakeplan plan` uses for ``scene_name`` when none is named."""
    return DEFAULT_PLANNER_BY_SCENE.get(scene_name, "as-rrt")
