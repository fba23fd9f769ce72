"""``snakeplan bench inspect``: inspection of the scene families by a fed arm's tip camera, every planner on the same
scenes, judged, against the points of interest that any valid configuration can see.

A configuration of the benchmark runner (:mod:`snakeplan.bench.runner`): families x seeds x inspection planners,
each scene given the inspect task, one row per mission in ``runs.jsonl`` (resumable, on any backend). The summary
is drawn from the logged rows: per family and planner the share of the points of interest seen, the share of the
*reachable-visible* ones seen, the mission time, the feed's travel, the retractions, the planning compute time
(median and worst), and how many missions the judge found valid.

The reachable-visible points of a scene come from an offline oracle (:func:`reachable_visible`) with a budget
beyond a planner's (:data:`ORACLE_TIME_S` against the planners' 30 s): branches grown by the reaching planner to
:data:`ORACLE_RANDOM_GOALS` goals anywhere free, then to goals facing every point of interest not yet seen, from
each of :data:`ORACLE_STANDOFFS` stand-offs in turn; a point is reachable-visible when some branch's views see it. It
is a lower bound of the points some valid configuration can see (a branch the oracle did not try could see more),
so the share of them a planner sees is an upper bound of its true share; it is computed once per scene, robot and
camera and kept in the cache folder.
"""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import numpy as np

from snakeplan.bench.runner import Sweep, run_sweep
from snakeplan.files import atomic_write, cache_root
from snakeplan.jsonable import jsonable
from snakeplan.parallel import Backend, streamed

SCHEMA = "snakeplan.bench.inspect/1"
CONFIG = "inspect"
#: The families inspected by default, the planners compared, seeds, output folder and planning budget (s).
FAMILIES = ("fuel-tank", "oil-tank", "confined", "pipework", "vessel", "engine")
PLANNERS = ("coverage", "iris", "random")
DEFAULT_SEEDS = 20
DEFAULT_OUT_DIR = "bench-inspect"
TIME_LIMIT_S = 30.0
#: The oracle: stand-offs (shares of the camera's range) of the goals facing each point, random goals, the
#: reaching planner's time per branch (s), and its whole budget per scene (s).
ORACLE_STANDOFFS = (0.5, 0.3, 0.15, 0.08)
ORACLE_RANDOM_GOALS = 200
ORACLE_BRANCH_TIME_S = 2.0
ORACLE_TIME_S = 120.0
ORACLE_VERSION = 2


def sweep(families: tuple[str, ...], seeds: list[int], planners: tuple[str, ...],
          time_limit_s: float = TIME_LIMIT_S) -> Sweep:
    """Every family's seeds inspected by every planner (each family's own robot)."""
    return Sweep(CONFIG, tuple(families), tuple(seeds), tuple((p, {}) for p in planners), time_limit_s,
                 task="inspect")


def _oracle_key(scene, robot) -> str:
    text = json.dumps({"scene": scene.to_dict(), "robot": robot.to_dict(), "version": ORACLE_VERSION,
                       "standoffs": ORACLE_STANDOFFS, "random": ORACLE_RANDOM_GOALS, "time": ORACLE_TIME_S,
                       "branch_time": ORACLE_BRANCH_TIME_S}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def reachable_visible(scene, robot, seed: int = 0, cache: bool = True) -> np.ndarray:
    """Which of ``scene``'s points of interest (n,) bool some branch of ``robot`` grown by the oracle sees (see the
    module); cached under the cache folder by the scene's, the robot's and the oracle's content."""
    from snakeplan.planners import Problem
    from snakeplan.planners.inspection import branches

    path = cache_root() / "oracle" / f"{_oracle_key(scene, robot)}.npy"
    if cache and path.is_file():
        return np.load(path)
    problem = Problem(scene, robot, time_limit_s=ORACLE_BRANCH_TIME_S, task="inspect")
    source = branches.BranchSource(problem, seed)
    n = len(source.pois)
    seen = np.zeros(n, dtype=bool)
    rng = np.random.default_rng(seed)

    deadline = time.perf_counter() + ORACLE_TIME_S

    def grow(goal) -> None:
        if goal is not None and time.perf_counter() < deadline:
            b = source.branch_to(goal, time.perf_counter() + ORACLE_BRANCH_TIME_S)
            if b is not None:
                seen[b.seen] = True

    for _ in range(ORACLE_RANDOM_GOALS):
        grow(source.random_goal(rng))
    d_max = problem.inspection.camera.d_max
    for share in ORACLE_STANDOFFS:
        for k in rng.permutation(n):
            if seen[k]:
                continue
            p, nrm = source.pois.points[k], source.pois.normals[k]
            for sign in (1.0, -1.0):
                goal = p + sign * nrm * share * d_max
                if source.free(goal[None])[0]:
                    grow(goal)
                    if seen[k]:
                        break
    if cache:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path.with_suffix(".tmp"), "wb") as f:
            np.save(f, seen)
        path.with_suffix(".tmp").replace(path)
    return seen


def _oracle_task(scene: tuple[str, int]) -> tuple[tuple[str, int], np.ndarray]:
    """The reachable-visible points of a family's seed with its own robot (in a worker)."""
    from snakeplan.robots import get_robot
    from snakeplan.scenes import make_scene, scene_spec

    family, seed = scene
    return scene, reachable_visible(make_scene(family, seed), get_robot(scene_spec(family).robot))


def summarise(rows: list[dict], visible: dict[tuple[str, int], np.ndarray]) -> dict:
    """Per family and planner, from the logged rows and each scene's reachable-visible points: missions, valid
    missions, mean coverage, mean and worst share of the reachable-visible points seen, mean mission time (s),
    feed travel (m) and retractions, median and worst compute time (s), and for a field the mean (and standard
    deviation) of the final map's RMSE (K) at the end of the mission."""
    table: dict[str, dict[str, dict]] = {}
    for r in rows:
        m = r["metrics"] or {}
        key = (r["scene"], r["seed"])
        seen = np.asarray(m.get("seen_points") or [], dtype=np.int64)
        vis = visible.get(key)
        share = None
        if vis is not None and vis.any():
            share = float(np.isin(np.flatnonzero(vis), seen).mean())
        entry = table.setdefault(r["scene"], {}).setdefault(r["planner"], {"rows": []})
        entry["rows"].append({"seed": r["seed"], "valid": bool(r["success"]), "coverage": m.get("coverage"),
                              "visible_share": share, "mission_time_s": m.get("mission_time_s"),
                              "motion_m": (m.get("motion_mm") or 0.0) / 1000.0,
                              "retractions": m.get("retractions"), "compute_time_s": r["compute_time_s"],
                              "final_rmse_k": m.get("final_rmse_k"), "status": r["status"]})
    for family in table.values():
        for entry in family.values():
            rs = entry["rows"]

            def col(k, rs=rs):
                return np.array([x[k] for x in rs if x[k] is not None], dtype=float)

            vis = col("visible_share")
            entry.update(missions=len(rs), valid=sum(x["valid"] for x in rs),
                         coverage=float(col("coverage").mean()),
                         visible_share=float(vis.mean()) if vis.size else None,
                         visible_share_min=float(vis.min()) if vis.size else None,
                         mission_time_s=float(col("mission_time_s").mean()), motion_m=float(col("motion_m").mean()),
                         retractions=float(col("retractions").mean()),
                         compute_median_s=float(np.median(col("compute_time_s"))),
                         compute_max_s=float(col("compute_time_s").max()),
                         final_rmse_k=float(col("final_rmse_k").mean()) if col("final_rmse_k").size else None,
                         final_rmse_std_k=float(col("final_rmse_k").std()) if col("final_rmse_k").size else None)
    return {"schema": SCHEMA, "families": table}


def coverage_maps(rows: list[dict], visible: dict[tuple[str, int], np.ndarray], summary: dict, out: Path
                  ) -> list[str]:
    """Per family, the coverage map of the first seed's mission by the planner that saw the most of the
    reachable-visible points (``inspect-<family>.png``): seen, not seen, never visible; the file names."""
    from snakeplan.bench.runner import row_path
    from snakeplan.scenes import make_scene
    from snakeplan.viz.coverage import coverage_map_figure
    from snakeplan.viz.figures import save_figure

    names = []
    for family, planners in summary["families"].items():
        best = max(planners, key=lambda p: planners[p]["visible_share"] or 0.0)
        row = min((r for r in rows if r["scene"] == family and r["planner"] == best), key=lambda r: r["seed"])
        scene = make_scene(family, row["seed"])
        seen = np.zeros(len(scene.points_of_interest), dtype=bool)
        seen[np.asarray(row["metrics"]["seen_points"], dtype=np.int64)] = True
        vis = visible.get((family, row["seed"]))
        title = (f"{scene.label}, {row['robot']}, {best}: {seen.mean():.0%} of the points seen"
                 + ("" if vis is None else f", {seen[vis].mean():.0%} of the reachable-visible"))
        name = f"inspect-{family}.png"
        save_figure(coverage_map_figure(scene, seen, None if vis is None else ~vis, row_path(out, row), title),
                    out / name)
        names.append(name)
    return names


def markdown(summary: dict) -> str:
    """The summary as a markdown table, a row per family and planner."""
    lines = ["| family | planner | valid | coverage | of reachable-visible (mean / worst) | final RMSE K | mission s | "
             "feed m | retractions | compute median / max s |", "|---|---|---|---|---|---|---|---|---|---|"]
    for family, planners in summary["families"].items():
        for name, e in planners.items():
            vis = "n/a" if e["visible_share"] is None else f"{e['visible_share']:.1%} / {e['visible_share_min']:.1%}"
            rmse = "" if e["final_rmse_k"] is None else f"{e['final_rmse_k']:.2f} ± {e['final_rmse_std_k']:.2f}"
            lines.append(f"| {family} | {name} | {e['valid']}/{e['missions']} | {e['coverage']:.1%} | {vis} | {rmse} | "
                         f"{e['mission_time_s']:.0f} | {e['motion_m']:.1f} | {e['retractions']:.1f} | "
                         f"{e['compute_median_s']:.1f} / {e['compute_max_s']:.1f} |")
    return "\n".join(lines)


def run_inspect_bench(families: tuple[str, ...] = FAMILIES, seeds: int = DEFAULT_SEEDS, seed0: int = 0,
                      planners: tuple[str, ...] = PLANNERS, out_dir: str | Path = DEFAULT_OUT_DIR,
                      backend: Backend = Backend(), fresh: bool = False, progress: bool = True) -> dict:
    """Inspect ``seeds`` seeds of each family with each planner through the runner into ``out_dir`` (resuming what
    it holds), compute (or load) each scene's reachable-visible points, write ``inspect.json``, ``inspect.md`` and a
    coverage map per family, and return the summary with the runner's outcome under ``"runner"``."""
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise ValueError(f"seeds: must be a positive integer, got {seeds!r}")
    seed_list = list(range(seed0, seed0 + seeds))
    outcome = run_sweep(sweep(families, seed_list, planners), out_dir, backend, fresh=fresh, progress=progress)
    rows = [r for r in outcome.rows if r.get("config") == CONFIG]
    scenes = sorted({(r["scene"], r["seed"]) for r in rows})
    visible = {}
    with streamed(_oracle_task, scenes, backend, name="oracle", progress=progress,
                  stopped=lambda: "stopped: the oracle's finished scenes are cached") as (results, tick):
        for key, seen in results:
            visible[key] = seen
            tick(f"{key[0]} seed {key[1]}")
    summary = summarise(rows, visible)
    out = Path(out_dir)
    summary["figures"] = coverage_maps(rows, visible, summary, out)
    atomic_write(out / "inspect.json", json.dumps(jsonable(summary), indent=1))
    atomic_write(out / "inspect.md", markdown(summary) + "\n")
    return {**summary, "runner": outcome.to_dict()}
