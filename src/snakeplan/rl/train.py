"""Training entry point for the learned planners: SAC-HER, SAC-PER and plain SAC (paper 000 Algorithms 1-3).

``train(scene, algorithm, steps, seed, out_dir)`` trains with a progress bar (on a terminal; in a log, a plain
line every 1 % of the run), evaluates the deterministic policy every ``eval_every`` steps on fixed
validation episodes (judged by :func:`snakeplan.evaluation.evaluate`), checkpoints every ``checkpoint_every``
steps (default :func:`snakeplan.checkpoints.checkpoint_interval`: a tenth of the run, within 1,000-10,000 steps
and at most the run) and writes into ``out_dir``:

- ``policy.npz``: the best validation policy as plain weights (:class:`snakeplan.planners.sac.NumpyPolicy`),
  ``last.npz`` the final one; ``curve.json`` and ``curve.png``: the learning curve. Each is written atomically.
- ``state.json`` and ``ckpt-<step>/`` folders: the resumable state, a :class:`snakeplan.checkpoints.StateFolder`
  (two generations; the manifest, written last, lists each one's files with sizes and sha256, its env steps
  and the evaluation history so far). A generation holds ``model.zip`` and ``replay.pkl`` (SB3's formats),
  ``envs.pkl`` (the training environments mid-episode), ``rng.pkl`` (torch, NumPy, Python and action-space
  generator states) and ``best.npz`` (the best policy so far). These are pickles: resume only your own.

Checkpoints are taken at the start of a rollout, where the last step's transition is stored and trained on, and
hold every generator the run draws from, so a run resumed from step k continues exactly as the uninterrupted run
would have (same buffer, same draws, same weights; tests/test_training_state.py checks it). Evaluations happen
where they always did; the manifest's history is the one source of them, so a resumed run continues after its
last recorded evaluation and never repeats one. A run killed at any moment (SIGKILL included) resumes from its
newest intact checkpoint, losing at most ``checkpoint_every`` steps; SIGINT or SIGTERM saves a checkpoint first
and raises :class:`snakeplan.interrupt.Interrupted` (the command line prints one line and exits 130).

Defaults (:data:`DEFAULT_CONFIG`), measured on the 2-core CPU with torch on one thread: the environment steps at
about 3,600/s, so gradient updates bound the wall time; 128 x 128 networks (an update with batch 128 takes 9.5 ms,
against 13.9 ms at 256 and 29.8 ms at §4.1's 512), one update per environment step, one environment, SB3's lr
3e-4 and tau 5e-3 (the paper's 2e-4 and 1e-3 are :data:`PAPER_CONFIG`, not re-measured here). With these,
fuel-tank SAC-HER reached 0.9 validation success in 40,000 steps (13 min); oil-tank SAC-PER, with the
look-ahead and a 130 mm turning radius (215 mm plateaued at 0.82-0.86), reached 0.98 in 10,000 steps (3-5 min;
seeds 0 and 1). The shared update (:mod:`snakeplan.rl.agents`), fused Adam and scenes made ahead on the spare
cores (``scene_workers``) later brought the same fuel-tank command to 289-556 s for 40,000 steps, depending on the
machine's load (0.94 validation success there; README). The same update in JAX (``--autodiff jax``), ten steps
then their ten updates in one compiled call, took 46-57 % of that wall time per step. With ``--overlap true`` as
well, the next ten steps run while XLA computes a call's updates, acting with the actor of the call before: 40,000
steps in 168-182 s, against 30,000 in 176-186 s without. :data:`JAX_CONFIG` (twenty updates per ten steps,
overlap, learning rate 1e-3; README) reached 0.9 validation success on fuel-tank within 99-151 s on seeds 0-4.
Run as ``snakeplan train rl SCENE ALGORITHM --steps N --seed S --out DIR [--robot NAME ...]`` (or
``python -m snakeplan.rl.train``, the same options); SCENE is any registered scene family with targets.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import multiprocessing
import os
import shlex
import sys
from collections import deque
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import torch as th
from stable_baselines3.common.buffers import DictReplayBuffer
from stable_baselines3.common.vec_env import DummyVecEnv

from snakeplan.checkpoints import Generation, StateFolder, checkpoint_interval, sb3_files, sb3_restore
from snakeplan.episode import run_episode
from snakeplan.files import atomic_path, atomic_write
from snakeplan.interrupt import StopRequest
from snakeplan.parallel import ProgressDisplay, usable_cores
from snakeplan.planners import Problem
from snakeplan.planners.sac.crawler import CAPTURE_STEPS, TURN_RADIUS_MM
from snakeplan.planners.sac.observation import RoomGraph
from snakeplan.planners.sac.planner import SacPlanner
from snakeplan.planners.sac.policy import NumpyPolicy, arm_record, fits_arm
from snakeplan.rl.agents import (
    AUTODIFF,
    EPSILON_DECAY,
    EPSILON_MIN,
    EPSILON_START,
    EpsilonGreedySAC,
)
from snakeplan.rl.envs import (
    TRAIN_SCENES,
    TRAIN_SEED,
    VALIDATION_SEED,
    SnakeEnv,
    distribution_arm,
    families,
    family_of,
    scene_of,
    upcoming,
)
from snakeplan.rl.extractor import GoalRouteExtractor
from snakeplan.rl.her import FastHerReplayBuffer
from snakeplan.rl.per import ALPHA, BETA_START, PerSAC, PrioritizedDictReplayBuffer
from snakeplan.rl.policy import from_sb3
from snakeplan.rl.resumable import Best, CheckpointCallback, ResumableRun
from snakeplan.rl.rewards import GUIDE_WEIGHT
from snakeplan.robots import Chain, get_robot, load_robot
from snakeplan.robots.arm_range import ARM_RANGE, turn_radius_for
from snakeplan.scenes import make_scene, scene_names, scene_spec
from snakeplan.scenes.prefetch import ScenePrefetch
from snakeplan.scenes.sizing import arm_sizing
from snakeplan.world import Knowledge

ALGORITHMS = ("sac-her", "sac-per", "sac")
#: Shortest episode (steps) the scene prefetch plans for: enough draws whatever the episodes' lengths.
PREFETCH_EPISODE_STEPS = 5
#: Episodes in the rolling training success rate shown on the progress bar and the curve.
ROLLING_EPISODES = 100


@dataclass(frozen=True)
class TrainConfig:
    """Hyper-parameters and bookkeeping of one training run (steps are environment steps summed over envs)."""

    observation: str = "local"
    #: The robot trained: a preset name or a robot file (:func:`snakeplan.robots.load_robot`); empty: the one the
    #: scene family's spec names. Its scenes are sized to it (:mod:`snakeplan.scenes.sizing`).
    robot: str = ""
    net_arch: tuple[int, ...] = (128, 128)
    learning_rate: float = 3e-4
    tau: float = 5e-3
    gamma: float = 0.99
    batch_size: int = 128
    buffer_size: int = 1_000_000
    #: Gradient updates per ``train_freq`` environment steps (per env): the update-to-data ratio.
    gradient_steps: int = 1
    train_freq: int = 1
    n_envs: int = 1
    learning_starts: int = 1000
    her_goals: int = 4
    per_alpha: float = ALPHA
    per_beta: float = BETA_START
    epsilon_start: float = EPSILON_START
    epsilon_min: float = EPSILON_MIN
    epsilon_decay: float = EPSILON_DECAY
    train_scenes: int = TRAIN_SCENES
    #: Smallest turning radius (mm) of the crawl's heading-change action.
    turn_radius_mm: float = TURN_RADIUS_MM
    #: Whether the observation carries the target after the current one (multi-target scenes).
    lookahead: bool = False
    #: Goal capture range of the crawl, in steps (see :data:`snakeplan.planners.sac.CAPTURE_STEPS`; 0 = off).
    capture_steps: int = CAPTURE_STEPS
    #: What the crawler's rays and route guide know while training and validating: "full" or "sensed".
    knowledge: str = "full"
    #: The guide design's residual policy: the crawl adds the action to the pursuit of the guide.
    residual: bool = False
    #: The guide design's reward per step length of progress along the guide (0: none).
    guide_weight: float = GUIDE_WEIGHT
    #: Each scene seed's episodes crawl an arm drawn from the distribution of arms
    #: (:mod:`snakeplan.robots.arm_range`), in the scene sized to it, and the policy observes the arm: one policy
    #: for arms it never saw.
    arm_conditioned: bool = False
    eval_every: int = 5000
    eval_episodes: int = 20
    #: 0: :func:`snakeplan.checkpoints.checkpoint_interval` of the run's steps.
    checkpoint_every: int = 0
    torch_threads: int = 1
    #: The library that runs the gradient updates: "torch", or "jax" (the same update compiled by XLA;
    #: :mod:`snakeplan.rl.jax_update`).
    autodiff: str = "torch"
    #: JAX only: each call's updates run on XLA's thread while the next ``train_freq`` roll-out steps run, which
    #: act with the actor of the call before (:meth:`snakeplan.rl.agents.EpsilonGreedySAC._train_jax`).
    overlap: bool = False
    #: Processes that make the run's training scenes ahead of use (:mod:`snakeplan.scenes.prefetch`); 0: none (each
    #: scene is made when first drawn; the default of :func:`train`, which a script may call unguarded); -1: one
    #: when this process may use another core (the default of the command line).
    scene_workers: int = 0


#: The measured default (see the module doc and the closing note of the issue).
DEFAULT_CONFIG = TrainConfig()
#: The measured faster setting (``snakeplan bench rl``): four environments stepped together, batch 512, one update
#: per four environment steps: a quarter of the default's updates per step, each on four times the samples.
FAST_CONFIG = replace(DEFAULT_CONFIG, n_envs=4, batch_size=512)
#: The measured fastest to 0.9 validation success on fuel-tank (README): the same update in JAX, ten environment
#: steps then twenty updates in one compiled call (twice the default's updates per step), the roll-outs overlapping
#: the updates, learning rate 1e-3. Seeds 0-4 crossed 0.9 in 99-151 s of training on two cores.
JAX_CONFIG = replace(DEFAULT_CONFIG, autodiff="jax", train_freq=10, gradient_steps=20, overlap=True,
                     learning_rate=1e-3)
#: Paper 000 §4.1: 512 x 512 networks, tau 1e-3, lr 2e-4, batch 128, buffer 1e6.
PAPER_CONFIG = TrainConfig(net_arch=(512, 512), learning_rate=2e-4, tau=1e-3)


@dataclass
class TrainResult:
    """Where a run left its files, and its evaluation history ``(env steps, wall s, validation success)``."""

    out_dir: Path
    policy: Path
    history: list[dict] = field(default_factory=list)


def robot_for(scene: str, config: TrainConfig) -> str:
    """The robot ``config`` trains in ``scene``: its own, else the (first) family's (its spec)."""
    return config.robot or scene_spec(families(scene)[0]).robot


def arm_for(scene: str, config: TrainConfig) -> Chain:
    """The arm of :func:`robot_for`: a preset, or read from its robot file (ValueError naming ``--robot``)."""
    try:
        return load_robot(robot_for(scene, config))
    except (KeyError, ValueError) as exc:
        raise ValueError(f"--robot: {exc.args[0]}") from None


def judge_policy(policy: NumpyPolicy, scene_name: str, seeds, robot: str | Chain = "",
                 knowledge: str = "full") -> dict:
    """Plan with ``policy``'s deterministic roll-out alone (one attempt, no smoothing) on the scenes ``seeds`` (of
    ``scene_name``'s families, see :func:`families`) with ``knowledge`` and judge each path: success rate, median
    plan time (s), mean smoothness index of the successes, and the per-seed verdicts. ``robot``: a preset or robot
    file name, or an arm; default the family's (its spec); the scenes are sized to it. An arm-conditioned policy
    plans each seed's arm of the distribution (:func:`snakeplan.rl.envs.distribution_arm`) instead."""
    if not isinstance(robot, Chain):
        robot = load_robot(robot or robot_for(scene_name, DEFAULT_CONFIG))
    fixed = robot
    planner = SacPlanner(policy=policy, attempts=1, smoothing=())
    runs = []
    for seed in seeds:
        robot = distribution_arm(int(seed)) if policy.arm_conditioned else fixed
        episode = run_episode(Problem(scene_of(scene_name, int(seed), robot), robot, knowledge=knowledge), planner)
        report = episode.report
        runs.append({"seed": int(seed), "scene": episode.problem.scene.name, "success": episode.success,
                     "reason": episode.reason,
                     "outcome": episode.plan.details.get("outcome"), "time_s": episode.plan.compute_time_s,
                     "smoothness_index": report.smoothness_index if report else math.nan,
                     "path_length_mm": report.path_length_mm if report else math.nan})
    ok = [r for r in runs if r["success"]]
    return {"success_rate": len(ok) / max(len(runs), 1),
            "median_time_s": float(np.median([r["time_s"] for r in runs])) if runs else math.nan,
            "smoothness_index": float(np.mean([r["smoothness_index"] for r in ok])) if ok else math.nan,
            "runs": runs}


def make_env(scene: str, config: TrainConfig, arm: Chain | None = None):
    """A factory of training environments for ``scene`` with ``config``'s crawl and observation settings and
    ``arm`` (default: ``config``'s, :func:`arm_for`)."""
    seeds = (TRAIN_SEED, TRAIN_SEED + config.train_scenes)
    arm = arm_for(scene, config) if arm is None else arm
    return lambda: SnakeEnv(scene, observation=config.observation, robot=arm, seeds=seeds,
                            turn_radius_mm=config.turn_radius_mm, capture_steps=config.capture_steps,
                            lookahead=config.lookahead, knowledge=config.knowledge, residual=config.residual,
                            guide_weight=config.guide_weight, arm_conditioned=config.arm_conditioned)


def route_graph(scene: str, config: TrainConfig) -> RoomGraph | None:
    """The scene family's route graph, which the local observation's features read (None for "paper" and
    "guide")."""
    return RoomGraph.from_scene(make_scene(scene, TRAIN_SEED)) if config.observation == "local" else None


def build_model(scene: str, algorithm: str, config: TrainConfig, seed: int, env, steps: int):
    """The SB3 model of ``algorithm`` on ``env`` (buffer sized for ``steps``) and the scene family's route graph."""
    graph = route_graph(scene, config)
    policy_kwargs = {"net_arch": list(config.net_arch), "features_extractor_class": GoalRouteExtractor,
                     "features_extractor_kwargs": {"mode": config.observation,
                                                   "graph": graph.arrays() if graph else None},
                     "optimizer_kwargs": {"fused": True}}  # Adam in one kernel per step (bench rl: 1.05-1.15x)
    common = {"policy": "MultiInputPolicy", "env": env, "learning_rate": config.learning_rate, "tau": config.tau,
              "gamma": config.gamma, "batch_size": config.batch_size,
              "buffer_size": min(config.buffer_size, steps), "gradient_steps": config.gradient_steps,
              "train_freq": config.train_freq, "learning_starts": config.learning_starts,
              "policy_kwargs": policy_kwargs, "seed": seed, "verbose": 0, "epsilon_start": config.epsilon_start,
              "epsilon_min": config.epsilon_min, "epsilon_decay": config.epsilon_decay, "device": "cpu",
              "autodiff": config.autodiff, "overlap": config.overlap}
    if algorithm == "sac-her":
        return EpsilonGreedySAC(replay_buffer_class=FastHerReplayBuffer,
                                replay_buffer_kwargs={"n_sampled_goal": config.her_goals,
                                                      "goal_selection_strategy": "future"}, **common), graph
    if algorithm == "sac-per":
        return PerSAC(replay_buffer_class=PrioritizedDictReplayBuffer,
                      replay_buffer_kwargs={"alpha": config.per_alpha, "seed": seed},
                      beta_start=config.per_beta, **common), graph
    return EpsilonGreedySAC(replay_buffer_class=DictReplayBuffer, **common), graph


class _Monitor(CheckpointCallback):
    """Rolling training success, periodic validation and progress at each step; checkpoints and stops at the
    start of each rollout (:class:`snakeplan.rl.resumable.CheckpointCallback`)."""

    run: _Run

    def _on_training_start(self) -> None:
        self.run.start_bar()
        self.run.start_prefetch(self.model.num_timesteps)

    def _on_step(self) -> bool:
        run = self.run
        for info, done in zip(self.locals["infos"], self.locals["dones"]):
            if done:
                run.episodes.append(bool(info.get("is_success", False)))
        n = self.model.num_timesteps
        if n - run.last_eval >= run.config.eval_every:
            run.validate(n)
        run.advance(n)
        return True


#: The manifest's ``best`` before any validation.
NO_BEST = -1.0


class _Run(ResumableRun):
    """One training run's files and bookkeeping; its state folder is ``out`` itself."""

    def __init__(self, scene: str, algorithm: str, steps: int, seed: int, out: Path, config: TrainConfig,
                 progress: bool, command: str, arm: Chain):
        super().__init__(StateFolder(out, run_identity(scene, algorithm, seed, config)),
                         config.checkpoint_every or checkpoint_interval(steps))
        self.scene, self.algorithm, self.steps, self.seed, self.out = scene, algorithm, steps, seed, out
        self.config, self.progress, self.command = config, progress, command
        self.arm = arm
        self.history: list[dict] = []
        self.episodes: deque[bool] = deque(maxlen=ROLLING_EPISODES)
        self.last_eval = 0
        #: The best validation success rate so far and its policy.
        self.best: Best[NumpyPolicy] | None = None
        self.graph: RoomGraph | None = None
        self._bar: ProgressDisplay | None = None
        self._prefetch: ScenePrefetch | None = None
        self.seeds = range(VALIDATION_SEED, VALIDATION_SEED + config.eval_episodes)

    def meta(self, n: int) -> dict:
        crawler = self.model.env.envs[0].crawler
        arm = ({"arm_conditioned": True, "arm_range": ARM_RANGE.to_dict()} if self.config.arm_conditioned
               else {"robot": self.arm.name, "arm": arm_record(self.arm)})
        turn = {} if self.config.arm_conditioned else {"turn_radius_mm": crawler.step_mm / crawler.max_turn}
        return {"name": f"{self.scene}-{self.algorithm}", "scene": self.scene, "algorithm": self.algorithm, **arm,
                "observation": self.config.observation, "step_mm": crawler.step_mm, **turn,
                "capture_steps": round(crawler.capture_mm / crawler.step_mm), "lookahead": crawler.lookahead,
                "residual": crawler.residual,
                "env_steps": n, "seed": self.seed,
                "command": self.command,
                "config": {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self.config).items()}}

    def export(self, n: int) -> NumpyPolicy:
        with self.model.newest_actor():
            return from_sb3(self.model, self.meta(n), self.graph)

    def validate(self, n: int) -> None:
        policy = self.export(n)
        result = judge_policy(policy, self.scene, self.seeds, self.arm, self.config.knowledge)
        rolling = float(np.mean(self.episodes)) if self.episodes else 0.0
        self.history.append({"env_steps": n, "updates": int(self.model._n_updates), "wall_s": self.wall,
                             "success": result["success_rate"], "train_success": rolling,
                             "median_time_s": result["median_time_s"], "smoothness": result["smoothness_index"]})
        self.last_eval = n
        success = result["success_rate"]
        if self.best is None or self.best.beaten_by(success):
            policy.meta["validation_success"] = success
            self.best = Best(n, success, policy)
            _save_policy(policy, self.out / "policy.npz")
        self.write_curve()

    def snapshot(self, n: int) -> tuple[dict, dict]:
        """Generation ``n`` (see the module doc): model, replay buffer, environments, RNG states, best policy; the
        manifest records the evaluation history and the counters."""
        writers = sb3_files(self.model)
        if self.best is not None:
            writers["best.npz"] = self.best.item.save
        record = {"env_steps": n, "history": self.history, "last_eval": self.last_eval, "wall_s": self.wall,
                  "best": NO_BEST if self.best is None else self.best.key, "episodes": list(self.episodes)}
        return writers, record

    def restore(self, generation: Generation) -> None:
        """Continue from ``generation``: the model, its replay buffer, environments and RNG states as saved, so the
        run goes on as if never stopped; the top-level policy and curve are rewritten to match it."""
        self.model = sb3_restore({"sac-per": PerSAC}.get(self.algorithm, EpsilonGreedySAC), generation)
        record = generation.record
        self.last_eval, self.wall_before, self.history = record["last_eval"], record["wall_s"], record["history"]
        self.episodes.extend(record["episodes"])
        if "best.npz" in generation.files:
            self.best = Best(None, record["best"], NumpyPolicy.load(generation.path("best.npz")))
            _save_policy(self.best.item, self.out / "policy.npz")
        if self.history:
            self.write_curve()

    def write_curve(self) -> None:
        atomic_write(self.out / "curve.json", json.dumps(self.history, indent=1))
        with atomic_path(self.out / "curve.png") as tmp:
            plot_curves({f"{self.scene} {self.algorithm}": [self.history]}, tmp)

    def start_bar(self) -> None:
        """Progress over the run's steps on standard output (:class:`snakeplan.parallel.ProgressDisplay`: a bar on
        a terminal; in a log a plain line ``... step n/steps ...`` every 1 % of the run)."""
        if self.progress:
            self._bar = ProgressDisplay(self.steps, f"{self.scene} {self.algorithm}", sys.stdout,
                                        every=self._every, unit="step ")

    @property
    def _every(self) -> int:
        return max(1, self.steps // 100)

    def advance(self, n: int) -> None:
        if self._bar is None or n % self._every:
            return
        last = self.history[-1]["success"] if self.history else float("nan")
        rolling = float(np.mean(self.episodes)) if self.episodes else 0.0
        self._bar.update(n, f"train {rolling:.0%}  val {last:.0%}  {n / max(self.wall, 1e-9):.0f} steps/s")

    def start_prefetch(self, n: int) -> None:
        """Make the scenes of the rest of the run, from step ``n``, ahead of use on ``config.scene_workers``
        processes (the environments have drawn their first scenes by now). Enough draws for episodes of
        ``PREFETCH_EPISODE_STEPS`` steps (a run's scenes repeat long before); the validation scenes come after as
        many training scenes as there are validation episodes (the first validation is thousands of steps away)."""
        workers = self.config.scene_workers
        workers = min(1, usable_cores() - 1) if workers < 0 else workers
        if workers == 0 or n >= self.steps or multiprocessing.current_process().daemon:  # a pool's worker: no pool
            return
        envs = [env.unwrapped for env in self.model.env.envs]
        draws = (self.steps - n) // (len(envs) * PREFETCH_EPISODE_STEPS) + 1
        seeds = upcoming(envs, draws)
        seeds = seeds[:len(self.seeds)] + list(self.seeds) + seeds[len(self.seeds):]
        families_of = [family_of(self.scene, seed) for seed in seeds]
        arms = [distribution_arm(seed) if self.config.arm_conditioned else self.arm for seed in seeds]
        keys = [(f, seed, arm_sizing(f, arm)) for f, seed, arm in zip(families_of, seeds, arms)]
        self._prefetch = ScenePrefetch(keys, workers).start()

    def stop_prefetch(self) -> None:
        if self._prefetch is not None:
            self._prefetch.close()
            self._prefetch = None

    def stop_bar(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def _save_policy(policy: NumpyPolicy, path: Path) -> None:
    with atomic_path(path) as tmp:
        policy.save(tmp)


#: Configuration fields that may change when a run is resumed (they do not change what is learned).
RESUMABLE_CHANGES = ("eval_every", "checkpoint_every", "torch_threads", "scene_workers")


#: Configuration fields added after checkpoints were first written: left out of a run's identity at their
#: defaults, so that a state folder written before them still resumes.
LATER_FIELDS = ("knowledge", "residual", "guide_weight", "autodiff", "overlap", "arm_conditioned")


def run_identity(scene: str, algorithm: str, seed: int, config: TrainConfig) -> dict:
    """What a checkpoint must match to be resumed: scene, algorithm, seed and the configuration (except
    :data:`RESUMABLE_CHANGES`, and :data:`LATER_FIELDS` at their defaults); the number of steps may grow."""
    base = asdict(DEFAULT_CONFIG)
    return {"trainer": "snakeplan.rl.train", "scene": scene, "algorithm": algorithm, "seed": seed,
            "config": {k: v for k, v in asdict(config).items() if k not in RESUMABLE_CHANGES
                       and not (k in LATER_FIELDS and v == base[k])}}


def train(scene: str, algorithm: str, steps: int, seed: int, out_dir: str | Path,
          config: TrainConfig = DEFAULT_CONFIG, progress: bool = True, resume: bool = True) -> TrainResult:
    """Train ``algorithm`` ("sac-her", "sac-per", "sac") on scene family ``scene`` for ``steps`` environment
    steps with ``seed``; files go to ``out_dir`` (see the module doc). With ``resume``, the checkpoint there is
    continued up to ``steps``; without, it is deleted first. SIGINT or SIGTERM saves a checkpoint and raises
    :class:`snakeplan.interrupt.Interrupted`. With scene workers (``config.scene_workers``, none by default here)
    a script that calls this must start under ``if __name__ == "__main__":``, as for any pool of spawned
    processes: each worker imports the script. A process that is itself a pool's worker makes its own scenes."""
    if algorithm not in ALGORITHMS:
        raise ValueError(f"algorithm: must be one of {ALGORITHMS}, got {algorithm!r}")
    if steps <= 0:
        raise ValueError(f"steps: must be positive, got {steps}")
    if config.checkpoint_every < 0:
        raise ValueError(f"--checkpoint-every: must be 0 (the default interval) or positive, "
                         f"got {config.checkpoint_every}")
    for family in families(scene):
        if family not in scene_names():
            raise ValueError(f"scene: unknown scene family {family!r} (known: {', '.join(scene_names())})")
        if scene_spec(family).task != "reach":
            raise ValueError(f"scene: {family} has no targets to learn to reach (its task: "
                             f"{scene_spec(family).task})")
    if config.observation == "local" and len(families(scene)) > 1:
        raise ValueError(f"scene: the local observation reads one family's rooms; train {scene} with "
                         f"--observation guide")
    if config.knowledge not in tuple(Knowledge):
        raise ValueError(f"--knowledge: must be full or sensed, got {config.knowledge!r}")
    if config.knowledge == "sensed" and config.observation == "paper":
        raise ValueError("--knowledge: the paper observation has no range sensor, so nothing would be sensed; "
                         "use local or guide")
    if config.observation != "guide" and (config.residual or config.guide_weight != DEFAULT_CONFIG.guide_weight):
        raise ValueError(f"--residual, --guide-weight: only the guide observation follows a route guide, not "
                         f"{config.observation}")
    if config.autodiff not in AUTODIFF:
        raise ValueError(f"--autodiff: must be one of {', '.join(AUTODIFF)}, got {config.autodiff!r}")
    if config.autodiff == "jax" and not all(importlib.util.find_spec(m) for m in ("jax", "optax")):
        raise ValueError("--autodiff: jax needs JAX and optax (pip install 'snakeplan[train]')")
    if config.overlap and config.autodiff != "jax":
        raise ValueError("--overlap: the roll-outs overlap the updates only when JAX computes them; add "
                         "--autodiff jax")
    if config.overlap and algorithm == "sac-per":
        raise ValueError("--overlap: SAC-PER sets its priorities from each call's TD errors before the next "
                         "sample; train it with --overlap false")
    if config.scene_workers < -1:
        raise ValueError(f"--scene-workers: must be -1 (one when another core is free), 0 (none) or positive, "
                         f"got {config.scene_workers}")
    if config.arm_conditioned and config.turn_radius_mm != DEFAULT_CONFIG.turn_radius_mm:
        raise ValueError("--turn-radius-mm: an arm-conditioned run turns each arm on its own radius "
                         "(snakeplan.robots.arm_range.turn_radius_for); leave it out")
    if config.arm_conditioned and config.robot:
        raise ValueError("--arm-conditioned: each scene seed draws its own arm; leave --robot out")
    if config.arm_conditioned and config.observation == "paper":
        raise ValueError("--arm-conditioned: the paper observation carries no arm features; use local or guide")
    if not (math.isfinite(config.guide_weight) and config.guide_weight >= 0.0):
        raise ValueError(f"--guide-weight: must be a finite number >= 0, got {config.guide_weight}")
    if not config.arm_conditioned:  # an arm-conditioned run's command names no robot: its seeds draw the arms
        config = replace(config, robot=robot_for(scene, config))
    arm, own = arm_for(scene, config), get_robot(scene_spec(families(scene)[0]).robot)
    if (config.turn_radius_mm == DEFAULT_CONFIG.turn_radius_mm and not config.arm_conditioned
            and not fits_arm(arm_record(own), arm)):
        config = replace(config, turn_radius_mm=turn_radius_for(arm))  # another arm turns on its own radius
    th.set_num_threads(config.torch_threads)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    command = _command(scene, algorithm, steps, seed, out, config)
    run = _Run(scene, algorithm, steps, seed, out, config, progress, command, arm)
    with run.session(resume) as (stop, generation):
        return _train(run, stop, generation)


def _train(run: _Run, stop: StopRequest, generation: Generation | None) -> TrainResult:
    if generation is None:
        env = DummyVecEnv([make_env(run.scene, run.config, run.arm)] * run.config.n_envs)
        env.seed(run.seed)
        run.model, run.graph = build_model(run.scene, run.algorithm, run.config, run.seed, env, run.steps)
    else:
        run.graph = route_graph(run.scene, run.config)
        run.restore(generation)
    try:
        try:
            n = run.learn(run.steps, _Monitor(run, stop), fresh=generation is None)
        finally:
            run.stop_bar()
        if run.last_eval < n:
            run.validate(n)
    finally:
        run.stop_prefetch()  # after the last validation, whose scenes it may be making
    _save_policy(run.export(n), run.out / "last.npz")
    run.finish(n, stop)
    return TrainResult(run.out, run.out / "policy.npz", run.history)


def _command(scene: str, algorithm: str, steps: int, seed: int, out: Path, config: TrainConfig) -> str:
    """The command line that reproduces this run."""
    args = ["python", "-m", "snakeplan.rl.train", scene, algorithm, "--steps", str(steps), "--seed", str(seed),
            "--out", str(out)]
    base = asdict(DEFAULT_CONFIG)
    for key, value in asdict(config).items():
        if value != base[key] and key != "scene_workers":  # how scenes are made, not what is learned
            flag = "--" + key.replace("_", "-")
            args += [flag, *map(str, value)] if isinstance(value, tuple) else [flag, str(value).lower()]
    return shlex.join(args)


def plot_curves(curves: dict[str, list[list[dict]]], path: str | Path, key: str = "success", title: str = "") -> None:
    """Validation success against environment steps: one line per label (mean over its runs, band = min-max)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for label, runs in curves.items():
        runs = [r for r in runs if r]
        if not runs:
            continue
        grid = np.unique(np.concatenate([[h["env_steps"] for h in r] for r in runs]))
        ys = np.array([np.interp(grid, [h["env_steps"] for h in r], [h[key] for h in r]) for r in runs])
        ax.plot(grid, ys.mean(axis=0), label=label)
        if len(runs) > 1:
            ax.fill_between(grid, ys.min(axis=0), ys.max(axis=0), alpha=0.2)
    ax.set_xlabel("environment steps")
    ax.set_ylabel("validation success rate" if key == "success" else key)
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")  # learning curves rise: the early, upper corner is empty
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _boolean(text: str) -> bool:
    if text.lower() in ("true", "1", "yes"):
        return True
    if text.lower() in ("false", "0", "no"):
        return False
    raise argparse.ArgumentTypeError(f"expected true or false, got {text!r}")


class _OptionParser(argparse.ArgumentParser):
    def error(self, message: str):  # a ValueError the command line reports as one line
        raise ValueError(f"trainer option: {message}")


def add_config_arguments(p) -> None:
    """``--paper`` or ``--jax`` (the configuration to start from) and one ``--field-name`` flag per
    :class:`TrainConfig` field, on ``p`` (a parser or an argument group)."""
    p.add_argument("--paper", action="store_true", help="start from the paper's hyper-parameters (§4.1)")
    p.add_argument("--jax", action="store_true", help="start from JAX_CONFIG: JAX updates overlapping the roll-outs, "
                   "learning rate 1e-3 (fuel-tank to 0.9 in under three minutes on two cores)")
    for f in DEFAULT_CONFIG.__dataclass_fields__.values():
        flag = "--" + f.name.replace("_", "-")
        if isinstance(f.default, tuple):
            p.add_argument(flag, type=int, nargs="+", default=None)
        elif isinstance(f.default, bool):
            p.add_argument(flag, type=_boolean, default=None, metavar="true|false")
        else:
            p.add_argument(flag, type=type(f.default), default=None)


def config_from(args: argparse.Namespace) -> TrainConfig:
    """The options' configuration; from the command line, scenes are made ahead by default (``--scene-workers -1``:
    its entry points are guarded)."""
    if args.paper and args.jax:
        raise ValueError("--paper, --jax: choose one configuration to start from")
    config = replace(PAPER_CONFIG if args.paper else JAX_CONFIG if args.jax else DEFAULT_CONFIG, scene_workers=-1)
    changes = {k: (tuple(v) if isinstance(v, list) else v) for k in DEFAULT_CONFIG.__dataclass_fields__
               if (v := getattr(args, k)) is not None}
    return replace(config, **changes)


def parse_config(options: list[str]) -> TrainConfig:
    """The configuration that trainer options (``--paper``, ``--turn-radius-mm 215``, ...) describe; ValueError
    naming the option on a bad one."""
    p = _OptionParser(prog="trainer options", add_help=False)
    add_config_arguments(p)
    return config_from(p.parse_args(options))


if __name__ == "__main__":  # the command shipped policies record: 'snakeplan train rl', trainer options listed
    # run by the command line's own parser in this process's place: this layer imports no command line
    os.execv(sys.executable, [sys.executable, "-c", "import sys; from snakeplan.cli import trainer_main; "
                              "sys.exit(trainer_main())", *sys.argv[1:]])
