"""The Table 2 configuration of the runner: judged rows, resumption, summaries with the paper's figures beside ours,
Fig. 7 from the logged rows."""

from snakeplan.bench.runner import read_rows, run_sweep
from snakeplan.bench.table2 import PAPER_TABLE2, Table2Config, run_table2, table2_outputs
from snakeplan.parallel import Backend
from snakeplan.planners import Planner


def test_table2_runs_resumes_and_summarises(tmp_path):
    config = Table2Config(planners=("sp-rrt",), scenes=("oil-tank",), seeds=(0, 1), time_limit_s=5.0,
                          generalist=False, optimize=("none",))
    summary = run_table2(config, tmp_path, progress=False, backend=Backend("serial"))
    rows = read_rows(tmp_path)
    # Sp-RRT needs the whole scene: its rows serve both knowledge blocks, planned once.
    assert [(r["seed"], r["planner"], r["knowledge"]) for r in rows] == [(0, "sp-rrt", "full"), (1, "sp-rrt", "full")]
    entry = summary["oil-tank/sp-rrt/sensed"]
    assert entry["runs"] == 2 and entry["paper"] == PAPER_TABLE2[("oil-tank", "sp-rrt")]
    assert entry["knowledge"] == "full" and summary["oil-tank/sp-rrt/full"]["paper"] is None
    assert entry["success_rate"] == sum(r["success"] for r in rows) / 2
    # A second run with one more seed plans only the missing episode.
    bigger = Table2Config(planners=("sp-rrt",), scenes=("oil-tank",), seeds=(0, 1, 2), time_limit_s=5.0,
                          generalist=False, optimize=("none",))
    run_table2(bigger, tmp_path, progress=False, backend=Backend("serial"))
    rows = read_rows(tmp_path)
    assert [r["seed"] for r in rows] == [0, 1, 2]
    text = (tmp_path / "table2.md").read_text()
    assert "1111.4" in text and "## Statistics (Appendix A)" in text  # the paper's Sp-RRT length; one group: no test
    assert (tmp_path / "fig7_oil-tank.png").read_bytes()[:4] == b"\x89PNG"


def test_figure_7_draws_the_logged_paths_without_planning(tmp_path, monkeypatch):
    config = Table2Config(planners=("sp-rrt",), scenes=("oil-tank",), seeds=(0,), time_limit_s=5.0, generalist=False,
                          optimize=("none",))
    rows = run_sweep(config.sweep(), tmp_path, Backend("serial"), progress=False).rows

    def no_planning(*args, **kwargs):
        raise AssertionError("figure 7 planned again")

    monkeypatch.setattr(Planner, "plan", no_planning)
    assert run_table2(config, tmp_path, progress=False, backend=Backend("serial"))["oil-tank/sp-rrt/full"]["runs"] == 1
    assert table2_outputs(config, rows, tmp_path)["oil-tank/sp-rrt/sensed"]["runs"] == 1
    assert (tmp_path / "fig7_oil-tank.png").read_bytes()[:4] == b"\x89PNG"


def test_learned_planners_have_rows_only_in_their_scene(tmp_path):
    config = Table2Config(planners=("sp-rrt", "sac-her", "sac-per"), scenes=("fuel-tank", "oil-tank"))
    assert config.planners_in("fuel-tank") == ("sp-rrt", "sac-her")
    assert config.planners_in("oil-tank") == ("sp-rrt", "sac-per")
    config = Table2Config(planners=("sp-rrt", "sac-her", "sac-per"), scenes=("fuel-tank",), seeds=(0, 1),
                          time_limit_s=5.0, generalist=False)
    summary = run_table2(config, tmp_path, progress=False, backend=Backend("serial"))
    labels = ("sp-rrt", "sac-her", "sp-rrt +fast", "sac-her +fast")  # each planner raw, then optimised
    assert set(summary) == {f"fuel-tank/{p}/{k}" for p in labels for k in ("sensed", "full")}
    assert summary["fuel-tank/sac-her/sensed"]["paper"] == PAPER_TABLE2[("fuel-tank", "sac-her")]
    assert summary["fuel-tank/sac-her +fast/sensed"]["paper"] == PAPER_TABLE2[("fuel-tank", "sac-her")]
    assert summary["fuel-tank/sac-her/sensed"]["knowledge"] == "sensed"
    rows = read_rows(tmp_path)
    assert sorted((r["planner"], r["options"]["optimize"], r["knowledge"]) for r in rows if r["seed"] == 0) == [
        ("sac-her", "fast", "full"), ("sac-her", "fast", "sensed"), ("sac-her", "none", "full"),
        ("sac-her", "none", "sensed"), ("sp-rrt", "fast", "full"), ("sp-rrt", "none", "full")]
    for r in rows:  # the optimised rows say what the optimiser did; the raw rows were not optimised
        assert ("optimize" in r["details"]) == (r["options"]["optimize"] == "fast")
        assert r["metrics"]["peak_tension_n"] > 0.0
    text = (tmp_path / "table2.md").read_text()
    assert "| fuel-tank | sp-rrt | full |" in text and "| fuel-tank | sac-her | sensed |" in text
    assert "| fuel-tank | sac-her +fast | sensed |" in text and "## Smoothness against cable tension" in text
    assert (tmp_path / "tension.png").read_bytes()[:4] == b"\x89PNG"
    assert "Welch ANOVA" in text
    assert "Games-Howell sac-her vs sp-rrt" in (tmp_path / "table2.md").read_text()  # the paper's reference
