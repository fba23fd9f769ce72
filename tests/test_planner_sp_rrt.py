"""`sp-rrt`: judged success on fixed seeds, the tree's geometry (sections apart, bends), determinism, failures."""

import numpy as np
import pytest

from snakeplan.evaluation import evaluate
from snakeplan.geometry.primitives import Plate
from snakeplan.planners.base import Problem
from snakeplan.planners.registry import get_planner
from snakeplan.planners.sp_rrt import TREE_BEND_FRACTION, SpRRT
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene
from snakeplan.scenes.scene import Entrance, Scene

ROBOT = get_robot("sjtu-snake-iii")
CASES = [("fuel-tank", 2), ("fuel-tank", 5), ("oil-tank", 1), ("oil-tank", 8)]


def _angles(path: np.ndarray) -> np.ndarray:
    """Turning angles (rad) at the interior points of a polyline."""
    d = np.diff(path, axis=0)
    a, b = d[:-1], d[1:]
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))


@pytest.fixture(scope="module")
def plans():
    out = {}
    for name, seed in CASES:
        scene = make_scene(name, seed)
        out[name, seed] = scene, get_planner("sp-rrt", optimize="none").plan(Problem(scene, ROBOT, time_limit_s=10.0),
                                                                         seed=seed)
    return out


@pytest.mark.parametrize("case", CASES)
def test_judge_says_success(plans, case):
    scene, plan = plans[case]
    assert plan.status == "found" and plan.planner == "sp-rrt"
    report = evaluate(scene, ROBOT, plan.path)
    assert report.success, report.reason
    assert report.targets_reached == len(scene.targets)
    assert report.max_bend_rad <= ROBOT.max_bends.max()
    assert plan.details["tree_size"] >= len(plan.path) - 2 and plan.details["iterations"] >= 0


@pytest.mark.parametrize("case", CASES)
def test_nodes_one_section_apart_and_bends_within_limit(plans, case):
    scene, plan = plans[case]
    path = plan.path
    np.testing.assert_array_equal(path[0], scene.entrance.position)
    np.testing.assert_allclose(path[-1], scene.targets[-1], atol=1e-9)
    gaps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    assert 0.0 < gaps[0] <= ROBOT.lengths[0] + 1e-9
    np.testing.assert_allclose(gaps[1:], ROBOT.lengths[0], atol=1e-6)
    # joints after the first node are nodes: their bends are the tree's (the first point is the entrance)
    assert np.all(_angles(path[1:]) <= ROBOT.max_bends[0] * TREE_BEND_FRACTION + 1e-9)


def test_same_seed_same_path():
    scene = make_scene("fuel-tank", 8)
    first = SpRRT().plan(Problem(scene, ROBOT, time_limit_s=10.0), seed=3)
    second = SpRRT().plan(Problem(scene, ROBOT, time_limit_s=10.0), seed=3)
    assert first.status == second.status == "found"
    np.testing.assert_array_equal(first.path, second.path)
    assert first.details["iterations"] == second.details["iterations"]


def _box_scene(targets, plates=()) -> Scene:
    """A 1000 mm empty cube entered at the middle of its x = 0 face, fed along +x."""
    return Scene("box", 0, [0.0, 0.0, 0.0], [1000.0, 1000.0, 1000.0],
                 Entrance([0.0, 500.0, 500.0], [1.0, 0.0, 0.0]), np.array(targets, dtype=float), list(plates))


def test_sealed_target_fails_at_once():
    wall = Plate([500.0, 500.0, 500.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], (1000.0, 1000.0), 10.0)
    plan = SpRRT().plan(Problem(_box_scene([[800.0, 500.0, 500.0]], [wall]), ROBOT, time_limit_s=5.0))
    assert plan.status == "no_progress" and plan.path is None and "geodesic field" in plan.why
    assert plan.compute_time_s < 5.0


def test_corridor_behind_the_entry_wall_times_out_within_budget():
    # a full-width plate 150 mm in front of the entry wall: the target in that corridor is geodesically near, but
    # the arm would have to turn 90 degrees within the corridor's width
    plate = Plate([150.0, 500.0, 500.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], (1000.0, 1000.0), 10.0)
    plan = SpRRT().plan(Problem(_box_scene([[70.0, 900.0, 500.0]], [plate]), ROBOT, time_limit_s=1.0))
    assert plan.status == "timeout" and plan.path is None
    assert plan.details["tree_size"] > 1
    assert plan.compute_time_s < 1.0 + 0.5


def test_needs_the_whole_scene():
    problem = Problem(make_scene("oil-tank", 1), ROBOT, time_limit_s=1.0, knowledge="sensed")
    with pytest.raises(ValueError, match="knowledge"):
        SpRRT().plan(problem)


def test_registered_under_its_name():
    pytest.importorskip("snakeplan.planners.rrt_star")
    pytest.importorskip("snakeplan.planners.as_rrt")
    from snakeplan.planners import get_planner

    assert isinstance(get_planner("sp-rrt"), SpRRT)
