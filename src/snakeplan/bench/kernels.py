"""Speed of the hot kernels: chain collision checks, chain clearance, follow-the-leader fits, learned roll-outs.

Each kernel is timed as the median of several repeats over one batch and compared with a baseline run in the
same process: dense-sampling NumPy clearance for the collision kernels, one-call-per-depth Python for the
follow-the-leader fit, the same crawl stepped from Python (as the training environments step it) for the compiled
roll-out. Scene: fuel-tank; robot: sjtu-snake-iii (the issue's reference case); policy: the shipped sac-her.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from snakeplan import ftl
from snakeplan.geometry.distance import sampled_chain_clearance
from snakeplan.robots import Chain, get_robot
from snakeplan.scenes import Scene, make_scene

#: Sampling step (mm) of the NumPy baseline clearance (its error bound is half of this).
BASELINE_SAMPLING_MM = 5.0


def median_seconds(fn: Callable[[], object], repeats: int) -> float:
    fn()  # warm-up: jit compilation and caches
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def random_bodies(scene: Scene, robot: Chain, count: int, seed: int, paths: int = 64) -> np.ndarray:
    """Joint positions ``(count, n+1, 3)`` of the arm fitted follow-the-leader onto random smooth tip paths.

    This is a planner's workload: bodies on a tip path from the entrance at random depths, the part not yet
    inserted straight behind the entrance; some touch obstacles, most do not.
    """
    rng = np.random.default_rng(seed)
    per_path = -(-count // paths)
    bodies = []
    for k in range(paths):
        path = smooth_path(scene.entrance.position, scene.entrance.direction, 1500.0, 150, seed * 1000 + k)
        depths = rng.uniform(0.0, 1500.0 * 0.999, per_path)
        bodies.append(ftl.fit_batch(path, robot.lengths, depths, scene.entrance.direction))
    return np.concatenate(bodies)[:count]


def smooth_path(entrance: np.ndarray, direction: np.ndarray, length: float, points: int, seed: int) -> np.ndarray:
    """A smooth random tip path of ``points`` vertices and about ``length`` mm starting at the entrance."""
    rng = np.random.default_rng(seed)
    step = length / (points - 1)
    heading = np.asarray(direction, dtype=float)
    turn = rng.normal(size=3) * 0.02
    out = [np.asarray(entrance, dtype=float)]
    for _ in range(points - 1):
        turn = 0.9 * turn + rng.normal(size=3) * 0.004
        heading = heading + turn - np.dot(turn, heading) * heading
        heading /= np.linalg.norm(heading)
        out.append(out[-1] + step * heading)
    return np.array(out)


def run_kernel_bench(repeats: int = 7, batch: int = 20000, seed: int = 0, print_table: bool = True) -> dict:
    """Time the kernels; returns per-second figures and speed-ups against the same-process baselines."""
    if repeats < 1 or batch < 10:
        raise ValueError("repeats must be >= 1 and batch >= 10")
    scene = make_scene("fuel-tank", seed)
    robot = get_robot("sjtu-snake-iii")
    bodies = random_bodies(scene, robot, batch, seed)
    radii = robot.radii
    small = bodies[: max(10, batch // 40)]

    t_collide = median_seconds(lambda: scene.chain_collides(bodies, radii), repeats)
    t_clear = median_seconds(lambda: scene.chain_clearance(bodies, radii), repeats)
    t_base = median_seconds(
        lambda: sampled_chain_clearance(scene.obstacle_set, small, radii, BASELINE_SAMPLING_MM), max(1, repeats // 2)
    )
    base_rate = len(small) / t_base

    path = smooth_path(scene.entrance.position, scene.entrance.direction, 2000.0, 200, seed)
    depths = np.random.default_rng(seed).uniform(0, 2000.0 * 0.999, batch)
    depths = np.minimum(depths, np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    u = scene.entrance.direction
    t_fit = median_seconds(lambda: ftl.fit_batch(path, robot.lengths, depths, u), repeats)
    loop_depths = depths[: max(10, batch // 100)]
    t_loop = median_seconds(lambda: [ftl.fit(path, robot.lengths, s, u) for s in loop_depths], max(1, repeats // 2))
    loop_rate = len(loop_depths) / t_loop

    from snakeplan.planners.sac.planner import rollout
    from snakeplan.planners.sac.policy import load_policy, policy_path

    policy = load_policy(policy_path("fuel-tank", "sac-her"))
    steps = len(rollout(policy, scene, robot)[0]) - 1
    t_roll = median_seconds(lambda: rollout(policy, scene, robot), repeats)
    t_stepped = median_seconds(lambda: stepped_rollout(policy, scene, robot), max(1, repeats // 2))

    colliding = float(scene.chain_collides(bodies, radii).mean())
    result = {
        "scene": "fuel-tank", "seed": seed, "robot": robot.name, "batch": batch, "repeats": repeats,
        "colliding_fraction": colliding,
        "collision_checks_per_s": batch / t_collide,
        "clearance_evals_per_s": batch / t_clear,
        "baseline_sampled_clearance_per_s": base_rate,
        "collision_speedup_vs_baseline": (batch / t_collide) / base_rate,
        "clearance_speedup_vs_baseline": (batch / t_clear) / base_rate,
        "ftl_fits_per_s": batch / t_fit,
        "baseline_ftl_single_fits_per_s": loop_rate,
        "ftl_speedup_vs_baseline": (batch / t_fit) / loop_rate,
        "rollout_steps": steps,
        "rollouts_per_s": 1.0 / t_roll,
        "baseline_stepped_rollouts_per_s": 1.0 / t_stepped,
        "rollout_speedup_vs_baseline": t_stepped / t_roll,
    }
    if print_table:
        _print(result)
    return result


def _print(r: dict) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"snakeplan kernels: {r['robot']} in {r['scene']} (seed {r['seed']}), batch {r['batch']}, "
                        f"median of {r['repeats']}; {100 * r['colliding_fraction']:.0f}% of bodies collide")
    for col in ("kernel", "per second", "baseline per second", "speed-up"):
        table.add_column(col, justify="right")
    table.add_row("chain collision check", f"{r['collision_checks_per_s']:,.0f}",
                  f"{r['baseline_sampled_clearance_per_s']:,.0f}", f"{r['collision_speedup_vs_baseline']:.0f}x")
    table.add_row("chain min clearance", f"{r['clearance_evals_per_s']:,.0f}",
                  f"{r['baseline_sampled_clearance_per_s']:,.0f}", f"{r['clearance_speedup_vs_baseline']:.0f}x")
    table.add_row("follow-the-leader fit", f"{r['ftl_fits_per_s']:,.0f}",
                  f"{r['baseline_ftl_single_fits_per_s']:,.0f}", f"{r['ftl_speedup_vs_baseline']:.0f}x")
    table.add_row(f"learned roll-out ({r['rollout_steps']} steps)", f"{r['rollouts_per_s']:,.0f}",
                  f"{r['baseline_stepped_rollouts_per_s']:,.0f}", f"{r['rollout_speedup_vs_baseline']:.0f}x")
    Console().print(table)
    Console().print(f"baselines: NumPy clearance sampled every {BASELINE_SAMPLING_MM:g} mm; one ftl.fit call per "
                    f"depth; the roll-out's crawl stepped from Python")


def stepped_rollout(policy, scene: Scene, robot: Chain, world=None, noise: float = 0.0,
                    rng: np.random.Generator | None = None) -> tuple[np.ndarray, str]:
    """The planning roll-out (:func:`snakeplan.planners.sac.rollout`) as a loop of ``Crawler`` steps in Python,
    one noise draw per step taken: the baseline of the compiled roll-out, and what a test holds it to."""
    from snakeplan.planners.sac.kernels import Outcome

    crawler = policy.crawler(robot, check_body=False)
    crawler.reset(scene, world)
    for _ in range(int(np.ceil(robot.total_length / crawler.step_mm)) + 1):
        action = policy.act(crawler.observation())
        if noise > 0.0:
            action = action + noise * rng.standard_normal(action.shape)
        failure, _ = crawler.advance(action)
        if failure is not None:
            return crawler.tip_path(), failure
        if crawler.done:
            return crawler.tip_path(), Outcome.REACHED
    return crawler.tip_path(), Outcome.STEPS
