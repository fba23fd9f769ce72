"""One registry for scenes, robots, planners and inspection planners: lazy built-ins, plugin packages found by
their entry points, unique names, and lookups that list the known names."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import snakeplan
from snakeplan.planners import Planner, register_planner
from snakeplan.registry import Registry
from snakeplan.robots import register_robot
from snakeplan.scenes import register_scene

TESTS = Path(__file__).parent
#: Installed-distribution layouts (a package beside its .dist-info with entry_points.txt), as pip leaves them.
PLUGIN = TESTS / "plugin_pkg"
DUPLICATE = TESTS / "plugin_dup"
SRC = Path(snakeplan.__file__).parents[1]


def snakeplan_cli(*argv, plugins=()):
    """Run the command line in a fresh interpreter whose path holds the ``plugins`` folders."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), *map(str, plugins)])}
    return subprocess.run([sys.executable, "-m", "snakeplan.cli", *argv], capture_output=True, text=True, env=env)


def test_a_lazy_entry_is_imported_only_when_asked_for(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))
    name = "lazy_thing_for_registry_test"
    (tmp_path / f"{name}.py").write_text("VALUE = ('made', 'on', 'import')\n")
    reg = Registry("thing", {"one": f"{name}:VALUE"})
    assert reg.names() == ["one"] and "one" in reg and name not in sys.modules
    assert reg.get("one") == ("made", "on", "import") and name in sys.modules


def test_a_built_in_registers_itself_as_its_lazy_entry_is_imported():
    from snakeplan.planners.registry import PLANNERS
    from snakeplan.scenes import scene_spec

    assert PLANNERS.get("rrt-star") is sys.modules["snakeplan.planners.rrt_star"].RRTStar
    assert scene_spec("pipe").generator is sys.modules["snakeplan.scenes.pipe"].pipe


def test_a_taken_name_raises_and_an_unknown_one_lists_the_known_names():
    reg = Registry("thing")
    reg.register("a", 1, "here:a")
    with pytest.raises(ValueError, match=r"thing 'a' is registered twice: by here:a and by there:b"):
        reg.register("a", 2, "there:b")
    with pytest.raises(KeyError, match=r"unknown thing 'z' \(known: a\)"):
        reg.get("z")
    reg.unregister("a")
    assert reg.names() == []


def test_the_user_facing_decorators_refuse_built_in_names():
    class Impostor(Planner):
        name = "rrt-star"

        def _solve(self, problem, rng, deadline):
            return "failed", None, {}

    with pytest.raises(ValueError, match="planner 'rrt-star' is registered twice"):
        register_planner(Impostor)
    with pytest.raises(ValueError, match="robot 'hsr-10' is registered twice"):
        register_robot("hsr-10", lambda: None)
    with pytest.raises(ValueError, match="scene 'pipe' is registered twice"):
        register_scene("pipe")(lambda seed: None)


def test_listing_names_imports_no_planner_or_generator_module():
    code = ("import json, sys; from snakeplan.planners import planner_names; from snakeplan.scenes import scene_names; "
            "names = planner_names() + scene_names(); "
            "print(json.dumps({'names': names, 'modules': sorted(sys.modules)}))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(SRC)})
    out = json.loads(proc.stdout)
    assert len(out["names"]) == 7 + 4 + 2 + 10 + 8  # reach, inspect and search planners; scene families, scanned
    plugins = ["planners.rrt_star", "planners.sp_rrt", "planners.as_rrt", "planners.sac", "planners.sscc",
               "planners.coverage", "planners.informative", "planners.random_views", "planners.iris",
               "planners.search.explore_reach", "planners.search.frontier", "scenes.fuel_tank", "scenes.oil_tank",
               "scenes.pipe", "scenes.station", "scenes.mesh_families", "scenes.scan"]
    assert not [m for m in plugins if f"snakeplan.{m}" in out["modules"]]


def test_plugin_entry_points_are_found_in_an_installed_distribution(monkeypatch):
    monkeypatch.syspath_prepend(str(PLUGIN))
    planners, scenes, robots = Registry("planner"), Registry("scene"), Registry("robot")
    assert planners.names() == ["example-straight"] and scenes.names() == ["example-corridor"]
    assert robots.names() == ["example-arm"]
    assert robots.get("example-arm")().total_length == pytest.approx(500.0)


def test_plugin_planner_scene_and_robot_plan_from_the_command_line():
    argv = ["plan", "--scene", "example-corridor", "--seed", "4", "--planner", "example-straight",
            "--robot", "example-arm", "--json"]
    assert snakeplan_cli(*argv).returncode == 2  # not installed: unknown names
    proc = snakeplan_cli(*argv, plugins=[PLUGIN])
    assert proc.returncode == 0, proc.stderr
    plan = json.loads(proc.stdout)
    assert (plan["scene"]["name"], plan["planner"], plan["robot"]) == ("example-corridor", "example-straight",
                                                                      "example-arm")
    assert plan["success"] and plan["metrics"]["targets_reached"] == 1
    # The plugin's scene spec names its robot and planner: the same plan without --planner and --robot.
    proc = snakeplan_cli("plan", "--scene", "example-corridor", "--seed", "4", "--json", plugins=[PLUGIN])
    again = json.loads(proc.stdout)
    assert (again["planner"], again["robot"], again["path"]) == ("example-straight", "example-arm", plan["path"])
    scene = json.loads(snakeplan_cli("scene", "example-corridor", "--json", plugins=[PLUGIN]).stdout)
    assert scene["metadata"]["robot"] == "example-arm"
    listed = snakeplan_cli("robot", plugins=[PLUGIN]).stdout.split()
    assert "example-arm" in listed and "sjtu-snake-iii" in listed


def test_a_plugin_planner_that_does_both_tasks_registers_once_and_bench_run_runs_it_for_both(tmp_path):
    """example-straight declares reach and inspect: one entry point, one class; bench run plans it in the corridor
    (reach) and flies it round the station (inspect), each row judged by the task's rules."""
    from snakeplan.bench.runner import read_rows

    out = tmp_path / "both"
    proc = snakeplan_cli("bench", "run", "--scenes", "example-corridor,station", "--planners", "example-straight",
                         "--seeds", "0", "--workers", "1", "--out", str(out), plugins=[PLUGIN])
    assert proc.returncode == 0, proc.stderr
    rows = {r["task"]: r for r in read_rows(out)}
    assert sorted(rows) == ["inspect", "reach"] and {r["planner"] for r in rows.values()} == {"example-straight"}
    assert rows["reach"]["success"] and rows["reach"]["metrics"]["targets_reached"] == 1
    assert rows["inspect"]["success"] and rows["inspect"]["reason"] == "inspected"
    assert rows["inspect"]["robot"] == "hsr-10" and rows["inspect"]["metrics"]["reach_share"] == 1.0


def test_a_plugin_that_takes_a_built_in_name_is_a_one_line_error():
    proc = snakeplan_cli("plan", "--scene", "oil-tank", "--planner", "sp-rrt", plugins=[DUPLICATE])
    assert proc.returncode == 2 and proc.stdout == "" and proc.stderr.count("\n") == 1
    assert "planner 'rrt-star' is registered twice" in proc.stderr
    assert "snakeplan.planners.rrt_star:RRTStar" in proc.stderr and "snakeplan-dup-plugin" in proc.stderr
