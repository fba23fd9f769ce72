"""``snakeplan bench rl --arms``: the arm-conditioned generalist on arms it never saw, beside policies trained for
each arm alone.

Per arm (a preset or a robot file; default the three held-out arms, :data:`HELD_OUT`): with ``train_steps``, a
policy trained for that arm alone from the command line's recipe (the generalist's: residual guide design, sensed,
the confined family and both tanks sized to the arm; :data:`PER_ARM_RECIPE`), resumable in
``out/train-<arm>``, with the wall time its validation first reached 0.9; then the generalist
(``policy="generalist-arms"``) and that policy planned through the one benchmark runner with sensed knowledge on
``seeds`` of each scene family sized to the arm, judged like every plan. The summary: per arm, family and policy,
judged success (Wilson 95 %) and the median and 90th percentile plan time.
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
#: The per-arm policies' training families and options (those of the generalist, for one arm).
PER_ARM_SCENE = "confined+fuel-tank+oil-tank"
PER_ARM_RECIPE = {"observation": "guide", "knowledge": "sensed", "lookahead": True, "residual": True, "n_envs": 4,
                  "batch_size": 512, "eval_every": 2000, "eval_episodes": 30}
#: Validation success that counts as trained.
TRAINED = 0.9


def arm_source(arm: str) -> str:
    """A held-out arm's shipped robot file, else ``arm`` itself (a preset or a robot file)."""
    from importlib.resources import files

    shipped = Path(str(files("snakeplan").joinpath("robots", "data", "arms", f"{arm}.json")))
    return str(shipped) if arm in HELD_OUT and shipped.is_file() else arm


def train_arm(arm: str, out: Path, steps: int, seed: int = 0) -> dict:
    """The per-arm policy of ``arm`` trained for ``steps`` environment steps into ``out`` (resumed when there);
    its policy file, validation history and the wall time (s) of training when validation first reached
    :data:`TRAINED` (None if it never did)."""
    from snakeplan.rl.train import DEFAULT_CONFIG, train

    config = replace(DEFAULT_CONFIG, robot=arm_source(arm), scene_workers=-1, **PER_ARM_RECIPE)
    result = train(PER_ARM_SCENE, "sac", steps, seed, out, config, progress=False)
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
        entries = [("sac", GENERALIST_OPTIONS)]
        trained = None
        if train_steps > 0:
            trained = train_arm(arm, out / f"train-{name}", train_steps)
            entries.append(("sac", {"policy": trained["policy"]}))
        rows = run_sweep(Sweep(f"arms-{name}", scenes, tuple(range(seeds)), tuple(entries), time_limit,
                               robot=arm_source(arm), knowledge="sensed"), out / f"plans-{name}", backend).rows
        table: dict = {}
        for e in summarise(rows):
            label = "generalist" if e["options"] == options_label(GENERALIST_OPTIONS) else "per-arm"
            table.setdefault(e["scene"], {})[label] = _figures(e)
        summary["arms"][name] = {
            "training": None if trained is None else {k: trained[k] for k in ("wall_s_to_trained", "best_success")},
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
             f"for {summary['train_steps']} environment steps.", "",
             "| arm | scene | policy | success (Wilson 95 %) | median / p90 plan (ms) | training to 0.9 (s) |",
             "|---|---|---|---|---|---|"]
    for arm, entry in summary["arms"].items():
        training = entry["training"]
        for scene, by in entry["scenes"].items():
            for label, f in by.items():
                took = ""
                if label == "per-arm" and training is not None:
                    took = ("never (best " + f"{training['best_success']:.2f})" if training["wall_s_to_trained"] is None
                            else f"{training['wall_s_to_trained']:.0f}")
                lines.append(f"| {arm} | {scene} | {label} | {f['success_pct']:.0f} % ({f['wilson_pct'][0]:.1f}-"
                             f"{f['wilson_pct'][1]:.1f}) | {f['median_ms']:.1f} / {f['p90_ms']:.1f} | {took} |")
    return "\n".join(lines) + "\n"
