"""The Table 2 harness: judged rows, resumption, summaries with the paper's figures beside ours."""

import csv

from snakeplan.bench.table2 import PAPER_TABLE2, Table2Config, run_table2


def test_table2_runs_resumes_and_summarises(tmp_path):
    config = Table2Config(planners=("sp-rrt",), scenes=("oil-tank",), seeds=(0, 1), time_limit_s=5.0)
    summary = run_table2(config, tmp_path, progress=False)
    rows = list(csv.DictReader((tmp_path / "runs.csv").open()))
    assert [(r["seed"], r["planner"]) for r in rows] == [("0", "sp-rrt"), ("1", "sp-rrt")]
    entry = summary["oil-tank/sp-rrt"]
    assert entry["runs"] == 2 and entry["paper"] == PAPER_TABLE2[("oil-tank", "sp-rrt")]
    assert 0.0 <= entry["success_rate"] <= 1.0
    # A second run with one more seed plans only the missing episode.
    bigger = Table2Config(planners=("sp-rrt",), scenes=("oil-tank",), seeds=(0, 1, 2), time_limit_s=5.0)
    run_table2(bigger, tmp_path, progress=False)
    rows = list(csv.DictReader((tmp_path / "runs.csv").open()))
    assert [r["seed"] for r in rows] == ["0", "1", "2"]
    text = (tmp_path / "table2.md").read_text()
    assert "1111.4" in text and "Welch ANOVA" in text  # the paper's Sp-RRT length and Appendix A
    assert (tmp_path / "fig7_oil-tank.png").read_bytes()[:4] == b"\x89PNG"


def test_learned_planners_have_rows_only_in_their_scene(tmp_path):
    config = Table2Config(planners=("sp-rrt", "sac-her", "sac-per"), scenes=("fuel-tank", "oil-tank"))
    assert config.planners_in("fuel-tank") == ("sp-rrt", "sac-her")
    assert config.planners_in("oil-tank") == ("sp-rrt", "sac-per")
    config = Table2Config(planners=("sp-rrt", "sac-her", "sac-per"), scenes=("fuel-tank",), seeds=(0, 1),
                          time_limit_s=5.0)
    summary = run_table2(config, tmp_path, progress=False)
    assert set(summary) == {"fuel-tank/sp-rrt", "fuel-tank/sac-her"}
    assert summary["fuel-tank/sac-her"]["paper"] == PAPER_TABLE2[("fuel-tank", "sac-her")]
    assert "Games-Howell sac-her vs sp-rrt" in (tmp_path / "table2.md").read_text()  # the paper's reference
