"""Paper 002's comparison (Figs. 6-9): informative (IP), coverage (CP) and random (RP) inspection of the station.

A configuration of the benchmark runner (:mod:`snakeplan.bench.runner`): for each seed the station scene of that
seed (its own temperature field) is flown by each planner with the same seed, budget, camera speed and
measurement frequency, one row per mission in ``runs.jsonl`` (resumable, on any backend). The summary and the
pictures are drawn from the logged rows, nothing is flown again: the map error (RMSE of the posterior mean
against the true field, K) and uncertainty (covariance trace, K^2) at every measurement averaged over seeds
(Fig. 9), the paper's final RMSEs (0.95 : 3.4 : 7.5, its units) beside ours as ratios to CP, planning compute
time per mission (all its replans, wall and process CPU), the judge's verdict on every mission (the arm's whole
body along every motion) and the share of views the arm holds, and for the first seed the true field, posterior mean with the path,
variance and the 3-D path (Figs. 6-8).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from snakeplan.bench.runner import Sweep, run_sweep
from snakeplan.files import atomic_write
from snakeplan.jsonable import jsonable
from snakeplan.parallel import Backend

SCHEMA = "snakeplan.bench.station/2"
#: The runner's configuration name of these missions (rows' ``config``; ``bench report`` draws them).
CONFIG = "station"
#: Seeds run by default, and the output folder.
DEFAULT_SEEDS = 5
DEFAULT_OUT_DIR = "bench-station"
#: The compared planners (paper's names) and the paper's final RMSEs (Fig. 9b, in its units).
METHODS = {"informative": "IP", "coverage": "CP", "random": "RP"}
PAPER_FINAL_RMSE = {"informative": 0.95, "coverage": 3.4, "random": 7.5}


#: Budget (s) of a mission's planning calls: ample, so that no mission stops on a busy machine's clock.
TIME_LIMIT_S = 300.0


def sweep(seeds: list[int]) -> Sweep:
    """The station missions as a sweep: every seed flown by IP, CP and RP (the scene's arm, hsr-10)."""
    return Sweep(CONFIG, ("station",), tuple(seeds), tuple((name, {}) for name in METHODS), TIME_LIMIT_S)


def run_station_bench(seeds: int = DEFAULT_SEEDS, seed0: int = 0, out_dir: str | Path = DEFAULT_OUT_DIR,
                      backend: Backend = Backend(), fresh: bool = False, progress: bool = True) -> dict:
    """Fly IP, CP and RP on ``seeds`` station seeds from ``seed0`` through the runner into ``out_dir``
    (resuming what it holds), write ``station.json``, ``station.md`` and the pictures from the rows, and return
    the summary (see :func:`summarise`) with the runner's outcome under ``"runner"``."""
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise ValueError(f"seeds: must be a positive integer, got {seeds!r}")
    seed_list = list(range(seed0, seed0 + seeds))
    outcome = run_sweep(sweep(seed_list), out_dir, backend, fresh=fresh, progress=progress)
    summary = station_outputs(outcome.rows, Path(out_dir))
    return {**summary, "runner": outcome.to_dict()}


def _padded(values: np.ndarray, length: int) -> np.ndarray:
    """A curve held at its last value to ``length`` samples (a mission that stopped early keeps its map)."""
    return np.concatenate([values, np.full(length - len(values), values[-1])])


def _by_method(rows: list[dict]) -> dict[str, list[dict]]:
    """The rows of each compared method present, in seed order."""
    groups = {n: sorted((r for r in rows if r["planner"] == n), key=lambda r: r["seed"]) for n in METHODS}
    groups = {n: g for n, g in groups.items() if g}
    if not groups:
        raise ValueError("rows: no station mission of IP, CP or RP")
    return groups


def curves(rows: list[dict]) -> tuple[np.ndarray, dict[str, dict[str, np.ndarray]]]:
    """(measurement times s, per method the RMSE K and trace K^2 curves as (seeds, times) arrays)."""
    groups = _by_method(rows)
    times = np.asarray(max((r["details"]["measurement_times"] for g in groups.values() for r in g), key=len))
    return times, {n: {k: np.array([_padded(np.asarray(r["details"][k], dtype=float), len(times)) for r in g])
                       for k in ("rmse_k", "trace_k2")} for n, g in groups.items()}


def summarise(rows: list[dict]) -> dict:
    """The comparison from logged station rows: per method the mean (and sd) final RMSE K, mean final trace
    K^2, mean and max planning time s, mean CPU s, replans per mission, reach share, each seed's values; the
    ratios to CP beside the paper's; whether IP < CP < RP; the averaged curves; the world's prior and library."""
    groups = _by_method(rows)
    first = next(iter(groups.values()))[0]
    times, method_curves = curves(rows)
    methods = {}
    for name, group in groups.items():
        per_seed = [{"seed": r["seed"], "final_rmse_k": r["metrics"]["final_rmse_k"],
                     "final_trace_k2": r["metrics"]["final_trace_k2"],
                     "compute_time_s": r["details"]["planning_time_s"],
                     "compute_cpu_s": r["details"]["compute_cpu_s"], "plans": r["details"]["plans"],
                     "reach_share": r["metrics"]["reach_share"]} for r in group]
        col = {k: np.array([p[k] for p in per_seed], dtype=float) for k in per_seed[0] if k != "seed"}
        methods[name] = {
            "label": METHODS[name], "missions": len(group), "judged_valid": sum(bool(r["success"]) for r in group),
            "final_rmse_k": float(col["final_rmse_k"].mean()), "final_rmse_std_k": float(col["final_rmse_k"].std()),
            "final_trace_k2": float(col["final_trace_k2"].mean()),
            "compute_time_s": float(col["compute_time_s"].mean()),
            "compute_time_max_s": float(col["compute_time_s"].max()),
            "compute_cpu_s": float(col["compute_cpu_s"].mean()),
            "plans_per_mission": float(col["plans"].mean()),
            "reach_share": float(col["reach_share"].mean()),
            "per_seed": per_seed,
        }
    rmse = {n: m["final_rmse_k"] for n, m in methods.items()}
    cp = rmse.get("coverage")
    return {
        "schema": SCHEMA, "scene": "station", "robot": first["robot"], "seeds": sorted({r["seed"] for r in rows}),
        "units": {"rmse": "K", "trace": "K^2", "time": "s", "length": "mm"},
        **first["details"]["mission"],
        "methods": methods,
        "ratios_to_cp": None if cp is None else {
            "ours": {n: r / cp for n, r in rmse.items()},
            "paper": {n: PAPER_FINAL_RMSE[n] / PAPER_FINAL_RMSE["coverage"] for n in rmse}},
        "paper_final_rmse": PAPER_FINAL_RMSE,
        "ordering_ip_cp_rp": (bool(rmse["informative"] < rmse["coverage"] < rmse["random"])
                              if len(rmse) == len(METHODS) else None),
        "world": first["details"]["world"],
        "curves": {"times_s": times.tolist(),
                   **{n: {"rmse_mean_k": c["rmse_k"].mean(axis=0).tolist(),
                          "trace_mean_k2": c["trace_k2"].mean(axis=0).tolist()} for n, c in method_curves.items()}},
    }


def station_outputs(rows: list[dict], out: Path) -> dict:
    """Write ``station.json``, ``station.md`` and the pictures (Figs. 6-8 of the first seed, Fig. 9) into
    ``out`` from the logged station missions of IP, CP and RP among ``rows`` (other rows are left out); return
    the summary (with the figure file names)."""
    rows = [r for r in rows if r.get("task") == "inspect" and r["scene"] == "station" and r["planner"] in METHODS]
    summary = jsonable(summarise(rows))
    summary["figures"] = [f.name for f in _figures(rows, out)]
    atomic_write(out / "station.json", json.dumps(summary, indent=2, allow_nan=False) + "\n")
    atomic_write(out / "station.md", summary_markdown(summary) + "\n")
    return summary


def _figures(rows: list[dict], out: Path) -> list[Path]:
    """Figs. 6-8 for the first seed (maps from the logged final mean and variance; the true field and the
    surface from the scene, regenerated from its seed) and Fig. 9 over all seeds."""
    from snakeplan.bench.runner import row_path
    from snakeplan.scenes import make_scene
    from snakeplan.viz.figures import save_figure
    from snakeplan.viz.maps import error_curves_figure, inspection_figure
    from snakeplan.viz.mission import station_mesh

    seed = min(r["seed"] for r in rows)
    scene = make_scene("station", seed)
    vertices, _ = station_mesh(scene)
    truth = np.asarray(scene.metadata["field"]["values"], dtype=float)
    files = []
    for r in sorted((r for r in rows if r["seed"] == seed), key=lambda r: list(METHODS).index(r["planner"])):
        d = r["details"]
        fig = inspection_figure(vertices, truth, np.asarray(d["final_mean_k"]), np.asarray(d["final_variance_k2"]),
                                row_path(out, r), f"{METHODS[r['planner']]} ({r['planner']}), station seed {seed}: "
                                f"final RMSE {r['metrics']['final_rmse_k']:.2f} K, covariance trace "
                                f"{r['metrics']['final_trace_k2']:.0f} K^2")
        files.append(save_figure(fig, out / f"station_{r['planner']}_seed{seed}.png"))
    seeds = sorted({r["seed"] for r in rows})
    times, method_curves = curves(rows)
    labelled = {f"{METHODS[n]} ({n})": {"rmse": c["rmse_k"], "trace": c["trace_k2"]} for n, c in method_curves.items()}
    fig = error_curves_figure(times, labelled, f"station, seeds {seeds[0]}-{seeds[-1]}: mean and one standard "
                              "deviation over seeds")
    files.append(save_figure(fig, out / "station_curves.png"))
    return files


def summary_markdown(summary: dict) -> str:
    """The comparison as markdown: per method final RMSE (mean ± sd), trace, ratio to CP beside the paper's,
    planning wall and CPU time per mission, reach share."""
    seeds = summary["seeds"]
    lines = [f"Station inspection, seeds {seeds[0]}-{seeds[-1]}: final values after {summary['budget_s']:.0f} s "
             "(mean ± sd over seeds; planning time per mission, all replans).", "",
             "| method | missions | judged valid | RMSE K | trace K^2 | /CP | paper /CP | plan wall s | plan max s | "
             "plan CPU s | reach |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    ratios = summary["ratios_to_cp"]
    for name, m in summary["methods"].items():
        ours = "-" if ratios is None else f"{ratios['ours'][name]:.2f}"
        paper = "-" if ratios is None else f"{ratios['paper'][name]:.2f}"
        lines.append(f"| {m['label']} ({name}) | {m['missions']} | {m['judged_valid']} | {m['final_rmse_k']:.2f} ± "
                     f"{m['final_rmse_std_k']:.2f} | {m['final_trace_k2']:.0f} | {ours} | {paper} | "
                     f"{m['compute_time_s']:.2f} | {m['compute_time_max_s']:.2f} | {m['compute_cpu_s']:.2f} | "
                     f"{m['reach_share']:.2f} |")
    if summary["ordering_ip_cp_rp"] is not None:
        lines += ["", f"Ordering IP < CP < RP: {summary['ordering_ip_cp_rp']}."]
    return "\n".join(lines)
