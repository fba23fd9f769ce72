"""Paper 000 Fig. 4: learning curves with and without the scenario's replay (HER in fuel-tank, PER in oil-tank)
over several seeds, the speed-up to convergence, and the same comparison for the two observation designs.

A run converges at the first validation whose success reaches ``CONVERGENCE_SUCCESS``; the speed-up is the
baseline's median steps to convergence over the variant's (a run that never converges counts as the run's
length, so the speed-up is then a lower bound, flagged in the result). Validation success is noisy, so the
result also gives each variant's mean validation success over the run (the area under its learning curve,
averaged over seeds). Every run is an ordinary
:func:`snakeplan.rl.train.train` run in its own folder, so an interrupted ablation resumes.
Run as ``snakeplan bench ablation --scene SCENE --seeds 3 --steps N [--compare observation]``.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from snakeplan.files import atomic_write
from snakeplan.rl.train import ALGORITHMS, DEFAULT_CONFIG, TrainConfig, plot_curves, train
from snakeplan.scenes import scene_spec

#: Validation success that counts as converged: the plain-SAC baselines rarely reach 0.9 within a run of a few
#: tens of thousands of steps on two cores, so the speed-up is measured to a level every variant reaches.
CONVERGENCE_SUCCESS = 0.6
COMPARISONS = ("replay", "observation")


def variants(scene: str, compare: str) -> dict[str, tuple[str, str]]:
    """Label -> (algorithm, observation design); the first entry is the one the speed-up is reported for. The
    algorithm is the scene family's planner (its spec; the paper's pairing for fuel-tank and oil-tank)."""
    algo = scene_spec(scene).planner
    if algo not in ALGORITHMS:
        raise ValueError(f"scene: {scene} is planned by {algo}, not by a learned planner ({', '.join(ALGORITHMS)})")
    if compare == "replay":
        return {algo.upper(): (algo, "local"), "SAC": ("sac", "local")}
    return {f"{algo.upper()} local": (algo, "local"), f"{algo.upper()} paper": (algo, "paper")}


def steps_to_converge(history: list[dict], threshold: float = CONVERGENCE_SUCCESS) -> tuple[float, bool]:
    """(environment steps at the first validation reaching ``threshold``, whether it did; else the last step)."""
    for h in history:
        if h["success"] >= threshold:
            return float(h["env_steps"]), True
    return (float(history[-1]["env_steps"]) if history else float("nan")), False


def run_ablation(scene: str, seeds: list[int], steps: int, out_dir: str | Path, compare: str = "replay",
                 config: TrainConfig = DEFAULT_CONFIG, threshold: float = CONVERGENCE_SUCCESS) -> dict:
    """Train every variant with every seed, plot ``ablation-{compare}.png`` and return (and write as JSON) the
    steps to convergence per run and the speed-up of the first variant over the second."""
    if compare not in COMPARISONS:
        raise ValueError(f"compare: must be one of {COMPARISONS}, got {compare!r}")
    out = Path(out_dir)
    curves: dict[str, list[list[dict]]] = {}
    result: dict = {"scene": scene, "compare": compare, "steps": steps, "seeds": list(seeds), "threshold": threshold,
                    "runs": {}}
    for label, (algo, observation) in variants(scene, compare).items():
        curves[label] = []
        result["runs"][label] = []
        for seed in seeds:
            run_dir = out / f"{scene}-{algo}-{observation}-seed{seed}"
            res = train(scene, algo, steps, seed, run_dir, replace(config, observation=observation), progress=False)
            curves[label].append(res.history)
            at, ok = steps_to_converge(res.history, threshold)
            result["runs"][label].append({"seed": seed, "steps_to_converge": at, "converged": ok,
                                          "final_success": res.history[-1]["success"] if res.history else None})
    first, second = list(result["runs"])
    med = {k: float(np.median([r["steps_to_converge"] for r in v])) for k, v in result["runs"].items()}
    result["median_steps_to_converge"] = med
    result["speedup"] = med[second] / med[first] if med[first] > 0 else None
    result["speedup_is_lower_bound"] = not all(r["converged"] for r in result["runs"][second])
    result["mean_success"] = {k: float(np.mean([np.mean([h["success"] for h in c]) for c in curves[k] if c]))
                              for k in curves}
    out.mkdir(parents=True, exist_ok=True)
    plot_curves(curves, out / f"ablation-{scene}-{compare}.png")
    atomic_write(out / f"ablation-{scene}-{compare}.json", json.dumps(result, indent=1))
    return result
