"""Training the Swinging Search's DDPG agent (paper 001) offline: the search as a Gymnasium environment
(:class:`SwingEnv`) and Stable-Baselines3's DDPG (:mod:`snakeplan.planners.sscc.ddpg`) trained on it, resumably
(:func:`train_agent`, a :class:`snakeplan.rl.resumable.ResumableRun`). The agent's online learning after each
plan uses the same model but not this module (:mod:`snakeplan.planners.sscc.agent`).

This module needs the ``train`` extra (torch, Stable-Baselines3, Gymnasium); planning with a trained agent does
not import it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import DDPG

from snakeplan.checkpoints import Generation, StateFolder, checkpoint_interval, sb3_files, sb3_restore
from snakeplan.files import atomic_path
from snakeplan.interrupt import StopRequest
from snakeplan.planners.sscc.agent import SwingAgent
from snakeplan.planners.sscc.ddpg import BUFFER_SIZE, LEARNING_STARTS, agent_spaces, ddpg_model, model_weights
from snakeplan.planners.sscc.swinging import InnerArm, SwingEpisode, SwingSettings, inner_module_counts
from snakeplan.rl.resumable import Best, CheckpointCallback, ResumableRun
from snakeplan.robots import Chain, get_robot
from snakeplan.scenes import Scene, make_scene
from snakeplan.world import FullView

#: Training targets: scenes and their seeds (``TRAIN_TARGETS`` per scene from ``TRAIN_SEED_OFFSET``).
TRAIN_SCENES = ("pipe", "concentric-pipe")
TRAIN_SEED_OFFSET = 10_000
TRAIN_TARGETS = 48
#: Training length (environment steps).
TRAIN_STEPS = 12_000
#: Checkpoint selection: every EVAL_EVERY steps, EVAL_EPISODES starts from EVAL_TARGETS held-out targets per scene.
EVAL_EVERY = 1_000
EVAL_EPISODES = 40
EVAL_TARGETS = 8
#: Redraws of an episode's start (target, module count, inverse kinematics) before accepting a solved one.
RESET_TRIES = 50
#: The trainer's name in its state folders' run identity: this module. A state folder written before the trainer
#: moved here (``snakeplan.planners.sscc.training``, whose environments its ``envs.pkl`` pickled) is another run's.
TRAINER = "snakeplan.rl.sscc"
#: The arms an agent is trained for (one agent per arm; the search's inner modules are theirs).
AGENT_ROBOTS = ("sscc-16", "sscc-24")


def check_agent_robot(robot: str, field: str = "robot") -> None:
    """ValueError naming ``field`` unless ``robot`` is one of :data:`AGENT_ROBOTS`."""
    if robot not in AGENT_ROBOTS:
        raise ValueError(f"{field}: the sscc agent is trained for {' or '.join(AGENT_ROBOTS)}, got {robot!r}")


class SwingEnv(gym.Env):
    """The Swinging Search as a Gymnasium environment: one episode swings one inner arm about one target.

    Each reset draws a training scene (uniformly among ``scenes`` and their ``targets`` seeds), a number of inner
    modules and an inverse-kinematics start that is not already a solution. Terminates on a clear crawl,
    truncates after ``settings.episode_steps``.
    """

    def __init__(self, robot: str = "sscc-24", scenes: tuple[str, ...] = TRAIN_SCENES,
                 targets: int = TRAIN_TARGETS, seed_offset: int = TRAIN_SEED_OFFSET,
                 settings: SwingSettings = SwingSettings()):
        self.chain: Chain = get_robot(robot)
        self.observation_space, self.action_space = agent_spaces(self.chain.n_sections)
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
        super().reset(seed=seed)
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
    torch.set_num_threads(threads)
    identity = {"trainer": TRAINER, "robot": robot, "seed": seed, "scenes": list(scenes), "targets": targets,
                "eval_episodes": eval_episodes, "learning_starts": learning_starts}
    run = _SwingRun(robot, Path(out), steps, seed, StateFolder(state_folder(out), identity),
                    checkpoint_every or checkpoint_interval(steps), eval_every,
                    SwingEnv(robot, scenes, EVAL_TARGETS, seed_offset=TRAIN_SEED_OFFSET + targets), eval_episodes)
    with run.session(resume) as (stop, generation):
        if generation is None:
            run.model = ddpg_model(SwingEnv(robot, scenes, targets), seed, buffer_size=min(BUFFER_SIZE, steps),
                                   learning_starts=learning_starts)
        else:
            run.restore(generation)
        return run.train(stop, fresh=generation is None)


class _Evaluations(CheckpointCallback):
    """Checkpoints and stops at the start of each rollout; scores the agent every ``eval_every`` steps."""

    run: _SwingRun

    def _on_step(self) -> bool:
        if self.num_timesteps % self.run.eval_every == 0:
            self.run.evaluate(self.num_timesteps)
        return True


class _SwingRun(ResumableRun):
    """One :func:`train_agent` run: the model, the evaluation history, the best agent, checkpoints."""

    def __init__(self, robot: str, out: Path, steps: int, seed: int, state: StateFolder, checkpoint_every: int,
                 eval_every: int, held_out: SwingEnv, eval_episodes: int):
        super().__init__(state, checkpoint_every)
        self.robot, self.out, self.steps, self.seed = robot, out, steps, seed
        self.eval_every, self.eval_episodes = eval_every, eval_episodes
        self.held_out = held_out
        self.history: list[tuple[int, float, float]] = []
        #: The best agent so far: its step, (share solved, -mean steps) and the agent.
        self.best: Best[SwingAgent] | None = None

    def evaluate(self, n: int) -> None:
        agent = SwingAgent(self.robot, model_weights(self.model))
        solved, mean_steps = evaluate_agent(agent, self.held_out, self.eval_episodes)
        self.history.append((n, solved, mean_steps))
        if self.best is None or self.best.beaten_by((solved, -mean_steps)):
            self.best = Best(n, (solved, -mean_steps), agent)

    def snapshot(self, n: int) -> tuple[dict, dict]:
        """Generation ``n``: :func:`snakeplan.checkpoints.sb3_files` and the best agent's ``best.npz``; the record
        holds the evaluation history, the best step with its score, and the seconds trained."""
        writers = sb3_files(self.model)
        best = None
        if self.best is not None:
            (solved, neg_steps), agent = self.best.key, self.best.item
            writers["best.npz"] = lambda path: _save_weights(agent.weights, path)
            best = {"step": self.best.step, "solved": solved, "mean_steps": -neg_steps}
        return writers, {"env_steps": n, "history": self.history, "best": best, "seconds": self.wall}

    def restore(self, generation: Generation) -> None:
        self.model = sb3_restore(DDPG, generation)
        record = generation.record
        self.history = [tuple(h) for h in record["history"]]
        self.wall_before = record["seconds"]
        if record["best"] is not None:
            b = record["best"]
            weights = SwingAgent.load(self.robot, generation.path("best.npz")).weights
            self.best = Best(b["step"], (b["solved"], -b["mean_steps"]), SwingAgent(self.robot, weights))

    def train(self, stop: StopRequest, fresh: bool) -> TrainingResult:
        """Learn up to ``steps``, checkpoint, and write the best agent to ``out``."""
        self.start_clock()
        n = self.learn(self.steps, _Evaluations(self, stop), fresh)
        self.finish(n, stop)
        if self.best is None:
            step, key, agent = self.steps, (math.nan, math.nan), SwingAgent(self.robot, model_weights(self.model))
        else:
            step, key, agent = self.best.step, self.best.key, self.best.item
        self.out.parent.mkdir(parents=True, exist_ok=True)
        _save_weights(agent.weights, self.out)
        return TrainingResult(self.robot, self.steps, self.seed, self.wall,
                              self.model.env.envs[0].unwrapped.episodes, step, key[0], -key[1], self.history,
                              str(self.out))


def _save_weights(weights: dict[str, np.ndarray], path: Path) -> None:
    """Write agent weights as a plain ``.npz`` at exactly ``path``, atomically."""
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, **weights)
