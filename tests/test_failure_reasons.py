"""Every failure has a reason (issue 38, item 5): a problem no plan can solve is refused before any search, as
OMPL refuses an invalid start or goal, and every plan that is not found says why, in plan/1 and on the console.

The refusals are bounds no judged path beats, so a problem the judge can see solved is never refused: checked
with hypothesis on arcs the judge accepts, between random bounds."""

import dataclasses
import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.cli import main
from snakeplan.evaluation import evaluate
from snakeplan.geometry.primitives import Box
from snakeplan.planners import Problem, get_planner, planner_names
from snakeplan.planners.base import input_refusal
from snakeplan.robots import get_robot
from snakeplan.scenes import Entrance, Scene, Task
from snakeplan.world import JUDGE, ValidityChecker, view_for

ROBOT = get_robot("sjtu-snake-iii")
#: The reach planners that plan this arm in any scene (sscc plans its own arms; the learned ones need a policy).
SEARCHERS = ("as-rrt", "sp-rrt", "rrt-star", "sac-her")


def box_scene(entrance, direction, targets, obstacles=(), lo=(-500, -500, -500), hi=(500, 500, 500)) -> dict:
    return {"schema": "snakeplan.scene/1", "name": "box", "bounds": {"min": list(lo), "max": list(hi)},
            "entrance": {"position": list(entrance), "direction": list(direction)},
            "targets": [list(t) for t in targets], "obstacles": list(obstacles)}


def plan_cli(capsys, tmp_path, scene: dict, planner: str):
    f = tmp_path / "scene.json"
    f.write_text(json.dumps(scene))
    code = main(["plan", "--scene-file", str(f), "--planner", planner, "--time-limit", "10"])
    out, err = capsys.readouterr()
    code_json = main(["plan", "--scene-file", str(f), "--planner", planner, "--time-limit", "10", "--json"])
    doc = json.loads(capsys.readouterr().out)
    return code, out, err, code_json, doc


@pytest.mark.parametrize("planner", SEARCHERS)
def test_an_entrance_pointing_out_of_the_scene_is_an_invalid_start_at_once(capsys, tmp_path, planner):
    """As the newcomer met it: the entrance 20 mm from the wall, facing out; it said "timeout in 10 s"."""
    scene = box_scene([-480, 0, 0], [-1, 0, 0], [[200, 0, 0]])
    code, out, err, code_json, doc = plan_cli(capsys, tmp_path, scene, planner)
    assert code == code_json == 1 and err == ""
    first, why = out.splitlines()[:2]
    assert f"{planner} on box with sjtu-snake-iii: invalid_start in 0.0" in first
    assert why.startswith("why: the entrance points out of the scene: the bounds lie 20 mm ahead along "
                          "entrance.direction [-1, 0, 0]") and "targets[0] behind it" in why
    assert doc["status"] == "invalid_start" and doc["why"] == why[len("why: "):] and doc["path"] == []
    assert doc["compute_time_s"] < 0.5


@pytest.mark.parametrize("planner", SEARCHERS)
def test_a_target_farther_than_the_arm_is_long_is_an_invalid_target(capsys, tmp_path, planner):
    scene = box_scene([-480, 0, 0], [1, 0, 0], [[4800, 0, 0]], hi=(5000, 500, 500))
    code, out, err, _, doc = plan_cli(capsys, tmp_path, scene, planner)
    assert code == 1 and doc["status"] == "invalid_target"
    # 5280 mm of straight leg, less the 10 mm reach tolerance, against the arm's 2130 mm
    assert doc["why"] == ("targets[0] [4800, 0, 0] needs at least 5270 mm of tip path from the entrance (through "
                          "the targets before it), beyond the arm's length 2130 mm")


def test_the_legs_through_earlier_targets_count_toward_the_reach():
    """Each target alone lies within the arm's 2130 mm; the way through the first to the second does not."""
    scene = Scene("two", None, [-500, -1500, -500], [1500, 1500, 500], Entrance([-480, 0, 0], [1, 0, 0]),
                  np.array([[520.0, 1000.0, 0.0], [520.0, -1000.0, 0.0]]))
    refusal = input_refusal(Problem(scene, ROBOT))
    assert refusal.status == "invalid_target" and refusal.why.startswith("targets[1]")
    assert input_refusal(Problem(Scene("one", None, scene.bounds_min, scene.bounds_max, scene.entrance,
                                       scene.targets[1:]), ROBOT)) is None


def test_an_obstacle_across_the_entrance_is_an_invalid_start():
    wall = Box([-445.0, 0.0, 0.0], [10.0, 400.0, 400.0])  # 30 mm ahead of the entrance, across it
    scene = Scene("walled", None, [-500] * 3, [500] * 3, Entrance([-480, 0, 0], [1, 0, 0]), [[200.0, 0, 0]], [wall])
    refusal = input_refusal(Problem(scene, ROBOT))
    assert refusal.status == "invalid_start"
    assert refusal.why == ("obstacles[0] blocks the entrance: 5 mm along entrance.direction [1, 0, 0] the tip's ball "
                           "of radius 27.5 mm is 25 mm from it")


def test_a_target_the_tip_cannot_fit_beside_is_refused_only_once_known():
    """A target 3 mm from an obstacle, less than the tip's radius less the reach tolerance: refused with the
    obstacle named when the planner knows it (the whole scene, or a sensed view with it in the prior); a sensed
    planner for which it is debris found on the job is not refused (it must find out by planning), and says so by
    its own status."""
    r = float(ROBOT.radii[-1])
    block = Box([600.0, 0.0, 0.0], [100.0, 100.0, 100.0])
    scene = Scene("near", None, [-500] * 3, [1000] * 3, Entrance([-480, 0, 0], [1, 0, 0]), [[547.0, 0, 0]],
                  [block])
    full = input_refusal(Problem(scene, ROBOT))
    assert r - 10.0 > 3.0 and full.status == "invalid_target"
    assert full.why == (f"targets[0] [547, 0, 0] lies 3 mm from obstacles[0]: the tip (radius {r:g} mm) cannot come "
                        f"within the reach tolerance 10 mm of it")
    prior = input_refusal(Problem(scene, ROBOT, knowledge="sensed"))
    assert prior.why.startswith("targets[0] [547, 0, 0] lies 3 mm from a known box")
    sensed = Problem(dataclasses.replace(scene, discovered=(0,)), ROBOT, knowledge="sensed", sensor_range_mm=200.0)
    assert input_refusal(sensed) is None
    plan = get_planner("as-rrt").plan(sensed, 0)
    assert plan.status != "found" and plan.why


def test_a_plan_that_is_not_found_says_why_on_the_console(capsys, tmp_path):
    """rrt-star gave up in 0.03 s with its budget unused and said only "failed": it now names each repair it
    tried and the crawl check's first failure."""
    code = main(["plan", "--scene", "confined", "--seed", "7", "--planner", "rrt-star", "--time-limit", "5"])
    out = capsys.readouterr().out
    first, why = out.splitlines()[:2]
    assert code == 1 and ": no_progress in " in first
    assert why.startswith("why: every repair was tried: the tree's path with 0 mm clearance") and "bend_limit" in why


@pytest.mark.parametrize("name", [n for n in planner_names(Task.REACH) if n != "sscc"])
def test_every_reach_planner_refuses_an_invalid_problem_before_searching(name):
    scene = Scene("out", None, [-500] * 3, [500] * 3, Entrance([-495, 0, 0], [-1, 0, 0]), [[0.0, 0, 0]])
    plan = get_planner(name).plan(Problem(scene, ROBOT, time_limit_s=5.0), 0)
    assert plan.status == "invalid_start" and plan.path is None and "5 mm ahead" in plan.why


@settings(max_examples=60, deadline=None)
@given(turn=st.floats(0.0, math.pi), radius=st.floats(1.1, 4.0), length=st.floats(100.0, 2000.0),
       room=st.floats(0.0, 300.0), seed=st.integers(0, 2**16))
def test_a_problem_the_judge_sees_solved_is_never_refused(turn, radius, length, room, seed):
    """An arc from the entrance (radius from 1.1 turning radii up, turning up to a half turn) that the judge
    accepts, in bounds fitted around it with random room: its end as the target is never refused."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    n = np.cross(d, rng.normal(size=3))
    n /= np.linalg.norm(n)
    start = rng.uniform(-200, 200, 3)
    probe = Scene("probe", None, [-1e4] * 3, [1e4] * 3, Entrance(start, d), [start + 100 * d])
    R = radius * ValidityChecker(view_for(probe, "full"), ROBOT, JUDGE).turn_radius
    theta = np.linspace(0.0, min(turn, length / R), 200)
    path = start + R * np.sin(theta)[:, None] * d + R * (1 - np.cos(theta))[:, None] * n
    lo, hi = path.min(axis=0) - ROBOT.radii.max() - room, path.max(axis=0) + ROBOT.radii.max() + room
    scene = Scene("arc", None, lo, hi, Entrance(start, d), path[-1:])
    if evaluate(scene, ROBOT, path).success:
        assert input_refusal(Problem(scene, ROBOT)) is None


def test_a_way_in_narrower_than_the_arm_is_warned_of_with_both_sizes(capsys, tmp_path):
    """A pipe drawn in cm read as mm: its bore, 20 mm in radius, narrower than every section of the arm (27.5 mm).
    plan warns, naming both sizes and how many sections fit, and the start is refused with its why."""
    pipe = {"type": "pipe", "center": [0, 0, 0], "axis": [1, 0, 0], "inner_radius": 20, "outer_radius": 25,
            "length": 600}
    scene = box_scene([-250, 0, 0], [1, 0, 0], [[200, 0, 0]], [pipe])
    code, out, err, _, doc = plan_cli(capsys, tmp_path, scene, "as-rrt")
    assert code == 1 and doc["status"] == "invalid_start"
    assert err == ("snakeplan: warning: entrance: the free space there is 20 mm in radius, narrower than "
                   "sjtu-snake-iii's thickest section (27.5 mm, section 0): 0 of its 12 sections fit through; are "
                   "the scene's units right?\n")
    assert "why: a known pipe" not in out and "why: obstacles[0] blocks the entrance: at the entrance" in out


def test_checking_a_plan_that_found_no_path_says_how_its_planner_ended(capsys, tmp_path):
    """The newcomer checked a plan whose planner found nothing and read "path: needs at least 2 entries, got 0"."""
    scene = box_scene([-480, 0, 0], [-1, 0, 0], [[200, 0, 0]])
    *_, doc = plan_cli(capsys, tmp_path, scene, "as-rrt")
    (tmp_path / "plan.json").write_text(json.dumps(doc))
    code = main(["check", "--scene-file", str(tmp_path / "scene.json"), str(tmp_path / "plan.json")])
    out, err = capsys.readouterr()
    assert (code, out) == (2, "") and err.count("\n") == 1
    assert err.startswith("snakeplan: error: path: the plan holds none to judge: its planner ended invalid_start "
                          "(the entrance points out of the scene")


def test_a_report_says_how_each_planners_runs_ended():
    from snakeplan.bench.report import markdown, summarise

    base = {"config": "run", "scene": "s", "planner": "p", "options": {}, "success": False, "compute_time_s": 1.0,
            "metrics": None}
    rows = [{**base, "status": s} for s in ("timeout", "failed", "timeout", "no_progress", "invalid_target")]
    (entry,) = summarise(rows)
    assert entry["ended"] == "timeout 2, no_progress 2, invalid_target 1"  # "failed", written before, is no_progress
    assert markdown([entry], "t").splitlines()[-1].endswith("| timeout 2, no_progress 2, invalid_target 1 |")


def test_an_entrance_facing_away_from_the_obstacles_behind_it_is_an_invalid_start():
    """The entrance turned to face out of the room, 100 mm from its wall: the arm not yet inserted lies straight
    back from the entrance, through the block 500 mm behind it, and the judge fails every path at depth 0 (rrt-star
    said 'collision at depth 0 mm' three times). Refused first, naming the block and where along the arm."""
    block = Box([0.0, 0.0, 0.0], [800.0, 600.0, 400.0])
    scene = Scene("facing-out", None, [-1000, -800, -700], [1000, 800, 700], Entrance([-900, 0, 0], [-1, 0, 0]),
                  [[550.0, 0, 0]], [block])
    failure = evaluate(scene, ROBOT, np.array([[-900.0, 0, 0], [-950.0, 0, 0]]))
    assert failure.reason == "collision" and failure.metrics()["first_failure_depth_mm"] == 0.0
    refusal = input_refusal(Problem(scene, ROBOT))
    assert refusal.status == "invalid_start"
    # sections of 177.5 mm of radius 27.5 mm: the third from the tip spans 355-532.5 mm back and reaches x = -400
    assert refusal.why == ("the arm waiting behind the entrance (straight back from it along entrance.direction "
                           "[-1, 0, 0], 2130 mm) meets obstacles[0] 355-532.5 mm back: does the entrance face into "
                           "the scene?")
