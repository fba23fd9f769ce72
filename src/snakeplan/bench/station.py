"""Paper 002's comparison (Figs. 6-9): informative (IP), coverage (CP) and random (RP) inspection of the station.

For each seed ``seed0 .. seed0 + seeds - 1`` the station scene of that seed (its own temperature field) is
inspected by each planner with the same seed, budget, camera speed and measurement frequency; the map error
(RMSE of the posterior mean against the true field, K) and uncertainty (covariance trace, K^2) are recorded at
every measurement and averaged over seeds (Fig. 9). The paper's final RMSEs (0.95 : 3.4 : 7.5, its units) stand
beside ours as ratios to CP. Planning compute time is the planner's own time per full mission (all its replans),
wall and process CPU; the share of executed measurement poses the arm reaches (inverse kinematics, body
collision-free) is reported per method. Pictures of the first seed: true field, posterior mean with the path,
variance, the 3-D path (Figs. 6-8), and the averaged curves (Fig. 9).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from snakeplan.files import atomic_write
from snakeplan.planners.inspection import (
    InspectionProblem,
    InspectionResult,
    get_inspection_planner,
)
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene
from snakeplan.viz.figures import save_figure
from snakeplan.viz.maps import error_curves_figure, inspection_figure

SCHEMA = "snakeplan.bench.station/1"
#: Seeds run by default, and the output folder.
DEFAULT_SEEDS = 5
DEFAULT_OUT_DIR = "bench-station"
#: The compared planners (paper's names) and the paper's final RMSEs (Fig. 9b, in its units).
METHODS = {"informative": "IP", "coverage": "CP", "random": "RP"}
PAPER_FINAL_RMSE = {"informative": 0.95, "coverage": 3.4, "random": 7.5}
ROBOT = "hsr-10"


def _padded(values: np.ndarray, length: int) -> np.ndarray:
    """A curve held at its last value to ``length`` samples (a mission that stopped early keeps its map)."""
    return np.concatenate([values, np.full(length - len(values), values[-1])])


def _figures(out: Path, problem: InspectionProblem, results: dict[str, InspectionResult], times: np.ndarray,
             curves: dict[str, dict[str, np.ndarray]], seeds: list[int]) -> list[str]:
    """Write Figs. 6-8 for the first seed and Fig. 9 over all seeds; return the file names."""
    world = problem.world()
    files = []
    for name, res in results.items():
        fig = inspection_figure(world.camera.nodes, problem.truth, res.final_map.mean, np.diag(res.final_map.cov),
                                res.path, f"{METHODS[name]} ({name}), station seed {problem.scene.seed}: final "
                                f"RMSE {res.rmse[-1]:.2f} K, covariance trace {res.trace[-1]:.0f} K^2")
        files.append(save_figure(fig, out / f"station_{name}_seed{problem.scene.seed}.png").name)
    labelled = {f"{METHODS[n]} ({n})": c for n, c in curves.items()}
    fig = error_curves_figure(times, labelled, f"station, seeds {seeds[0]}-{seeds[-1]}: mean and one standard "
                              "deviation over seeds")
    files.append(save_figure(fig, out / "station_curves.png").name)
    return files


def run_station_bench(seeds: int = DEFAULT_SEEDS, seed0: int = 0, out_dir: str | Path = DEFAULT_OUT_DIR,
                      as_json: bool = False) -> dict:
    """Run IP, CP and RP on ``seeds`` station seeds from ``seed0``; write the pictures and ``station.json`` to
    ``out_dir``; return the JSON-ready summary (per method: final RMSE K, final covariance trace K^2, planning
    compute time s, reach share; ratios beside the paper's; the averaged curves). Without ``as_json`` progress
    goes to stderr and a summary table to stdout; with it nothing is printed (the caller prints the JSON)."""
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise ValueError(f"seeds: must be a positive integer, got {seeds!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    robot = get_robot(ROBOT)
    seed_list = list(range(seed0, seed0 + seeds))
    per_seed: dict[str, list[dict]] = {n: [] for n in METHODS}
    raw: dict[str, dict[str, list[np.ndarray]]] = {n: {"rmse": [], "trace": []} for n in METHODS}
    first: dict[str, InspectionResult] = {}
    first_problem = None
    times = None
    world = None
    for seed in seed_list:
        problem = InspectionProblem(make_scene("station", seed), robot)
        world = problem.world()
        ticks = problem.ticks()
        times = ticks if times is None else times
        for name in METHODS:
            res = get_inspection_planner(name).plan(problem, seed=seed)
            reach = world.reach.check(res.poses).share
            per_seed[name].append({"seed": seed, "final_rmse_k": float(res.rmse[-1]),
                                   "final_trace_k2": float(res.trace[-1]), "compute_time_s": res.compute_time_s,
                                   "compute_cpu_s": res.compute_cpu_s, "plans": res.plans, "reach_share": reach})
            raw[name]["rmse"].append(_padded(res.rmse, len(ticks)))
            raw[name]["trace"].append(_padded(res.trace, len(ticks)))
            if seed == seed0:
                first[name] = res
                first_problem = problem
            if not as_json:
                sys.stderr.write(f"seed {seed} {name}: RMSE {res.rmse[-1]:.3f} K, trace {res.trace[-1]:.0f} K^2, "
                                 f"planning {res.compute_time_s:.2f} s wall / {res.compute_cpu_s:.2f} s CPU\n")
    curves = {n: {k: np.array(v) for k, v in c.items()} for n, c in raw.items()}
    methods = {}
    for name, rows in per_seed.items():
        col = {k: np.array([r[k] for r in rows]) for k in rows[0] if k != "seed"}
        methods[name] = {
            "label": METHODS[name],
            "final_rmse_k": float(col["final_rmse_k"].mean()), "final_rmse_std_k": float(col["final_rmse_k"].std()),
            "final_trace_k2": float(col["final_trace_k2"].mean()),
            "compute_time_s": float(col["compute_time_s"].mean()),
            "compute_time_max_s": float(col["compute_time_s"].max()),
            "compute_cpu_s": float(col["compute_cpu_s"].mean()),
            "plans_per_mission": float(col["plans"].mean()),
            "reach_share": float(col["reach_share"].mean()),
            "per_seed": rows,
        }
    cp = methods["coverage"]["final_rmse_k"]
    rmse = {n: m["final_rmse_k"] for n, m in methods.items()}
    prior = world.prior
    summary = {
        "schema": SCHEMA, "scene": "station", "robot": ROBOT, "seeds": seed_list,
        "units": {"rmse": "K", "trace": "K^2", "time": "s", "length": "mm"},
        "budget_s": first_problem.budget_s, "camera_speed_mm_s": first_problem.speed_mm_s,
        "measurement_hz": first_problem.measurement_hz,
        "methods": methods,
        "ratios_to_cp": {"ours": {n: r / cp for n, r in rmse.items()},
                         "paper": {n: r / PAPER_FINAL_RMSE["coverage"] for n, r in PAPER_FINAL_RMSE.items()}},
        "paper_final_rmse": PAPER_FINAL_RMSE,
        "ordering_ip_cp_rp": bool(rmse["informative"] < rmse["coverage"] < rmse["random"]),
        "library": {"viewpoints": len(world.library), "reachable_share": float(world.library.reachable.mean())},
        "prior": {"mean_k": float(prior.mean[0]), "sigma_f_k": prior.sigma_f, "length_scale_mm": prior.length_scale,
                  "pd_fix": {"smallest_eigenvalues_before": list(prior.pd_fix.smallest_before),
                             "smallest_eigenvalues_after": list(prior.pd_fix.smallest_after),
                             "clipped": prior.pd_fix.n_clipped, "max_entry_change": prior.pd_fix.max_change}},
        "world_build_s": world.build_time_s,
        "curves": {"times_s": times.tolist(),
                   **{n: {"rmse_mean_k": c["rmse"].mean(axis=0).tolist(),
                          "trace_mean_k2": c["trace"].mean(axis=0).tolist()} for n, c in curves.items()}},
    }
    summary["figures"] = _figures(out, first_problem, first, times, curves, seed_list)
    atomic_write(out / "station.json", json.dumps(summary, indent=2, allow_nan=False) + "\n")
    if not as_json:
        _print_table(summary, out)
    return summary


def _print_table(summary: dict, out: Path) -> None:
    """The human summary: per method final RMSE, trace, ratio to CP beside the paper's, compute time, reach."""
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"station inspection, seeds {summary['seeds'][0]}-{summary['seeds'][-1]}, final values "
                        f"after {summary['budget_s']:.0f} s (mean ± sd over seeds)")
    for col in ("method", "RMSE K", "trace K^2", "/CP", "paper /CP", "plan wall s", "plan CPU s", "reach"):
        table.add_column(col, justify="right")
    for name, m in summary["methods"].items():
        table.add_row(m["label"], f"{m['final_rmse_k']:.2f} ± {m['final_rmse_std_k']:.2f}",
                      f"{m['final_trace_k2']:.0f}", f"{summary['ratios_to_cp']['ours'][name]:.2f}",
                      f"{summary['ratios_to_cp']['paper'][name]:.2f}", f"{m['compute_time_s']:.2f}",
                      f"{m['compute_cpu_s']:.2f}", f"{m['reach_share']:.2f}")
    console = Console()
    console.print(table)
    console.print(f"ordering IP < CP < RP: {summary['ordering_ip_cp_rp']}; wrote {out}/station.json and "
                  + ", ".join(summary["figures"]))
