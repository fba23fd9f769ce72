"""The Swinging Search's DDPG agent (paper 001): environment, training, shipped weights, online learning.

The agent is Stable-Baselines3's DDPG (actor-critic, target networks, Gaussian exploration noise) on
:class:`SwingEnv`, whose state, action and reward are those of :mod:`snakeplan.planners.sscc.swinging`. One agent
per arm (``sscc-16``, ``sscc-24``), trained on targets of both pipe scenes drawn from seeds ``TRAIN_SEED_OFFSET``
onwards, disjoint from the benchmark's and the tests' seeds. Episodes whose inverse-kinematics start is already
a solution are redrawn: they teach nothing.

Shipped weights are the policy's ``state_dict`` as a plain ``.npz`` (``data/<robot>.npz``, read with
``allow_pickle=False``). Planning runs the actor in NumPy (a two-layer MLP; no torch needed); only learning needs
torch and Stable-Baselines3. As in the paper, the agent can keep learning from every task: with ``learning`` on,
each search's transitions go to its replay buffer and up to ``ONLINE_GRADIENT_STEPS`` updates follow.

Training keeps the best checkpoint on held-out targets, not the last: on this task DDPG's actor peaks after a few
thousand updates and then drifts (see :func:`train_agent`'s history).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from snakeplan.planners.sscc.swinging import (
    InnerArm,
    SwingEpisode,
    SwingSettings,
    Transition,
    action_size,
    inner_module_counts,
    observation_size,
)
from snakeplan.robots import Chain, get_robot
from snakeplan.scenes import Scene, make_scene
from snakeplan.world import FullView

#: Training targets: scenes and their seeds (``TRAIN_TARGETS`` per scene from ``TRAIN_SEED_OFFSET``).
TRAIN_SCENES = ("pipe", "concentric-pipe")
TRAIN_SEED_OFFSET = 10_000
TRAIN_TARGETS = 48
#: Training length (environment steps) and DDPG settings.
TRAIN_STEPS = 12_000
NET_ARCH = (128, 128)
LEARNING_RATE = 3e-4
BUFFER_SIZE = 100_000
LEARNING_STARTS = 1_000
BATCH_SIZE = 128
TAU = 0.005
GAMMA = 0.95
ACTION_NOISE = 0.3
#: Checkpoint selection: every EVAL_EVERY steps, EVAL_EPISODES starts from EVAL_TARGETS held-out targets per scene.
EVAL_EVERY = 1_000
EVAL_EPISODES = 40
EVAL_TARGETS = 8
#: Redraws of an episode's start (target, module count, inverse kinematics) before accepting a solved one.
RESET_TRIES = 50
#: Online learning after each plan: gradient steps per task (at most one per new transition), smallest buffer,
#: and a learning rate a tenth of training's (longer DDPG training drifted away from its best, see train_agent).
ONLINE_GRADIENT_STEPS = 32
ONLINE_MIN_BUFFER = BATCH_SIZE
ONLINE_LEARNING_RATE = LEARNING_RATE / 10
#: Online learning: replay buffer size and torch CPU threads (small networks: one thread avoids contention).
ONLINE_BUFFER_SIZE = 20_000
ONLINE_THREADS = 1
#: Exploration noise (std of the action) when the agent plans.
PLAN_NOISE = 0.1
#: Package whose ``data`` folder holds the shipped agents, one ``<robot>.npz`` each.
DATA_PACKAGE = "snakeplan.planners.sscc"


def shipped_agent_path(robot: str) -> Path:
    """Where the pretrained agent for ``robot`` ships: ``data/<robot>.npz`` inside this package."""
    return Path(str(files(DATA_PACKAGE).joinpath("data", f"{robot}.npz")))


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


def _arrays(model) -> dict[str, np.ndarray]:
    return {k: v.detach().cpu().numpy().copy() for k, v in model.policy.state_dict().items()}


class SwingAgent:
    """A DDPG swing policy for one arm: NumPy actor for planning, an SB3 model behind it for learning.

    ``weights`` are the SB3 policy's ``state_dict`` arrays. Use as a :class:`~.swinging.SwingPolicy`.
    """

    def __init__(self, robot: str, weights: dict[str, np.ndarray], learning: bool = False, seed: int = 0,
                 noise: float = PLAN_NOISE):
        self.robot = robot
        self.n_sections = get_robot(robot).n_sections
        self.weights = {k: np.asarray(v) for k, v in weights.items()}
        self.learning, self.seed, self.noise = learning, seed, noise
        self._model = None
        self.last_action: np.ndarray | None = None
        self._layers = self._actor_layers()
        w_in = self._layers[0][0].shape[1]
        if w_in != observation_size(self.n_sections) or self._layers[-1][0].shape[0] != action_size(self.n_sections):
            raise ValueError(f"agent weights do not fit {robot}: input {w_in}, expected "
                             f"{observation_size(self.n_sections)}")

    @classmethod
    def load(cls, robot: str, path: str | Path | None = None, **options: Any) -> SwingAgent:
        """The agent stored at ``path`` (default: the shipped one for ``robot``)."""
        source = Path(path) if path is not None else shipped_agent_path(robot)
        if not source.exists():
            raise FileNotFoundError(f"no SSCC agent for {robot} at {source}; train one with train_agent()")
        with np.load(source, allow_pickle=False) as data:
            weights = {k: data[k] for k in data.files}
        return cls(robot, weights, **options)

    def save(self, path: str | Path) -> Path:
        """Write the weights as a plain ``.npz``."""
        out = Path(path)
        out.parent.mkdir(parents=True, exist_ok=True)
        np.savez(out, **self.weights)
        return out

    def _actor_layers(self) -> list[tuple[np.ndarray, np.ndarray]]:
        keys = sorted({k.rsplit(".", 1)[0] for k in self.weights if k.startswith("actor.mu.")},
                      key=lambda k: int(k.rsplit(".", 1)[1]))
        return [(self.weights[f"{k}.weight"].astype(np.float64), self.weights[f"{k}.bias"].astype(np.float64))
                for k in keys]

    def act(self, observation: np.ndarray) -> np.ndarray:
        """The deterministic action (the actor network: ReLU hidden layers, tanh output) for a state."""
        x = np.asarray(observation, dtype=np.float64)
        for i, (W, b) in enumerate(self._layers):
            x = W @ x + b
            x = np.maximum(x, 0.0) if i < len(self._layers) - 1 else np.tanh(x)
        return x

    def reset(self, episode: SwingEpisode, rng: np.random.Generator) -> None:
        return None

    def __call__(self, episode: SwingEpisode, rng: np.random.Generator) -> np.ndarray:
        a = self.act(episode.observation())
        if self.noise > 0:
            a = a + self.noise * rng.standard_normal(a.shape)
        self.last_action = np.clip(a, -1.0, 1.0)
        return episode.forces(self.last_action)

    def learn(self, transitions: list[Transition]) -> int:
        """Add a task's transitions to the replay buffer and train on it (``ONLINE_GRADIENT_STEPS`` at most, one
        per new transition, once the buffer holds ``ONLINE_MIN_BUFFER``); returns the gradient steps taken."""
        if not self.learning or not transitions:
            return 0
        import torch

        if self._model is None:
            from stable_baselines3.common.logger import Logger

            self._model = _ddpg(_Spaces(self.n_sections), self.seed, ONLINE_LEARNING_RATE, ONLINE_BUFFER_SIZE)
            self._model.policy.load_state_dict({k: torch.as_tensor(v) for k, v in self.weights.items()})
            self._model.set_logger(Logger(None, []))
        buffer = self._model.replay_buffer
        for obs, action, reward, next_obs, done in transitions:
            buffer.add(obs[None], next_obs[None], action[None], np.array([reward]), np.array([done]), [{}])
        if buffer.size() < ONLINE_MIN_BUFFER:
            return 0
        steps = min(ONLINE_GRADIENT_STEPS, len(transitions))
        threads = torch.get_num_threads()
        torch.set_num_threads(ONLINE_THREADS)
        try:
            self._model.train(gradient_steps=steps, batch_size=BATCH_SIZE)
        finally:
            torch.set_num_threads(threads)
        self.weights = _arrays(self._model)
        self._layers = self._actor_layers()
        return steps


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
                agent = SwingAgent(robot, _arrays(model))
                solved, mean_steps = evaluate_agent(agent, held_out)
                history.append((self.num_timesteps, solved, mean_steps))
                if (solved, -mean_steps) > best["key"]:
                    best.update(key=(solved, -mean_steps), agent=agent, step=self.num_timesteps)
            return True

    t0 = time.perf_counter()
    model.learn(total_timesteps=steps, callback=_KeepBest())
    seconds = time.perf_counter() - t0
    if "agent" not in best:
        best.update(key=(math.nan, math.nan), agent=SwingAgent(robot, _arrays(model)), step=steps)
    path = best["agent"].save(out)
    return TrainingResult(robot, steps, seed, seconds, env.episodes, best["step"], best["key"][0],
                          -best["key"][1], history, str(path))
