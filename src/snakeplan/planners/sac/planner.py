"""Learned planners `sac-her`, `sac-per`, `sac` (paper 000): a deterministic roll-out of a trained actor (mm, rad, s).

The planners roll the policy out from the entrance (compiled whole, :func:`rollout`: about a millisecond) until
every target is reached; the smoothest of the roll-out and its Gaussian smoothings (``SMOOTHING_SIGMAS_MM``) that
passes the planning-time crawl check (the ``PLANNING`` profile of :class:`~snakeplan.world.ValidityChecker`) is
planned; when none passes, the policy is rolled out again with seeded action noise, up to ``PLAN_ATTEMPTS`` times
within the budget; the path goes to the judge.

A ``guide`` policy (the generalists) follows the taut route guide first. Its every other retry follows a turning
route instead (:func:`~.guide.turning_guide`): one an arm turning on nearly its full bend limits can follow, where
the taut guide's corners are sharper than the arm turns and its roll-outs swing past them (measured on confined
seeds 0-99 sized to the arm, sensed, the arm-conditioned generalist: the 10 x 220 mm arm 72 -> 86 %, the
16 x 120 mm 89 -> 95 %; README). The first roll-out on each new turning route is noise-free. A residual policy
(the generalists) crawls a turning route by its pursuit alone (:meth:`~.policy.NumpyPolicy.pursuit_only`): the
route is made of the crawl's own steps, while the residual, trained on taut guides, turns early for corners the
route does not have (the 10 x 220 mm arm on eight confined seeds it failed: 17-93 mm mean distance from the route
with the residual, 4-7 mm without).

The planner registry's built-in entries name these classes through the package (``snakeplan.planners.sac:SacPlanner``)
and register them when first asked for; ``@register_planner`` here would clash with those entries, which name the
package, not this module.
"""

from __future__ import annotations

import math
import time
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

from snakeplan.evaluation.metrics import path_smoothness
from snakeplan.geometry import polyline
from snakeplan.planners.base import Planner, Problem, Solution, Status
from snakeplan.planners.sac.guide import (
    GUIDE_MARGIN_MAX_MM,
    GUIDE_MARGIN_MM,
    GUIDE_MARGIN_STEP_MM,
    guide_space,
    turning_crawl_radius,
    turning_guide,
    warm_up_turning,
)
from snakeplan.planners.sac.kernels import ROLL_OUTCOMES, Outcome, _roll
from snakeplan.planners.sac.observation import action_dim, route_tables
from snakeplan.planners.sac.policy import (
    ARM_GENERALIST,
    GENERALISTS,
    NumpyPolicy,
    arm_refusal,
    check_policy_fits,
    generalist_path,
    load_policy,
    shipped_policy,
)
from snakeplan.robots import Chain
from snakeplan.scenes import Scene, SceneSpec, spec_for
from snakeplan.scenes.routes.grid import FieldDeadline
from snakeplan.scenes.routes.guide import RouteGuide, route_through
from snakeplan.world import PLANNING, FullView, KnowledgeView, ValidityChecker

#: Roll-outs a planner may try: the deterministic one, then ones with Gaussian action noise whose std cycles
#: through ``RETRY_LEVELS`` values evenly spaced over ``RETRY_NOISE``.
PLAN_ATTEMPTS = 16
RETRY_NOISE = (0.2, 0.8)
RETRY_LEVELS = 4
#: Gaussian smoothing scales (mm of arc length) tried on a roll-out that reaches every target. The roll-out and
#: its smoothings are ranked by the smoothness index of eq. 20 (curvature at the section length, the planner's
#: own objective, as RRT* ranks by length) and the best that passes the crawl check is planned. The policy
#: steers in ``STEP_MM`` steps with turns of up to its turning radius; spreading a turn over a few sections lowers
#: the peak curvature towards the mean (fuel-tank), while a path whose turns are pinned at targets a cell apart
#: only loses mean curvature by it (oil-tank), so the ranking, not the widest, decides.
SMOOTHING_SIGMAS_MM = (480.0, 320.0, 240.0, 160.0, 120.0, 80.0)


def rollout(policy: NumpyPolicy, scene: Scene, robot: Chain, deadline: float = math.inf,
            max_steps: int | None = None, noise: float = 0.0, rng: np.random.Generator | None = None,
            world: KnowledgeView | None = None, guide: RouteGuide | None = None,
            turn_radius_mm: float | None = None) -> tuple[np.ndarray, Outcome]:
    """Roll the policy out in ``scene``: (tip path, :class:`~.kernels.Outcome`), every target reached, a failure
    (out of bounds, insertion), out of steps, or timeout (``deadline``, a perf_counter value, passed before it
    began). The crawl of :meth:`NumpyPolicy.crawler` without its body check (planning: the path is checked
    afterwards), compiled whole (:func:`_roll`). Deterministic unless ``noise`` (std of Gaussian action noise
    from ``rng``, one draw per step taken, as a step-by-step loop would draw it). The crawler senses through ``world``
    (default: the whole scene) and, in the ``guide`` design, follows ``guide`` (default: the route guide of what
    ``world`` knows). The crawl turns no tighter than ``turn_radius_mm`` (mm) when given, else as the policy was
    trained."""
    crawler = policy.crawler(robot, check_body=False)
    if turn_radius_mm is not None:
        crawler.max_turn = crawler.step_mm / turn_radius_mm
    world = FullView(scene) if world is None else world
    crawler.reset(scene, world, guide)
    if time.perf_counter() > deadline:
        return crawler.tip_path(), Outcome.TIMEOUT
    limit = max_steps or math.ceil(robot.total_length / crawler.step_mm) + 1
    adim = action_dim(policy.mode)
    if noise > 0.0:
        start = rng.bit_generator.state
        shake = noise * rng.standard_normal((limit, adim))
    else:
        shake = np.zeros((limit, adim))
    path = np.empty((limit + 1, 3))
    path[0] = scene.entrance.position
    sensor = world.sensor()
    count, outcome = _roll(crawler.code, crawler.lookahead, crawler.residual, crawler.step_mm, crawler.max_turn,
                           crawler.capture_mm, crawler.tank_scale, float(robot.total_length),
                           np.array(scene.bounds_min, dtype=float), np.array(scene.bounds_max, dtype=float),
                           crawler.targets, np.array(scene.entrance.direction, dtype=float), crawler.rays,
                           *crawler.guide_arrays, policy.graph is not None, *route_tables(policy.graph),
                           policy.weights, policy.biases, policy.shapes, crawler.arm,
                           *sensor, shake, path)
    if noise > 0.0:  # leave ``rng`` where drawing each step's noise as it is taken would (the same plans)
        rng.bit_generator.state = start
        rng.standard_normal((count - 1, adim))
    return path[:count].copy(), ROLL_OUTCOMES[outcome]


def _generalist(name: str) -> NumpyPolicy:
    """The shipped generalist called ``name`` (:data:`GENERALISTS`); ValueError when it is not installed."""
    path = generalist_path(GENERALISTS[name])
    if path is None:
        raise ValueError(f"policy: the {name} policy is not installed ({GENERALISTS[name][1].removeprefix('rl/')})")
    return load_policy(path)


class ArmGeneralistWarning(UserWarning):
    """A learned planner plans an arm with the arm-conditioned generalist: no policy it would use was trained for
    the arm."""


class SacPlanner(Planner):
    """`sac`: a plain-SAC policy rolled out deterministically; ``policy=`` a file (``"generalist"``: the shipped
    generalist), else the one that ships for the scene (:func:`shipped_policy`). A roll-out that reaches every
    target is planned as the smoothest of itself and its ``smoothing`` scales (:data:`SMOOTHING_SIGMAS_MM`) that
    passes the planning-time crawl check (the ``PLANNING`` profile of
    :class:`~snakeplan.world.ValidityChecker`); when none passes, it is rolled out again with seeded action noise,
    up to ``attempts`` roll-outs within the budget; when none passes, the plan is ``approximate``: the reaching
    roll-out whose crawl failed deepest, else the first roll-out. It plans with ``knowledge="sensed"`` too: its
    rays and every crawl check then see only what the tip sensor has revealed along its roll-outs
    (``problem.world``), so a retry re-plans within what has been sensed; a ``guide`` policy's route guide is
    made again from what has been sensed when a retry knows more than the last guide did, and with ``turning``
    (the default) its odd-numbered retries follow the turning route of what is known (see the module), crawling on
    :func:`~.guide.turning_crawl_radius` or the policy's own radius, the tighter (a residual policy by its pursuit
    alone). A found plan's details name the ``route`` it followed."""

    name = "sac"
    needs_full_scene = False
    takes_policy = True

    def __init__(self, policy: str | Path | NumpyPolicy | None = None, attempts: int = PLAN_ATTEMPTS,
                 retry_noise: tuple[float, float] = RETRY_NOISE,
                 smoothing: tuple[float, ...] = SMOOTHING_SIGMAS_MM, turning: bool = True):
        self.policy = policy
        self.turning = bool(turning)
        self.attempts = int(attempts)
        self.smoothing = tuple(float(s) for s in smoothing)
        self.noise_levels = np.linspace(retry_noise[0], retry_noise[1], RETRY_LEVELS)

    def _choice(self, spec: SceneSpec, robot: Chain) -> tuple[Path | None, bool]:
        """The file of the policy to plan ``robot`` with in ``spec``'s family: the one given (a file,
        ``"generalist"``, ``"generalist-arms"``), else the one that ships for the family (:func:`shipped_policy`),
        else, when that one was trained for another arm, the arm-conditioned generalist's; and whether it is the
        latter standing in. None when none is given and none ships."""
        if self.policy in GENERALISTS:
            return generalist_path(GENERALISTS[self.policy]), False
        path = Path(self.policy) if self.policy else shipped_policy(spec, self.name)
        if self.policy or path is None or arm_refusal(load_policy(path), robot) is None \
                or generalist_path(ARM_GENERALIST) is None:
            return path, False
        return generalist_path(ARM_GENERALIST), True

    def policy_file(self, spec: SceneSpec, robot: Chain) -> Path | None:
        """The file this planner reads its policy from to plan ``robot`` in ``spec``'s family (None for a policy
        given as an object, or when none ships, named generalists included)."""
        return None if isinstance(self.policy, NumpyPolicy) else self._choice(spec, robot)[0]

    def _policy(self, scene: Scene, robot: Chain) -> tuple[NumpyPolicy, bool]:
        """The policy to plan ``robot`` in ``scene`` with (:meth:`_choice`) and whether it is the arm-conditioned
        generalist standing in for a policy trained for another arm."""
        if isinstance(self.policy, NumpyPolicy):
            return self.policy, False
        if self.policy in GENERALISTS:
            return _generalist(self.policy), False
        path, standing_in = self._choice(spec_for(scene), robot)
        if path is None:
            raise ValueError(f"policy: no {self.name} policy ships for scene family {scene.name}; train one "
                             f"('snakeplan train rl') and pass its policy.npz")
        return load_policy(path), standing_in

    def warm_up(self, problem: Problem) -> None:
        """The validity checker's kernels, the policy, one roll-out step (rays, actor), a smoothing and a crawl
        check, and a guide policy's turning route search, outside the timed plan."""
        super().warm_up(problem)
        policy, _ = self._policy(problem.scene, problem.robot)
        path, _ = rollout(policy, problem.scene, problem.robot, max_steps=2, world=problem.world)
        if policy.mode == "guide" and self.turning:
            crawl = policy.crawler(problem.robot)
            warm_up_turning(crawl.step_mm, crawl.capture_mm)
        if len(path) > 2:
            smoothed = polyline.smooth(path, self.smoothing[0], pins=path[-1:]) if self.smoothing else path
            path_smoothness(smoothed, float(np.mean(problem.robot.lengths)), problem.robot.k_ul)
            ValidityChecker(problem.world, problem.robot, PLANNING).first_failure(smoothed)

    def _smoothest(self, path: np.ndarray, problem: Problem, model: ValidityChecker
                   ) -> tuple[np.ndarray | None, float, float]:
        """The smoothest of ``path`` and its smoothings (targets kept) that passes the crawl check, with its
        smoothing scale (mm; 0 for the roll-out itself); when none passes, (None, 0, depth (mm) at which the
        roll-out's own crawl fails)."""
        step, k_ul = float(np.mean(problem.robot.lengths)), problem.robot.k_ul
        candidates = [(path, 0.0)] + list(zip(polyline.smoothings(path, self.smoothing, pins=problem.goals),
                                              self.smoothing))
        candidates.sort(key=lambda c: -path_smoothness(c[0], step, k_ul))
        raw_failure = 0.0
        for candidate, sigma in candidates:
            if candidate is not path:
                if model.feasible(candidate):
                    return candidate, sigma, 0.0
                continue
            failure = model.first_failure(path)
            if failure is None:
                return path, 0.0, 0.0
            raw_failure = failure.depth_mm
        return None, 0.0, raw_failure

    def _solve(self, problem: Problem, rng: np.random.Generator, deadline: float) -> Solution:
        policy, stands_in = self._policy(problem.scene, problem.robot)
        if stands_in:
            warnings.warn(f"{self.name}: {problem.robot.name} has no policy of its own here; planning with the "
                          f"arm-conditioned generalist", ArmGeneralistWarning, stacklevel=2)
        check_policy_fits(policy, problem.scene, problem.robot)
        model = ValidityChecker(problem.world, problem.robot, PLANNING)
        details = {"policy": policy.meta.get("name", str(self.policy or self.name))
                   + (" (arm-conditioned)" if policy.arm_conditioned else "")}
        best, best_reach, path = None, -1.0, None
        guide, known, margin, routed, widest = None, -1, GUIDE_MARGIN_MM, GUIDE_MARGIN_MM, GUIDE_MARGIN_MAX_MM
        space, radius = None, float(np.max(problem.robot.radii))
        turning: dict[tuple, RouteGuide | None] = {}
        crawl = policy.crawler(problem.robot)  # the policy's own step, turning radius and goal capture
        turning_radius = min(turning_crawl_radius(problem.robot), crawl.step_mm / crawl.max_turn)
        pursuer = None  # on a turning route, a residual policy's crawl pursues it alone (made when first needed)
        ends: Counter[str] = Counter()
        for attempt in range(self.attempts):
            noise = self.noise_levels[(attempt - 1) % RETRY_LEVELS] if attempt else 0.0
            if policy.mode == "guide" and (len(problem.world.obstacle_set) != known or margin != routed):
                known = len(problem.world.obstacle_set)  # re-route on what was sensed, or farther from it
                try:
                    space = guide_space(problem.scene, problem.world, radius, deadline, space)
                except FieldDeadline:
                    details.update(outcome=Outcome.TIMEOUT, attempts=attempt)
                    ends["the time limit ran out while routing the guide"] += 1
                    break
                wider = route_through(space, problem.scene.entrance, problem.scene.targets, radius + margin)
                if guide is None or wider.complete:
                    guide, routed = wider, margin
                else:  # too wide for an opening: keep the last guide, and try no wider
                    margin = widest = routed
            follow, radius_mm, driver = guide, None, policy
            if attempt % 2 and policy.mode == "guide" and self.turning:
                key = (known, routed)
                fresh = key not in turning
                if fresh:  # a turning route on what is known now
                    turning[key] = turning_guide(space, problem.scene, problem.robot, routed, crawl.step_mm,
                                                 crawl.capture_mm, deadline - time.perf_counter())
                if turning[key] is not None:
                    pursuer = pursuer or (policy.pursuit_only() if crawl.residual else policy)
                    follow, radius_mm, driver = turning[key], turning_radius, pursuer
                    noise = 0.0 if fresh else noise
            path, outcome = rollout(driver, problem.scene, problem.robot, deadline, noise=noise, rng=rng,
                                    world=problem.world, guide=follow, turn_radius_mm=radius_mm)
            details.update(outcome=outcome, attempts=attempt + 1, steps=len(path) - 1)
            if outcome != Outcome.REACHED:
                ends[_ENDS[outcome]] += 1
            if outcome == Outcome.TIMEOUT:
                break
            if outcome == Outcome.REACHED:
                chosen, sigma, failure = self._smoothest(path, problem, model)
                if chosen is not None:
                    details["smoothing_sigma_mm"] = sigma
                    if policy.mode == "guide":
                        details["guide_margin_mm"] = routed
                        details["route"] = "taut" if follow is guide else "turning"
                    return Solution(Status.FOUND, chosen, details)
                ends["reached every target, but no smoothing of it crawled"] += 1
                margin = min(margin + GUIDE_MARGIN_STEP_MM, widest)
                if failure > best_reach:
                    best, best_reach = path, failure
            elif best is None:
                best = path
        stopped = Status.TIMEOUT if details["outcome"] == Outcome.TIMEOUT else Status.NO_PROGRESS
        why = (f"{'the time limit ran out' if stopped is Status.TIMEOUT else 'no roll-out found a path'} after "
               f"{details['attempts']} of {self.attempts} roll-outs: "
               + ", ".join(f"{n} {what}" for what, n in ends.items()))
        if turning:
            found = sum(route is not None for route in turning.values())
            why += (f" ({found} of {len(turning)} turning routes found)" if found
                    else "; the search found no turning route the arm can follow (in its budget)")
        best = best if best is not None else path
        if best is None or len(best) < 2:
            return Solution(stopped, None, details, why)
        details["stopped"] = stopped
        return Solution(Status.APPROXIMATE, best, details, why + "; the path given is the one that went farthest")


#: A roll-out's end in words, for a plan's why.
_ENDS = {Outcome.OUT_OF_BOUNDS: "left the bounds", Outcome.INSERTION: "inserted the whole arm",
         Outcome.STEPS: "ran out of steps", Outcome.TIMEOUT: "stopped at the time limit"}


class SacHerPlanner(SacPlanner):
    """`sac-her`: the SAC + hindsight-replay policy (paper 000's multi-obstacle planner)."""

    name = "sac-her"


class SacPerPlanner(SacPlanner):
    """`sac-per`: the SAC + prioritised-replay policy (paper 000's multi-target planner)."""

    name = "sac-per"
