"""Training sweeps: one resumable :func:`snakeplan.rl.train.train` run per seed, on the same backends as the
benchmark runner (:mod:`snakeplan.parallel`: serial, a local process pool, Ray), and a summary of the learning
curves.

Each seed trains in its own folder (``run_dir(seed)``; by default ``OUT/seed<N>``), which holds its own
checkpoints and lock, so an interrupted sweep resumes every run where it stopped, on any backend. The summary
(``OUT/sweep.json``, ``sweep.md``, ``curves.png``) gives per seed the final and best validation success and the
environment steps to a validation success of ``threshold``, and over seeds the mean learning curve. Run as
``snakeplan train rl SCENE ALGORITHM --steps N --seeds 0-9 --out DIR [--workers N | --ray ADDRESS]``.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from snakeplan.files import atomic_write
from snakeplan.parallel import Backend, streamed

#: Validation success that counts as converged in the summaries (the Fig. 4 ablation's level).
CONVERGENCE_SUCCESS = 0.6


def steps_to_converge(history: list[dict], threshold: float = CONVERGENCE_SUCCESS) -> tuple[float, bool]:
    """(environment steps at the first validation reaching ``threshold``, whether it did; else the last step)."""
    for h in history:
        if h["success"] >= threshold:
            return float(h["env_steps"]), True
    return (float(history[-1]["env_steps"]) if history else float("nan")), False


@dataclass(frozen=True)
class TrainJob:
    """One training of a sweep: what it trains and its resumable folder."""

    scene: str
    algorithm: str
    steps: int
    seed: int
    folder: str
    config: dict


def _train_one(job: TrainJob) -> tuple[TrainJob, list[dict]]:
    """One training (in a worker); the job and its evaluation history."""
    from snakeplan.extras import require_training

    require_training("train rl --seeds")
    from snakeplan.rl.train import TrainConfig, train

    config = TrainConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in job.config.items()})
    result = train(job.scene, job.algorithm, job.steps, job.seed, job.folder, config, progress=False)
    return job, result.history


def run_jobs(jobs: Sequence[TrainJob], backend: Backend, progress: bool = True,
             name: str = "train") -> list[list[dict]]:
    """Every job's evaluation history (in the jobs' order), trained on ``backend``; SIGINT/SIGTERM stop every
    training (each saves a checkpoint; :class:`~snakeplan.interrupt.Interrupted`); rerunning resumes them. On a
    parallel backend a job's ``scene_workers`` of -1 (the command line's default) becomes 0."""
    where = {job.folder: i for i, job in enumerate(jobs)}
    if len(where) != len(jobs):
        raise ValueError("jobs: two trainings share a folder")
    if backend.kind != "serial":  # parallel trainings keep the cores busy: each makes its own scenes by default
        jobs = [replace(job, config={**job.config, "scene_workers": 0}) if job.config.get("scene_workers") == -1
                else job for job in jobs]
    histories: dict[int, list[dict]] = {}
    def stopped() -> str:
        return (f"interrupted: {len(histories)} of {len(jobs)} trainings finished, the others saved where they "
                f"were; rerun the same command to resume")

    with streamed(_train_one, list(jobs), backend, name=name, progress=progress, stopped=stopped) as (stream, tick):
        for job, history in stream:
            histories[where[job.folder]] = history
            tick(f"{job.algorithm} seed {job.seed}")
    return [histories[i] for i in range(len(jobs))]


def train_seeds(scene: str, algorithm: str, steps: int, seeds: Sequence[int], out_dir: str | Path, config=None,
                backend: Backend = Backend(), progress: bool = True, threshold: float = CONVERGENCE_SUCCESS) -> dict:
    """Train ``algorithm`` on ``scene`` once per seed on ``backend`` (each run resumable in ``out_dir/seed<N>``);
    write ``sweep.json``, ``sweep.md`` and ``curves.png`` there and return the summary (see the module doc)."""
    from snakeplan.rl.train import DEFAULT_CONFIG, plot_curves

    config = DEFAULT_CONFIG if config is None else config
    out = Path(out_dir)
    jobs = [TrainJob(scene, algorithm, steps, seed, str(out / f"seed{seed}"), asdict(config)) for seed in seeds]
    histories = run_jobs(jobs, backend, progress, f"train {scene} {algorithm}")
    summary = summarise(scene, algorithm, steps, dict(zip(seeds, histories)), threshold)
    summary["backend"] = backend.settings()
    out.mkdir(parents=True, exist_ok=True)
    atomic_write(out / "sweep.json", json.dumps(summary, indent=1))
    atomic_write(out / "sweep.md", markdown(summary) + "\n")
    plot_curves({f"{algorithm} ({len(seeds)} seeds)": histories}, out / "curves.png")
    return summary


def summarise(scene: str, algorithm: str, steps: int, histories: dict[int, list[dict]],
              threshold: float = CONVERGENCE_SUCCESS) -> dict:
    """Per seed: final and best validation success, steps to ``threshold``; over seeds: their means and the
    mean validation success at each evaluation."""
    runs = []
    for seed, history in histories.items():
        at, ok = steps_to_converge(history, threshold)
        runs.append({"seed": seed, "evaluations": len(history),
                     "final_success": history[-1]["success"] if history else None,
                     "best_success": max((h["success"] for h in history), default=None),
                     "mean_success": float(np.mean([h["success"] for h in history])) if history else None,
                     "steps_to_converge": at, "converged": ok})
    grid = sorted({h["env_steps"] for history in histories.values() for h in history})
    mean_curve = [{"env_steps": g, "success": float(np.mean(vals))} for g in grid
                  if (vals := [h["success"] for history in histories.values() for h in history
                               if h["env_steps"] == g])]
    return {"scene": scene, "algorithm": algorithm, "steps": steps, "threshold": threshold, "runs": runs,
            "converged": sum(r["converged"] for r in runs),
            "median_steps_to_converge": float(np.median([r["steps_to_converge"] for r in runs])) if runs else None,
            "mean_final_success": float(np.mean([r["final_success"] or 0.0 for r in runs])) if runs else None,
            "mean_curve": mean_curve}


def markdown(summary: dict) -> str:
    lines = [f"{summary['algorithm']} on {summary['scene']}, {summary['steps']} steps per seed; converged: validation "
             f"success >= {summary['threshold']:g}.", "",
             "| seed | final success | best success | mean success | steps to converge |", "|---|---|---|---|---|"]
    for r in summary["runs"]:
        at = f"{r['steps_to_converge']:.0f}" + ("" if r["converged"] else " (not converged)")
        lines.append(f"| {r['seed']} | {r['final_success']:.2f} | {r['best_success']:.2f} | {r['mean_success']:.3f} "
                     f"| {at} |")
    lines += ["", f"{summary['converged']} of {len(summary['runs'])} converged; median steps to converge "
                  f"{summary['median_steps_to_converge']:.0f}; mean final success {summary['mean_final_success']:.3f}."]
    return "\n".join(lines)
