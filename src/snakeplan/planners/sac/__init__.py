"""Learned planners `sac-her`, `sac-per`, `sac` (paper 000): a deterministic roll-out of a trained actor (mm, rad, s).

This package holds everything a roll-out needs, so planning never imports the training stack
(:mod:`snakeplan.rl`, a higher layer, builds its Gymnasium environments on :class:`Crawler`). One concept per
module, lowest first:

- :mod:`.observation`: what the actor sees: the tip frame, the rays, :class:`RoomGraph` (the coarse structure of a
  tank: rooms, holes, fewest-holes routes) and :func:`policy_input`, the actor's input from an observation;
- :mod:`.kernels`: the compiled crawl step, the actor and a whole roll-out (numba), and its :class:`Outcome`;
- :mod:`.guide`: the ``guide`` design's route guide through what a knowledge view knows
  (:func:`guide_for`; the routing itself is :mod:`snakeplan.scenes.routes.guide`);
- :mod:`.crawler`: :class:`Crawler`, the crawl one action at a time (the environment core);
- :mod:`.policy`: :class:`NumpyPolicy` and its file format, checks and cache (:func:`load_policy`), whether a policy
  fits a problem (:func:`check_policy_fits`), which policy ships for a scene family (:func:`shipped_policy`,
  :func:`policy_path`, :func:`generalist_path`);
- :mod:`.planner`: :func:`rollout` and the planners :class:`SacPlanner`, :class:`SacHerPlanner`,
  :class:`SacPerPlanner`, with their retries and smoothings.

The names exported here are the package's public ones, which the planner registry's built-in entries
(``snakeplan.planners.sac:SacPlanner``, ...), the tests and user code import from the package; the library's own
modules import from the concept modules.
"""

from snakeplan.planners.sac.crawler import CAPTURE_STEPS, STEP_MM, TURN_RADIUS_MM, Crawler
from snakeplan.planners.sac.guide import GUIDE_MARGIN_MM, guide_for
from snakeplan.planners.sac.kernels import PURSUIT_GAIN, Outcome
from snakeplan.planners.sac.observation import (
    FEATURE_CLIP,
    FEATURE_SCALE_MM,
    GOAL_SCALE_MM,
    GUIDE_AHEAD_MM,
    RoomGraph,
    action_dim,
    input_dim,
    observation_dim,
    policy_input,
)
from snakeplan.planners.sac.planner import SacHerPlanner, SacPerPlanner, SacPlanner, rollout
from snakeplan.planners.sac.policy import (
    NumpyPolicy,
    PolicyTransferWarning,
    check_policy_fits,
    generalist_path,
    load_policy,
    policy_path,
    shipped_policy,
)

__all__ = ["CAPTURE_STEPS", "FEATURE_CLIP", "FEATURE_SCALE_MM", "GOAL_SCALE_MM", "GUIDE_AHEAD_MM", "GUIDE_MARGIN_MM",
           "PURSUIT_GAIN", "STEP_MM", "TURN_RADIUS_MM", "Crawler", "NumpyPolicy", "Outcome", "PolicyTransferWarning",
           "RoomGraph", "SacHerPlanner", "SacPerPlanner", "SacPlanner", "action_dim", "check_policy_fits",
           "generalist_path", "guide_for", "input_dim", "load_policy", "observation_dim", "policy_input", "policy_path",
           "rollout", "shipped_policy"]
