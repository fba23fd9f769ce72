"""The path optimiser: a found tip path made as smooth and as clear as the space allows, checked by the one
validity checker (:mod:`snakeplan.optimize.optimizer`), from smoothing ladders (:mod:`snakeplan.optimize.fits`).
Every planner reaches it through ``Problem.optimize``."""

from snakeplan.optimize.optimizer import LEVELS, Optimized, as_level, optimize_path, warm_up

__all__ = ["LEVELS", "Optimized", "as_level", "optimize_path", "warm_up"]
