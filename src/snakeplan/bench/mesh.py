"""Planning on meshes: speed on 100k-triangle watertight scenes, and success in the mesh scene families.

``speed``: the fuel-tank (seed 0) rebuilt as one closed mesh of about :data:`SPEED_TRIANGLES` triangles (the union
of its primitives, refined), and the ``pipework`` family (a swept pipe run, about 110k triangles). Figures: the
judge's time on a planned path, per 1.5 m and for the path, and its clearance (the least over the crawl) against
settling every crawl state's own; ``as-rrt`` plan times (median over seeds); chain
clearance and collision checks per second on the mesh against the same scene from primitives (the fuel-tank's
crawl states along a planned path).

``families``: the sampling planners (``rrt-star``, ``sp-rrt``, ``as-rrt``) over seeds of ``pipework``, ``vessel``
and ``engine``, each plan judged; one JSON line per run in ``runs.jsonl`` (resumable), a summary with success rates
and median plan times. Each planner first plans once unrecorded, so jit compilation is not counted.
"""

from __future__ import annotations

import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from snakeplan import ftl
from snakeplan.bench.kernels import median_seconds
from snakeplan.evaluation import evaluate
from snakeplan.geometry.polyline import arclength_grid, cumulative_length
from snakeplan.robots import get_robot
from snakeplan.scenes import Scene, make_scene
from snakeplan.world import JUDGE, FullView, ValidityChecker

#: Triangles of the fuel-tank rebuilt as a mesh.
SPEED_TRIANGLES = 100_000
#: Families and planners of the success runs.
FAMILIES = ("pipework", "vessel", "engine")
PLANNERS = ("rrt-star", "sp-rrt", "as-rrt")
#: Budget (s) of the unrecorded warm-up plan of each planner.
WARMUP_LIMIT_S = 2.0
#: Crawl step (mm) of the clearance workload.
WORKLOAD_STEP_MM = 2.0


def fuel_tank_mesh(triangles: int = SPEED_TRIANGLES) -> tuple[Scene, Scene]:
    """(fuel-tank seed 0, the same scene with its obstacles as one closed mesh of about ``triangles``)."""
    from snakeplan.scenes.meshing import obstacles_mesh

    scene = make_scene("fuel-tank", 0)
    return scene, replace(scene, obstacles=(obstacles_mesh(scene.obstacles, triangles),), discovered=())


def _plan(scene: Scene, planner: str, seed: int, time_limit: float):
    from snakeplan.episode import run_episode
    from snakeplan.planners import Problem

    robot = get_robot(scene.metadata.get("robot", "sjtu-snake-iii"))
    return run_episode(Problem(scene, robot, time_limit_s=time_limit), planner, seed=seed)


def speed(seeds: int = 5, time_limit: float = 30.0, repeats: int = 3) -> dict:
    """The speed figures (see the module); times in seconds."""
    robot = get_robot("sjtu-snake-iii")
    t0 = time.perf_counter()
    prim, mesh = fuel_tank_mesh()
    built = time.perf_counter() - t0
    t0 = time.perf_counter()
    _ = mesh.obstacle_set
    packed = time.perf_counter() - t0
    pipework = make_scene("pipework", 0)
    out: dict = {"fuel_tank_mesh": {"triangles": len(mesh.obstacles[0].faces), "build_s": round(built, 3),
                                    "pack_s": round(packed, 3)},
                 "pipework": {"triangles": len(pipework.obstacles[0].faces)}}
    for key, scene in (("fuel_tank_mesh", mesh), ("pipework", pipework)):
        runs = [_plan(scene, "as-rrt", s, time_limit) for s in range(seeds)]
        times = [r.plan.compute_time_s for r in runs]
        good = [r for r in runs if r.success]
        entry = out[key]
        entry["as_rrt_plan_s_median"] = round(float(np.median(times)), 3)
        entry["as_rrt_success"] = f"{len(good)}/{seeds}"
        if good:
            path = good[0].plan.path
            length = float(cumulative_length(path)[-1])
            judge = median_seconds(lambda: evaluate(scene, robot, path), repeats)
            entry["judge_path_mm"] = round(length, 1)
            entry["judge_s"] = round(judge, 3)
            entry["judge_s_per_1500_mm"] = round(judge * 1500.0 / length, 3)
            # the judge's clearance (the least over its crawl) against settling every state's own, as it did
            joints = ValidityChecker(FullView(scene), robot, JUDGE).crawl(path).states.joints
            obstacles = scene.obstacle_set
            entry["judge_least_clearance_s"] = round(
                median_seconds(lambda: obstacles.least_clearance(joints, robot.radii), repeats), 3)
            entry["judge_every_state_clearance_s"] = round(
                median_seconds(lambda: obstacles.chain_clearance(joints, robot.radii), repeats), 3)
    base = _plan(prim, "as-rrt", 0, time_limit)
    if base.plan.path is not None:
        path = base.plan.path
        states = ftl.fit_states(path, robot.lengths, arclength_grid(float(cumulative_length(path)[-1]),
                                                                     WORKLOAD_STEP_MM), prim.entrance.direction)
        joints = states.joints
        for name, scene in (("primitives", prim), ("mesh", mesh)):
            obstacles = scene.obstacle_set
            clear = median_seconds(lambda: obstacles.chain_clearance(joints, robot.radii), repeats)
            hit = median_seconds(lambda: obstacles.chain_collides(joints, robot.radii), repeats)
            out[f"clearance_per_s_{name}"] = round(len(joints) / clear)
            out[f"collides_per_s_{name}"] = round(len(joints) / hit)
        out["clearance_ratio_primitives_over_mesh"] = round(out["clearance_per_s_primitives"]
                                                             / out["clearance_per_s_mesh"], 2)
        out["collides_ratio_primitives_over_mesh"] = round(out["collides_per_s_primitives"]
                                                            / out["collides_per_s_mesh"], 2)
        out["workload_states"] = len(joints)
    return out


def families(out: Path, seeds: int = 20, time_limit: float = 10.0, families_: tuple[str, ...] = FAMILIES,
             planners: tuple[str, ...] = PLANNERS) -> dict:
    """Run every (family, planner, seed) not yet in ``out/runs.jsonl``; return the summary (also written to
    ``out/summary.json``)."""
    out.mkdir(parents=True, exist_ok=True)
    runs_file = out / "runs.jsonl"
    done = {}
    if runs_file.exists():
        for line in runs_file.read_text().splitlines():
            if line.strip():
                row = json.loads(line)
                done[(row["family"], row["planner"], row["seed"])] = row
    todo = [(f, p, s) for f in families_ for s in range(seeds) for p in planners if (f, p, s) not in done]
    for planner in {p for _, p, _ in todo}:  # warm-up, not recorded: jit compilation is not planning time
        _plan(make_scene(todo[0][0], 0), planner, 0, WARMUP_LIMIT_S)
    for family in families_:
        for seed in range(seeds):
            scene = None
            for planner in planners:
                if (family, planner, seed) in done:
                    continue
                scene = scene or make_scene(family, seed)
                ep = _plan(scene, planner, seed, time_limit)
                row = {"family": family, "planner": planner, "seed": seed, "success": bool(ep.success),
                       "status": str(ep.plan.status), "plan_s": round(ep.plan.compute_time_s, 4),
                       "reason": None if ep.report is None else ep.report.reason}
                with runs_file.open("a") as f:
                    f.write(json.dumps(row) + "\n")
                done[(family, planner, seed)] = row
    summary: dict = {}
    for family in families_:
        for planner in planners:
            rows = [r for (f, p, s), r in done.items() if f == family and p == planner and s < seeds]
            if rows:
                summary[f"{family}/{planner}"] = {
                    "runs": len(rows), "success_rate": round(sum(r["success"] for r in rows) / len(rows), 3),
                    "plan_s_median": round(float(np.median([r["plan_s"] for r in rows])), 3)}
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    return summary
