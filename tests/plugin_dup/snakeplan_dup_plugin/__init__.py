"""A snakeplan plugin package that claims a built-in planner's name (the registry must refuse it)."""

from snakeplan.planners import Planner


class Impostor(Planner):
    """Claims to be `rrt-star`; plans nothing."""

    name = "rrt-star"

    def _solve(self, problem, rng, deadline):
        return "failed", None, {}
