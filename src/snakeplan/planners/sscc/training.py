"""Training the Swinging Search's DDPG agent (paper 001): the search as a Gymnasium environment, and
Stable-Baselines3's DDPG trained on it offline (:func:`train_agent`) or online after each plan
(:func:`online_model`). The settings are :mod:`.agent`'s.

This module needs the ``train`` extra (torch, Stable-Baselines3, Gymnasium); planning with a trained agent does
not import it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np

from snakeplan.planners.sscc.agent import (
    ACTION_NOISE,
    BATCH_SIZE,
    BUFFER_SIZE,
    EVAL_EPISODES,
    EVAL_EVERY,
    EVAL_TARGETS,
    GAMMA,
    LEARNING_RATE,
    LEARNING_STARTS,
    NET_ARCH,
    ONLINE_BUFFER_SIZE,
    ONLINE_LEARNING_RATE,
    RESET_TRIES,
    TAU,
    TRAIN_SCENES,
    TRAIN_SEED_OFFSET,
    TRAIN_STEPS,
    TRAIN_TARGETS,
    SwingAgent,
    model_weights,
)
from snakeplan.planners.sscc.swinging import (
    InnerArm,
    SwingEpisode,
    SwingSettings,
    action_size,
    inner_module_counts,
    observation_size,
)
from snakeplan.robots import Chain, get_robot
from snakeplan.scenes import Scene, make_scene
from snakeplan.world import FullView


class _Spaces(gym.Env):
    """Just the state and action spaces of an arm, for building a DDPG model without an environment to run."""

    def __init__(self, n_sections: int):
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (observation_size(n_sections),), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (action_size(n_sections),), np.float32)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        raise NotImplementedError("a spaces-only environment cannot run")

    def step(self, action):
        raise NotImplementedError("a spaces-only environment cannot run")


class SwingEnv(_Spaces):
    """The Swinging Search as a Gymnasium environment: one episode swings one inner arm about one target.

    Each reset draws a training scene (uniformly among ``scenes`` and their ``targets`` seeds), a number of inner
    modules and an inverse-kinematics start that is not already a solution. Terminates on a clear crawl,
    truncates after ``settings.episode_steps``.
    """

    def __init__(self, robot: str = "sscc-24", scenes: tuple[str, ...] = TRAIN_SCENES,
                 targets: int = TRAIN_TARGETS, seed_offset: int = TRAIN_SEED_OFFSET,
                 settings: SwingSettings = SwingSettings()):
        self.chain: Chain = get_robot(robot)
        super().__init__(self.chain.n_sections)
        self.settings = settings
        self._keys = [(name, seed_offset + i) for name in scenes for i in range(targets)]
        self._scenes: dict[tuple[str, int], Scene] = {}
        self._arms: dict[tuple[str, int, int], InnerArm] = {}
        self.episode: SwingEpisode | None = None
        self.episodes = 0
        self.successes = 0

    def _scene(self, key: tuple[str, int]) -> Scene:
        if key not in self._scenes:
            self._scenes[key] = make_scene(*key)
        return self._scenes[key]

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super(_Spaces, self).reset(seed=seed)
        rng = self.np_random
        self.episode = None
        for _ in range(RESET_TRIES):
            key = self._keys[int(rng.integers(len(self._keys)))]
            scene = self._scene(key)
            target = scene.targets[0]
            counts = inner_module_counts(self.chain, scene.entrance.position, target,
                                         self.settings.inner_module_schedule)
            k = counts[int(rng.integers(len(counts)))]
            if (*key, k) not in self._arms:
                self._arms[(*key, k)] = InnerArm(self.chain, FullView(scene), target, k, self.settings)
            q0 = self._arms[(*key, k)].initial(rng)
            if q0 is None:
                continue
            self.episode = SwingEpisode(self._arms[(*key, k)], q0)
            if not self.episode.status.feasible:
                break
        if self.episode is None:
            raise RuntimeError(f"no inverse-kinematics start in {RESET_TRIES} draws")
        self.episodes += 1
        return self.episode.observation(), {}

    def step(self, action):
        status = self.episode.advance(self.episode.forces(action))
        self.successes += int(status.feasible)
        truncated = self.episode.steps >= self.settings.episode_steps and not status.feasible
        return self.episode.observation(), float(status.reward), status.feasible, truncated, {}


def _ddpg(env: gym.Env, seed: int, learning_rate: float = LEARNING_RATE, buffer_size: int = BUFFER_SIZE):
    """A fresh Stable-Baselines3 DDPG model with this module's settings."""
    from stable_baselines3 import DDPG
    from stable_baselines3.common.noise import NormalActionNoise

    n_act = env.action_space.shape[0]
    noise = NormalActionNoise(np.zeros(n_act), ACTION_NOISE * np.ones(n_act))
    return DDPG("MlpPolicy", env, learning_rate=learning_rate, buffer_size=buffer_size,
                learning_starts=LEARNING_STARTS, batch_size=BATCH_SIZE, tau=TAU, gamma=GAMMA,
                action_noise=noise, policy_kwargs={"net_arch": list(NET_ARCH)}, seed=seed, device="cpu")


def online_model(n_sections: int, seed: int, weights: dict[str, np.ndarray]):
    """A DDPG model for online learning (:meth:`.agent.SwingAgent.learn`): the online learning rate and buffer,
    its policy set to ``weights``, logging off."""
    import torch
    from stable_baselines3.common.logger import Logger

    model = _ddpg(_Spaces(n_sections), seed, ONLINE_LEARNING_RATE, ONLINE_BUFFER_SIZE)
    model.policy.load_state_dict({k: torch.as_tensor(v) for k, v in weights.items()})
    model.set_logger(Logger(None, []))
    return model


def evaluate_agent(agent: SwingAgent, env: SwingEnv, episodes: int = EVAL_EPISODES) -> tuple[float, float]:
    """(share solved, mean swing steps) of ``agent`` over ``episodes`` fixed starts of ``env`` (reset seeds
    0 .. episodes-1, policy noise seeded the same way), each run to a clear crawl or the episode's end."""
    solved = steps = 0
    for i in range(episodes):
        env.reset(seed=i)
        episode, rng = env.episode, np.random.default_rng(i)
        while not episode.status.feasible and episode.steps < env.settings.episode_steps:
            episode.advance(agent(episode, rng))
        solved += int(episode.status.feasible)
        steps += episode.steps
    return solved / episodes, steps / episodes


@dataclass(frozen=True)
class TrainingResult:
    """What :func:`train_agent` did: robot, steps, seed, seconds, training episodes, the checkpoint kept (step)
    with its held-out share solved and mean steps, the evaluation history ``(step, solved, mean steps)``, file."""

    robot: str
    steps: int
    seed: int
    seconds: float
    episodes: int
    best_step: int
    best_solved: float
    best_mean_steps: float
    history: list[tuple[int, float, float]]
    out: str


def train_agent(robot: str, out: str | Path, steps: int = TRAIN_STEPS, seed: int = 0,
                scenes: tuple[str, ...] = TRAIN_SCENES, targets: int = TRAIN_TARGETS,
                threads: int = 1) -> TrainingResult:
    """Train the DDPG swing agent for ``robot`` from scratch for ``steps`` environment steps and write it to
    ``out`` (``.npz``). Every ``EVAL_EVERY`` steps the actor is scored on ``EVAL_EPISODES`` starts drawn from
    ``EVAL_TARGETS`` held-out targets (seeds after the training ones); the best checkpoint (most solved, then
    fewest steps) is kept, since DDPG's return is not monotone in training time. Seeded: the same seed and
    settings give the same file on the same software stack. ``threads`` caps torch's CPU threads (the networks
    are small; more threads rarely help)."""
    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    torch.set_num_threads(threads)
    env = SwingEnv(robot, scenes, targets)
    held_out = SwingEnv(robot, scenes, EVAL_TARGETS, seed_offset=TRAIN_SEED_OFFSET + targets)
    model = _ddpg(env, seed)
    history: list[tuple[int, float, float]] = []
    best: dict = {"key": (-1.0, 0.0)}

    class _KeepBest(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps % EVAL_EVERY == 0:
                agent = SwingAgent(robot, model_weights(model))
                solved, mean_steps = evaluate_agent(agent, held_out)
                history.append((self.num_timesteps, solved, mean_steps))
                if (solved, -mean_steps) > best["key"]:
                    best.update(key=(solved, -mean_steps), agent=agent, step=self.num_timesteps)
            return True

    t0 = time.perf_counter()
    model.learn(total_timesteps=steps, callback=_KeepBest())
    seconds = time.perf_counter() - t0
    if "agent" not in best:
        best.update(key=(math.nan, math.nan), agent=SwingAgent(robot, model_weights(model)), step=steps)
    path = best["agent"].save(out)
    return TrainingResult(robot, steps, seed, seconds, env.episodes, best["step"], best["key"][0],
                          -best["key"][1], history, str(path))
