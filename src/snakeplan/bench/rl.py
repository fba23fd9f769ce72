"""Training throughput of the learned planners: environment steps, SAC updates, policy calls (per second).

Each figure is the median of several timed blocks, with a baseline timed in the same process:

- environment steps with random actions (``local`` observation: rays, route features; both scenes), against the
  ``paper`` observation (the tip position alone), which costs only the crawl;
- SAC-HER training steps (one environment step and one gradient update of batch 128 each, the default
  update-to-data ratio) with the default 128 x 128 networks, against paper 000's 512 x 512;
- one deterministic action of the NumPy actor that planning uses, against SB3's ``model.predict``;
- the levers of training speed:
  - the shared SAC update (:class:`snakeplan.rl.agents.EpsilonGreedySAC`, batch 128) against SB3's ``SAC.train``
    on the same model, and its fused Adam against the unfused one (alternating blocks, the median of paired
    ratios);
  - training steps per second of the first ``PREFETCH_STEPS`` steps of a fuel-tank SAC-HER run on fresh scenes,
    made ahead by a worker (:mod:`snakeplan.scenes.prefetch`) against made when drawn, with the seconds the
    trainer spent on scenes in each;
  - one SAC gradient update (128 x 128, torch, one thread) per batch size (``BATCH_SIZES``; updates and samples
    per second), against batch 128;
  - training steps per second of the guide design with the default settings (one environment, batch 128, one
    update per step) against :data:`snakeplan.rl.train.FAST_CONFIG` (four environments, batch 512, one update per
    four steps: a quarter of the update-to-data ratio at four times the samples per update, so as many samples per
    step);
  - the JAX updates (:mod:`snakeplan.rl.jax_update`, the same update) against the torch ones on copies of the same
    model, one update per call and ``JAX_CONFIG.gradient_steps`` per call (paired blocks), and the training steps
    per second of :data:`snakeplan.rl.train.JAX_CONFIG` (ten environment steps, then twenty updates in one call)
    without overlap against the default (one step, one update), and with the roll-outs overlapping the updates
    (``overlap``: XLA computes a call's updates on its own thread while the next ten steps run) against without;
  - when SBX (JAX) is installed, the same update in SBX one call at a time and ``FUSED_UPDATES`` fused into one
    call, against torch.

Torch runs on one thread, as training does. Apart from the prefetch runs, episodes draw from ``BENCH_SCENES``
scenes generated before timing, so the figures are the per-step costs, not scene generation (a fuel-tank scene
takes about 90 ms to generate; training meets each of its scenes once before the cache serves it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
import torch as th
from stable_baselines3.common.vec_env import DummyVecEnv

from snakeplan.bench.kernels import median_seconds
from snakeplan.planners.sac.observation import input_dim, observation_dim
from snakeplan.rl.envs import TRAIN_SEED, SnakeEnv
from snakeplan.rl.policy import from_sb3
from snakeplan.rl.train import (
    DEFAULT_CONFIG,
    FAST_CONFIG,
    JAX_CONFIG,
    PAPER_CONFIG,
    build_model,
    make_env,
)

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
#: Batch sizes of the update benchmark.
BATCH_SIZES = (128, 256, 512, 1024)
#: Alternating blocks, and updates per block, of the shared update against SB3's.
PAIRED_BLOCKS = 10
PAIRED_UPDATES = 100
#: Training steps of the scene prefetch benchmark (one run each way, on the same fresh scenes).
PREFETCH_STEPS = 3000
#: Updates per timed block of the update benchmark, and updates fused into one SBX call.
UPDATE_BLOCK = 20
FUSED_UPDATES = 50


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


def _learning_model(config, seed: int):
    """A SAC-HER model with ``config`` on ``BENCH_SCENES`` fuel-tank scenes, past its random first
    ``TRAIN_BLOCK`` steps, and its route graph."""
    config = replace(config, learning_starts=TRAIN_BLOCK, train_scenes=BENCH_SCENES)
    env = DummyVecEnv([make_env("fuel-tank", config)] * config.n_envs)
    for e in env.envs:
        _generate_scenes(e.unwrapped)
    env.seed(seed)
    model, graph = build_model("fuel-tank", "sac-her", config, seed, env, BUFFER_STEPS)
    model.learn(TRAIN_BLOCK)
    return model, graph


def _block(model) -> Callable[[], None]:
    """``TRAIN_BLOCK`` more training steps of ``model``, and the wait for the updates it still computes (with
    ``overlap``), so that each block's work is timed in that block."""
    def block() -> None:
        model.learn(TRAIN_BLOCK, reset_num_timesteps=False)
        with model.newest_actor():  # reading the newest weights waits for them
            pass
    return block


def _train_rate(config, repeats: int, seed: int):
    """SAC-HER training steps per second with ``config``, and the trained model with its route graph."""
    model, graph = _learning_model(config, seed)
    return TRAIN_BLOCK / median_seconds(_block(model), repeats), model, graph


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


def _update_rates(model, repeats: int) -> dict[int, float]:
    """Gradient updates per second of a trained SB3 model at each of ``BATCH_SIZES``."""
    rates = {}
    for batch in BATCH_SIZES:
        model.batch_size = batch
        rates[batch] = UPDATE_BLOCK / median_seconds(lambda b=batch: model.train(UPDATE_BLOCK, b), repeats)
    return rates


def _paired_update_rates(ours: Callable[[int, int], None], baseline: Callable[[int, int], None],
                         repeats: int) -> dict:
    """Gradient updates per second (batch 128) of ``ours`` and ``baseline`` (each called as ``f(updates,
    batch)``), in ``PAIRED_BLOCKS`` alternating pairs of ``PAIRED_UPDATES`` each (medians; the ratio is the median
    of the pairs' ratios, which a machine's load swings cancel out of)."""
    return _paired_rates(lambda: ours(PAIRED_UPDATES, DEFAULT_CONFIG.batch_size),
                         lambda: baseline(PAIRED_UPDATES, DEFAULT_CONFIG.batch_size), PAIRED_UPDATES, repeats)


def _paired_rates(ours: Callable[[], None], baseline: Callable[[], None], units: int, repeats: int) -> dict:
    """Units per second of ``ours`` and ``baseline`` (each call does ``units``), in ``PAIRED_BLOCKS`` (or
    ``repeats``) alternating pairs: medians, and the median of the pairs' ratios."""
    import time

    rates: tuple[list[float], list[float]] = ([], [])
    for _ in range(max(repeats, PAIRED_BLOCKS)):
        for out, step in zip(rates, (ours, baseline)):
            t0 = time.perf_counter()
            step()
            out.append(units / (time.perf_counter() - t0))
    return {"ours": float(np.median(rates[0])), "baseline": float(np.median(rates[1])),
            "ratio": float(np.median(np.divide(*rates)))}


def _update_levers(model, repeats: int) -> dict:
    """The shared update (:class:`snakeplan.rl.agents.EpsilonGreedySAC`) against SB3's ``SAC.train`` on the same
    model; fused Adam (training's optimiser) against the same model's copy with the unfused one."""
    import copy

    from stable_baselines3 import SAC

    unfused = copy.deepcopy(model)
    for optimizer in (unfused.actor.optimizer, unfused.critic.optimizer):
        for group in optimizer.param_groups:
            group["fused"] = False
    return {"shared_vs_sb3": _paired_update_rates(model.train, lambda n, b: SAC.train(model, n, b), repeats),
            "fused_vs_unfused": _paired_update_rates(model.train, unfused.train, repeats)}


def _jax_levers(model, default: float, repeats: int, seed: int) -> dict:
    """The JAX updates (one per call, and ``JAX_CONFIG.gradient_steps`` per call) against the torch
    ones on copies of ``model``; the training steps per second of ``JAX_CONFIG`` against the default's
    (``default``, measured by the caller), and with the roll-outs overlapping the updates against without."""
    import copy

    jax_model = copy.deepcopy(model)
    jax_model.autodiff = "jax"
    fused = JAX_CONFIG.gradient_steps

    def calls(per_call: int) -> Callable[[int, int], None]:
        def step(n: int, batch: int) -> None:
            for _ in range(n // per_call):
                jax_model.train(per_call, batch)
        return step

    for per_call in (1, fused):  # compiles each
        jax_model.train(per_call, DEFAULT_CONFIG.batch_size)
    one = _paired_update_rates(calls(1), model.train, repeats)
    many = _paired_update_rates(calls(fused), model.train, repeats)
    plain, _ = _learning_model(replace(JAX_CONFIG, overlap=False), seed)
    overlapped, _ = _learning_model(replace(JAX_CONFIG, overlap=True), seed)
    overlap = _paired_rates(_block(overlapped), _block(plain), TRAIN_BLOCK, repeats)
    jax_rate = overlap["baseline"]
    return {"one_per_call": one, "fused": many,
            "train_steps_per_s": {"jax_config": jax_rate, "default": default, "ratio": jax_rate / default},
            "overlap_train_steps_per_s": overlap}


def _prefetch_rates(seed: int) -> dict:
    """The first ``PREFETCH_STEPS`` steps of the default fuel-tank SAC-HER run with its scenes made ahead by one
    worker and made when drawn, each starting with no scene made: training steps per second, and the seconds the
    trainer spent making scenes or waiting for them (what the worker takes off it; the steps per second swing with
    the machine's load as much as this changes them)."""
    import tempfile
    import time

    from snakeplan.rl import envs
    from snakeplan.rl.train import train

    config = replace(DEFAULT_CONFIG, eval_every=10 * PREFETCH_STEPS, eval_episodes=1,
                     checkpoint_every=10 * PREFETCH_STEPS)
    spent = [0.0]

    def timed(f: Callable) -> Callable:
        def call(*args):
            t0 = time.perf_counter()
            try:
                return f(*args)
            finally:
                spent[0] += time.perf_counter() - t0
        return call

    out: dict = {}
    family_scene = envs.family_scene  # every scene of a run comes through it (made, taken or cached)
    envs.family_scene = timed(family_scene)
    try:
        for name, workers in (("made_when_drawn", 0), ("made_ahead", 1)):
            family_scene.cache_clear()
            spent[0] = 0.0
            with tempfile.TemporaryDirectory() as folder:
                t0 = time.perf_counter()
                train("fuel-tank", "sac-her", PREFETCH_STEPS, seed, folder, replace(config, scene_workers=workers),
                      progress=False)
                out[name] = {"steps_per_s": PREFETCH_STEPS / (time.perf_counter() - t0), "scene_s": spent[0]}
    finally:
        envs.family_scene = family_scene
        family_scene.cache_clear()
    out["ratio"] = out["made_ahead"]["steps_per_s"] / out["made_when_drawn"]["steps_per_s"]
    return out


def _sbx_rates(repeats: int, seed: int) -> dict | None:
    """SBX's SAC update (same widths and batch 128, flat inputs of the guide design's width) one call at a time and
    fused, against SB3's on the same inputs: updates per second; None when SBX is not installed."""
    try:
        import sbx
    except ImportError:
        return None
    import gymnasium as gym
    import stable_baselines3 as sb3
    from gymnasium import spaces

    width = input_dim("guide", observation_dim("guide"))

    class Flat(gym.Env):
        observation_space = spaces.Box(-1.0, 1.0, (width,), np.float32)
        action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)

        def reset(self, *, seed=None, options=None):
            super().reset(seed=seed)
            return self.observation_space.sample(), {}

        def step(self, action):
            return self.observation_space.sample(), 0.0, False, False, {}

    kwargs = {"learning_starts": TRAIN_BLOCK, "policy_kwargs": {"net_arch": list(DEFAULT_CONFIG.net_arch)},
              "seed": seed, "verbose": 0, "batch_size": DEFAULT_CONFIG.batch_size}
    torch_model = sb3.SAC("MlpPolicy", Flat(), device="cpu", **kwargs)
    jax_model = sbx.SAC("MlpPolicy", Flat(), **kwargs)
    out = {}
    for name, model in (("torch", torch_model), ("sbx", jax_model)):
        model.learn(TRAIN_BLOCK + 1)
        for fused in (1, FUSED_UPDATES):
            calls = max(1, UPDATE_BLOCK // fused) if fused == 1 else 1

            def block(m=model, f=fused, c=calls) -> None:
                for _ in range(c):
                    m.train(f, DEFAULT_CONFIG.batch_size)

            out[f"{name}_fused_{fused}"] = calls * fused / median_seconds(block, repeats)
    out["sbx_fused_vs_torch"] = out[f"sbx_fused_{FUSED_UPDATES}"] / out["torch_fused_1"]
    return out


def run_rl_bench(repeats: int = 5, seed: int = 0) -> dict:
    """The figures of the module doc as a dict (rates per second, ratios against the baselines)."""
    threads = th.get_num_threads()
    th.set_num_threads(DEFAULT_CONFIG.torch_threads)
    try:
        env = {scene: {obs: _env_rate(scene, obs, repeats, seed) for obs in ("local", "paper")}
               for scene in ("fuel-tank", "oil-tank")}
        env["fuel-tank"]["guide"] = _env_rate("fuel-tank", "guide", repeats, seed)
        ours, model, graph = _train_rate(DEFAULT_CONFIG, repeats, seed)
        paper, _, _ = _train_rate(PAPER_CONFIG, repeats, seed)
        numpy_rate, sb3_rate = _call_rates(model, graph, repeats, seed)
        updates = _update_rates(model, repeats)
        levers = _update_levers(model, repeats)
        prefetch = _prefetch_rates(seed)
        guide = replace(DEFAULT_CONFIG, observation="guide", knowledge="sensed")
        guide_default, _, _ = _train_rate(guide, repeats, seed)
        guide_fast, _, _ = _train_rate(replace(FAST_CONFIG, observation="guide", knowledge="sensed"), repeats, seed)
        sbx_rates = _sbx_rates(repeats, seed)
        jax_levers = _jax_levers(model, ours, repeats, seed)
    finally:
        th.set_num_threads(threads)
    return {
        "env_steps_per_s": env,
        "train_steps_per_s": {"default_128x128": ours, "paper_512x512": paper, "ratio": ours / paper},
        "policy_calls_per_s": {"numpy_actor": numpy_rate, "sb3_predict": sb3_rate, "ratio": numpy_rate / sb3_rate},
        "updates_per_s": {str(b): r for b, r in updates.items()},
        "update_levers_per_s": levers,
        "prefetch_train_steps_per_s": prefetch,
        "guide_train_steps_per_s": {"default": guide_default, "fast": guide_fast, "ratio": guide_fast / guide_default},
        "sbx_updates_per_s": sbx_rates,
        "jax_autodiff_per_s": jax_levers,
        "settings": {"repeats": repeats, "seed": seed, "env_block": ENV_BLOCK, "train_block": TRAIN_BLOCK,
                     "prefetch_steps": PREFETCH_STEPS,
                     "batch_size": DEFAULT_CONFIG.batch_size, "torch_threads": DEFAULT_CONFIG.torch_threads,
                     "fast": {"n_envs": FAST_CONFIG.n_envs, "batch_size": FAST_CONFIG.batch_size,
                              "gradient_steps": FAST_CONFIG.gradient_steps, "train_freq": FAST_CONFIG.train_freq},
                     "jax": {"train_freq": JAX_CONFIG.train_freq, "gradient_steps": JAX_CONFIG.gradient_steps}},
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
    for key, ours, baseline in (("shared_vs_sb3", "shared update", "SB3 SAC.train"),
                                ("fused_vs_unfused", "fused Adam", "unfused Adam")):
        v = r["update_levers_per_s"][key]
        rows.append(f"| SAC updates, batch 128, {ours} | {v['ours']:,.1f} | {baseline} | {v['baseline']:,.1f} | "
                    f"{v['ratio']:.2f}x |")
    f = r["prefetch_train_steps_per_s"]
    ahead, drawn = f["made_ahead"], f["made_when_drawn"]
    rows.append(f"| first {r['settings']['prefetch_steps']:,} training steps, fresh scenes made ahead (trainer's "
                f"scene time {ahead['scene_s']:.1f} s) | {ahead['steps_per_s']:,.1f} | made when drawn "
                f"({drawn['scene_s']:.1f} s) | {drawn['steps_per_s']:,.1f} | {f['ratio']:.2f}x |")
    u = r["updates_per_s"]
    for batch, rate in u.items():
        rows.append(f"| SAC updates, batch {batch} (samples/s {rate * int(batch):,.0f}) | {rate:,.1f} | batch 128 | "
                    f"{u['128']:,.1f} | {rate * int(batch) / (u['128'] * 128):.2f}x samples/s |")
    g = r["guide_train_steps_per_s"]
    fast = r["settings"]["fast"]
    rows.append(f"| guide design training steps, {fast['n_envs']} envs, batch {fast['batch_size']}, "
                f"{fast['gradient_steps']} update per {fast['n_envs'] * fast['train_freq']} steps | {g['fast']:,.1f} | "
                f"1 env, batch 128, 1 update per step | {g['default']:,.1f} | {g['ratio']:.2f}x |")
    j, jax = r["jax_autodiff_per_s"], r["settings"]["jax"]
    for key, what in (("one_per_call", "one per call"), ("fused", f"{jax['gradient_steps']} per call")):
        v = j[key]
        rows.append(f"| SAC updates, batch 128, JAX, {what} | {v['ours']:,.1f} | torch, one per "
                    f"call | {v['baseline']:,.1f} | {v['ratio']:.2f}x |")
    t = j["train_steps_per_s"]
    rows.append(f"| SAC-HER training steps, JAX, {jax['train_freq']} steps then {jax['gradient_steps']} updates | "
                f"{t['jax_config']:,.1f} | "
                f"torch, 1 step then 1 update | {t['default']:,.1f} | {t['ratio']:.2f}x |")
    o = j["overlap_train_steps_per_s"]
    rows.append(f"| the same, roll-outs overlapping the updates (a call behind) | {o['ours']:,.1f} | not overlapping | "
                f"{o['baseline']:,.1f} | {o['ratio']:.2f}x |")
    x = r["sbx_updates_per_s"]
    if x is None:
        rows.append("| SBX (JAX) updates | not installed | | | |")
    else:
        rows.append(f"| SBX updates, batch 128, one per call | {x['sbx_fused_1']:,.1f} | torch | "
                    f"{x['torch_fused_1']:,.1f} | {x['sbx_fused_1'] / x['torch_fused_1']:.2f}x |")
        rows.append(f"| SBX updates, batch 128, {FUSED_UPDATES} per call | {x[f'sbx_fused_{FUSED_UPDATES}']:,.1f} | "
                    f"torch | {x['torch_fused_1']:,.1f} | {x['sbx_fused_vs_torch']:.2f}x |")
    return "\n".join(rows)
