"""Paper 000's Table 2 harness: planners side by side on identical seeded episodes, judged by one judge.

A configuration of the benchmark runner (:mod:`snakeplan.bench.runner`): every (scene, seed, planner) run is
planned with the same time budget and judged by :func:`snakeplan.evaluation.evaluate`, one row per run in
``runs.jsonl``, so an interrupted benchmark resumes where it stopped, on any backend. The summary, drawn from the
logged rows, gives mean +- std of path length and smoothness index over
successful runs, compute time over all runs, and the success rate, with the paper's figures beside ours, plus
Appendix A's statistics and a Fig. 7-like picture of the planners' paths and curvature profiles.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from snakeplan.bench.runner import Sweep, row_path, run_sweep
from snakeplan.parallel import Backend
from snakeplan.bench.statistics import games_howell, levene_p, shapiro_p, welch_anova
from snakeplan.evaluation import evaluate
from snakeplan.files import atomic_write
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene, scene_names, scene_spec

SCENES = ("fuel-tank", "oil-tank")
DEFAULT_PLANNERS = ("rrt-star", "sp-rrt", "as-rrt", "sac-her", "sac-per")
#: Runs per scene and planner in the paper.
DEFAULT_RUNS = 10
#: The same planning budget (s) for every planner.
DEFAULT_TIME_LIMIT_S = 10.0
#: The runner's configuration name of this table (rows' ``config``; ``bench report`` draws its figures).
CONFIG = "table2"
METRICS = ("path_length_mm", "compute_time_s", "smoothness_index")

#: Paper 000, Table 2: (mean, std) of path length (mm), computation time (s), smoothness index.
PAPER_TABLE2: dict[tuple[str, str], dict[str, tuple[float, float]]] = {
    ("fuel-tank", "rrt-star"): {"path_length_mm": (1525.47, 1.89), "compute_time_s": (35.48, 0.32),
                                "smoothness_index": (0.0647, 0.0011)},
    ("fuel-tank", "sp-rrt"): {"path_length_mm": (1821.65, 2.15), "compute_time_s": (0.300, 0.01),
                              "smoothness_index": (0.4393, 0.0024)},
    ("fuel-tank", "as-rrt"): {"path_length_mm": (1764.89, 6.45), "compute_time_s": (59.45, 1.28),
                              "smoothness_index": (0.4721, 0.0091)},
    ("fuel-tank", "sac-her"): {"path_length_mm": (1693.23, 5.87), "compute_time_s": (1.220, 0.05),
                               "smoothness_index": (0.5259, 0.0088)},
    ("oil-tank", "rrt-star"): {"path_length_mm": (947.935, 1.24), "compute_time_s": (18.79, 0.24),
                               "smoothness_index": (0.0222, 0.0007)},
    ("oil-tank", "sp-rrt"): {"path_length_mm": (1111.36, 1.83), "compute_time_s": (0.174, 0.01),
                             "smoothness_index": (0.0351, 0.0011)},
    ("oil-tank", "as-rrt"): {"path_length_mm": (1003.56, 4.62), "compute_time_s": (46.37, 0.97),
                             "smoothness_index": (0.1228, 0.0049)},
    ("oil-tank", "sac-per"): {"path_length_mm": (997.208, 4.08), "compute_time_s": (0.723, 0.04),
                              "smoothness_index": (0.1231, 0.0045)},
}

@dataclass(frozen=True)
class Table2Config:
    planners: tuple[str, ...] = DEFAULT_PLANNERS
    scenes: tuple[str, ...] = SCENES
    seeds: tuple[int, ...] = tuple(range(DEFAULT_RUNS))
    time_limit_s: float = DEFAULT_TIME_LIMIT_S
    #: One robot for every scene; empty: each scene's own (its spec; sjtu-snake-iii in both tanks, as the paper).
    robot: str = ""

    def planners_in(self, scene: str) -> tuple[str, ...]:
        """The planners compared in ``scene``: all but those whose trained policy ships only for other scene
        families (paper 000 pairs each learned planner with the scene it was trained in; elsewhere no row)."""
        return tuple(p for p in self.planners if scene in policy_scenes(p) or not policy_scenes(p))

    def robot_in(self, scene: str) -> str:
        """The robot planned in ``scene``."""
        return self.robot or scene_spec(scene).robot

    def sweep(self) -> Sweep:
        """This table as a sweep of the benchmark runner."""
        return Sweep(CONFIG, self.scenes, self.seeds, tuple((p, {}) for p in self.planners), self.time_limit_s,
                     self.robot, include=lambda scene, planner: planner in self.planners_in(scene))


def policy_scenes(planner: str) -> tuple[str, ...]:
    """The scene families whose spec ships a policy for ``planner``."""
    return tuple(s for s in scene_names() if planner in scene_spec(s).policies)


def run_table2(config: Table2Config, out_dir: str | Path, fresh: bool = False, progress: bool = True,
               backend: Backend = Backend()) -> dict:
    """Run every missing (scene, seed, planner) episode on ``backend`` (rows in ``out_dir/runs.jsonl``), then
    write the summary, statistics and Fig. 7 drawn from the logged rows; returns the summary."""
    outcome = run_sweep(config.sweep(), out_dir, backend, fresh=fresh, progress=progress)
    return table2_outputs(config, outcome.rows, Path(out_dir))


def table2_outputs(config: Table2Config, rows: list[dict], out: Path) -> dict:
    """Write ``table2.md`` (summary and Appendix A), ``table2.csv`` and ``fig7_*.png`` from logged rows."""
    summary = summarise(rows, config)
    atomic_write(out / "table2.md", summary_markdown(summary, config) + "\n\n" + statistics_markdown(rows, config))
    _write_summary_csv(out / "table2.csv", summary)
    figure_7(config, rows, out)
    return summary


def _values(rows: list[dict], metric: str, successful_only: bool) -> np.ndarray:
    """``metric`` of each row (the plan's compute time, or the judge's metric), of the judged successes only when
    ``successful_only``."""
    vals = [r[metric] if metric in r else (r["metrics"] or {}).get(metric) for r in rows
            if not successful_only or r["success"]]
    return np.array([v for v in vals if v is not None], dtype=float)


def summarise(rows: list[dict], config: Table2Config) -> dict:
    """Per (scene, planner): mean, std and count of each metric, success rate, and the paper's figures."""
    out = {}
    for s in config.scenes:
        for p in config.planners_in(s):
            group = [r for r in rows if r["scene"] == s and r["planner"] == p]
            entry = {"runs": len(group),
                     "success_rate": float(np.mean([r["success"] is True for r in group])) if group else math.nan}
            for metric in METRICS:
                v = _values(group, metric, successful_only=metric != "compute_time_s")
                entry[metric] = (float(v.mean()) if v.size else math.nan,
                                 float(v.std(ddof=1)) if v.size > 1 else math.nan)
            entry["median_compute_time_s"] = float(np.median(_values(group, "compute_time_s", False))) if group \
                else math.nan
            entry["paper"] = PAPER_TABLE2.get((s, p))
            out[f"{s}/{p}"] = entry
    return out


def _pm(pair: tuple[float, float] | None, digits: int) -> str:
    if pair is None or math.isnan(pair[0]):
        return "-"
    mean, std = pair
    return f"{mean:.{digits}f} ± {std:.{digits}f}" if not math.isnan(std) else f"{mean:.{digits}f}"


def summary_markdown(summary: dict, config: Table2Config) -> str:
    head = ("| scene | planner | runs | success | path length (mm) | paper | time (s) | paper | "
            "smoothness index | paper |\n|---|---|---|---|---|---|---|---|---|---|")
    seeds = list(config.seeds)
    contiguous = len(seeds) > 2 and seeds == list(range(seeds[0], seeds[-1] + 1))
    shown = f"{seeds[0]}-{seeds[-1]}" if contiguous else ", ".join(map(str, seeds))
    lines = [f"Table 2 on seeds {shown} with a {config.time_limit_s:g} s budget per plan "
             f"({', '.join(dict.fromkeys(map(config.robot_in, config.scenes)))}); length and smoothness over "
             f"successful runs, time over all runs.", "", head]
    for key, e in summary.items():
        s, p = key.split("/")
        paper = e["paper"] or {}
        lines.append(
            f"| {s} | {p} | {e['runs']} | {100 * e['success_rate']:.0f} % | {_pm(e['path_length_mm'], 1)} | "
            f"{_pm(paper.get('path_length_mm'), 1)} | {_pm(e['compute_time_s'], 3)} | "
            f"{_pm(paper.get('compute_time_s'), 3)} | {_pm(e['smoothness_index'], 4)} | "
            f"{_pm(paper.get('smoothness_index'), 4)} |")
    return "\n".join(lines)


def statistics_markdown(rows: list[dict], config: Table2Config) -> str:
    """Appendix A: Shapiro-Wilk per group, Levene and Welch's ANOVA per metric, Games-Howell against the scene's
    learned planner (as the paper) when it is compared, else against the first planner."""
    lines = ["## Statistics (Appendix A)", ""]
    for s in config.scenes:
        compared = config.planners_in(s)
        if not compared:
            continue
        ref = next((p for p in compared if p in scene_spec(s).policies), compared[0])
        for metric in METRICS:
            groups = {p: _values([r for r in rows if r["scene"] == s and r["planner"] == p], metric,
                                 metric != "compute_time_s") for p in config.planners_in(s)}
            anova = welch_anova(list(groups.values()))
            normal = ", ".join(f"{p} {shapiro_p(v):.3g}" for p, v in groups.items())
            lines.append(f"**{s}, {metric}**: Shapiro-Wilk p: {normal}; Levene p = {levene_p(list(groups.values())):.3g}; "
                         f"Welch ANOVA F({anova.df1:.3g}, {anova.df2:.3g}) = {anova.f:.4g}, p = {anova.p:.3g}")
            for c in games_howell(groups, reference=ref):
                lines.append(f"- Games-Howell {c.a} vs {c.b}: difference {c.mean_difference:.4g}, "
                             f"adjusted p = {c.p_adjusted:.3g}")
            lines.append("")
    return "\n".join(lines)


def _write_summary_csv(path: Path, summary: dict) -> None:
    text = io.StringIO()
    w = csv.writer(text)
    w.writerow(["scene", "planner", "runs", "success_rate", "path_length_mean", "path_length_std",
                "time_mean", "time_std", "time_median", "smoothness_mean", "smoothness_std",
                "paper_path_length", "paper_time", "paper_smoothness"])
    for key, e in summary.items():
        s, p = key.split("/")
        paper = e["paper"] or {}
        w.writerow([s, p, e["runs"], e["success_rate"], *e["path_length_mm"], *e["compute_time_s"],
                    e["median_compute_time_s"], *e["smoothness_index"],
                    paper.get("path_length_mm", ("",))[0], paper.get("compute_time_s", ("",))[0],
                    paper.get("smoothness_index", ("",))[0]])
    atomic_write(path, text.getvalue())


def figure_7(config: Table2Config, rows: list[dict], out: Path) -> list[Path]:
    """For each scene, the planners' logged paths on the first seed and their curvature profiles (like Fig. 7);
    the paths are read from the rows (and judged again for the profile), not planned again."""
    import matplotlib.pyplot as plt

    from snakeplan.viz.figures import save_figure
    from snakeplan.viz.scene_plot import draw_scene

    written = []
    seed = config.seeds[0]
    for s in config.scenes:
        scene = make_scene(s, seed)
        robot = get_robot(config.robot_in(s))
        logged = {r["planner"]: r for r in rows if r["scene"] == s and r["seed"] == seed}
        fig = plt.figure(figsize=(14, 6))
        ax = fig.add_subplot(1, 2, 1, projection="3d")
        ax2 = fig.add_subplot(1, 2, 2)
        draw_scene(ax, scene)
        for i, p in enumerate(config.planners_in(s)):
            path = row_path(out, logged[p]) if p in logged else None
            if path is None:
                continue
            report = evaluate(scene, robot, path)
            color = f"C{i}"
            ax.plot(*path.T, color=color, lw=1.5, label=p)
            ax2.plot(report.curvature_s, report.curvature, color=color, marker=".",
                     label=f"{p}: S = {report.smoothness_index:.3f} ({report.reason})")
        ax.legend(fontsize=7)
        ax.set_title(f"{s} seed {seed}: paths")
        ax2.axhline(robot.k_ul, color="k", ls="--", label="k_UL")
        ax2.set_xlabel("arc length (mm)")
        ax2.set_ylabel("curvature (1/mm)")
        ax2.legend(fontsize=8)
        ax2.grid(alpha=0.3)
        ax2.set_title("curvature profiles")
        fig.tight_layout()
        written.append(save_figure(fig, out / f"fig7_{s}.png"))
    return written
