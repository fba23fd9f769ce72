"""Training state that survives any interruption: atomic checkpoint folders, the interruption helper, and the
trainers behind ``snakeplan train rl`` and ``snakeplan train sscc`` killed (SIGKILL), stopped (SIGINT, SIGTERM)
and damaged, then resumed. Resumed runs are compared with an uninterrupted run of the same command."""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from snakeplan.checkpoints import StateError, StateFolder, atomic_path, atomic_write, checkpoint_interval
from snakeplan.interrupt import EXIT_INTERRUPTED, Interrupted, interruptible, report

SRC = str(Path(__file__).resolve().parents[1] / "src")
ENV = {**os.environ, "PYTHONPATH": SRC, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
#: A tiny SAC-HER run: 8 x 8 networks, a checkpoint every 30 steps, 2 validation episodes every 60.
INTERVAL = 30
LEARNING_STARTS = 150
TINY = ["--net-arch", "8", "8", "--batch-size", "16", "--learning-starts", str(LEARNING_STARTS), "--eval-every", "60",
        "--eval-episodes", "2", "--checkpoint-every", str(INTERVAL), "--train-scenes", "2", "--torch-threads", "1"]
STEPS = 240
LINE = re.compile(r"^snakeplan: interrupted at step (\d+); checkpoint saved in (.+); rerun the same command to "
                  r"resume$")
PROGRESS = re.compile(r"step (\d+)/(\d+)")


# --- the state folder ----------------------------------------------------------------------------------------
def _writer(text: str):
    return lambda path: Path(path).write_text(text)


def _manifest(root: Path) -> dict:
    return json.loads((root / "state.json").read_text())


def test_checkpoint_interval_is_a_tenth_within_1000_and_10000_and_never_beyond_the_run():
    assert checkpoint_interval(3_000) == 1_000  # the run the issue killed at 60 s
    assert checkpoint_interval(50_000) == 5_000
    assert checkpoint_interval(40_000) == 4_000
    assert checkpoint_interval(1_000_000) == 10_000
    assert checkpoint_interval(600) == 600
    assert checkpoint_interval(1) == 1


def test_state_folder_keeps_two_generations_and_records_files_with_their_sha256(tmp_path):
    state = StateFolder(tmp_path, {"seed": 0})
    for step in (10, 20, 30):
        state.save(step, {"a.txt": _writer(f"a{step}"), "b.bin": _writer("b" * step)}, {"history": [step]})
        names = sorted(p.name for p in tmp_path.iterdir() if p.is_dir())
        assert names[-1] == f"ckpt-{step:08d}" and len(names) == min(2, step // 10)
    manifest = _manifest(tmp_path)
    assert [g["step"] for g in manifest["generations"]] == [30, 20]
    newest = manifest["generations"][0]
    assert newest["files"]["b.bin"] == {"bytes": 30, "sha256": hashlib.sha256(b"b" * 30).hexdigest()}
    again = StateFolder(tmp_path, {"seed": 0})
    generation = again.load()
    assert generation.step == 30 and generation.record == {"history": [30]} and again.warnings == []
    assert generation.path("a.txt").read_text() == "a30"
    assert not list(tmp_path.rglob(".*.tmp*"))


@pytest.mark.parametrize("damage", ["truncated", "flipped byte", "missing"])
def test_damaged_newest_generation_falls_back_to_the_previous_one(tmp_path, damage):
    state = StateFolder(tmp_path, {"seed": 0})
    for step in (10, 20):
        state.save(step, {"w.bin": _writer(f"weights at {step}")}, {"step": step})
    target = tmp_path / "ckpt-00000020" / "w.bin"
    if damage == "truncated":
        target.write_text("weights")
    elif damage == "flipped byte":
        target.write_text("weights at 21")
    else:
        target.unlink()
    generation = StateFolder(tmp_path, {"seed": 0}).load()
    assert generation.step == 10 and generation.path("w.bin").read_text() == "weights at 10"
    again = StateFolder(tmp_path, {"seed": 0})
    again.load()
    assert len(again.warnings) == 1 and "ckpt-00000020 is damaged" in again.warnings[0]
    again.save(20, {"w.bin": _writer("weights at 20")}, {"step": 20})  # the damaged one is rewritten
    assert [g["step"] for g in _manifest(tmp_path)["generations"]] == [20, 10]


def test_a_save_that_dies_midway_leaves_the_previous_manifest_and_is_cleaned_up(tmp_path):
    state = StateFolder(tmp_path, {"seed": 0})
    state.save(10, {"w.bin": _writer("10")}, {})

    def dies(path):
        Path(path).write_text("half")
        raise KeyboardInterrupt

    before = (tmp_path / "state.json").read_bytes()
    with pytest.raises(KeyboardInterrupt):
        state.save(20, {"a.bin": _writer("20"), "w.bin": dies}, {})
    assert (tmp_path / "state.json").read_bytes() == before
    assert not list(tmp_path.rglob(".*.tmp*"))  # the temporary file went with the failure
    assert StateFolder(tmp_path, {"seed": 0}).load().step == 10
    state.save(30, {"w.bin": _writer("30")}, {})
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_dir()) == ["ckpt-00000010", "ckpt-00000030"]


def test_another_runs_state_or_an_unreadable_manifest_is_one_clear_error(tmp_path):
    StateFolder(tmp_path, {"seed": 0, "scene": "fuel-tank"}).save(10, {"w.bin": _writer("w")}, {})
    with pytest.raises(StateError, match=r"another run \(seed: 1 here, 0 there\)"):
        StateFolder(tmp_path, {"seed": 1, "scene": "fuel-tank"}).load()
    (tmp_path / "ckpt-00000010" / "w.bin").write_text("x")
    with pytest.raises(StateError, match=r"no intact checkpoint \(ckpt-00000010 is damaged"):
        StateFolder(tmp_path, {"seed": 0, "scene": "fuel-tank"}).load()
    (tmp_path / "state.json").write_text('{"last_eval": 0}')  # an older snakeplan's state.json
    with pytest.raises(StateError, match="not a snakeplan.checkpoint/1 manifest"):
        StateFolder(tmp_path, {"seed": 0}).load()
    (tmp_path / "state.json").write_bytes(b"\xff{")
    with pytest.raises(StateError, match="unreadable"):
        StateFolder(tmp_path, {"seed": 0}).load()
    assert StateFolder(tmp_path / "none", {"seed": 0}).load() is None


def test_manifest_entries_cannot_point_outside_their_folder(tmp_path):
    StateFolder(tmp_path, {"seed": 0}).save(10, {"w.bin": _writer("w")}, {})
    manifest = _manifest(tmp_path)
    manifest["generations"][0]["folder"] = "../elsewhere"
    atomic_write(tmp_path / "state.json", json.dumps(manifest))
    with pytest.raises(StateError, match="malformed entry"):
        StateFolder(tmp_path, {"seed": 0}).load()


def test_a_second_job_on_the_same_folder_is_refused(tmp_path):
    first, second = StateFolder(tmp_path, {}), StateFolder(tmp_path, {})
    with first.locked():
        with pytest.raises(StateError, match="in use by another job"):
            with second.locked():
                pass
    with second.locked():
        pass


def test_atomic_path_leaves_the_old_file_when_the_writer_fails(tmp_path):
    dest = tmp_path / "curve.json"
    dest.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_path(dest) as tmp:
            assert tmp.parent == tmp_path and tmp.suffix == ".json"
            tmp.write_text("new, half")
            raise RuntimeError
    assert dest.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["curve.json"]
    with atomic_path(dest) as tmp:
        tmp.write_text("new")
    assert dest.read_text() == "new"


# --- the interruption helper ---------------------------------------------------------------------------------
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_first_signal_asks_to_stop_and_a_second_stops_at_once(signum):
    before = signal.getsignal(signum)
    with interruptible() as stop:
        assert not stop.requested
        signal.raise_signal(signum)
        assert stop.requested and stop.signum == signum
        with pytest.raises(Interrupted, match="interrupted again") as caught:
            signal.raise_signal(signum)
        assert caught.value.signum == signum and isinstance(caught.value, KeyboardInterrupt)
    assert signal.getsignal(signum) is before


def test_immediate_mode_stops_at_the_first_signal_and_blocks_nest():
    with interruptible() as outer:
        with interruptible(immediate=True):
            with pytest.raises(Interrupted, match="^interrupted$"):
                signal.raise_signal(signal.SIGTERM)
        signal.raise_signal(signal.SIGTERM)  # the outer handler is back
        assert outer.requested


def test_off_the_main_thread_the_block_runs_unguarded():
    seen = []

    def work():
        with interruptible() as stop:
            seen.append((signal.getsignal(signal.SIGINT), stop.requested))

    before = signal.getsignal(signal.SIGINT)
    thread = threading.Thread(target=work)
    thread.start()
    thread.join()
    assert seen == [(before, False)]


def test_report_writes_one_line_and_returns_130(capsys):
    assert report(Interrupted("interrupted at step 7; checkpoint saved in d; rerun")) == EXIT_INTERRUPTED == 130
    assert report(KeyboardInterrupt()) == 130
    assert capsys.readouterr().err == "snakeplan: interrupted at step 7; checkpoint saved in d; rerun\n" \
                                      "snakeplan: interrupted\n"


# --- snakeplan train rl, through the command line ----------------------------------------------------------
class _Job:
    """``snakeplan train rl fuel-tank sac-her`` (the tiny run) in a subprocess, its progress lines read as they
    come: each names the environment step reached; one comes every ``every`` steps (1 % of the run)."""

    def __init__(self, out: Path, steps: int = STEPS, options: tuple[str, ...] = ()):
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "snakeplan.cli", "train", "rl", "fuel-tank", "sac-her", "--steps", str(steps),
             "--out", str(out), *TINY, *options], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            env=ENV)
        self.t0 = time.monotonic()
        self.every = max(1, steps // 100)
        self.steps: list[int] = []
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line)
            if m := PROGRESS.search(line):
                self.steps.append(int(m.group(1)))

    def reached(self) -> int:
        return self.steps[-1] if self.steps else -1

    def wait_until(self, condition, limit: float = 120.0) -> None:
        """Until ``condition()`` holds, the job ends or ``limit`` seconds have passed since it started."""
        while self.proc.poll() is None and not condition() and time.monotonic() - self.t0 < limit:
            time.sleep(0.001)

    def finish(self, timeout: float = 300) -> tuple[int, str]:
        rc = self.proc.wait(timeout)
        self._reader.join(10)
        return rc, self.proc.stderr.read()


def _verified_step(out: Path) -> int:
    """The step a rerun resumes from, found independently of the code under test: the first generation in the
    manifest whose files all have the recorded size and sha256 (0 when there is none)."""
    try:
        manifest = json.loads((out / "state.json").read_text())
    except FileNotFoundError:
        return 0
    for g in manifest["generations"]:
        files = [(out / g["folder"] / name, rec) for name, rec in g["files"].items()]
        if all(p.is_file() and hashlib.sha256(p.read_bytes()).hexdigest() == rec["sha256"] for p, rec in files):
            return g["step"]
    raise AssertionError(f"no intact generation in {out}")


def _mid_checkpoint(out: Path, since_ns: int) -> bool:
    """Whether a checkpoint was being written after ``since_ns`` (the job's start): a generation folder the
    manifest does not name or a temporary file of the manifest or of a generation, changed since then (not one
    that a killed job left)."""
    try:
        named = {g["folder"] for g in json.loads((out / "state.json").read_text())["generations"]}
    except (FileNotFoundError, ValueError):
        named = set()
    unnamed = [p for p in out.glob("ckpt-*") if p.name not in named]
    for path in [*unnamed, *out.glob(".state.*.tmp*"), *out.glob("ckpt-*/.*.tmp*")]:
        try:
            if path.stat().st_mtime_ns > since_ns:
                return True
        except FileNotFoundError:  # deleted meanwhile
            continue
    return False


def _result(out: Path) -> dict:
    history = json.loads((out / "curve.json").read_text())
    with np.load(out / "last.npz") as last, np.load(out / "policy.npz") as best:
        weights = {f"last/{k}": last[k] for k in last.files if k != "meta"}
        weights.update({f"best/{k}": best[k] for k in best.files if k != "meta"})
    return {"eval_steps": [h["env_steps"] for h in history], "weights": weights,
            "curve": [{k: v for k, v in h.items() if k not in ("wall_s", "median_time_s")} for h in history]}


_BASELINES: dict[tuple, dict] = {}


def _baseline(tmp_path_factory, steps: int, options: tuple[str, ...] = ()) -> dict:
    """The uninterrupted run of the same command (once per module, length and options)."""
    if (steps, options) not in _BASELINES:
        out = tmp_path_factory.mktemp(f"baseline{steps}")
        rc, err = _Job(out, steps, options).finish()
        assert rc == 0, err
        _BASELINES[steps, options] = {"out": out, **_result(out)}
    return _BASELINES[steps, options]


def _same_as(result: dict, baseline: dict) -> None:
    assert result["eval_steps"] == baseline["eval_steps"]
    assert all(b > a for a, b in itertools.pairwise(result["eval_steps"]))
    assert result["weights"].keys() == baseline["weights"].keys()
    for key, value in baseline["weights"].items():  # resumed exactly: the same weights, bit for bit
        np.testing.assert_array_equal(result["weights"][key], value, err_msg=key)
    assert json.dumps(result["curve"]) == json.dumps(baseline["curve"])


def _kill_and_resume(out: Path, kills: int, steps: int, seed: int, options: tuple[str, ...] = (),
                     after: int = 0) -> list[dict]:
    """Kill the run with SIGKILL ``kills`` times at random moments (any time in the first quarter of the run, a
    random step of training from step ``after``, or while a checkpoint is being written), rerunning the same
    command after each; then let it finish. The moments are bounded in steps as well as in seconds, so that a fast
    machine does not finish the run before a kill. Returns one record per kill: the last step the killed run
    reported (``reached``) and the step the rerun resumes from. Checkpoint steps are multiples of the reporting
    period, so a kill mid-checkpoint reports the checkpoint's own step."""
    rng = random.Random(seed)
    records, resumed_from = [], 0
    room = steps - 2 * INTERVAL  # the first two kills fall before this step, so that the third finds checkpoints left
    for i in range(kills):
        since = time.time_ns()
        job = _Job(out, steps, options)
        mode = ("anytime", "training", "checkpoint")[i % 3]
        if mode == "anytime":  # start-up, restoring, training, evaluating, saving: wherever it falls
            job.wait_until(lambda: job.reached() >= steps // 4, rng.uniform(3.0, 9.0))  # noqa: B023 (called at once)
        elif mode == "training":  # a random step of the next two intervals, not before step `after`, then a
            # random moment before `room`
            target = min(max(resumed_from + rng.randint(1, 2 * INTERVAL), after), room)
            job.wait_until(lambda: job.reached() >= target)  # noqa: B023 (called at once)
            job.wait_until(lambda: job.reached() >= room,  # noqa: B023 (called at once)
                           time.monotonic() - job.t0 + rng.uniform(0.0, 0.5))
        else:  # while the first or the second checkpoint of this run is being written
            target = resumed_from + rng.choice([1, INTERVAL + 1])
            job.wait_until(lambda: job.reached() >= target and _mid_checkpoint(out, since))  # noqa: B023
            time.sleep(rng.uniform(0.0, 0.003))
        if job.proc.poll() is not None:
            raise AssertionError(f"kill {i}: the run ended before it was killed ({mode}): {job.finish()[1]}")
        caught_mid_checkpoint = _mid_checkpoint(out, since)
        job.proc.kill()
        rc, err = job.finish()
        assert rc == -signal.SIGKILL and "Traceback" not in err
        if job.steps:  # the rerun resumed where the manifest said
            assert resumed_from < job.steps[0] <= resumed_from + job.every, (resumed_from, job.steps[:3])
        reached = job.steps[-1] if job.steps else resumed_from
        saved = _verified_step(out)
        records.append({"kill": i, "mode": mode, "reached": reached, "resumes_from": saved,
                        "mid_checkpoint": caught_mid_checkpoint and _mid_checkpoint(out, since)})
        assert saved >= resumed_from  # a kill never undoes a saved checkpoint
        assert reached - saved <= INTERVAL, records[-1]  # at most one checkpoint interval lost
        resumed_from = saved
    job = _Job(out, steps, options)
    rc, err = job.finish()
    assert rc == 0, err
    if resumed_from < steps:
        assert resumed_from < job.steps[0] <= resumed_from + job.every
    return records


@pytest.mark.parametrize(("steps", "options"), [
    (STEPS, ()),
    # JAX: ten steps, then ten updates in one call; twice the steps, so that checkpoints are left for the third kill
    # to fall in after the first two (with 240, one run ended before the third kill caught one)
    (2 * STEPS, ("--autodiff", "jax", "--train-freq", "10", "--gradient-steps", "10")),
    # the same with the roll-outs overlapping the updates: killed while lagging a call behind, it resumes so
    (2 * STEPS, ("--autodiff", "jax", "--train-freq", "10", "--gradient-steps", "10", "--overlap", "true"))],
    ids=["torch", "jax-fused", "jax-overlap"])
def test_sigkill_at_3_random_moments_resumes_to_the_uninterrupted_result(tmp_path, tmp_path_factory, steps, options):
    baseline = _baseline(tmp_path_factory, steps, options)
    # JAX: the second kill once updates have begun and a checkpoint has been taken since
    after = LEARNING_STARTS + 2 * INTERVAL if options else 0
    records = _kill_and_resume(tmp_path, kills=3, steps=steps, seed=3, options=options, after=after)
    print(json.dumps(records))
    assert records[2]["mid_checkpoint"]  # the third kill fell while a checkpoint was being written
    if options:  # a rerun resumed from a checkpoint taken after updates began (with overlap: while lagging)
        assert max(r["resumes_from"] for r in records) > LEARNING_STARTS, records
    _same_as(_result(tmp_path), baseline)
    assert _verified_step(tmp_path) == steps


@pytest.mark.slow
def test_sigkill_at_20_random_moments_resumes_to_the_uninterrupted_result(tmp_path, tmp_path_factory):
    steps = 600
    baseline = _baseline(tmp_path_factory, steps)
    t0 = time.monotonic()
    records = _kill_and_resume(tmp_path, kills=20, steps=steps, seed=20)
    mid = sum(r["mid_checkpoint"] for r in records)
    print(f"\n20 SIGKILLs in {time.monotonic() - t0:.0f} s, {mid} of them while a checkpoint was being written; "
          f"progress lost per kill (steps): {[r['reached'] - r['resumes_from'] for r in records]} "
          f"(interval {INTERVAL})")
    print(json.dumps(records))
    assert len(records) == 20 and mid >= 5
    _same_as(_result(tmp_path), baseline)


def test_sigint_saves_prints_one_line_exits_130_and_the_rerun_resumes(tmp_path, tmp_path_factory):
    baseline = _baseline(tmp_path_factory, STEPS)
    job = _Job(tmp_path)
    job.wait_until(lambda: job.reached() >= 170)
    job.proc.send_signal(signal.SIGINT)
    rc, err = job.finish()
    assert rc == EXIT_INTERRUPTED and err.count("\n") == 1, err
    m = LINE.match(err.rstrip("\n"))
    assert m and Path(m.group(2)) == tmp_path, err
    step = int(m.group(1))
    assert job.steps[-1] <= step < STEPS and _verified_step(tmp_path) == step
    assert [h["env_steps"] for h in json.loads((tmp_path / "state.json").read_text())["generations"][0]["record"]
            ["history"]] == [s for s in baseline["eval_steps"] if s <= step]
    again = _Job(tmp_path)
    rc, err = again.finish()
    assert rc == 0 and err == "" and step < again.steps[0] <= step + 2
    _same_as(_result(tmp_path), baseline)


def test_a_damaged_newest_checkpoint_falls_back_to_the_previous_one(tmp_path, tmp_path_factory):
    baseline = _baseline(tmp_path_factory, STEPS)
    out = tmp_path / "run"
    shutil.copytree(baseline["out"], out)
    newest = json.loads((out / "state.json").read_text())["generations"][0]
    replay = out / newest["folder"] / "replay.pkl"
    data = bytearray(replay.read_bytes())
    data[len(data) // 2] ^= 0xFF
    replay.write_bytes(bytes(data))
    job = _Job(out)
    rc, err = job.finish()
    previous = STEPS - INTERVAL
    assert rc == 0 and err == (f"snakeplan: warning: checkpoint {newest['folder']} is damaged (replay.pkl does not "
                               f"match its sha256); resuming from ckpt-{previous:08d}\n")
    assert previous < job.steps[0] <= previous + 2
    _same_as(_result(out), baseline)


def test_another_runs_checkpoint_is_refused_in_one_line(tmp_path, tmp_path_factory):
    baseline = _baseline(tmp_path_factory, STEPS)
    out = tmp_path / "run"
    shutil.copytree(baseline["out"], out)
    proc = subprocess.run([sys.executable, "-m", "snakeplan.cli", "train", "rl", "fuel-tank", "sac-her", "--steps",
                           str(STEPS), "--seed", "1", "--out", str(out), *TINY],
                          capture_output=True, text=True, env=ENV, timeout=300)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1
    assert proc.stderr.startswith(f"snakeplan: error: --out: {out} holds the state of another run (seed: 1 here, "
                                  f"0 there)") and "--fresh" in proc.stderr


# --- snakeplan train sscc ------------------------------------------------------------------------------------
SSCC = {"steps": 150, "seed": 1, "scenes": ("pipe",), "targets": 2, "checkpoint_every": 25, "eval_every": 50,
        "eval_episodes": 2, "learning_starts": 40}


def test_sscc_training_stopped_mid_run_resumes_to_the_same_agent(tmp_path, monkeypatch):
    from snakeplan.rl import sscc as training

    whole = training.train_agent("sscc-16", tmp_path / "whole.npz", **SSCC)
    calls = []
    evaluate = training.evaluate_agent

    def stopped_during_the_second_evaluation(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            signal.raise_signal(signal.SIGTERM)
        return evaluate(*args, **kwargs)

    monkeypatch.setattr(training, "evaluate_agent", stopped_during_the_second_evaluation)
    part = tmp_path / "part.npz"
    with pytest.raises(Interrupted, match=rf"^interrupted at step 100; checkpoint saved in "
                                          rf"{re.escape(str(part))}.state; rerun the same command to resume$"):
        training.train_agent("sscc-16", part, **SSCC)
    monkeypatch.undo()
    assert not part.exists()
    resumed = training.train_agent("sscc-16", part, **SSCC)
    assert resumed.history == whole.history and [h[0] for h in whole.history] == [50, 100, 150]
    assert (resumed.best_step, resumed.episodes) == (whole.best_step, whole.episodes)
    with np.load(part) as a, np.load(tmp_path / "whole.npz") as b:
        assert a.files == b.files and all(np.array_equal(a[k], b[k]) for k in a.files)


def test_sscc_command_stops_on_sigterm_in_one_line_and_resumes(tmp_path):
    out = tmp_path / "agent.npz"
    argv = [sys.executable, "-m", "snakeplan.cli", "train", "sscc", "--robot", "sscc-16", "--steps", "200",
            "--checkpoint-every", "20", "--out", str(out)]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    state = tmp_path / "agent.npz.state"
    t0 = time.monotonic()
    while proc.poll() is None and not (state / "state.json").exists() and time.monotonic() - t0 < 120:
        time.sleep(0.01)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == EXIT_INTERRUPTED and err.count("\n") == 1, err
    m = LINE.match(err.rstrip("\n"))
    assert m and Path(m.group(2)) == state and _verified_step(state) == int(m.group(1)) < 200
    assert not out.exists()
    done = subprocess.run(argv, capture_output=True, text=True, env=ENV, timeout=300)
    assert done.returncode == 0 and done.stderr == "" and out.is_file() and _verified_step(state) == 200
