"""Planners: the `Problem` / `Plan` / `Planner` interface, a registry by name, the built-in planners, and the
conformance suite `check_planner` that checks a planner against the interface's contract."""

from snakeplan.planners.base import Plan, Planner, Problem, Solution, Status
from snakeplan.planners.conformance import ConformanceError, check_planner
from snakeplan.planners.registry import get_planner, planner_names, register_planner

__all__ = ["ConformanceError", "Plan", "Planner", "Problem", "Solution", "Status", "check_planner", "get_planner",
           "planner_names", "register_planner"]
