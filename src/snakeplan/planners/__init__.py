"""Planners: the `Problem` / `Plan` / `Planner` interface, a registry by name, and the built-in planners."""

from snakeplan.planners.base import Plan, Planner, Problem, Status
from snakeplan.planners.registry import get_planner, planner_names, register_planner

__all__ = ["Plan", "Planner", "Problem", "Status", "get_planner", "planner_names", "register_planner"]
