"""Gymnasium environments for learning follow-the-leader paths: ``snakeplan/FuelTank-v0``, ``snakeplan/OilTank-v0``.

A Gymnasium face on :class:`snakeplan.planners.sac.Crawler` (the same crawl the planners roll out): the tip
moves one step per action and the body follows the leader. Each episode is a seeded scene (entrance, clutter and
targets drawn by the scene generator, paper 000 §4.1); targets are visited in order. An episode terminates when
every target is reached, on a collision of the body, a bend beyond a limit, the tip leaving the bounds, or an
insertion beyond the arm; it is truncated after ``max_steps`` (H = 1000).

Observations are goal-conditioned dicts (``observation``, ``achieved_goal`` = tip position, ``desired_goal`` =
current target, both in mm / ``GOAL_SCALE_MM``) so SB3's HER can relabel them. ``observation="paper"``: tip
position, action = direction of the next step (a careless one breaks a bend limit). ``observation="local"``
(default): tip position, tip frame, ray ranges, previous action, inserted fraction (``lookahead``: and the target
after the current one); action = a bounded heading change. The reward is eqs. 4-8 (:mod:`snakeplan.rl.rewards`).

Scene seeds: training draws from ``TRAIN_SCENES`` seeds from ``TRAIN_SEED``; periodic evaluation uses seeds
from ``VALIDATION_SEED``; seeds below that (the test episodes are seeds 0-99) are never trained on.
"""

from __future__ import annotations

import copy
from functools import lru_cache
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from snakeplan.planners.sac.crawler import CAPTURE_STEPS, STEP_MM, TURN_RADIUS_MM, Crawler
from snakeplan.planners.sac.guide import guide_for
from snakeplan.planners.sac.observation import GOAL_SCALE_MM, action_dim, observation_dim
from snakeplan.rl.rewards import (
    GUIDE_WEIGHT,
    collide_reward,
    compute_reward,
    global_reward,
    guide_reward,
    in_view,
    local_reward,
)
from snakeplan.robots import Chain, get_robot
from snakeplan.robots.arm_range import sample_arm
from snakeplan.scenes import Scene
from snakeplan.scenes.prefetch import made_ahead
from snakeplan.scenes.routes.guide import RouteGuide
from snakeplan.scenes.sizing import arm_sizing, scene_sizing, sized_scene
from snakeplan.world import KnowledgeView, view_for

#: Truncation horizon H (steps), paper 000 §4.1.
MAX_STEPS = 1000
TRAIN_SEED = 1_000_000
VALIDATION_SEED = 500_000
#: Distinct training scenes an environment draws from (each generated once, then kept).
TRAIN_SCENES = 1000
#: Largest number of scenes (and of route guides) kept per process.
SCENE_CACHE = 4096
#: Bound of the observation boxes (every component is scaled well inside it).
OBS_BOUND = 10.0


class SnakeEnv(gym.Env):
    """A snake arm crawling from a scene's entrance through its targets (mm, rad).

    ``scene``: a scene family name, several joined by ``+`` (seed s draws from the (s mod n)-th), episodes drawing
    seeded scenes from ``seeds`` (a half-open range), or one fixed :class:`Scene`. ``reset(options={"scene_seed":
    s})`` or ``{"scene": Scene}`` picks an episode's scene. ``knowledge``: what the crawler's rays and route guide
    know (``"sensed"``: the prior obstacles and what the tip has sensed, a fresh view each episode); the reward's
    line of sight to the target is the environment's, from the whole scene. ``arm_conditioned``: each generated
    scene's episode crawls the arm its seed draws from the distribution of arms (:meth:`arm_of`), in the scene
    sized to it, observing the arm's features; ``robot`` crawls the caller's scenes.
    """

    metadata: ClassVar[dict] = {"render_modes": []}

    def __init__(self, scene: str | Scene = "fuel-tank", observation: str = "local",
                 robot: str | Chain = "sjtu-snake-iii", step_mm: float = STEP_MM,
                 turn_radius_mm: float = TURN_RADIUS_MM, max_steps: int = MAX_STEPS,
                 seeds: tuple[int, int] = (TRAIN_SEED, TRAIN_SEED + TRAIN_SCENES), capture_steps: int = CAPTURE_STEPS,
                 lookahead: bool = False, knowledge: str = "full", residual: bool = False,
                 guide_weight: float = GUIDE_WEIGHT, arm_conditioned: bool = False):
        self.family = scene if isinstance(scene, str) else scene.name
        self.families = families(self.family)
        self.fixed_scene = None if isinstance(scene, str) else scene
        self.knowledge = knowledge
        self.guide_weight = float(guide_weight)
        self._own_guide: tuple[Scene, RouteGuide] | None = None
        self.robot = get_robot(robot) if isinstance(robot, str) else robot
        self.arm_conditioned = arm_conditioned
        self.crawler = Crawler(self.robot, observation, step_mm, turn_radius_mm, capture_steps=capture_steps,
                               lookahead=lookahead, residual=residual, arm_conditioned=arm_conditioned)
        self.mode = observation
        self.max_steps = int(max_steps)
        self.seed_range = (int(seeds[0]), int(seeds[1]))
        self.action_space = spaces.Box(-1.0, 1.0, (action_dim(observation),), np.float32)
        goal_box = spaces.Box(-OBS_BOUND, OBS_BOUND, (3,), np.float32)
        self.observation_space = spaces.Dict({
            "observation": spaces.Box(-OBS_BOUND, OBS_BOUND,
                                      (observation_dim(observation, lookahead, arm_conditioned),), np.float32),
            "achieved_goal": goal_box,
            "desired_goal": goal_box,
        })
        self.scene = self.fixed_scene or self.scene_for(self.seed_range[0])
        self._start(self.fixed_scene is None)
        self.outcome = "running"

    def __setstate__(self, state: dict) -> None:
        """Unpickled (a training checkpoint), with the defaults of attributes added since it was written."""
        state.setdefault("families", families(state["family"]))
        state.setdefault("knowledge", "full")
        state.setdefault("guide_weight", GUIDE_WEIGHT)
        state.setdefault("_own_guide", None)
        state.setdefault("arm_conditioned", False)
        state.pop("_cache", None)
        self.__dict__.update(state)

    def arm_of(self, seed: int) -> Chain:
        """The arm an episode in the scene of ``seed`` crawls: the environment's, or, arm-conditioned, the seed's
        arm of the distribution (:func:`distribution_arm`)."""
        return distribution_arm(seed) if self.arm_conditioned else self.robot

    def scene_for(self, seed: int) -> Scene:
        """The scene for ``seed`` of its family sized to its arm (generated once per process: see
        :func:`scene_of`)."""
        return scene_of(self.family, seed, self.arm_of(seed))

    def _start(self, generated: bool) -> None:
        """Put the crawler at the scene's entrance with a fresh view (and, for the guide design, the scene's
        route guide: for a ``generated`` scene, one of the family's by seed, made once per process, see
        :func:`scene_guide`)."""
        world: KnowledgeView = view_for(self.scene, self.knowledge)
        arm = self.arm_of(self.scene.seed) if generated else self.robot
        self.crawler.set_arm(arm)
        guide = None
        if self.crawler.mode == "guide" and generated:
            guide = scene_guide(self.scene.name, self.scene.seed, self.knowledge, float(np.max(arm.radii)),
                                scene_sizing(self.scene))
        elif self.crawler.mode == "guide":  # a scene of the caller's: its guide made once while it is reused
            if self._own_guide is None or self._own_guide[0] is not self.scene:
                self._own_guide = (self.scene, self.crawler.route_guide(self.scene, world))
            guide = self._own_guide[1]
        self.crawler.reset(self.scene, world, guide)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        options = options or {}
        generated = "scene" not in options and ("scene_seed" in options or self.fixed_scene is None)
        if "scene" in options:
            self.scene = options["scene"]
        elif "scene_seed" in options:
            self.scene = self.scene_for(int(options["scene_seed"]))
        elif self.fixed_scene is not None:
            self.scene = self.fixed_scene
        else:
            self.scene = self.scene_for(int(self.np_random.integers(*self.seed_range)))
        self._start(generated)
        self.outcome = "running"
        return self.crawler.observation(), {"scene_seed": self.scene.seed}

    def step(self, action):
        c = self.crawler
        a = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        old_heading, prev_action, goal, guide_s = c.heading, c.prev_action, c.goal.copy(), c.guide_s
        failure, _ = c.advance(a)
        a = c.prev_action  # the applied action (a residual crawler's pursuit plus the policy's)
        tip, heading = c.tip, c.heading
        visible = bool(in_view(tip, heading, goal)) and bool(self.scene.line_of_sight(tip, goal))
        shaping = (local_reward(a, prev_action) + global_reward(old_heading, heading)
                   + collide_reward(failure is not None and failure != "insertion"))
        if c.guide is not None:
            shaping += guide_reward(c.guide_s - guide_s, c.step_mm, self.guide_weight)
        info = {"heading": heading.copy(), "goal": goal / GOAL_SCALE_MM, "visible": visible, "shaping": shaping}
        reward = float(compute_reward(tip / GOAL_SCALE_MM, goal / GOAL_SCALE_MM, info))
        terminated = failure is not None or c.done
        truncated = not terminated and c.steps >= self.max_steps
        self.outcome = failure or ("reached" if c.done else ("truncated" if truncated else "running"))
        info.update({"is_success": c.done and failure is None, "targets_reached": c.target_index,
                     "outcome": self.outcome})
        return c.observation(), reward, terminated, truncated, info

    def compute_reward(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """Eq. 4 for a batch (HER): see :func:`snakeplan.rl.rewards.compute_reward`."""
        return compute_reward(achieved_goal, desired_goal, info)

    def tip_path(self) -> np.ndarray:
        """The tip path so far ``(m, 3)`` mm, starting at the entrance."""
        return self.crawler.tip_path()


def families(scene: str) -> tuple[str, ...]:
    """The scene families a training run draws from: ``scene``, or several joined by ``+``."""
    return tuple(scene.split("+"))


def family_of(scene: str, seed: int) -> str:
    """The family of ``scene``'s families that ``seed`` draws from: the (seed mod n)-th."""
    names = families(scene)
    return names[seed % len(names)]


def scene_of(scene: str, seed: int, robot: Chain | None = None) -> Scene:
    """The scene of ``seed`` in ``scene``'s families (:func:`family_of`, :func:`family_scene`), sized to ``robot``
    (:mod:`snakeplan.scenes.sizing`; None: the family's own arm)."""
    family = family_of(scene, seed)
    return family_scene(family, int(seed), arm_sizing(family, robot))


def upcoming(envs, draws: int) -> list[int]:
    """The scene seeds of the next ``draws`` episodes of each of ``envs``, in the order of their first draw (the
    environments step together), each once. Each environment draws its episodes' seeds from its own generator
    (:meth:`SnakeEnv.reset`), so copies of the generators draw the same seeds; the environments' own are not
    touched."""
    gens = [copy.deepcopy(env.np_random) for env in envs]
    seeds: dict[int, None] = {}
    for _ in range(draws):
        for env, gen in zip(envs, gens):
            seeds.setdefault(int(gen.integers(*env.seed_range)), None)
    return list(seeds)


@lru_cache(maxsize=SCENE_CACHE)
def distribution_arm(seed: int) -> Chain:
    """The arm of scene seed ``seed`` in arm-conditioned training and validation: the seed's arm of the
    distribution (:func:`snakeplan.robots.arm_range.sample_arm`), made once per process."""
    return sample_arm(seed)


@lru_cache(maxsize=SCENE_CACHE)
def family_scene(family: str, seed: int, params: tuple = ()) -> Scene:
    """A family's scene for ``seed`` with sizing ``params`` (:func:`snakeplan.scenes.sizing.sized_scene`),
    generated once per process and shared by every environment in it (a vector of environments meets the same
    training scenes); made ahead by a worker while a training run prefetches (:mod:`snakeplan.scenes.prefetch`)."""
    scene = made_ahead(family, seed, params)
    return sized_scene(family, seed, params) if scene is None else scene


@lru_cache(maxsize=SCENE_CACHE)
def scene_guide(family: str, seed: int, knowledge: str, radius_mm: float, params: tuple = ()) -> RouteGuide:
    """The route guide of :func:`family_scene` through what a fresh ``knowledge`` view of it knows, for an arm of
    body radius ``radius_mm`` (:func:`snakeplan.planners.sac.guide_for`); made once per process."""
    scene = family_scene(family, seed, params)
    return guide_for(scene, view_for(scene, knowledge), radius_mm)


class FuelTankEnv(SnakeEnv):
    """``snakeplan/FuelTank-v0``: the multi-obstacle fuel tank (one target)."""

    def __init__(self, **kwargs):
        super().__init__(scene=kwargs.pop("scene", "fuel-tank"), **kwargs)


class OilTankEnv(SnakeEnv):
    """``snakeplan/OilTank-v0``: the multi-target oil tank (three targets in order)."""

    def __init__(self, **kwargs):
        super().__init__(scene=kwargs.pop("scene", "oil-tank"), **kwargs)


ENV_IDS = {"fuel-tank": "snakeplan/FuelTank-v0", "oil-tank": "snakeplan/OilTank-v0"}


def register_envs() -> None:
    """Register both environments with Gymnasium (idempotent)."""
    for cls, env_id in ((FuelTankEnv, ENV_IDS["fuel-tank"]), (OilTankEnv, ENV_IDS["oil-tank"])):
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point=f"{__name__}:{cls.__name__}")
