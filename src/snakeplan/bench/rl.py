"""Training throughput of the learned planners: environment steps, SAC updates, policy calls (per second).

Each figure is the median of several timed blocks, with a baseline timed in the same process:

- environment steps with random actions (``local`` observation: rays, route features; both scenes), against the
  ``paper`` observation (the tip position alone), which costs only the crawl;
- SAC-HER training steps (one environment step and one gradient update of batch 128 each, the default
  update-to-data ratio) with the default 128 x 128 networks, against paper 000's 512 x 512;
- one deterministic action of the NumPy actor that planning uses, against SB3's ``model.predict``.

Torch runs on one thread, as training does. Episodes draw from ``BENCH_SCENES`` scenes generated before timing,
so the figures are the per-step costs, not scene generation (a fuel-tank scene takes tens of milliseconds to
generate; training meets each of its scenes once before the cache serves it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
import torch as th
from stable_baselines3.common.vec_env import DummyVecEnv

from snakeplan.bench.kernels import median_seconds
from snakeplan.rl.envs import TRAIN_SEED, SnakeEnv
from snakeplan.rl.policy import from_sb3
from snakeplan.rl.train import DEFAULT_CONFIG, PAPER_CONFIG, build_model, make_env

#: Environment steps per timed block.
ENV_BLOCK = 500
#: Training steps per timed block (after ``learning_starts`` steps that fill the buffer).
TRAIN_BLOCK = 200
#: Scenes the timed environments draw from (generated before timing).
BENCH_SCENES = 4
#: Replay buffer size of the timed models (more than they ever hold).
BUFFER_STEPS = 100_000
#: Policy calls per timed block.
CALL_BLOCK = 200


def _generate_scenes(env: SnakeEnv) -> None:
    """Generate the ``BENCH_SCENES`` scenes an environment draws from, before anything is timed."""
    for k in range(BENCH_SCENES):
        env.scene_for(TRAIN_SEED + k)


def _env_rate(scene: str, observation: str, repeats: int, seed: int) -> float:
    env = SnakeEnv(scene, observation=observation, seeds=(TRAIN_SEED, TRAIN_SEED + BENCH_SCENES))
    _generate_scenes(env)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)

    def block() -> None:
        for _ in range(ENV_BLOCK):
            _, _, terminated, truncated, _ = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape))
            if terminated or truncated:
                env.reset()

    return ENV_BLOCK / median_seconds(block, repeats)


def _train_rate(config, repeats: int, seed: int):
    """SAC-HER training steps per second with ``config``, and the trained model with its route graph."""
    config = replace(config, learning_starts=TRAIN_BLOCK, train_scenes=BENCH_SCENES)
    env = DummyVecEnv([make_env("fuel-tank", config)])
    _generate_scenes(env.envs[0].unwrapped)
    env.seed(seed)
    model, graph = build_model("fuel-tank", "sac-her", config, seed, env, BUFFER_STEPS)
    model.learn(TRAIN_BLOCK)
    rate = TRAIN_BLOCK / median_seconds(lambda: model.learn(TRAIN_BLOCK, reset_num_timesteps=False), repeats)
    return rate, model, graph


def _call_rates(model, graph, repeats: int, seed: int) -> tuple[float, float]:
    """Actor calls per second: the NumPy export of ``model`` and SB3's ``predict`` on the same observation."""
    policy = from_sb3(model, {"observation": "local"}, graph)
    obs, _ = SnakeEnv("fuel-tank").reset(seed=seed)

    def calls(fn: Callable) -> Callable[[], None]:
        def block() -> None:
            for _ in range(CALL_BLOCK):
                fn(obs)
        return block

    numpy_rate = CALL_BLOCK / median_seconds(calls(policy.act), repeats)
    sb3_rate = CALL_BLOCK / median_seconds(calls(lambda o: model.predict(o, deterministic=True)), repeats)
    return numpy_rate, sb3_rate


def run_rl_bench(repeats: int = 5, seed: int = 0) -> dict:
    """The figures of the module doc as a dict (rates per second, ratios against the baselines)."""
    threads = th.get_num_threads()
    th.set_num_threads(DEFAULT_CONFIG.torch_threads)
    try:
        env = {scene: {obs: _env_rate(scene, obs, repeats, seed) for obs in ("local", "paper")}
               for scene in ("fuel-tank", "oil-tank")}
        ours, model, graph = _train_rate(DEFAULT_CONFIG, repeats, seed)
        paper, _, _ = _train_rate(PAPER_CONFIG, repeats, seed)
        numpy_rate, sb3_rate = _call_rates(model, graph, repeats, seed)
    finally:
        th.set_num_threads(threads)
    return {
        "env_steps_per_s": env,
        "train_steps_per_s": {"default_128x128": ours, "paper_512x512": paper, "ratio": ours / paper},
        "policy_calls_per_s": {"numpy_actor": numpy_rate, "sb3_predict": sb3_rate, "ratio": numpy_rate / sb3_rate},
        "settings": {"repeats": repeats, "seed": seed, "env_block": ENV_BLOCK, "train_block": TRAIN_BLOCK,
                     "batch_size": DEFAULT_CONFIG.batch_size, "torch_threads": DEFAULT_CONFIG.torch_threads},
    }


def rl_markdown(r: dict) -> str:
    """The figures as a small Markdown table."""
    rows = ["| figure | per second | baseline | per second | ratio |", "|---|---|---|---|---|"]
    for scene, e in r["env_steps_per_s"].items():
        rows.append(f"| {scene} env steps, local observation | {e['local']:,.0f} | paper observation | "
                    f"{e['paper']:,.0f} | {e['local'] / e['paper']:.2f}x |")
    t = r["train_steps_per_s"]
    rows.append(f"| SAC-HER training steps (1 update each), 128 x 128 | {t['default_128x128']:,.1f} | 512 x 512 | "
                f"{t['paper_512x512']:,.1f} | {t['ratio']:.2f}x |")
    c = r["policy_calls_per_s"]
    rows.append(f"| actor calls, NumPy | {c['numpy_actor']:,.0f} | SB3 predict | {c['sb3_predict']:,.0f} | "
                f"{c['ratio']:.1f}x |")
    return "\n".join(rows)
