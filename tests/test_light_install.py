"""Without the ``train`` extra: planning and judging import no torch, Stable-Baselines3 or Gymnasium, and every
command that trains says in one line how to install it (exit status 2).

Each test runs a fresh interpreter in which a meta-path finder refuses those imports, as if they were not
installed, and records every attempt to import them.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import snakeplan

#: Makes the training extra look uninstalled and records what tried to import it (``_blocked.attempts``).
BLOCK = '''
import sys

class _Blocked:
    roots = ("torch", "stable_baselines3", "gymnasium")
    attempts = []

    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in self.roots:
            self.attempts.append(name)
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None

_blocked = _Blocked()
sys.meta_path.insert(0, _blocked)
'''

PLAN_AND_JUDGE = '''
import json
from snakeplan.evaluation import evaluate
from snakeplan.planners import Problem, get_planner, planner_names
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene

names = planner_names()  # every built-in planner, reach and inspect
runs = {}
for scene_name, seed, planner, robot in [("fuel-tank", 0, "sac-her", "sjtu-snake-iii"),
                                         ("oil-tank", 0, "sac-per", "sjtu-snake-iii"),
                                         ("pipe", 0, "sscc", "sscc-16")]:
    scene, chain = make_scene(scene_name, seed), get_robot(robot)
    plan = get_planner(planner).plan(Problem(scene, chain, time_limit_s=10.0), seed=0)
    report = evaluate(scene, chain, plan.path)
    runs[planner] = {"status": str(plan.status), "success": bool(report.success),
                     "search": plan.details.get("search"), "policy": plan.details.get("policy")}
print(json.dumps({"planners": names, "runs": runs, "attempts": _blocked.attempts}))
'''

COMMANDS = '''
import contextlib, io, json, tempfile
from pathlib import Path
from snakeplan.cli import main

out = Path(tempfile.mkdtemp())
argvs = [["train", "rl", "fuel-tank", "sac-her", "--steps", "10", "--out", str(out / "rl")],
         ["train", "sscc", "--robot", "sscc-16", "--out", str(out / "agent.npz")],
         ["bench", "rl", "--repeats", "1"],
         ["bench", "ablation", "--steps", "10", "--out", str(out / "ablation")],
         ["bench", "sscc", "--variants", "agent-learning", "--targets", "1", "--out", str(out / "sscc")]]
results = []
for argv in argvs:
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(argv)
    results.append({"argv": argv, "code": code, "stderr": err.getvalue()})
try:
    import snakeplan.rl
    library = "imported"
except ImportError as exc:
    library = str(exc)
print(json.dumps({"results": results, "library": library, "written": sorted(p.name for p in out.iterdir())}))
'''


def _run_blocked(code: str) -> dict:
    """Run ``code`` after the blocker in a fresh interpreter that imports this snakeplan; its JSON output."""
    env = {**os.environ, "PYTHONPATH": str(Path(snakeplan.__file__).parents[1])}
    proc = subprocess.run([sys.executable, "-c", BLOCK + code], capture_output=True, text=True, env=env,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_planning_and_judging_with_the_shipped_weights_import_no_training_library():
    out = _run_blocked(PLAN_AND_JUDGE)
    assert out["attempts"] == []
    assert {"rrt-star", "sp-rrt", "as-rrt", "sac-her", "sac-per", "sscc"} <= set(out["planners"])
    runs = out["runs"]
    assert runs["sac-her"]["policy"] == "fuel-tank-sac-her" and runs["sac-per"]["policy"] == "oil-tank-sac-per"
    assert runs["sscc"]["search"] == "agent"  # the shipped .npz agent, not a fallback search
    for planner, run in runs.items():
        assert run["status"] == "found" and run["success"], (planner, run)


def test_commands_that_train_say_in_one_line_how_to_install_the_extra():
    out = _run_blocked(COMMANDS)
    for result in out["results"]:
        command = " ".join(result["argv"][:2])
        assert result["code"] == 2, result
        expected = f'snakeplan: error: {command}: needs the training extra: pip install "snakeplan[train]"'
        if command == "bench sscc":
            expected = expected.replace("bench sscc:", "bench sscc --variants agent-learning:")
        assert result["stderr"] == expected + "\n"
    assert out["written"] == []
    assert out["library"] == 'snakeplan.rl: needs the training extra: pip install "snakeplan[train]"'


#: Libraries a plain plan never needs (the start-up rule): importing them costs a command seconds.
HEAVY = ("torch", "stable_baselines3", "gymnasium", "ompl", "trimesh", "matplotlib", "cma", "scipy.ndimage",
         "snakeplan.trajectory", "snakeplan.viz")

PLAN_COMMAND = '''
import contextlib, io, json, sys
import snakeplan.cli
after_import = sorted(m for m in HEAVY if m in sys.modules)
with contextlib.redirect_stdout(io.StringIO()):
    code = snakeplan.cli.main(["plan", "--scene", "fuel-tank", "--seed", "1"])
print(json.dumps({"code": code, "after_import": after_import,
                  "after_plan": sorted(m for m in HEAVY if m in sys.modules)}))
'''


def test_the_plan_command_imports_no_heavy_library():
    """``import snakeplan.cli`` and a whole ``snakeplan plan`` (learned planner, judge) load none of the heavy
    libraries: sys.modules of a fresh interpreter, checked after each."""
    env = {**os.environ, "PYTHONPATH": str(Path(snakeplan.__file__).parents[1])}
    proc = subprocess.run([sys.executable, "-c", f"HEAVY = {HEAVY!r}\n" + PLAN_COMMAND], capture_output=True,
                          text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["code"] in (0, 1)  # planned and judged (1: the judge found the plan infeasible)
    assert out["after_import"] == [] and out["after_plan"] == []
