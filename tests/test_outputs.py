"""Output safety: output paths refused before any work, files written whole or not at all, Ctrl-C is one line."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from snakeplan.files import atomic_path, atomic_write, check_output

ENV = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}


def snakeplan(*args, cwd, timeout=120):
    return subprocess.run([sys.executable, "-m", "snakeplan.cli", *args], cwd=cwd, env=ENV, capture_output=True,
                          text=True, timeout=timeout)


def test_plan_json_with_plot_into_a_missing_folder_is_refused_before_planning(tmp_path):
    """`plan --json --plot bad/dir/x.png` used to plan, print a traceback and lose the plan: now nothing runs."""
    t0 = time.perf_counter()
    r = snakeplan("plan", "--scene", "fuel-tank", "--seed", "3", "--json", "--plot", "bad/dir/x.png", cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.count("\n") == 1 and "--plot" in r.stderr and "bad/dir" in r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "bad").exists()
    assert time.perf_counter() - t0 < 30.0  # no planning (and no kernel compilation) happened


@pytest.mark.parametrize("args, field", [(("show", "--out", "scene.jpg"), "--out"),
                                         (("show", "--out", "nowhere/scene.png"), "--out"),
                                         (("demo", "--out", "."), "--out")])
def test_bad_picture_paths_are_one_line_errors_and_create_nothing(tmp_path, args, field):
    r = snakeplan(*args, cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.startswith(f"snakeplan: error: {field}:")
    assert r.stderr.count("\n") == 1 and list(tmp_path.iterdir()) == []


def test_check_output_names_the_field(tmp_path):
    assert check_output(tmp_path / "a.png", "--plot", (".png",)) == tmp_path / "a.png"
    for bad, why in ((tmp_path / "a.gif", "expected a .png file"), (tmp_path / "no" / "a.png", "does not exist"),
                     (tmp_path, "expected a .png file")):
        with pytest.raises(ValueError, match=f"--plot: .*{why}|--plot: {why}"):
            check_output(bad, "--plot", (".png",))
    with pytest.raises(ValueError, match="is a folder"):
        check_output(tmp_path, "--out")


def test_an_atomic_write_that_fails_leaves_the_old_file_and_no_debris(tmp_path):
    target = atomic_write(tmp_path / "table.md", "old\n")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half of the new")
            raise RuntimeError("interrupted")
    assert target.read_text() == "old\n" and [p.name for p in tmp_path.iterdir()] == ["table.md"]
    atomic_write(target, "new\n")
    assert target.read_text() == "new\n" and [p.name for p in tmp_path.iterdir()] == ["table.md"]


def test_ctrl_c_in_a_benchmark_is_one_line_and_exit_130(tmp_path):
    proc = subprocess.Popen([sys.executable, "-m", "snakeplan.cli", "bench", "table2", "--runs", "50", "--out",
                             str(tmp_path / "t2")], cwd=tmp_path, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    runs = tmp_path / "t2" / "runs.jsonl"
    deadline = time.monotonic() + 120.0
    while not (runs.exists() and runs.stat().st_size > 0) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.2)  # interrupt mid-run, once the first episode is written
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1].startswith("snakeplan: interrupted") and "Traceback" not in err


def _wrapped_interrupt(args):
    """What a Ctrl-C inside a C callback (numba loading a cached kernel) reaches Python as."""
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt as stop:
        raise SystemError("CPUDispatcher(<function _lazy_theta>) returned a result with an exception set") from stop


def test_a_ctrl_c_wrapped_by_a_c_callback_is_still_one_line_and_exit_130(monkeypatch, capsys):
    """CI once sent SIGINT while numba was unpickling a cached kernel: a SystemError traceback and exit 1."""
    from snakeplan import cli
    from snakeplan.commands import scene
    from snakeplan.interrupt import interruption

    assert interruption(ValueError("plain")) is None
    monkeypatch.setattr(scene, "cmd_scene_entry", _wrapped_interrupt)
    assert cli.main(["scene", "--list"]) == 130
    assert capsys.readouterr().err == "snakeplan: interrupted\n"
    monkeypatch.setattr(scene, "cmd_scene_entry", lambda args: (_ for _ in ()).throw(SystemError("a real bug")))
    with pytest.raises(SystemError, match="a real bug"):
        cli.main(["scene", "--list"])
