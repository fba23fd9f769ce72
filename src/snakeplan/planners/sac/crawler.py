"""The crawl a learned policy drives (mm, rad): :class:`Crawler`, the arm following its tip from a scene's entrance
one step per action, the environment core that the planners' roll-outs and :mod:`snakeplan.rl`'s Gymnasium
environments share.

The tip advances ``step_mm`` per action, the body follows the leader; observations are the paper's (tip position;
action = direction of the next step) or ours, ``local`` (tip position, tip frame, ray ranges, previous action,
inserted fraction; action = a heading change bounded so the path never turns tighter than ``turn_radius_mm``: at
the default every step keeps the bend limits; below 207 mm (where section chords bend 50.7 deg) only turns shorter
than a section do, and the crawl check ends the others). A goal within ``SNAP_FACTOR`` steps and inside the
turning bound ends the step on the goal; with goal capture (``capture_steps``) a goal a few steps ahead that an arc
within the turning bound reaches is steered to by pure pursuit. The ``guide`` design follows a route guide
(:mod:`.guide`); a ``residual`` guide policy corrects the pursuit of the guide (:meth:`Crawler.pursuit`).
"""

from __future__ import annotations

import math

import numpy as np

from snakeplan.planners.sac.guide import GUIDE_MARGIN_MM, guide_for
from snakeplan.planners.sac.kernels import Outcome, _follow, _guide_end, _observe, _pursuit_into, _steer
from snakeplan.planners.sac.observation import (
    GOAL_SCALE_MM,
    GUIDE_DIM,
    OBSERVATIONS,
    RAY_EPS_MM,
    RAY_RANGE_MM,
    _guide_into,
    action_dim,
    arm_features,
    heading_frame,
    observation_dim,
    ray_directions,
)
from snakeplan.robots import Chain
from snakeplan.robots.arm_range import turn_radius_for
from snakeplan.scenes import Scene
from snakeplan.scenes.routes.guide import RouteGuide
from snakeplan.world import REACH_TOLERANCE_MM, ROLLOUT, FullView, KnowledgeView, ValidityChecker

#: Tip advance per step (mm).
STEP_MM = 35.0
#: Smallest turning radius (mm) of the local action: 177.5 mm chords on it bend 43 deg (limit 50.7 deg). The
#: oil-tank policy turns down to 130 mm (its file's ``turn_radius_mm``): its targets a cell apart need turns
#: sharper than any arc the bend limits allow over a whole section, which short ones may take.
TURN_RADIUS_MM = 240.0
#: Goal capture (local design): a goal within this many steps that an arc no tighter than the turning radius
#: reaches is steered to by pure pursuit, overriding the action (0 disables it).
CAPTURE_STEPS = 4

_NO_GUIDE = (np.zeros((1, 3)), np.zeros(1), np.zeros(1))
_NO_RANGES = np.zeros(0)


def _length(v: np.ndarray) -> float:
    """Length of a 3-vector (mm): the crawl's per-step arithmetic, without ``np.linalg.norm``'s overhead."""
    return math.sqrt(float(v @ v))


class Crawler:
    """The arm crawling follow-the-leader from a scene's entrance, one tip step per action (mm, rad)."""

    def __init__(self, robot: Chain, mode: str = "local", step_mm: float = STEP_MM,
                 turn_radius_mm: float = TURN_RADIUS_MM, check_body: bool = True, capture_steps: int = CAPTURE_STEPS,
                 lookahead: bool = False, residual: bool = False, arm_conditioned: bool = False):
        if mode not in OBSERVATIONS:
            raise ValueError(f"observation: must be one of {OBSERVATIONS}, got {mode!r}")
        if arm_conditioned and mode == "paper":
            raise ValueError("observation: the paper observation carries no arm features; use local or guide")
        self.mode = mode
        self.step_mm = float(step_mm)
        self.arm_conditioned = arm_conditioned
        self.turn_radius_mm = float(turn_radius_mm)
        self.set_arm(robot)
        self.check_body = check_body
        self.capture_mm = capture_steps * self.step_mm if mode != "paper" else 0.0
        self.lookahead = lookahead and mode != "paper"
        self.residual = residual and mode == "guide"
        self.rays = ray_directions()
        self.code = OBSERVATIONS.index(mode)

    def set_arm(self, robot: Chain) -> None:
        """Crawl ``robot`` from the next :meth:`reset`; an arm-conditioned crawler turns on the arm's own radius
        (:func:`~snakeplan.robots.arm_range.turn_radius_for`) and observes its features
        (:func:`~.observation.arm_features`), any other on the radius it was made with."""
        self.robot = robot
        radius = turn_radius_for(robot) if self.arm_conditioned else self.turn_radius_mm
        self.max_turn = self.step_mm / radius
        self.arm = arm_features(robot) if self.arm_conditioned else _NO_RANGES

    def reset(self, scene: Scene, world: KnowledgeView | None = None, guide: RouteGuide | None = None) -> None:
        """Start at the entrance of ``scene``, heading along the feed direction, sensing through ``world`` (default:
        the whole scene) and, with ``check_body``, checking each step's crawl with the ``ROLLOUT`` profile. The
        ``guide`` design follows ``guide`` (default: :meth:`route_guide` of what ``world`` knows now)."""
        self.scene = scene
        self.world = FullView(scene) if world is None else world
        self.checker = ValidityChecker(self.world, self.robot, ROLLOUT) if self.check_body else None
        self.guide = (guide or self.route_guide(scene, self.world)) if self.mode == "guide" else None
        self._compiled_state()
        self.guide_s = 0.0
        self.tank_scale = float(np.max(scene.bounds_max))
        self.path = [scene.entrance.position.copy()]
        self.heading = scene.entrance.direction.copy()
        self.frame = heading_frame(self.heading)
        self.depth = 0.0
        self.steps = 0
        self.target_index = 0
        self.prev_action = np.zeros(action_dim(self.mode))

    def __setstate__(self, state: dict) -> None:
        """Unpickled (a training checkpoint's environment), with the defaults of attributes added since."""
        state.setdefault("residual", False)
        state.setdefault("guide", None)
        state.setdefault("guide_s", 0.0)
        state.setdefault("code", OBSERVATIONS.index(state["mode"]))
        state.setdefault("arm_conditioned", False)
        state.setdefault("arm", _NO_RANGES)
        state.setdefault("turn_radius_mm", state["step_mm"] / state["max_turn"])
        self.__dict__.update(state)
        if "scene" in state and "targets" not in state:
            self._compiled_state()

    def _compiled_state(self) -> None:
        """The scene's targets and the guide's arrays in the form the compiled crawl kernels take."""
        self.targets = np.array(self.scene.targets, dtype=float).reshape(-1, 3)
        self.guide_arrays = _NO_GUIDE if self.guide is None else (
            np.array(self.guide.points, dtype=float), np.array(self.guide.arc, dtype=float),
            np.array(self.guide.target_arc, dtype=float))

    def route_guide(self, scene: Scene, world: KnowledgeView, deadline: float | None = None,
                    margin_mm: float = GUIDE_MARGIN_MM) -> RouteGuide:
        """The route guide through what ``world`` knows now, kept ``margin_mm`` beyond the arm's radius
        (:class:`~snakeplan.scenes.routes.grid.FieldDeadline` past ``deadline``)."""
        return guide_for(scene, world, float(np.max(self.robot.radii)), deadline, margin_mm)

    @property
    def tip(self) -> np.ndarray:
        return self.path[-1]

    @property
    def goal(self) -> np.ndarray:
        """The next unreached target (mm), or the last one when all are reached."""
        t = self.scene.targets
        return t[min(self.target_index, len(t) - 1)]

    @property
    def done(self) -> bool:
        return self.target_index >= len(self.scene.targets)

    def ranges(self) -> np.ndarray:
        """Distances (mm, capped at ``RAY_RANGE_MM``) to the first surface along each ray from the tip."""
        d = self.world.raycast(self.tip, self.rays @ self.frame, RAY_RANGE_MM, RAY_EPS_MM)
        return np.minimum(d, RAY_RANGE_MM)

    def observation(self) -> dict[str, np.ndarray]:
        """The goal-conditioned observation dict (float32): ``paper``, the tip position scaled by the scene's size;
        else the tip position so scaled, the tip frame, the ray ranges (fractions of ``RAY_RANGE_MM``), the
        previous applied action and the inserted fraction of the arm, then the next target (look-ahead) and the
        route guide's features (``guide``: :func:`_guide_into`) and, arm-conditioned, the arm's
        (:func:`~.observation.arm_features`)."""
        tip = self.tip
        ranges = self.ranges() if self.mode != "paper" else _NO_RANGES
        vec = np.empty(observation_dim(self.mode, self.lookahead, self.arm_conditioned))
        points, arc, target_arc = self.guide_arrays
        _observe(self.code, self.lookahead, tip, self.frame, ranges, self.prev_action,
                 self.depth / self.robot.total_length, self.tank_scale, self.targets, self.target_index, points, arc,
                 self.guide_s, _guide_end(target_arc, self.target_index), self.arm, vec)
        return {"observation": vec.astype(np.float32),
                "achieved_goal": (tip / GOAL_SCALE_MM).astype(np.float32),
                "desired_goal": (self.goal / GOAL_SCALE_MM).astype(np.float32)}

    def _guide_features(self) -> np.ndarray:
        """The guide points ``GUIDE_AHEAD_MM`` ahead of the tip's place on it (never past the current target) and
        the guide's direction at the first, in the tip frame."""
        out = np.empty(GUIDE_DIM)
        points, arc, target_arc = self.guide_arrays
        _guide_into(self.frame, self.tip, points, arc, self.guide_s, _guide_end(target_arc, self.target_index), out)
        return out

    def _failure(self) -> str | None:
        """Why the crawl over the last step is infeasible, or None: with ``check_body`` the validity checker's
        verdict on the step's depths; without (a planning roll-out, whose whole path is checked afterwards) only
        a tip out of the bounds or past the arm's length ends it."""
        if self.check_body:
            last = self.depth - _length(self.path[-1] - self.path[-2])
            failure = self.checker.first_failure(np.array(self.path), last)
            return None if failure is None else failure.kind
        if not bool(self.world.in_bounds(self.tip)):
            return Outcome.OUT_OF_BOUNDS
        return Outcome.INSERTION if self.depth > self.robot.total_length else None

    def pursuit(self) -> np.ndarray:
        """The pursuit of the guide as an action: ``PURSUIT_GAIN`` times the side and up components of the unit
        direction from the tip to the first guide point ahead, clipped to the action box."""
        out = np.empty(GUIDE_DIM)
        points, arc, target_arc = self.guide_arrays
        _pursuit_into(self.frame, self.tip, points, arc, self.guide_s, _guide_end(target_arc, self.target_index),
                      out)
        return out[:2].copy()

    def advance(self, action) -> tuple[str | None, bool]:
        """Apply one action (a residual crawler adds it to :meth:`pursuit`); return (failure or None, whether a
        target was reached by this step). ``prev_action`` becomes the applied action.

        A goal within ``SNAP_FACTOR`` steps inside the turning bound ends the step on it; else, with goal capture,
        a goal an arc within the turning bound reaches is steered to by pure pursuit; else the action turns the
        heading (``paper``: the action is the new heading)."""
        old = self.tip
        a = np.ascontiguousarray(action, dtype=float).reshape(action_dim(self.mode))
        new, turned, applied, feats = np.empty(3), np.empty(3), np.empty(a.shape[0]), np.empty(GUIDE_DIM)
        points, arc, target_arc = self.guide_arrays
        _steer(self.code, self.residual, self.step_mm, self.max_turn, self.capture_mm, old, self.heading,
               self.frame, self.goal, a, points, arc, self.guide_s, _guide_end(target_arc, self.target_index), feats,
               new, turned, applied)
        self.path.append(new)
        self.depth += _length(new - old)
        self.heading = turned
        self.frame = heading_frame(turned)
        self.prev_action = applied
        self.steps += 1
        failure = self._failure()
        reached = failure is None and _length(new - self.goal) <= REACH_TOLERANCE_MM
        if reached:
            self.target_index += 1
        if self.guide is not None:
            self.guide_s = float(_follow(points, arc, target_arc, self.target_index, self.guide_s, self.step_mm, new))
        return failure, reached

    def tip_path(self) -> np.ndarray:
        return np.array(self.path)

