"""The `snakeplan` command: JSON contracts, exit codes, and one-line errors for a user's mistakes."""

import json
import subprocess
import sys

import numpy as np
import pytest

from snakeplan.cli import main
from snakeplan.scenes import make_scene, scene_names


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("name", ["fuel-tank", "oil-tank", "pipe", "concentric-pipe", "station"])
def test_scene_json_identical_across_runs(capsys, name):
    code, first, _ = run(capsys, "scene", name, "--seed", "3", "--json")
    assert code == 0
    _, second, _ = run(capsys, "scene", name, "--seed", "3", "--json")
    assert first == second
    data = json.loads(first)
    assert data["schema"] == "snakeplan.scene/1" and data["name"] == name and data["seed"] == 3
    assert data["units"] == "mm"


def test_scene_list_names_every_scene(capsys):
    code, out, _ = run(capsys, "scene", "--list")
    assert code == 0 and out.split() == scene_names()
    assert set(out.split()) >= {"fuel-tank", "oil-tank", "pipe", "concentric-pipe", "station"}


def test_robot_json_schema(capsys):
    code, out, _ = run(capsys, "robot", "sjtu-snake-iii", "--json")
    data = json.loads(out)
    assert code == 0 and data["schema"] == "snakeplan.robot/1"
    assert len(data["sections"]) == 12
    assert data["total_length"] == pytest.approx(2130)
    assert data["k_ul"] == pytest.approx(0.0055)
    assert data["sections"][0]["radius"] == pytest.approx(27.5)
    assert data["sections"][0]["max_bend"] == pytest.approx(np.radians(50.7))


def straight_into(scene, depth):
    e, d = scene.entrance.position, scene.entrance.direction
    return (e + np.linspace(0, depth, 30)[:, None] * d).tolist()


def test_check_scores_a_straight_path_into_the_fuel_tank(capsys, tmp_path):
    scene = make_scene("fuel-tank", 1)
    f = tmp_path / "path.json"
    f.write_text(json.dumps({"path": straight_into(scene, 150)}))
    code, out, _ = run(capsys, "check", "--scene", "fuel-tank", "--seed", "1", "--json", str(f))
    data = json.loads(out)
    # A short straight insertion is collision-free but does not reach the debris: exit 1 (infeasible plan).
    assert code == 1 and data["reason"] == "not_reached"
    m = data["metrics"]
    assert m["collision_free"] and m["bend_limits_ok"] and m["path_length_mm"] == pytest.approx(150)
    assert m["max_curvature_per_mm"] == pytest.approx(0, abs=1e-12) and m["smoothness_index"] == 1.0


def test_check_plot_writes_png(capsys, tmp_path):
    scene = make_scene("fuel-tank", 2)
    f = tmp_path / "plan.json"
    f.write_text(json.dumps({"schema": "snakeplan.plan/1", "path": straight_into(scene, 100)}))
    png = tmp_path / "check.png"
    code, _, _ = run(capsys, "check", "--seed", "2", "--plot", str(png), str(f))
    assert code == 1 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "content, argv, fragment",
    [
        ("{not json", [], "malformed JSON"),
        ('{"path": [[0, 0, 0], [NaN, 0, 0]]}', [], "NaN"),
        ('{"path": [[0, 0, 0], [1e999, 0, 0]]}', [], "path[1][0]"),
        ('{"path": [[0, 0, 0]]}', [], "at least 2"),
        ('{"points": []}', [], '"path"'),
        ('{"path": [[0, 0, 0], [1, 2]]}', [], "[x, y, z]"),
        ('{"path": [[0, 0, 0], [10, 0, 0]]}', ["--scene", "moon-base"], "--scene"),
        ('{"path": [[0, 0, 0], [10, 0, 0]]}', ["--robot", "octopus"], "--robot"),
        ('{"path": [[0, 0, 0], [10, 0, 0]]}', ["--seed", "-3"], "--seed"),
        ('{"path": [[0, 0, 0], [10, 0, 0]]}', [], "entrance"),
    ],
)
def test_bad_input_exits_2_with_one_line(capsys, tmp_path, content, argv, fragment):
    f = tmp_path / "p.json"
    f.write_text(content)
    code, out, err = run(capsys, "check", *argv, str(f))
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and fragment in err and "Traceback" not in err


def test_bad_scene_file_names_the_field(capsys, tmp_path):
    scene = make_scene("pipe", 0).to_dict()
    scene["obstacles"][0]["inner_radius"] = -4
    f = tmp_path / "scene.json"
    f.write_text(json.dumps(scene))
    p = tmp_path / "p.json"
    p.write_text(json.dumps({"path": [[0, 0, 0], [1, 0, 0]]}))
    code, _, err = run(capsys, "check", "--scene-file", str(f), str(p))
    assert code == 2 and "obstacles[0].inner_radius" in err


def test_missing_file_and_unknown_command(capsys):
    code, _, err = run(capsys, "check", "/no/such/path.json")
    assert code == 2 and "not found" in err
    code, _, err = run(capsys, "fly")
    assert code == 2 and err.count("\n") == 1


def test_console_script_exit_code_and_no_traceback():
    proc = subprocess.run([sys.executable, "-m", "snakeplan.cli", "robot", "octopus"], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and "octopus" in proc.stderr


def test_demo_writes_picture_and_metrics(capsys, tmp_path):
    png = tmp_path / "demo.png"
    code, out, err = run(capsys, "demo", "--out", str(png))
    assert code == 0, err
    assert "smoothness_index" in out and png.exists()


@pytest.mark.parametrize("planner", ["rrt-star", "sp-rrt", "as-rrt"])
@pytest.mark.parametrize("scene", ["fuel-tank", "oil-tank"])
def test_plan_json_carries_the_judges_verdict(capsys, planner, scene):
    code, out, _ = run(capsys, "plan", "--scene", scene, "--seed", "1", "--planner", planner, "--time-limit", "20",
                       "--json")
    data = json.loads(out)
    assert data["schema"] == "snakeplan.plan/1" and data["planner"] == planner
    assert data["scene"] == {"name": scene, "seed": 1}
    assert code == (0 if data["success"] else 1)
    assert data["success"] and data["reason"] == "reached"
    path = np.array(data["path"])
    assert np.allclose(path[0], make_scene(scene, 1).entrance.position)
    assert data["metrics"]["targets_reached"] == len(make_scene(scene, 1).targets)


def test_plan_plot_and_bad_planner_or_budget(capsys, tmp_path):
    png = tmp_path / "plan.png"
    code, _, _ = run(capsys, "plan", "--seed", "2", "--planner", "sp-rrt", "--plot", str(png))
    assert code == 0 and png.read_bytes()[:4] == b"\x89PNG"
    code, _, err = run(capsys, "plan", "--planner", "teleport")
    assert code == 2 and "--planner" in err and err.count("\n") == 1
    for budget in ("0", "-5", "inf"):
        code, _, err = run(capsys, "plan", "--planner", "sp-rrt", "--time-limit", budget)
        assert code == 2 and "time" in err and err.count("\n") == 1


def test_plan_on_the_station_flies_an_inspection_mission(capsys):
    code, out, _ = run(capsys, "plan", "--scene", "station", "--seed", "0", "--planner", "coverage", "--json")
    data = json.loads(out)
    assert code == 0 and data["schema"] == "snakeplan.inspection/1" and data["robot"] == "hsr-10"
    # Fusing measurements can only shrink the map's uncertainty.
    assert np.all(np.diff(data["trace_k2"]) <= 1e-6)
    assert data["final_rmse_k"] == pytest.approx(data["rmse_k"][-1])
    code, _, err = run(capsys, "plan", "--scene", "station", "--planner", "sp-rrt")
    assert code == 2 and "--planner" in err


def test_plan_in_a_pipe_uses_sscc_and_the_sized_robot(capsys):
    code, out, _ = run(capsys, "plan", "--scene", "concentric-pipe", "--seed", "3", "--json")
    data = json.loads(out)
    assert code == 0 and data["planner"] == "sscc" and data["robot"] == "sscc-24" and data["success"]


def test_plan_and_scene_name_the_same_robot_for_the_pipe(capsys):
    code, out, _ = run(capsys, "plan", "--scene", "pipe", "--json")
    planned = json.loads(out)["robot"]
    _, out, _ = run(capsys, "scene", "pipe", "--json")
    assert code == 0 and planned == json.loads(out)["metadata"]["robot"]


def test_bench_sscc_smoke_and_train_input_errors(capsys, tmp_path):
    code, out, _ = run(capsys, "bench", "sscc", "--targets", "1", "--variants", "agent", "--out", str(tmp_path),
                       "--json")
    data = json.loads(out)
    assert code == 0 and len(data["settings"]) == 3
    code, _, err = run(capsys, "bench", "sscc", "--variants", "telepathy")
    assert code == 2 and "--variants" in err
    code, _, err = run(capsys, "train", "sscc", "--robot", "sjtu-snake-iii", "--out", str(tmp_path / "a.npz"))
    assert code == 2 and "--robot" in err and not (tmp_path / "a.npz").exists()


def test_train_rl_for_your_robot_and_scene_then_plan_with_the_policy(capsys, tmp_path):
    from snakeplan.planners.sac import NumpyPolicy

    out = tmp_path / "run"
    code, _, err = run(capsys, "train", "rl", "pipe", "sac", "--steps", "120", "--out", str(out),
                       "--turn-radius-mm", "abc")
    assert code == 2 and "--turn-radius-mm" in err and not out.exists()
    code, _, err = run(capsys, "train", "rl", "station", "sac", "--steps", "120", "--out", str(out))
    assert code == 2 and "no targets" in err and not out.exists()
    code, _, err = run(capsys, "plan", "--scene", "oil-tank", "--turn-radius-mm", "215")
    assert code == 2 and "unrecognized arguments" in err
    code, stdout, _ = run(capsys, "train", "rl", "pipe", "sac", "--steps", "120", "--out", str(out),
                          "--robot", "sscc-24", "--net-arch", "16", "16", "--learning-starts", "60",
                          "--eval-every", "100", "--eval-episodes", "2", "--checkpoint-every", "100",
                          "--train-scenes", "2", "--batch-size", "16", "--turn-radius-mm", "215")
    assert code == 0 and "policy.npz" in stdout
    meta = NumpyPolicy.load(out / "last.npz").meta
    assert meta["robot"] == "sscc-24" and meta["scene"] == "pipe"
    assert meta["config"]["net_arch"] == [16, 16] and meta["turn_radius_mm"] == pytest.approx(215.0)
    assert "--robot sscc-24" in meta["command"] and "--turn-radius-mm 215" in meta["command"]
    code, stdout, _ = run(capsys, "plan", "--scene", "pipe", "--seed", "1", "--planner", "sac", "--policy",
                          str(out / "last.npz"), "--time-limit", "2", "--json")
    data = json.loads(stdout)
    assert code in (0, 1) and data["planner"] == "sac" and data["robot"] == "sscc-24" and len(data["path"]) > 1
    assert data["status"] in ("found", "approximate")  # a roll-out that fails its own checks is approximate
    code, _, err = run(capsys, "plan", "--scene", "pipe", "--planner", "sscc", "--policy", str(out / "last.npz"))
    assert code == 2 and "policy: " in err and "is not an SSCC agent for sscc-24" in err and err.count("\n") == 1


@pytest.mark.parametrize("scene, fragment", [("moon-base", "--scene: unknown scene"),
                                             ("pipe", "scene: pipe is planned by sscc")])
def test_bench_ablation_needs_a_scene_planned_by_a_learned_planner(capsys, tmp_path, scene, fragment):
    code, _, err = run(capsys, "bench", "ablation", "--scene", scene, "--out", str(tmp_path / "out"))
    assert code == 2 and fragment in err and err.count("\n") == 1 and not (tmp_path / "out").exists()


def test_bench_ablation_trains_both_variants_and_reports(capsys, tmp_path):
    code, out, _ = run(capsys, "bench", "ablation", "--scene", "oil-tank", "--seeds", "1", "--steps", "120",
                       "--eval-every", "60", "--eval-episodes", "2", "--threshold", "0.5", "--out", str(tmp_path),
                       "--net-arch", "16", "16", "--learning-starts", "60", "--train-scenes", "2",
                       "--batch-size", "16", "--json")
    result = json.loads(out)
    assert code == 0 and set(result["runs"]) == {"SAC-PER", "SAC"} and result["threshold"] == 0.5
    for label, runs in result["runs"].items():
        assert len(runs) == 1 and 0 < runs[0]["steps_to_converge"] <= 120
        curve = json.loads((tmp_path / f"oil-tank-{'sac-per' if label == 'SAC-PER' else 'sac'}-local-seed0"
                            / "curve.json").read_text())
        assert result["mean_success"][label] == pytest.approx(np.mean([h["success"] for h in curve]))
    assert (tmp_path / "ablation-oil-tank-replay.png").read_bytes()[:4] == b"\x89PNG"
    assert result["paper_speedup"] == 1.27  # paper 000, Fig. 4: PER in oil-tank
    code, _, err = run(capsys, "bench", "ablation", "--steps", "0")
    assert code == 2 and "--steps" in err


def test_bench_rl_rejects_bad_repeats(capsys):
    code, _, err = run(capsys, "bench", "rl", "--repeats", "0")
    assert code == 2 and "--repeats" in err


@pytest.mark.parametrize(("option", "value", "says"), [("--scene-workers", "-3", "-3"),
                                                      ("--autodiff", "tensorflow", "tensorflow"),
                                                      ("--overlap", "true", "--autodiff jax")])
def test_train_rl_rejects_a_bad_option_and_writes_nothing(capsys, tmp_path, option, value, says):
    out = tmp_path / "run"
    code, stdout, err = run(capsys, "train", "rl", "fuel-tank", "sac-her", "--steps", "10", "--out", str(out),
                            option, value)
    assert code == 2 and stdout == ""
    assert err.count("\n") == 1 and option in err and says in err
    assert not out.exists()


@pytest.mark.parametrize("options", [["--autodiff", "tensorflow"], ["--bogus", "3"], ["--paper", "--jax"]])
def test_the_trainer_module_rejects_a_bad_option_in_one_line(tmp_path, options):
    """``python -m snakeplan.rl.train``, the command every shipped policy records, answers a mistake as the
    ``snakeplan`` command does."""
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "snakeplan.rl.train", "fuel-tank", "sac-her", "--steps", "10",
                           "--out", str(out), *options], capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("snakeplan: error: ") and options[0] in proc.stderr
    assert not out.exists()


def test_jax_option_starts_from_the_jax_configuration():
    from dataclasses import replace

    from snakeplan.rl.train import JAX_CONFIG, parse_config

    assert parse_config(["--jax"]) == replace(JAX_CONFIG, scene_workers=-1)
    assert parse_config(["--jax", "--learning-rate", "3e-4"]).learning_rate == 3e-4
    assert JAX_CONFIG.autodiff == "jax" and JAX_CONFIG.overlap


def test_bench_speed_saves_each_row_and_a_rerun_measures_only_the_rest(capsys, tmp_path, monkeypatch):
    import os
    import signal

    from snakeplan.bench import speed

    calls = []
    judge = {"10^6-point path": {"seconds": 0.5, "peak_mb": 100.0}, "1e8 mm path": {"seconds": 0.1, "peak_mb": 50.0}}
    command = {"now": {"median_s": 1.0, "max_s": 2.0}, "before": {"median_s": 0.1, "max_s": 0.2}}
    monkeypatch.setattr(speed, "command_rows", lambda repeats, say: calls.append("command") or command)
    monkeypatch.setattr(speed, "judge_rows", lambda say: os.kill(os.getpid(), signal.SIGINT))  # Ctrl-C in a row
    out = tmp_path / "speed.md"
    partial = tmp_path / "speed.partial.json"
    argv = ("bench", "speed", "--rows", "judge,command", "--out", str(out))
    code, _, err = run(capsys, *argv)
    assert code == 130 and err.splitlines()[-1] == (f"snakeplan: interrupted; 1 of 2 rows saved in {partial}, rerun "
                                                    "the same command to resume")
    assert json.loads(partial.read_text())["rows"] == {"plan command": command} and not out.exists()
    monkeypatch.setattr(speed, "judge_rows", lambda say: calls.append("judge") or judge)
    code, text, _ = run(capsys, *argv)
    summary = json.loads(out.with_suffix(".json").read_text())
    assert code == 0 and calls == ["command", "judge"] and not partial.exists()  # the command row not measured again
    assert summary["rows"] == {"plan command": command, "judge": judge}
    assert summary["resumed_rows"] == ["plan command"]
    assert "| judge, 10^6-point path / 1e8 mm path | 0.50 s, 100 MB / 0.10 s, 50 MB |" in text
    partial.write_text(json.dumps({**summary, "repeats": 99}))  # saved with other settings: measured afresh
    code, _, _ = run(capsys, *argv)
    assert code == 0 and calls == ["command", "judge", "command", "judge"]


@pytest.mark.parametrize(("argv", "expected"), [
    (["--seeds", "0"], "snakeplan: error: --seeds: expected a positive integer, got 0\n"),
    (["--station-seeds", "-1"], "snakeplan: error: --station-seeds: expected a positive integer, got -1\n"),
    (["--out", "speed.txt"], "snakeplan: error: --out: expected a .md file, got 'speed.txt'\n"),
    (["--rows", "station,warp"], "snakeplan: error: --rows: unknown warp (known: rrt-star, sp-rrt, as-rrt, sac-her, "
                                 "optimize, command, judge, station)\n"),
])
def test_bench_speed_refuses_bad_options_before_any_work(capsys, tmp_path, monkeypatch, argv, expected):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, "bench", "speed", *argv)
    assert code == 2 and err == expected and out == ""
    assert list(tmp_path.iterdir()) == []


def test_bench_kernels_reports_each_kernel_beside_its_baseline(capsys):
    code, out, _ = run(capsys, "bench", "kernels", "--batch", "10", "--repeats", "1", "--json")
    result = json.loads(out[out.index("{"):])
    assert code == 0 and result["rollout_steps"] > 0
    for kernel in ("collision", "clearance", "ftl", "rollout"):
        assert result[f"{kernel}_speedup_vs_baseline"] > 0.0


def test_a_task_the_scene_or_the_planner_does_not_do_is_one_line_exit_2_and_nothing_written(tmp_path, capsys):
    png = tmp_path / "plan.png"
    code, out, err = run(capsys, "plan", "--scene", "fuel-tank", "--task", "inspect", "--planner", "informative",
                         "--plot", str(png))
    assert (code, out) == (2, "") and err.startswith("snakeplan: error: task: planner informative maps a field, and "
                                                     "fuel-tank has none at its points of interest (no inspect.field)")
    code, out, err = run(capsys, "plan", "--scene", "station", "--task", "inspect", "--planner", "sp-rrt", "--plot",
                         str(png))
    assert (code, out) == (2, "") and err == ("snakeplan: error: --task: planner sp-rrt does not inspect (it does: "
                                              "reach); scene station's task is inspect\n")
    code, out, err = run(capsys, "plan", "--scene", "station", "--task", "reach", "--plot", str(png))
    assert (code, out) == (2, "") and err == "snakeplan: error: --task: station has no targets to plan to\n"
    assert not png.exists()


def test_check_judges_a_plan_with_the_arm_it_was_made_with(tmp_path, capsys):
    """A plan made for one's own (thinner) arm is judged with that arm, says so, and refuses another --robot."""
    from snakeplan.evaluation import evaluate
    from snakeplan.robots import get_robot
    from snakeplan.scenes.sizing import arm_sizing, sized_scene

    arm = get_robot("sjtu-snake-iii").to_dict()
    arm["name"] = "thin-arm"
    for section in arm["sections"]:
        section["radius"] = 12.0
    arm_file = tmp_path / "thin.json"
    arm_file.write_text(json.dumps(arm))
    code, out, _ = run(capsys, "plan", "--seed", "2", "--planner", "as-rrt", "--robot", str(arm_file), "--json")
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(out)
    code, out, err = run(capsys, "check", "--seed", "2", str(plan_file))
    assert out.splitlines()[0] == "arm: thin-arm (the plan's)"
    thin = get_robot("sjtu-snake-iii").__class__.from_dict(arm)
    scene = sized_scene("fuel-tank", 2, arm_sizing("fuel-tank", thin))  # the fuel tank sized to the thinner arm
    assert scene.metadata["sizing"]["inflate_mm"] == pytest.approx(14.5)
    path = np.asarray(json.loads(plan_file.read_text())["path"])
    judged = float(out.split("min_clearance_mm")[1].split()[0])
    ours = evaluate(scene, thin, path).min_clearance_mm
    theirs = evaluate(scene, get_robot("sjtu-snake-iii"), path).min_clearance_mm
    assert judged == pytest.approx(ours, abs=1e-3) and abs(ours - theirs) > 10.0
    code, out, err = run(capsys, "check", "--seed", "2", "--robot", "sjtu-snake-iii", str(plan_file))
    assert (code, out) == (2, "") and err.startswith("snakeplan: error: --robot: sjtu-snake-iii is not the arm the "
                                                     "plan was made with (thin-arm)") and err.count("\n") == 1
    code, out, _ = run(capsys, "check", "--seed", "2", "--robot", str(arm_file), str(plan_file))
    assert out.splitlines()[0] == "arm: thin-arm (--robot)"


def test_check_judges_an_inspect_plans_mission_from_its_document_alone(tmp_path, capsys, monkeypatch):
    """plan's inspection document, given to check, is judged again the same way; a view moved off the arm in the
    file is refused."""
    import snakeplan.world.mission as missions
    from snakeplan.world.mission import InspectionSettings

    monkeypatch.setattr(missions, "default_settings", lambda scene, robot=None: InspectionSettings(budget_s=16.0))
    code, out, _ = run(capsys, "plan", "--scene", "station", "--planner", "coverage", "--json")
    doc = json.loads(out)
    assert code == 0 and doc["mission"]["settings"]["budget_s"] == 16.0
    plan_file = tmp_path / "mission.json"
    plan_file.write_text(out)
    code, out, _ = run(capsys, "check", "--scene", "station", "--json", str(plan_file))
    checked = json.loads(out)
    assert code == 0 and checked["success"] and checked["reason"] == "inspected"
    assert checked["metrics"]["rmse_k"] == doc["metrics"]["rmse_k"]
    doc["mission"]["views"]["positions"][2][0] += 100.0
    plan_file.write_text(json.dumps(doc))
    code, out, _ = run(capsys, "check", "--scene", "station", str(plan_file))
    assert code == 1 and out.splitlines()[:2] == ["arm: hsr-10 (the plan's)", out.splitlines()[1]]
    assert "view_off_arm" in out.splitlines()[1]
    doc["mission"]["motions"][0]["q"] = "nope"
    plan_file.write_text(json.dumps(doc))
    code, out, err = run(capsys, "check", "--scene", "station", str(plan_file))
    assert (code, out) == (2, "") and err.startswith("snakeplan: error: mission.motions[0]: ") and err.count("\n") == 1
