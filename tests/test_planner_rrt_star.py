"""`rrt-star`: judged success on fixed seeds, determinism, the time budget, and problems it cannot solve."""

import dataclasses
import time

import numpy as np
import pytest

from snakeplan.evaluation import evaluate
from snakeplan.geometry.polyline import densify
from snakeplan.geometry.primitives import Box
from snakeplan.planners import Problem
from snakeplan.planners.rrt_star import RRTStar
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene

ROBOT = get_robot("sjtu-snake-iii")
#: Allowance (s) past the budget for the last smoothing and crawl check, which are not interrupted.
OVERRUN_S = 0.5


def _enclosed(scene, target, inner_half_mm: float, wall_mm: float = 10.0):
    """The scene with a closed box of walls around ``target`` (``inner_half_mm`` from it to each wall)."""
    walls = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            centre = np.array(target, dtype=float)
            centre[axis] += sign * (inner_half_mm + wall_mm / 2)
            size = np.full(3, 2 * (inner_half_mm + wall_mm))
            size[axis] = wall_mm
            walls.append(Box(centre, size))
    return dataclasses.replace(scene, obstacles=[*scene.obstacles, *walls])


@pytest.mark.parametrize(("name", "seed"), [("fuel-tank", 0), ("oil-tank", 1)])
def test_plan_passes_the_judge(name, seed):
    scene = make_scene(name, seed)
    plan = RRTStar().plan(Problem(scene, ROBOT, time_limit_s=10.0), seed=seed)
    assert plan.status == "found" and plan.planner == "rrt-star"
    report = evaluate(scene, ROBOT, plan.path)
    assert report.success, report.reason
    assert plan.details["legs"] == len(scene.targets)
    assert len(plan.details["tree_sizes"]) >= len(scene.targets)
    assert plan.details["smoothed_length_mm"] == pytest.approx(report.path_length_mm)
    dense = densify(plan.path, 1.0)
    for target in scene.targets:  # smoothing keeps the tip on every target, not just within the tolerance
        assert np.min(np.linalg.norm(dense - target, axis=1)) < 5.0


def test_same_seed_same_plan():
    problem = Problem(make_scene("oil-tank", 3), ROBOT, time_limit_s=10.0)
    first = RRTStar().plan(problem, seed=7)
    second = RRTStar().plan(problem, seed=7)
    assert first.status == second.status == "found"
    np.testing.assert_array_equal(first.path, second.path)
    assert first.details == second.details


def test_stops_within_a_short_budget():
    problem = Problem(make_scene("oil-tank", 0), ROBOT, time_limit_s=0.05)
    t0 = time.perf_counter()
    plan = RRTStar().plan(problem, seed=0)
    assert time.perf_counter() - t0 < problem.time_limit_s + OVERRUN_S
    assert plan.status in ("found", "timeout")
    assert (plan.path is None) == (plan.status != "found")


def test_enclosed_target_times_out_within_budget():
    scene = make_scene("fuel-tank", 0)
    boxed = _enclosed(scene, scene.targets[0], inner_half_mm=80.0)
    plan = RRTStar().plan(Problem(boxed, ROBOT, time_limit_s=1.5), seed=0)
    assert plan.status == "timeout" and plan.path is None
    assert plan.compute_time_s < 1.5 + OVERRUN_S


def test_blocked_target_fails_at_once():
    scene = make_scene("fuel-tank", 0)
    solid = dataclasses.replace(scene, obstacles=[*scene.obstacles, Box(scene.targets[0], np.full(3, 40.0))])
    plan = RRTStar().plan(Problem(solid, ROBOT, time_limit_s=5.0), seed=0)
    assert plan.status == "failed" and plan.path is None
    assert plan.compute_time_s < 1.0
