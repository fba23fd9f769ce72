"""The benchmark runner: the same rows on every backend, exact resumption after SIGKILL, one writer per folder,
torn last lines, and the report's Wilson interval against an independent inversion of the score test."""

import json
import math
import os
import random
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from scipy import optimize, stats

import snakeplan
from snakeplan.bench.report import summarise, wilson, write_report
from snakeplan.bench.runner import RUNS_FILE, ResultsLog, Sweep, chunks, comparable, read_rows, run_sweep
from snakeplan.bench.table2 import Table2Config
from snakeplan.parallel import Backend, backend_from

ENV = {**os.environ, "PYTHONPATH": str(Path(snakeplan.__file__).parents[1]), "OPENBLAS_NUM_THREADS": "1"}


def _same_rows_on_every_backend(tmp_path: Path, seeds: tuple[int, ...]) -> None:
    # Every Table 2 planner in both tanks, with a budget that does not bind on a loaded machine: a time-limited
    # planner stopped by its clock (rrt-star's legs) plans less on a slower worker, on any backend.
    config = Table2Config(seeds=seeds, time_limit_s=30.0)
    results = {}
    for backend in (Backend("serial"), Backend("processes", 2), Backend("ray", 2, "local")):
        outcome = run_sweep(config.sweep(), tmp_path / backend.kind, backend, progress=False)
        assert outcome.ran == len(config.sweep().runs()) and outcome.skipped == 0
        rows = read_rows(tmp_path / backend.kind)
        assert len({r["key"] for r in rows}) == len(rows) == outcome.ran
        results[backend.kind] = {r["key"]: comparable(r) for r in rows}
        provenance = rows[0]["provenance"]
        assert provenance["settings"]["backend"] == backend.kind and provenance["snakeplan"] == snakeplan.__version__
        assert {"python", "platform", "host", "started", "commit"} <= set(provenance)
    assert results["serial"] == results["processes"] == results["ray"]
    assert {(r["scene"], r["planner"]) for r in results["serial"].values()} == {
        (s, planner) for s in config.scenes for _, planner, _ in config.entries_in(s)}


def test_table2_rows_are_identical_on_serial_processes_and_ray(tmp_path):
    pytest.importorskip("ray")
    _same_rows_on_every_backend(tmp_path, (0,))


@pytest.mark.slow
def test_table2_20_seeds_rows_are_identical_on_serial_processes_and_ray(tmp_path):
    pytest.importorskip("ray")
    _same_rows_on_every_backend(tmp_path, tuple(range(20)))


def _bench_run(out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "snakeplan.cli", "bench", "run", "--scenes", "oil-tank", "--planners",
            "sp-rrt,sac-per", "--seeds", "0-5", "--time-limit", "5", "--out", str(out), "--json", *extra]


def test_sigkill_at_random_moments_then_resume_gives_the_uninterrupted_rows(tmp_path):
    sweep = Sweep("run", ("oil-tank",), tuple(range(6)), (("sp-rrt", {}), ("sac-per", {})), 5.0)
    reference = {r["key"]: comparable(r) for r in run_sweep(sweep, tmp_path / "whole", Backend("serial"),
                                                             progress=False).rows}
    out = tmp_path / "killed"
    rng = random.Random(11)
    kills = 0
    for attempt in range(12):
        proc = subprocess.Popen(_bench_run(out, "--workers", "2"), env=ENV, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE)
        if attempt < 2:  # killed while planning, at a random moment once some rows are in
            before = len(read_rows(out))
            deadline = time.monotonic() + 120
            while len(read_rows(out)) <= before and proc.poll() is None and time.monotonic() < deadline:
                time.sleep(0.05)
            time.sleep(rng.uniform(0.0, 1.0))
            if proc.poll() is None:
                proc.send_signal(signal.SIGKILL)
                kills += 1
        proc.wait(timeout=300)
        if proc.returncode == 0:
            break
    assert kills >= 1 and proc.returncode == 0
    rows = read_rows(out)
    assert len(rows) == len({r["key"] for r in rows})  # nothing twice
    assert {r["key"]: comparable(r) for r in rows} == reference


def test_a_torn_last_line_is_cut_and_the_run_redone(tmp_path):
    sweep = Sweep("run", ("oil-tank",), (0, 1), (("sp-rrt", {}),), 5.0)
    first = run_sweep(sweep, tmp_path, Backend("serial"), progress=False)
    runs = tmp_path / RUNS_FILE
    lines = runs.read_bytes().splitlines(keepends=True)
    runs.write_bytes(lines[0] + lines[1][: len(lines[1]) // 2])  # the writer died inside the second row
    assert [r["key"] for r in read_rows(tmp_path)] == [first.rows[0]["key"]]
    again = run_sweep(sweep, tmp_path, Backend("serial"), progress=False)
    assert again.ran == 1 and again.skipped == 1
    assert [comparable(r) for r in read_rows(tmp_path)] == [comparable(r) for r in first.rows]
    assert runs.read_bytes().endswith(b"\n") and runs.read_bytes().count(b"\n") == 2


def test_a_second_writer_is_refused_in_one_line_and_writes_nothing(tmp_path):
    out = tmp_path / "busy"
    with ResultsLog(out).open():
        proc = subprocess.run(_bench_run(out, "--workers", "1"), env=ENV, capture_output=True, text=True,
                              timeout=300)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1
    assert proc.stderr.startswith(f"snakeplan: error: --out: {out} is in use by another job")
    assert "choose another --out" in proc.stderr and proc.stdout == ""
    assert sorted(p.name for p in out.iterdir()) == [".lock", RUNS_FILE] and (out / RUNS_FILE).stat().st_size == 0


def test_backends_from_the_command_line_options():
    assert backend_from(None, None).kind == "processes" and backend_from(None, None).slots >= 1
    assert backend_from(1, None) == Backend("serial", 1)
    assert backend_from(2, None) == Backend("processes", 2)
    assert backend_from(None, "auto") == Backend("ray", 0, "auto")
    with pytest.raises(ValueError, match="--workers"):
        backend_from(0, None)


def test_chunks_keep_a_stateful_planners_runs_together_in_seed_order():
    sweep = Sweep("sscc", ("pipe",), tuple(range(10)), (("sscc", {"learning": True}), ("sscc", {})), 5.0,
                  stateful=lambda planner, options: options.get("learning", False))
    runs = sweep.runs()
    tasks = chunks(runs, 2)
    assert sorted(r.key for t in tasks for r in t) == sorted(r.key for r in runs)
    learning = [t for t in tasks if any(dict(r.options) for r in t)]
    assert len(learning) == 1 and [r.seed for r in learning[0]] == list(range(10))


def _score_interval(k: int, n: int) -> tuple[float, float]:
    """The rates p whose score test |k/n - p| <= z sqrt(p (1 - p) / n) does not reject, found by root finding."""
    z = stats.norm.ppf(0.975)
    gap = lambda p: abs(k / n - p) - z * math.sqrt(p * (1 - p) / n)  # noqa: E731
    lo = 0.0 if k == 0 else optimize.brentq(gap, 1e-12, k / n - 1e-12, xtol=1e-14)
    hi = 1.0 if k == n else optimize.brentq(gap, k / n + 1e-12, 1 - 1e-12, xtol=1e-14)
    return lo, hi


@pytest.mark.parametrize("k, n", [(0, 10), (8, 10), (10, 10), (97, 100), (1, 3), (50, 50)])
def test_wilson_interval_inverts_the_score_test(k, n):
    assert wilson(k, n) == pytest.approx(_score_interval(k, n), abs=1e-9)


def test_report_tables_count_each_run_once(tmp_path):
    sweep = Sweep("run", ("oil-tank",), (0, 1, 2), (("sp-rrt", {}), ("sac-per", {})), 5.0)
    run_sweep(sweep, tmp_path, Backend("serial"), progress=False)
    run_sweep(sweep, tmp_path, Backend("serial"), progress=False)  # a rerun adds nothing
    result = write_report(tmp_path)
    rows = read_rows(tmp_path)
    assert len(rows) == 6
    for entry in result["entries"]:
        group = [r for r in rows if r["planner"] == entry["planner"]]
        wins = sum(r["success"] for r in group)
        assert entry["runs"] == 3 and entry["successes"] == wins
        assert (entry["success_lo95"], entry["success_hi95"]) == pytest.approx(_score_interval(wins, 3))
        assert entry["time_max_s"] == max(r["compute_time_s"] for r in group)
    text = (tmp_path / "report.md").read_text()
    assert "| run | oil-tank | sp-rrt |" in text and (tmp_path / "report.csv").read_text().count("\n") == 3
    assert summarise(rows) == result["entries"]


def test_bench_report_without_html_support_says_so_and_writes_nothing(tmp_path, capsys, monkeypatch):
    from snakeplan.cli import main

    sweep = Sweep("run", ("oil-tank",), (0,), (("sp-rrt", {}),), 5.0)
    run_sweep(sweep, tmp_path, Backend("serial"), progress=False)
    monkeypatch.setitem(sys.modules, "snakeplan.viz.report", None)  # as if this snakeplan had no HTML report
    assert main(["bench", "report", str(tmp_path), "--html", str(tmp_path / "r.html")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("snakeplan: error: --html: ") and err.count("\n") == 1
    assert not (tmp_path / "report.md").exists() and not (tmp_path / "r.html").exists()
    assert main(["bench", "report", str(tmp_path / "nothing")]) == 2
    assert "holds no runs.jsonl" in capsys.readouterr().err


def test_train_rl_seeds_trains_one_resumable_run_per_seed_and_summarises(tmp_path, capsys):
    from snakeplan.cli import main

    argv = ["train", "rl", "oil-tank", "sac-per", "--steps", "60", "--seeds", "3,5", "--workers", "1", "--out",
            str(tmp_path), "--eval-every", "30", "--eval-episodes", "2", "--net-arch", "16", "16",
            "--learning-starts", "30", "--train-scenes", "2", "--batch-size", "16"]
    assert main(argv) == 0
    summary = json.loads((tmp_path / "sweep.json").read_text())
    assert [r["seed"] for r in summary["runs"]] == [3, 5] and summary["backend"]["backend"] == "serial"
    for run in summary["runs"]:
        curve = json.loads((tmp_path / f"seed{run['seed']}" / "curve.json").read_text())
        assert run["evaluations"] == len(curve) and run["final_success"] == curve[-1]["success"]
        assert run["best_success"] == max(h["success"] for h in curve)
    steps = {s: json.loads((tmp_path / f"seed{s}" / "state.json").read_text())["generations"][0]["step"]
             for s in (3, 5)}
    assert main(argv) == 0 and steps == {  # a rerun resumes finished runs and trains nothing more
        s: json.loads((tmp_path / f"seed{s}" / "state.json").read_text())["generations"][0]["step"] for s in (3, 5)}
    assert (tmp_path / "curves.png").read_bytes()[:4] == b"\x89PNG" and "| 3 |" in capsys.readouterr().out


def _untimed(methods: dict) -> dict:
    """A station summary's methods without planning times (they differ from run to run)."""
    timed = ("compute_time_s", "compute_time_max_s", "compute_cpu_s")
    return {n: {k: [{f: v for f, v in p.items() if f not in timed} for p in m[k]] if k == "per_seed" else m[k]
                for k in m if k not in timed} for n, m in methods.items()}


def test_station_missions_are_runner_rows_the_same_on_two_backends_and_the_report_flies_nothing(tmp_path,
                                                                                              monkeypatch, capsys):
    from snakeplan.bench.station import run_station_bench, station_outputs
    from snakeplan.cli import main
    from snakeplan.planners.inspection import InspectionPlanner
    from snakeplan.scenes import make_scene

    serial = run_station_bench(1, 0, tmp_path / "serial", Backend("serial"), progress=False)
    assert main(["bench", "station", "--seeds", "1", "--workers", "2", "--out", str(tmp_path / "processes"),
                 "--json"]) == 0
    processes = json.loads(capsys.readouterr().out)
    assert processes["runner"]["backend"] == {"backend": "processes", "workers": 2} and processes["runner"]["ran"] == 3
    rows = read_rows(tmp_path / "serial")
    assert sorted(r["planner"] for r in rows) == ["coverage", "informative", "random"]
    assert {r["key"]: comparable(r) for r in rows} == {
        r["key"]: comparable(r) for r in read_rows(tmp_path / "processes")}
    assert _untimed(serial["methods"]) == _untimed(processes["methods"])
    truth = np.asarray(make_scene("station", 0).metadata["field"]["values"])
    for r in rows:  # the logged final map scores as the logged metric, against the scene's own field
        mean = np.asarray(r["details"]["final_mean_k"])
        assert r["metrics"]["final_rmse_k"] == pytest.approx(float(np.sqrt(np.mean((mean - truth) ** 2))), rel=1e-9)
        assert r["success"] is True and r["details"]["mission"]["budget_s"] == r["details"]["measurement_times"][-1]
        assert r["metrics"]["final_trace_k2"] == pytest.approx(sum(r["details"]["final_variance_k2"]), rel=1e-9)
    monkeypatch.setattr(InspectionPlanner, "plan", lambda *a, **k: pytest.fail("the report flew a mission"))
    # a reach run logged under the same configuration name, in the same folder: left out of the station tables
    run_sweep(Sweep("station", ("oil-tank",), (0,), (("sp-rrt", {}),), 5.0), tmp_path / "serial", Backend("serial"),
              progress=False)
    again = station_outputs(read_rows(tmp_path / "serial"), tmp_path / "serial")
    assert again["methods"] == serial["methods"]
    result = write_report(tmp_path / "serial")
    text = (tmp_path / "serial" / "report.md").read_text()
    assert "## Paper 002, Figs. 6-9" in text and "![station_curves](station_curves.png)" in text
    assert {e["planner"] for e in result["entries"]} == {"coverage", "informative", "random", "sp-rrt"}


def test_planners_run_in_the_scenes_whose_task_they_do_and_one_that_does_none_is_one_line_and_exit_2(tmp_path,
                                                                                                   capsys):
    from snakeplan.cli import main

    mixed = Sweep("run", ("station", "oil-tank"), (0, 1), (("coverage", {}), ("sp-rrt", {})))
    assert [(r.scene, r.planner, r.task) for r in mixed.runs()] == [
        ("station", "coverage", "inspect")] * 2 + [("oil-tank", "sp-rrt", "reach")] * 2
    for scenes, planners in (("fuel-tank", "informative"), ("station,oil-tank", "sp-rrt,random,as-rrt,x")):
        assert main(["bench", "run", "--scenes", scenes, "--planners", planners, "--seeds", "0", "--out",
                     str(tmp_path / "out")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1
    assert err.startswith("snakeplan: error: --planners: ")  # an unknown name, before any task is looked at
    assert main(["bench", "run", "--scenes", "fuel-tank", "--planners", "informative,random", "--seeds", "0",
                 "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err.startswith("snakeplan: error: planners: informative, random can do none of "
                                              "these scenes' tasks (fuel-tank)")
    assert not (tmp_path / "out").exists()


def test_bench_run_joins_a_running_ray_cluster_by_address_with_the_serial_rows(tmp_path):
    pytest.importorskip("ray")
    import socket as sockets
    import threading

    with sockets.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    ray_cli = [sys.executable, "-m", "ray.scripts.scripts"]
    home = tmp_path / "home"  # this test's own ~/.ray: its token, nobody else's
    home.mkdir()
    env = {**{k: v for k, v in ENV.items() if not k.startswith("RAY_AUTH")}, "RAY_USAGE_STATS_ENABLED": "0",
           "HOME": str(home)}
    wrong = subprocess.run(_bench_run(tmp_path / "nobody", "--ray", f"127.0.0.1:{port}"), env=env,
                           capture_output=True, text=True, timeout=300)
    assert wrong.returncode == 2 and wrong.stderr.count("\n") == 1, wrong.stderr[-2000:]
    assert wrong.stderr.startswith(f"snakeplan: error: --ray: cannot join a Ray cluster at '127.0.0.1:{port}' "
                                   "(nothing answers there")
    assert not (tmp_path / "nobody").exists()
    subprocess.run([*ray_cli, "get-auth-token", "--generate"], env=env, capture_output=True, check=True, timeout=120)
    # A head that asks for the token, in its own process group (stopped below without touching other Ray jobs),
    # its workers at niceness 0 as for --ray local (Ray's default, 15, starves them on a shared two-core machine).
    head = subprocess.Popen([*ray_cli, "start", "--head", "--block", "--port", str(port), "--num-cpus", "2",
                             "--include-dashboard", "false", "--disable-usage-stats",
                             "--system-config", json.dumps({"worker_niceness": 0})],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    try:
        address = None
        for line in head.stdout:
            found = re.search(r"--address='([^']+)'", line)
            if found:
                address = found.group(1)
                break
        threading.Thread(target=head.stdout.read, daemon=True).start()
        assert address is not None, "ray start printed no address"
        refused = subprocess.run(_bench_run(tmp_path / "refused", "--ray", address), env=env,
                                 capture_output=True, text=True, timeout=600)
        assert refused.returncode == 2 and "needs RAY_AUTH_MODE=token" in refused.stderr.splitlines()[-1]
        proc = subprocess.run(_bench_run(tmp_path / "cluster", "--ray", address), env={**env, "RAY_AUTH_MODE": "token"},
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr[-2000:]
    finally:
        head.send_signal(signal.SIGTERM)  # 'ray start --block' stops what it started
        try:
            head.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(head.pid, signal.SIGKILL)
        record = Path("/tmp/ray/ray_current_cluster")  # Ray's note of the newest head here, if it still names ours
        if record.exists() and record.read_text().strip().endswith(f":{port}"):
            record.unlink()
    sweep = Sweep("run", ("oil-tank",), tuple(range(6)), (("sp-rrt", {}), ("sac-per", {})), 5.0)
    serial = run_sweep(sweep, tmp_path / "serial", Backend("serial"), progress=False).rows
    rows = read_rows(tmp_path / "cluster")
    assert {r["key"]: comparable(r) for r in rows} == {r["key"]: comparable(r) for r in serial}
    settings = rows[0]["provenance"]["settings"]
    assert settings["backend"] == "ray" and settings["ray"] == address
    assert {r["provenance"]["pid"] for r in rows} != {os.getpid()}


def test_progress_in_a_log_is_a_plain_line_every_percent(capsys):
    from snakeplan.parallel import progress_bar

    with progress_bar(250, "sweep") as tick:  # pytest's captured stderr is not a terminal, as a log file
        for i in range(250):
            tick(f"item {i}")
    lines = capsys.readouterr().err.splitlines()
    # the first item, then each whole percent as it is passed: 3/250 is the first item past 1 %
    assert len(lines) == 101 and lines[0].startswith("sweep: 1/250 (0 %, ") and lines[0].endswith(" item 0")
    assert lines[1].startswith("sweep: 3/250 (1 %, ") and lines[1].endswith(" item 2")
    assert lines[-1].startswith("sweep: 250/250 (100 %, ") and lines[-1].endswith(" item 249")
    with progress_bar(3, "small") as tick:
        for i in range(3):
            tick(f"run {i}")
    assert [line.split(" (")[0] for line in capsys.readouterr().err.splitlines()] == [
        "small: 1/3", "small: 2/3", "small: 3/3"]


def test_bench_run_takes_a_robot_file_as_plan_does(tmp_path, capsys):
    """The newcomer's own arm from its robot/1 file (before: presets only, 'register your robot'): every row names
    it, and the judge judged with it."""
    from snakeplan.cli import main
    from snakeplan.evaluation import evaluate
    from snakeplan.robots import get_robot, load_robot
    from snakeplan.scenes import make_scene

    arm = get_robot("sjtu-snake-iii").to_dict()
    arm["name"] = "thin-arm"
    for section in arm["sections"]:
        section["radius"] = 12.0
    (tmp_path / "thin.json").write_text(json.dumps(arm))
    out = tmp_path / "rows"
    assert main(["bench", "run", "--scenes", "fuel-tank", "--planners", "as-rrt", "--seeds", "0", "--workers", "1",
                 "--robot", str(tmp_path / "thin.json"), "--out", str(out)]) == 0
    capsys.readouterr()
    [row] = read_rows(out)
    assert row["robot"] == "thin-arm" and row["success"]
    judged = evaluate(make_scene("fuel-tank", 0), load_robot(arm), np.asarray(row["path"]))
    assert row["metrics"]["min_clearance_mm"] == pytest.approx(judged.min_clearance_mm)
    assert main(["bench", "run", "--scenes", "fuel-tank", "--planners", "as-rrt", "--seeds", "0", "--robot",
                 str(tmp_path / "nope.json"), "--out", str(tmp_path / "x")]) == 2
    assert capsys.readouterr().err.startswith("snakeplan: error: --robot: no such file")


def test_bench_report_names_the_folder_as_the_report_it_writes(tmp_path, capsys):
    """After bench run the report said 'Results in rows: 1 runs', bench report printed 'Results in /tmp/.../rows':
    one heading now, the file's."""
    from snakeplan.cli import main

    run_sweep(Sweep("run", ("oil-tank",), (0,), (("sp-rrt", {}),), 5.0), tmp_path / "rows", Backend("serial"),
              progress=False)
    assert main(["bench", "report", str(tmp_path / "rows")]) == 0
    printed = capsys.readouterr().out.splitlines()[0]
    assert printed == (tmp_path / "rows" / "report.md").read_text().splitlines()[0]
    assert "Results in rows: 1 runs" in printed


@pytest.mark.slow
def test_a_cold_cache_costs_one_compile_however_many_workers(tmp_path):
    """On 16 cores with a cold kernel cache, bench table2 on 16 workers took 120 s against 42 s warm: every worker
    compiled the same kernels at once. The kernels its workers compile, summed over the rows, are now no more
    than one serial run compiles from a cold cache of its own: each kernel once per machine."""
    def compiled(workers: int) -> int:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / f"numba-{workers}"), "SNAKEPLAN_KERNELS": "numba",
               "SNAKEPLAN_CACHE_DIR": str(tmp_path / f"cache-{workers}")}
        out = tmp_path / f"w{workers}"
        subprocess.run([sys.executable, "-c", "import sys; from snakeplan.cli import main; sys.exit(main(sys.argv[1:]))",
                        "bench", "table2", "--runs", "2", "--workers", str(workers), "--out", str(out)],
                       env=env, check=True, capture_output=True, timeout=1800)
        rows = read_rows(out)
        by_pid = {r["provenance"]["pid"] for r in rows if r["provenance"]["kernels_compiled"]}
        assert workers == 1 or len(by_pid) >= 1
        return sum(r["provenance"]["kernels_compiled"] for r in rows)

    serial = compiled(1)
    assert serial > 50  # a cold cache: the planners' kernels compiled
    assert compiled(2) <= serial


def test_a_benchmark_piped_into_head_logs_every_run_and_does_not_claim_success(tmp_path):
    """bench run ... 2>&1 | head -2 stopped after 3 of 15 runs when head went away, and exited 0. The progress
    lines stop, the runs go on to the end, and the exit status is a broken pipe's (141), not success."""
    out = tmp_path / "runs"
    cmd = (f"{sys.executable} -c 'import sys; from snakeplan.cli import main; sys.exit(main(sys.argv[1:]))' bench run "
           f"--scenes fuel-tank --planners as-rrt --seeds 0-5 --workers 1 --time-limit 5 --out {out} 2>&1 | head -1;"
           " exit ${PIPESTATUS[0]}")
    proc = subprocess.run(["bash", "-c", cmd], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 141 and proc.stdout.startswith("run: 1/6 ")
    assert len(read_rows(out)) == 6


def test_a_sweep_plans_a_scene_file_whose_mesh_lies_beside_it_and_keys_it_by_content(tmp_path):
    """A scene file naming its mesh relative to itself: the runner's worker reads it from the file's folder and
    plans; the run's key is the same when the folder moves (nothing absolute in it) and changes when the mesh
    does."""
    import hashlib
    import shutil

    import trimesh

    from snakeplan.scenes.meshing import pipe_run, to_mesh

    elbow = to_mesh([pipe_run([[0, 0, 0], [500, 0, 0], [500, 500, 0]], 100.0, 15.0, 250.0, 48)])
    job = tmp_path / "job"
    (job / "parts").mkdir(parents=True)
    trimesh.Trimesh(elbow.vertices / 1000.0, elbow.faces).export(job / "parts" / "elbow.stl")
    doc = {"schema": "snakeplan.scene/1", "name": "elbow", "units": "mm",
           "bounds": {"min": [-150, -150, -150], "max": [650, 650, 150]},
           "entrance": {"position": [0, 0, 0], "direction": [1, 0, 0]}, "targets": [[500, 450, 0]],
           "obstacles": [{"type": "mesh", "file": "parts/elbow.stl", "units": "m"}]}
    (job / "elbow.json").write_text(json.dumps(doc))

    def sweep(folder):
        return Sweep("elbow", (str(folder / "elbow.json"),), (0,), (("as-rrt", {}),), 20.0)

    rows = run_sweep(sweep(job), tmp_path / "out", Backend("serial"), progress=False).rows
    assert len(rows) == 1 and rows[0]["success"], rows[0]["why"]
    assert rows[0]["files_sha256"] == {"parts/elbow.stl": hashlib.sha256((job / "parts" / "elbow.stl").read_bytes())
                                       .hexdigest()}
    shutil.move(job, tmp_path / "moved")
    assert sweep(tmp_path / "moved").runs()[0].key == rows[0]["key"]
    bent = trimesh.load(tmp_path / "moved" / "parts" / "elbow.stl")
    bent.vertices *= 1.01
    bent.export(tmp_path / "moved" / "parts" / "elbow.stl")
    assert sweep(tmp_path / "moved").runs()[0].key != rows[0]["key"]


def test_a_run_is_keyed_by_its_policy_files_content_so_a_retrained_policy_is_planned_again(tmp_path):
    """``--option policy=DIR/policy.npz`` rerun after training rewrote the file in place: the old rows were
    skipped as planned (the key held the path alone). The key holds the file's SHA-256, the row records it, and a
    shipped generalist named by ``policy=``, or the policy a planner loads when none is named, counts by its
    file's content too."""
    import hashlib
    import shutil

    from snakeplan.planners.sac.policy import ARM_GENERALIST, GENERALIST, generalist_path, policy_path

    policy = tmp_path / "policy.npz"
    shutil.copy(policy_path("fuel-tank", "sac-her"), policy)
    sweep = Sweep("retrained", ("fuel-tank",), (1,), (("sac", {"policy": str(policy)}),), 10.0)
    first = run_sweep(sweep, tmp_path / "out", Backend("serial"), progress=False).rows
    assert first[0]["policy_sha256"] == hashlib.sha256(policy.read_bytes()).hexdigest()
    assert run_sweep(sweep, tmp_path / "out", Backend("serial"), progress=False).rows == first
    shutil.copy(generalist_path(GENERALIST), policy)
    rows = run_sweep(sweep, tmp_path / "out", Backend("serial"), progress=False).rows
    assert rows[0]["key"] != first[0]["key"] and len(read_rows(tmp_path / "out")) == 2
    assert rows[0]["details"]["policy"] == "confined+fuel-tank+oil-tank-sac"
    assert rows[0]["policy_sha256"] == hashlib.sha256(policy.read_bytes()).hexdigest()
    report = write_report(tmp_path / "out")  # the folder's report counts the run once, as planned now
    assert [e["runs"] for e in report["entries"]] == [1] and report["heading"].endswith(
        "1 runs (1 older rows of runs planned again with changed files left out)")
    assert report["entries"][0]["successes"] == int(rows[0]["success"])

    def digest(path):
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()

    def keyed(planner, options, robot=""):
        return Sweep("k", ("fuel-tank",), (1,), ((planner, options),), robot=robot).runs()[0].identity()

    assert keyed("sac", {"policy": "generalist-arms"})["policy_sha256"] == digest(generalist_path(ARM_GENERALIST))
    # a run naming no policy is keyed by the one its planner loads: the family's, or the arm generalist for an
    # arm that one was not trained for; a planner that reads none has none
    assert keyed("sac-her", {})["policy_sha256"] == digest(policy_path("fuel-tank", "sac-her"))
    arm = str(Path(snakeplan.__file__).parent / "robots" / "data" / "arms" / "arm-16x120.json")
    assert keyed("sac-her", {}, arm)["policy_sha256"] == digest(generalist_path(ARM_GENERALIST))
    assert "policy_sha256" not in keyed("as-rrt", {})
