"""The search task: targets hidden until the tip camera sees them. What a view sees against hand-computed geometry
and a dense line-of-sight walk; the judge's times to find and to reach by hand; a plan that drives to a target it
has not seen does not score; a planner that reads a target before seeing it fails the honesty rule; the search
planners in the tanks, checked from the plan document alone; scene files and the command line; a real CAD file from
a package no one here wrote, end to end with its video."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.cli import main
from snakeplan.evaluation.search import evaluate_search
from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Sphere
from snakeplan.mapping.models import TIP_CAMERA
from snakeplan.planners import ConformanceError, Planner, Problem, Solution, Status, check_planner
from snakeplan.robots import Chain, Section, get_robot
from snakeplan.scenes import Entrance, Scene, make_scene
from snakeplan.world.mission import Crawl, InspectionSettings, Mission, Views
from snakeplan.world.search import TARGET_RADIUS_MM, TargetSight, UnseenTargetError, first_sightings, in_sight

CAM = TIP_CAMERA  # 35 deg half-angle, 20-600 mm


# --- what a view sees -----------------------------------------------------------------------------------------------
def test_a_target_is_seen_within_the_cone_and_range_unless_something_stands_between():
    """A camera at the origin looking along +x: a target 300 mm ahead is seen; at 34 deg off the axis seen, at 36 deg
    not (35 deg half-angle); at 10 mm (under d_min) and 610 mm (over d_max) not; behind not; a ball of 30 mm on the
    line of sight hides it, the same ball 100 mm off the line does not."""
    c, v = np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0]])

    def at(deg, d):
        a = math.radians(deg)
        return [d * math.cos(a), d * math.sin(a), 0.0]

    targets = np.array([at(0, 300), at(34, 300), at(36, 300), at(0, 10), at(0, 610), at(180, 300)])
    empty = ObstacleSet([])
    assert in_sight(empty, targets, CAM, c, v)[0].tolist() == [True, True, False, False, False, False]
    block = ObstacleSet([Sphere([150.0, 0.0, 0.0], 30.0)])
    aside = ObstacleSet([Sphere([150.0, 100.0, 0.0], 30.0)])
    assert not in_sight(block, targets[:1], CAM, c, v)[0, 0]
    assert in_sight(aside, targets[:1], CAM, c, v)[0, 0]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3), st.lists(st.floats(-700.0, 700.0), min_size=3,
                                                                       max_size=3))
def test_a_target_is_seen_exactly_when_the_cone_contains_it_and_nothing_on_the_line_of_sight_is_nearer(direction,
                                                                                                       target):
    """Random view directions and targets round a ball: ``in_sight`` agrees with the cone test by hand and a walk of
    the ball's signed distance along the line of sight every 0.5 mm (seen unless the walk meets the ball more than
    the debris' radius short of the target)."""
    v = np.array(direction)
    if np.linalg.norm(v) < 1e-3:
        return
    v = v / np.linalg.norm(v)
    t = np.array(target)
    ball = Sphere([120.0, -80.0, 40.0], 90.0)
    if ball.signed_distance(t) < 0:
        return
    rel = t
    d = float(np.linalg.norm(rel))
    in_cone = CAM.d_min <= d <= CAM.d_max and rel @ v >= math.cos(CAM.fov_half_angle) * d
    s = np.arange(0.0, max(d - TARGET_RADIUS_MM, 0.0), 0.5)
    clear = bool(np.all(ball.signed_distance(np.outer(s, rel / max(d, 1e-12))) > 0.0)) if s.size else True
    margin = np.abs(ball.signed_distance(np.outer(s, rel / max(d, 1e-12)))).min() if s.size else 1.0
    if in_cone and margin < 0.5:  # grazing the ball: the walk's step decides, not the geometry
        return
    got = bool(in_sight(ObstacleSet([ball]), t[None], CAM, np.zeros((1, 3)), v[None])[0, 0])
    assert got == (in_cone and clear)


def test_the_sight_reveals_a_target_only_once_a_view_has_seen_it():
    sight = TargetSight([[300.0, 0.0, 0.0], [0.0, 300.0, 0.0]], ObstacleSet([]), CAM)
    with pytest.raises(UnseenTargetError, match="target 0"):
        sight.position(0)
    assert sight.look([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]]) == []  # looking up sees neither
    assert sight.look([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]], [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]) == [1, 0]
    assert sight.position(0).tolist() == [300.0, 0.0, 0.0] and sight.count == 2
    assert not sight.fresh().found.any()


# --- the judge --------------------------------------------------------------------------------------------------------
def _arm() -> Chain:
    return Chain([Section(100.0, 10.0, math.radians(40.0))] * 12, name="probe", feed_range=(0.0, 1200.0))


def _corridor(targets) -> Scene:
    return Scene("corridor", None, [-100.0, -300.0, -300.0], [1200.0, 300.0, 300.0], Entrance([0.0, 0.0, 0.0],
                 [1, 0, 0]), np.asarray(targets, dtype=float), ())


def _straight(scene: Scene, robot: Chain, length: float, views: bool = True) -> Mission:
    """In along +x to ``length`` mm and back out at the feed speed, a view every 50 mm on the way in."""
    v = robot.limits.feed_speed_mm_s
    path = np.array([[0.0, 0.0, 0.0], [length, 0.0, 0.0]])
    crawl = Crawl(path, [0.0, length, 0.0], [0.0, length / v, 2 * length / v])
    looks = np.arange(50.0, length, 50.0) if views else np.zeros(0)
    settings = InspectionSettings(budget_s=1e5, speed_mm_s=v, measurement_hz=None, camera=robot.camera)
    return Mission((crawl,), Views(looks / v, np.column_stack([looks, 0 * looks, 0 * looks]),
                                   np.tile([1.0, 0.0, 0.0], (len(looks), 1))), settings, 0)


def test_the_judge_times_finding_and_reaching_by_hand():
    """A straight insertion to 1000 mm towards a target at 900 mm: the first view that has it within 600 mm is the one
    at 300 mm (views every 50 mm), so it is found at 300 / v s; the tip first comes within 10 mm of it at 890 mm, at
    890 / v s. A target at 1100 mm, past the insertion, is found (from 500 mm) but never reached."""
    robot = _arm()
    v = robot.limits.feed_speed_mm_s
    scene = _corridor([[900.0, 0.0, 0.0], [1100.0, 0.0, 0.0]])
    report = evaluate_search(scene, robot, _straight(scene, robot, 1000.0))
    assert report.failure is None and report.reason == "not_reached" and not report.success
    assert report.found_s == pytest.approx([300.0 / v, 500.0 / v])
    assert report.reached_s[0] == pytest.approx(890.0 / v, abs=1.0 / v) and math.isinf(report.reached_s[1])
    m = report.metrics()
    assert m["found"] == 1.0 and m["reached"] == 0.5 and m["reached_s"][1] is None and m["time_to_reach_s"] is None
    one = _corridor([[900.0, 0.0, 0.0]])
    assert evaluate_search(one, robot, _straight(one, robot, 1000.0)).success


def test_driving_to_a_target_before_seeing_it_does_not_score():
    """The same insertion with no views passes through the target: never seen, so never reached; a ball between the
    views and the target hides it from every view, with the same verdict."""
    robot = _arm()
    scene = _corridor([[900.0, 0.0, 0.0]])
    blind = evaluate_search(scene, robot, _straight(scene, robot, 1000.0, views=False))
    assert blind.reason == "not_found" and math.isinf(blind.found_s[0]) and math.isinf(blind.reached_s[0])
    hidden = Scene("corridor", None, scene.bounds_min, scene.bounds_max, scene.entrance, scene.targets,
                   (Sphere([800.0, 0.0, 0.0], 50.0),))
    mission = _straight(hidden, robot, 700.0)
    assert first_sightings(ObstacleSet([]), hidden.targets, CAM, mission.views.positions,
                           mission.views.directions)[0] >= 0  # seen, were it not for the balls
    assert evaluate_search(hidden, robot, mission).reason == "not_found"


# --- honesty --------------------------------------------------------------------------------------------------------
class _Peeker(Planner):
    """Reads the targets from the problem, as a reaching planner would: a search must not."""

    name = "peeker"
    tasks = frozenset({"search"})
    needs_full_scene = False

    def _solve(self, problem, rng, deadline):
        return Status.FOUND, np.vstack([problem.start, problem.goals]), {}


class _AsksEarly(_Peeker):
    """Asks its sight where target 0 is before any view."""

    name = "asks-early"

    def _solve(self, problem, rng, deadline):
        return Status.FOUND, np.vstack([problem.start, problem.sight.position(0)]), {}


class _LooksAround(_Peeker):
    """Looks for the targets from the port, a view its mission never flies (it flies none)."""

    name = "looks-around"

    def _solve(self, problem, rng, deadline):
        e = problem.scene.entrance
        problem.sight.look(e.position[None], e.direction[None])
        return Solution(Status.NO_PROGRESS, None, {}, "it only looked")


def test_a_search_planner_that_looks_from_a_view_its_mission_never_flies_fails_the_honesty_rule():
    problem = Problem(make_scene("oil-tank", 1), get_robot("sjtu-snake-iii"), 2.0, knowledge="sensed", task="search")
    with pytest.raises(ConformanceError, match=r"\[honesty\].*1 poses its mission never flies"):
        check_planner(_LooksAround(), [problem])


@pytest.mark.parametrize("cheat", [_Peeker, _AsksEarly])
def test_a_search_planner_that_reads_a_target_before_any_view_has_seen_it_fails_the_honesty_rule(cheat):
    problem = Problem(make_scene("oil-tank", 1), get_robot("sjtu-snake-iii"), 2.0, knowledge="sensed", task="search")
    with pytest.raises(UnseenTargetError):
        cheat().plan(problem)
    with pytest.raises(ConformanceError, match=r"\[honesty\]"):
        check_planner(cheat(), [problem])


def test_a_search_knows_the_scene_only_through_its_views_and_sensor():
    scene = make_scene("fuel-tank", 2)
    robot = get_robot("sjtu-snake-iii")
    with pytest.raises(ValueError, match=r"^knowledge\b"):
        Problem(scene, robot, task="search")
    hidden = Problem(scene, robot, knowledge="sensed", task="search").hidden()
    for where in (hidden.scene, hidden.world.scene):
        for read in ("targets", "obstacles"):
            with pytest.raises(RuntimeError):
                getattr(where, read)
    with pytest.raises(RuntimeError):
        hidden.goals
    assert not any("target" in k for k in hidden.scene.metadata)  # the generator's facts do not give it away


# --- the planners ---------------------------------------------------------------------------------------------------
def _outside_check(doc: dict, scene: Scene) -> None:
    """From the plan document alone, with NumPy: every motion's tip path starts at the entrance; each target is
    within the camera's cone and range of the view at its found time with nothing on the line of sight (the scene's
    signed distance walked every 1 mm); the tip, following the crawls' depth profiles, is within 10 mm of it at its
    reached time, after it was found; the plan's path is the crawl that reached the last one."""
    mission, m = doc["mission"], doc["metrics"]
    views = mission["views"]
    cam = mission["settings"]["camera"]
    crawls = [c for c in mission["motions"] if c["kind"] == "crawl"]
    for c in crawls:
        assert np.allclose(c["path"][0], scene.entrance.position, atol=1e-6)
    for k, target in enumerate(scene.targets):
        found, reached = m["found_s"][k], m["reached_s"][k]
        assert found is not None and reached is not None and found <= reached
        i = views["times_s"].index(found)
        c, v = np.array(views["positions"][i]), np.array(views["directions"][i])
        rel = target - c
        d = float(np.linalg.norm(rel))
        assert cam["d_min_mm"] <= d <= cam["d_max_mm"]
        assert rel @ v >= math.cos(cam["fov_half_angle_rad"]) * d * (1 - 1e-9)
        walk = c + np.outer(np.arange(0.0, d - TARGET_RADIUS_MM, 1.0), rel / d)
        assert scene.signed_distance(walk).min() > -1e-3
        tips = []
        for crawl in crawls:
            t, depth = np.array(crawl["times_s"]), np.array(crawl["depths_mm"])
            if t[0] <= reached <= t[-1]:
                p = np.array(crawl["path"])
                s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]
                at = np.interp(reached, t, depth)
                tips.append(np.array([np.interp(at, s, p[:, j]) for j in range(3)]))
        assert min(np.linalg.norm(tip - target) for tip in tips) <= 10.0 + 1e-6
    last = int(np.argmax(m["reached_s"]))
    owner = [c for c in crawls if c["times_s"][0] <= m["reached_s"][last] <= c["times_s"][-1]]
    assert any(np.array_equal(np.array(c["path"]), np.array(doc["path"])) for c in owner)


@pytest.mark.parametrize(("family", "seed", "reach"), [("oil-tank", 3, "as-rrt"), ("fuel-tank", 3, "rrt-star")])
def test_explore_reach_finds_and_reaches_and_the_document_lets_an_outside_tool_check_it(family, seed, reach, tmp_path,
                                                                                         capsys):
    """From the command line: every target found and reached, every motion valid; the document checked from its
    numbers alone (:func:`_outside_check`), and ``snakeplan check`` gives the same verdict."""
    assert main(["plan", "--scene", family, "--seed", str(seed), "--task", "search", "--reach", reach, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["task"] == "search" and doc["knowledge"] == "sensed" and doc["planner"] == "explore-reach"
    assert doc["success"] and doc["metrics"]["searched"] and doc["details"]["reach_planner"] == reach
    _outside_check(doc, make_scene(family, seed))
    (tmp_path / "plan.json").write_text(json.dumps(doc))
    assert main(["check", "--scene", family, "--seed", str(seed), str(tmp_path / "plan.json"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["metrics"]["found_s"] == doc["metrics"]["found_s"]


def test_frontier_searches_the_oil_tank_and_a_scene_file_names_its_task(tmp_path, capsys):
    """A scene file whose ``task`` is search is planned by the search default (explore-reach), another planner by
    ``--planner``; a task no one knows is one line naming the field, exit 2."""
    doc = make_scene("oil-tank", 4).to_dict()
    doc["task"] = "search"
    f = tmp_path / "oil.json"
    f.write_text(json.dumps(doc))
    assert main(["plan", "--scene-file", str(f), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["planner"] == "explore-reach"
    assert main(["plan", "--scene-file", str(f), "--planner", "frontier", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["planner"] == "frontier" and out["success"] and out["metrics"]["found"] == 1.0
    doc["task"] = "hunt"
    f.write_text(json.dumps(doc))
    assert main(["plan", "--scene-file", str(f)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "task: must be one of reach, inspect, search" in err[0]
    assert main(["plan", "--scene", "station", "--task", "search"]) == 2  # its arm is not fed: no tip camera to search
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("snakeplan: error: --task: a search looks with a fed arm's tip camera")


def test_a_search_in_a_real_cad_file_end_to_end_with_its_video(tmp_path, capsys, browser):
    """gymnasium-robotics' kitchen base cabinets (an open STL in metres), a floor, two pieces of debris placed here:
    ``scene import``, a scene file that says search, planned, judged and drawn (picture, video, page) from the
    command line; both found and reached; the page in Chromium counts the targets seen at the start and the end."""
    import shutil

    from test_inspect_any_space import gymnasium_robotics_mesh

    mesh = shutil.copy(gymnasium_robotics_mesh("cabinetbase.stl"), tmp_path / "cabinetbase.stl")
    scene_file = tmp_path / "kitchen.json"
    assert main(["scene", "import", str(mesh), "--units", "m", "--entrance", "0,-1900,700", "--direction", "0,1,0",
                 "--bounds", "-1500,-1900,0,1400,800,1800", "--target", "-150,-300,80", "--target", "800,-1000,80",
                 "--obstacle", '{"type": "box", "center": [0, -500, -10], "size": [3000, 3000, 20]}',
                 "-o", str(scene_file)]) == 0
    doc = json.loads(scene_file.read_text())
    doc["task"] = "search"
    scene_file.write_text(json.dumps(doc))
    capsys.readouterr()
    code = main(["plan", "--scene-file", str(scene_file), "--time-limit", "40", "--json", "--plot",
                 str(tmp_path / "s.png"), "--animate", str(tmp_path / "s.gif"), "--frames", "6", "--html",
                 str(tmp_path / "s.html")])
    plan = json.loads(capsys.readouterr().out)
    assert code == 0 and plan["task"] == "search" and plan["success"], plan.get("why")
    assert plan["metrics"]["found"] == plan["metrics"]["reached"] == 1.0
    for name in ("s.png", "s.gif", "s.html"):
        assert (tmp_path / name).stat().st_size > 10_000
    assert re.search(r'"point_size":\s*12', Path(tmp_path / "s.html").read_text())  # the targets, drawn large
    browser.events.clear()
    browser.open(tmp_path / "s.html", "window.snakeplan && window.snakeplan.ready")
    assert browser.evaluate("document.getElementById('readout').textContent").endswith("targets seen 2 of 2")
    browser.evaluate("window.snakeplan.setFrame(0)")
    assert browser.evaluate("document.getElementById('readout').textContent").endswith("targets seen 0 of 2")
    assert browser.errors() == []


def test_table2_in_the_search_setting_tables_every_combination_from_its_judged_rows(tmp_path, capsys):
    """``bench table2 --search`` on one oil-tank seed, two reaching planners under both explorers: four judged rows,
    one table row per combination whose shares are the rows' own, and a second call resumes with nothing to run."""
    args = ["bench", "table2", "--search", "--runs", "1", "--seed", "5", "--scenes", "oil-tank", "--planners",
            "as-rrt,rrt-star", "--out", str(tmp_path), "--json"]
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    rows = [json.loads(line) for line in (tmp_path / "runs.jsonl").read_text().splitlines()]
    assert len(rows) == 4 and {r["task"] for r in rows} == {"search"} and {r["knowledge"] for r in rows} == {"sensed"}
    for r in rows:
        entry = out["summary"][f"oil-tank/{r['planner']} + {r['options']['reach']}"]
        assert entry["runs"] == 1 and entry["valid"] == int(r["metrics"]["searched"])
        assert entry["found"] == r["metrics"]["found"] and entry["reached"] == r["metrics"]["reached"]
    assert "| oil-tank | frontier + as-rrt | 1 |" in (tmp_path / "search.md").read_text()
    assert (tmp_path / "search-oil-tank.png").stat().st_size > 10_000
    assert main(args) == 0 and json.loads(capsys.readouterr().out)["runner"]["ran"] == 0
