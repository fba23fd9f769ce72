"""Training the Swinging Search's DDPG agent (paper 001): the search as a Gymnasium environment, and
Stable-Baselines3's DDPG trained on it offline (:func:`train_agent`) or online after each plan
(:func:`online_model`). The settings are :mod:`.agent`'s.

This module needs the ``train`` extra (torch, Stable-Baselines3, Gymnasium); planning with a trained agent does
not import it.
"""

from __future__ import annotations

import math
import signal
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np

from snakeplan.checkpoints import (
    Generation,
    StateError,
    StateFolder,
    checkpoint_interval,
    sb3_files,
    sb3_restore,
)
from snakeplan.files import atomic_path
from snakeplan.interrupt import Interrupted, interruptible
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

#: The arms an agent is trained for (one agent per arm; the search's inner modules are theirs).
AGENT_ROBOTS = ("sscc-16", "sscc-24")


def check_agent_robot(robot: str, field: str = "robot") -> None:
    """ValueError naming ``field`` unless ``robot`` is one of :data:`AGENT_ROBOTS`."""
    if robot not in AGENT_ROBOTS:
        raise ValueError(f"{field}: the sscc agent is trained for {' or '.join(AGENT_ROBOTS)}, got {robot!r}")


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

    def __getstate__(self) -> dict:
        """Pickled (a training checkpoint) without the scene and arm caches: they are rebuilt from their keys."""
        return {**self.__dict__, "_scenes": {}, "_arms": {}}

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


def _ddpg(env: gym.Env, seed: int, learning_rate: float = LEARNING_RATE, buffer_size: int = BUFFER_SIZE,
          learning_starts: int = LEARNING_STARTS):
    """A fresh Stable-Baselines3 DDPG model with this module's settings."""
    from stable_baselines3 import DDPG
    from stable_baselines3.common.noise import NormalActionNoise

    n_act = env.action_space.shape[0]
    noise = NormalActionNoise(np.zeros(n_act), ACTION_NOISE * np.ones(n_act))
    return DDPG("MlpPolicy", env, learning_rate=learning_rate, buffer_size=buffer_size,
                learning_starts=learning_starts, batch_size=BATCH_SIZE, tau=TAU, gamma=GAMMA,
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


def state_folder(out: str | Path) -> Path:
    """Where :func:`train_agent` writing ``out`` keeps its resumable state: the folder ``<out>.state`` beside it."""
    out = Path(out)
    return out.with_name(out.name + ".state")


def train_agent(robot: str, out: str | Path, steps: int = TRAIN_STEPS, seed: int = 0,
                scenes: tuple[str, ...] = TRAIN_SCENES, targets: int = TRAIN_TARGETS,
                threads: int = 1, resume: bool = True, checkpoint_every: int = 0, eval_every: int = EVAL_EVERY,
                eval_episodes: int = EVAL_EPISODES, learning_starts: int = LEARNING_STARTS) -> TrainingResult:
    """Train the DDPG swing agent for ``robot`` for ``steps`` environment steps and write it to ``out``
    (``.npz``). Every ``eval_every`` steps the actor is scored on ``eval_episodes`` starts drawn from
    ``EVAL_TARGETS`` held-out targets (seeds after the training ones); the best checkpoint (most solved, then
    fewest steps) is kept, since DDPG's return is not monotone in training time. Seeded: the same seed and
    settings give the same file on the same software stack. ``threads`` caps torch's CPU threads (the networks
    are small; more threads rarely help).

    Resumable: every ``checkpoint_every`` steps (0: :func:`snakeplan.checkpoints.checkpoint_interval`) the run
    is saved in :func:`state_folder` (a :class:`snakeplan.checkpoints.StateFolder`; its generations hold
    :func:`snakeplan.checkpoints.sb3_files` and ``best.npz``, the manifest the evaluation history and the best
    step). With ``resume`` a call continues from there exactly as if never stopped (without, the state is
    deleted first); a finished run's state stays, so calling again only rewrites ``out``. SIGINT or SIGTERM
    saves a checkpoint and raises :class:`snakeplan.interrupt.Interrupted`."""
    import torch

    torch.set_num_threads(threads)
    identity = {"trainer": "snakeplan.planners.sscc.training", "robot": robot, "seed": seed, "scenes": list(scenes),
                "targets": targets, "eval_episodes": eval_episodes, "learning_starts": learning_starts}
    run = _SwingRun(robot, Path(out), steps, seed, StateFolder(state_folder(out), identity),
                    checkpoint_every or checkpoint_interval(steps), eval_every,
                    SwingEnv(robot, scenes, EVAL_TARGETS, seed_offset=TRAIN_SEED_OFFSET + targets), eval_episodes)
    try:
        with run.state.locked(), interruptible() as stop:
            if not resume:
                run.state.clear()
            generation = run.state.load()
            for warning in run.state.warnings:
                sys.stderr.write(f"snakeplan: warning: {warning}\n")
            if generation is None:
                run.model = _ddpg(SwingEnv(robot, scenes, targets), seed, buffer_size=min(BUFFER_SIZE, steps),
                                  learning_starts=learning_starts)
            else:
                run.restore(generation)
            return run.train(stop, fresh=generation is None)
    except StateError as exc:
        raise ValueError(f"--out: {exc}; {exc.advice}") from None


class _SwingRun:
    """One :func:`train_agent` run: the model, the evaluation history, the best agent, checkpoints."""

    def __init__(self, robot: str, out: Path, steps: int, seed: int, state: StateFolder, checkpoint_every: int,
                 eval_every: int, held_out: SwingEnv, eval_episodes: int):
        self.robot, self.out, self.steps, self.seed, self.state = robot, out, steps, seed, state
        self.checkpoint_every, self.eval_every, self.eval_episodes = checkpoint_every, eval_every, eval_episodes
        self.held_out = held_out
        self.model = None
        self.history: list[tuple[int, float, float]] = []
        #: The best agent so far: its step, (share solved, -mean steps) and the agent.
        self.best: tuple[int, tuple[float, float], SwingAgent] | None = None
        self.seconds_before = 0.0
        self.t0 = time.perf_counter()

    @property
    def seconds(self) -> float:
        return self.seconds_before + time.perf_counter() - self.t0

    def evaluate(self, n: int) -> None:
        agent = SwingAgent(self.robot, model_weights(self.model))
        solved, mean_steps = evaluate_agent(agent, self.held_out, self.eval_episodes)
        self.history.append((n, solved, mean_steps))
        if self.best is None or (solved, -mean_steps) > self.best[1]:
            self.best = (n, (solved, -mean_steps), agent)

    def checkpoint(self, n: int) -> None:
        writers = sb3_files(self.model)
        best = None
        if self.best is not None:
            step, (solved, neg_steps), agent = self.best
            writers["best.npz"] = lambda path: _save_weights(agent.weights, path)
            best = {"step": step, "solved": solved, "mean_steps": -neg_steps}
        self.state.save(n, writers, {"env_steps": n, "history": self.history, "best": best,
                                     "seconds": self.seconds})

    def interrupt(self, n: int, stop) -> None:
        """Save step ``n`` unless saved already, and stop with the one line that says how to go on."""
        if self.state.current is None or n > self.state.current.step:
            self.checkpoint(n)
        raise Interrupted(f"interrupted at step {n}; checkpoint saved in {self.state.root}; rerun the same command "
                          f"to resume", stop.signum or signal.SIGINT)

    def restore(self, generation: Generation) -> None:
        from stable_baselines3 import DDPG

        self.model = sb3_restore(DDPG, generation)
        record = generation.record
        self.history = [tuple(h) for h in record["history"]]
        self.seconds_before = record["seconds"]
        if record["best"] is not None:
            b = record["best"]
            weights = SwingAgent.load(self.robot, generation.path("best.npz")).weights
            self.best = (b["step"], (b["solved"], -b["mean_steps"]), SwingAgent(self.robot, weights))

    def train(self, stop, fresh: bool) -> TrainingResult:
        from stable_baselines3.common.callbacks import BaseCallback

        run = self

        class _Callback(BaseCallback):
            def _on_rollout_start(self) -> None:  # the last step is stored and trained on: a consistent state
                n = self.num_timesteps
                if stop.requested:
                    run.interrupt(n, stop)
                if n - (run.state.current.step if run.state.current else 0) >= run.checkpoint_every:
                    run.checkpoint(n)

            def _on_step(self) -> bool:
                if self.num_timesteps % run.eval_every == 0:
                    run.evaluate(self.num_timesteps)
                return True

        self.t0 = time.perf_counter()
        remaining = self.steps - self.model.num_timesteps
        if remaining > 0:
            self.model.learn(total_timesteps=remaining, callback=_Callback(), reset_num_timesteps=fresh)
        n = self.model.num_timesteps
        if self.state.current is None or n > self.state.current.step:
            self.checkpoint(n)
        if stop.requested:
            self.interrupt(n, stop)
        if self.best is None:
            step, key, agent = self.steps, (math.nan, math.nan), SwingAgent(self.robot, model_weights(self.model))
        else:
            step, key, agent = self.best
        self.out.parent.mkdir(parents=True, exist_ok=True)
        _save_weights(agent.weights, self.out)
        return TrainingResult(self.robot, self.steps, self.seed, self.seconds,
                              self.model.env.envs[0].unwrapped.episodes, step, key[0], -key[1], self.history,
                              str(self.out))


def _save_weights(weights: dict[str, np.ndarray], path: Path) -> None:
    """Write agent weights as a plain ``.npz`` at exactly ``path``, atomically."""
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, **weights)
