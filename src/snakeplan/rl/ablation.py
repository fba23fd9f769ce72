"""Paper 000 Fig. 4: learning curves with and without the scenario's replay (HER in fuel-tank, PER in oil-tank)
over several seeds, the speed-up to convergence, and the same comparison for the two observation designs.

A run converges at the first validation whose success reaches ``CONVERGENCE_SUCCESS``; the speed-up is the
baseline's median steps to convergence over the variant's (a run that never converges counts as the run's
length, so the speed-up is then a lower bound, flagged in the result). Validation success is noisy, so the
result also gives each variant's mean validation success over the run (the area under its learning curve,
averaged over seeds). Every run is an ordinary :func:`snakeplan.rl.train.train` run in its own folder
(``{scene}-{algorithm}-{observation}-seed{seed}``), trained through a training sweep
(:func:`snakeplan.rl.sweep.run_jobs`) on any backend, so an interrupted ablation resumes, on one core or a
cluster. Run as ``snakeplan bench ablation --scene SCENE --seeds 3 --steps N [--compare observation]
[--workers N | --ray ADDRESS]``; the threshold is :data:`snakeplan.rl.sweep.CONVERGENCE_SUCCESS` (0.6: the
plain-SAC baselines rarely reach 0.9 within a run of a few tens of thousands of steps on two cores, so the
speed-up is measured to a level every variant reaches).
"""

from __future__ import annotations

import json
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from snakeplan.files import atomic_write
from snakeplan.parallel import Backend
from snakeplan.rl.sweep import CONVERGENCE_SUCCESS, TrainJob, run_jobs, steps_to_converge
from snakeplan.rl.train import ALGORITHMS, DEFAULT_CONFIG, TrainConfig, plot_curves
from snakeplan.scenes import scene_spec

COMPARISONS = ("replay", "observation")
#: Paper 000's Fig. 4 speed-ups of the scenario's replay over plain SAC (HER in fuel-tank, PER in oil-tank).
PAPER_SPEEDUP = {"fuel-tank": 2.88, "oil-tank": 1.27}


def variants(scene: str, compare: str) -> dict[str, tuple[str, str]]:
    """Label -> (algorithm, observation design); the first entry is the one the speed-up is reported for. The
    algorithm is the scene family's planner (its spec; the paper's pairing for fuel-tank and oil-tank)."""
    algo = scene_spec(scene).planner
    if algo not in ALGORITHMS:
        raise ValueError(f"scene: {scene} is planned by {algo}, not by a learned planner ({', '.join(ALGORITHMS)})")
    if compare == "replay":
        return {algo.upper(): (algo, "local"), "SAC": ("sac", "local")}
    return {f"{algo.upper()} local": (algo, "local"), f"{algo.upper()} paper": (algo, "paper")}


def run_ablation(scene: str, seeds: list[int], steps: int, out_dir: str | Path, compare: str = "replay",
                 config: TrainConfig = DEFAULT_CONFIG, threshold: float = CONVERGENCE_SUCCESS,
                 backend: Backend = Backend("serial"), progress: bool = False) -> dict:
    """Train every variant with every seed on ``backend`` (a training sweep, seed by seed so that an unfinished
    ablation still pairs its variants), plot ``ablation-{scene}-{compare}.png`` and return (and write as JSON) the
    steps to convergence per run and the speed-up of the first variant over the second."""
    if compare not in COMPARISONS:
        raise ValueError(f"compare: must be one of {COMPARISONS}, got {compare!r}")
    out = Path(out_dir)
    labels = variants(scene, compare)
    jobs = [TrainJob(scene, algo, steps, seed, str(out / f"{scene}-{algo}-{observation}-seed{seed}"),
                     asdict(replace(config, observation=observation)))
            for seed in seeds for algo, observation in labels.values()]
    histories = iter(run_jobs(jobs, backend, progress, f"ablation {scene}"))
    by_seed = [{label: next(histories) for label in labels} for _ in seeds]
    curves = {label: [h[label] for h in by_seed] for label in labels}
    result: dict = {"scene": scene, "compare": compare, "steps": steps, "seeds": list(seeds), "threshold": threshold,
                    "backend": backend.settings(), "runs": {}}
    for label, runs in curves.items():
        result["runs"][label] = []
        for seed, history in zip(seeds, runs):
            at, ok = steps_to_converge(history, threshold)
            result["runs"][label].append({"seed": seed, "steps_to_converge": at, "converged": ok,
                                          "final_success": history[-1]["success"] if history else None})
    first, second = list(result["runs"])
    med = {k: float(np.median([r["steps_to_converge"] for r in v])) for k, v in result["runs"].items()}
    result["median_steps_to_converge"] = med
    result["speedup"] = med[second] / med[first] if med[first] > 0 else None
    result["speedup_is_lower_bound"] = not all(r["converged"] for r in result["runs"][second])
    result["mean_success"] = {k: float(np.mean([np.mean([h["success"] for h in c]) for c in curves[k] if c]))
                              for k in curves}
    result["paper_speedup"] = PAPER_SPEEDUP.get(scene) if compare == "replay" else None
    out.mkdir(parents=True, exist_ok=True)
    ours = "n/a" if result["speedup"] is None else (
        f"{'>= ' if result['speedup_is_lower_bound'] else ''}{result['speedup']:.2f}x")
    paper = "" if result["paper_speedup"] is None else f" (paper {result['paper_speedup']:.2f}x)"
    plot_curves(curves, out / f"ablation-{scene}-{compare}.png",
                title=f"{scene}: {first} vs {second}, seeds {seeds[0]}-{seeds[-1]} (mean, band min-max)\n"
                      f"{ours} faster to {threshold:g} validation success{paper}")
    atomic_write(out / f"ablation-{scene}-{compare}.json", json.dumps(result, indent=1))
    return result
