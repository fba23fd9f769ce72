"""``snakeplan bench rl --arms``: the arm-conditioned generalist on arms it never saw, beside policies trained for
each arm alone.

Per arm (a preset or a robot file; default the three held-out arms, :data:`HELD_OUT`): with ``train_steps``, a
policy trained for that arm alone in each family from the command line's recipe (:data:`PER_ARM_RECIPE`: the
generalist's residual guide design, with the JAX updates of ``--jax``, validated with full knowledge), resumable
in ``out/train-<arm>-<family>``, with the wall time its validation first reached 0.9; then the generalist
(``policy="generalist-arms"``) and, in its own family, each such policy planned through the one benchmark runner
with sensed knowledge on ``seeds`` of each scene family sized to the arm, judged like every plan. The summary: per
arm, family and policy, judged success (Wilson 95 %) and the median and 90th percentile plan time.

The per-arm policies train and validate with the whole scene known: the validation is one roll-out on the taut
guide, which in sensed mode runs into clutter the tip has not yet seen (the planner's retries, which see more,
then pass it), so a sensed validation measures the first roll-out's luck more than the policy.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

from snakeplan.bench.report import options_label, summarise
from snakeplan.files import atomic_write

#: The held-out arms of the arm-conditioned generalist: never drawn in its training (the distribution draws
#: continuous lengths, radii and limits), named by the issue that asked for it.
HELD_OUT = ("arm-16x120", "arm-24x90", "arm-10x220")
#: The families the arms plan in, sized to each arm.
SCENES = ("confined", "fuel-tank")
#: The per-arm policies' options, over ``--jax`` (``snakeplan train rl FAMILY sac --jax --robot ARM`` with these).
PER_ARM_RECIPE = {"observation": "guide", "knowledge": "full", "lookahead": True, "residual": True, "n_envs": 4,
                  "batch_size": 512, "eval_every": 2000, "eval_episodes": 30}
#: Validation success that counts as trained.
TRAINED = 0.9


def arm_source(arm: str) -> str:
    """A held-out arm's shipped robot file, else ``arm`` itself (a preset or a robot file)."""
    from importlib.resources import files

    shipped = Path(str(files("snakeplan").joinpath("robots", "data", "arms", f"{arm}.json")))
    return str(shipped) if arm in HELD_OUT and shipped.is_file() else arm


def train_arm(arm: str, family: str, out: Path, steps: int, seed: int = 0) -> dict:
    """The per-arm policy of ``arm`` in ``family`` trained for ``steps`` environment steps into ``out`` (resumed
    when there); its policy file, validation history and the wall time (s) of training when validation first
    reached :data:`TRAINED` (None if it never did)."""
    from snakeplan.rl.train import JAX_CONFIG, train

    config = replace(JAX_CONFIG, robot=arm_source(arm), scene_workers=-1, **PER_ARM_RECIPE)
    result = train(family, "sac", steps, seed, out, config, progress=False)
    reached = next((h["wall_s"] for h in result.history if h["success"] >= TRAINED), None)
    return {"policy": str(result.policy), "history": result.history, "wall_s_to_trained": reached,
            "best_success": max((h["success"] for h in result.history), default=0.0)}


#: The generalist's planner options in the sweeps.
GENERALIST_OPTIONS = {"policy": "generalist-arms"}


def run(out: Path, arms: tuple[str, ...] = HELD_OUT, seeds: int = 100, scenes: tuple[str, ...] = SCENES,
        train_steps: int = 0, time_limit: float = 10.0, backend=None) -> dict:
    """Train (``train_steps`` > 0) and plan every arm (see the module) into ``out``; the summary, also written to
    ``out/summary.json`` and ``out/arms.md``."""
    from snakeplan.bench.runner import Sweep, run_sweep
    from snakeplan.parallel import Backend

    backend = backend or Backend()
    out.mkdir(parents=True, exist_ok=True)
    summary: dict = {"seeds": seeds, "scenes": list(scenes), "train_steps": train_steps, "arms": {}}
    for arm in arms:
        name = Path(arm).stem
        trained = {family: train_arm(arm, family, out / f"train-{name}-{family}", train_steps)
                   for family in scenes} if train_steps > 0 else {}
        entries = (("sac", GENERALIST_OPTIONS),) + tuple(("sac", {"policy": t["policy"]}) for t in trained.values())

        def own(family: str, planner: str, options: dict) -> bool:
            return options == GENERALIST_OPTIONS or options["policy"] == trained[family]["policy"]

        rows = run_sweep(Sweep(f"arms-{name}", scenes, tuple(range(seeds)), entries, time_limit,
                               robot=arm_source(arm), knowledge="sensed", include=own),
                         out / f"plans-{name}", backend).rows
        table: dict = {}
        for e in summarise(rows):
            label = "generalist" if e["options"] == options_label(GENERALIST_OPTIONS) else "per-arm"
            table.setdefault(e["scene"], {})[label] = _figures(e)
        summary["arms"][name] = {
            "training": {family: {k: t[k] for k in ("wall_s_to_trained", "best_success")}
                         for family, t in trained.items()} or None,
            "scenes": table}
    atomic_write(out / "summary.json", json.dumps(summary, indent=1, allow_nan=False) + "\n")
    atomic_write(out / "arms.md", markdown(summary))
    return summary


def _figures(entry: dict) -> dict:
    """The table's figures of one :func:`snakeplan.bench.report.summarise` entry (percent, ms)."""
    return {"runs": entry["runs"], "success_pct": 100.0 * entry["success_rate"],
            "wilson_pct": [100.0 * entry["success_lo95"], 100.0 * entry["success_hi95"]],
            "median_ms": 1000.0 * entry["time_median_s"], "p90_ms": 1000.0 * entry["time_p90_s"]}


def markdown(summary: dict) -> str:
    """The summary as a table: per arm, family and policy, judged success and plan times."""
    lines = [f"Sensed knowledge, {summary['seeds']} seeds per family sized to each arm; per-arm policies trained "
             f"for {summary['train_steps']} environment steps in each family.", "",
             "| arm | scene | policy | success (Wilson 95 %) | median / p90 plan (ms) | training to 0.9 (s) |",
             "|---|---|---|---|---|---|"]
    for arm, entry in summary["arms"].items():
        training = entry["training"]
        for scene, by in entry["scenes"].items():
            for label, f in by.items():
                took = ""
                if label == "per-arm" and training is not None:
                    t = training[scene]
                    took = (f"never (best {t['best_success']:.2f})" if t["wall_s_to_trained"] is None
                            else f"{t['wall_s_to_trained']:.0f}")
                lines.append(f"| {arm} | {scene} | {label} | {f['success_pct']:.0f} % ({f['wilson_pct'][0]:.1f}-"
                             f"{f['wilson_pct'][1]:.1f}) | {f['median_ms']:.1f} / {f['p90_ms']:.1f} | {took} |")
    return "\n".join(lines) + "\n"
