"""The judge against hand-built scenes whose verdicts are known in advance."""

import json
import math

import numpy as np
import pytest

from snakeplan.evaluation import JudgeSettings, Reason, evaluate
from snakeplan.geometry.primitives import Box
from snakeplan.robots import get_robot
from snakeplan.scenes import Entrance, Scene
from snakeplan.world import FailureKind, FullView, ValidityChecker

ROBOT = get_robot("sjtu-snake-iii")  # 12 x 177.5 mm, radius 27.5 mm, bend <= 50.7 deg


def corridor(targets, obstacles=()):
    """A 3000 x 1000 x 1000 mm box world entered at the origin along +x."""
    return Scene("corridor", None, [0, -500, -500], [3000, 500, 500],
                 Entrance([0, 0, 0], [1, 0, 0]), np.array(targets, dtype=float).reshape(-1, 3), list(obstacles))


def line(a, b, n=50):
    return np.linspace(a, b, n)


def test_straight_path_to_target_is_feasible_with_zero_curvature():
    scene = corridor([[1500, 0, 0]])
    report = evaluate(scene, ROBOT, line([0, 0, 0], [1500, 0, 0]))
    assert report.success and report.reason == "reached"
    assert report.path_length_mm == pytest.approx(1500)
    assert report.max_curvature_per_mm == pytest.approx(0, abs=1e-12)
    assert report.smoothness_index == 1.0
    assert report.max_deviation_mm == pytest.approx(0, abs=1e-9)
    assert report.min_clearance_mm == math.inf


def test_collision_found_at_the_hand_computed_depth():
    # A wall across the corridor at x in [1000, 1100]: the tip capsule (radius 27.5) touches it at depth 972.5.
    wall = Box([1050, 0, 0], [100, 2000, 2000])
    scene = corridor([[1500, 0, 0]], [wall])
    report = evaluate(scene, ROBOT, line([0, 0, 0], [1500, 0, 0]), JudgeSettings(crawl_step_mm=1.0))
    assert not report.success and report.reason == "collision"
    assert report.first_failure_depth_mm == pytest.approx(973.0, abs=1.0)
    assert report.min_clearance_mm < 0


def test_clearance_of_a_body_passing_an_obstacle():
    # A box whose face is 100 mm from the straight body axis: clearance = 100 - 27.5.
    box = Box([700, 200, 0], [200, 200, 200])
    scene = corridor([[1500, 0, 0]], [box])
    report = evaluate(scene, ROBOT, line([0, 0, 0], [1500, 0, 0]))
    assert report.success
    assert report.min_clearance_mm == pytest.approx(100 - 27.5, abs=0.06)


def test_sharp_corner_breaks_the_bend_limit():
    corner = np.vstack([line([0, 0, 0], [600, 0, 0]), line([600, 0, 0], [600, 400, 0])[1:]])
    report = evaluate(corridor([[600, 400, 0]]), ROBOT, corner)
    assert report.reason == "bend_limit" and not report.bend_limits_ok
    assert report.max_bend_rad > ROBOT.max_bends[0]


def test_gentle_arc_keeps_bends_equal_to_chord_angle():
    R = 1500.0
    t = np.linspace(0, 0.8, 4000)  # stays inside the corridor: R (1 - cos 0.8) = 455 mm
    arc = np.stack([R * np.sin(t), R * (1 - np.cos(t)), np.zeros_like(t)], axis=1)
    report = evaluate(corridor([arc[-1]]), ROBOT, arc)
    assert report.success
    l = ROBOT.lengths[0]
    assert report.max_bend_rad == pytest.approx(2 * math.asin(l / (2 * R)), abs=1e-3)
    assert report.max_curvature_per_mm == pytest.approx(1 / R, rel=0.01)
    assert report.max_deviation_mm == pytest.approx(R - math.sqrt(R * R - l * l / 4), rel=0.01)


def test_path_longer_than_the_arm_fails_insertion():
    scene = corridor([[2900, 0, 0]])
    report = evaluate(scene, ROBOT, line([0, 0, 0], [2900, 0, 0]))
    assert report.reason == "insertion" and not report.insertion_ok
    assert report.first_failure_depth_mm == pytest.approx(ROBOT.total_length, abs=JudgeSettings().crawl_step_mm)


def test_targets_in_order_and_out_of_bounds():
    scene = corridor([[400, 0, 0], [800, 0, 0]])
    assert evaluate(scene, ROBOT, line([0, 0, 0], [800, 0, 0])).targets_reached == 2
    reverse = corridor([[800, 0, 0], [400, 0, 0]])
    r = evaluate(reverse, ROBOT, line([0, 0, 0], [800, 0, 0]))
    assert r.targets_reached == 1 and r.reason == "not_reached"
    up = np.vstack([line([0, 0, 0], [300, 0, 0]), [[300, 0, 0]] + np.linspace(0, 1, 30)[1:, None] * [[600, 0, 600]]])
    assert evaluate(corridor([[900, 0, 600]]), ROBOT, up).in_bounds is False


def test_path_must_start_at_the_entrance():
    with pytest.raises(ValueError, match="entrance"):
        evaluate(corridor([[500, 0, 0]]), ROBOT, line([5, 0, 0], [500, 0, 0]))
    with pytest.raises(ValueError):
        evaluate(corridor([[500, 0, 0]]), ROBOT, [[0, 0, 0], [np.nan, 0, 0]])


def test_reasons_and_failure_kinds_are_typed_and_print_their_plain_value():
    wall = Box([1050, 0, 0], [100, 2000, 2000])
    scene = corridor([[1500, 0, 0]], [wall])
    path = line([0, 0, 0], [1500, 0, 0])
    report = evaluate(scene, ROBOT, path)
    failure = ValidityChecker(FullView(scene), ROBOT).first_failure(path)
    assert report.reason is Reason.COLLISION and failure.kind is FailureKind.COLLISION
    for value in (report.reason, failure.kind):
        assert value == "collision" and str(value) == f"{value}" == "%s" % value == "collision"
        assert json.dumps({"reason": value}) == '{"reason": "collision"}'
    assert [str(r) for r in Reason] == ["reached", "collision", "bend_limit", "insertion", "out_of_bounds",
                                        "not_reached", "not_holdable"]
    assert {str(k) for k in FailureKind} < {str(r) for r in Reason}
