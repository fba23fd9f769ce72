"""Planners registered by name: ``get_planner("rrt-star")``."""

from __future__ import annotations

from snakeplan.planners.base import Planner

_PLANNERS: dict[str, type[Planner]] = {}


def register_planner(cls: type[Planner]) -> type[Planner]:
    """Class decorator: register a planner under its ``name``."""
    if not cls.name:
        raise ValueError(f"{cls.__name__} has no name")
    if cls.name in _PLANNERS:
        raise ValueError(f"planner {cls.name!r} is registered twice")
    _PLANNERS[cls.name] = cls
    return cls


def planner_names() -> list[str]:
    _load_builtin()
    return sorted(_PLANNERS)


def get_planner(name: str, **options) -> Planner:
    """A new planner instance; KeyError lists the known names for an unknown one."""
    _load_builtin()
    if name not in _PLANNERS:
        raise KeyError(f"unknown planner {name!r} (known: {', '.join(sorted(_PLANNERS))})")
    return _PLANNERS[name](**options)


def _load_builtin() -> None:
    """Import the built-in planners (they register themselves on import)."""
    from snakeplan.planners import as_rrt, rrt_star, sac, sp_rrt, sscc  # noqa: F401


#: The planner per scene used when none is named: the learned planner with its shipped policy where one ships
#: (milliseconds, smoothest paths in Table 2; see README), SSCC in pipes.
DEFAULT_PLANNER_BY_SCENE = {"fuel-tank": "sac-her", "oil-tank": "sac-per", "pipe": "sscc", "concentric-pipe": "sscc"}


def default_planner(scene_name: str) -> str:
    """The planner `snakeplan plan` uses for ``scene_name`` when none is named."""
    return DEFAULT_PLANNER_BY_SCENE.get(scene_name, "as-rrt")
