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
METRICS = ("path_length_mm", "compute_time_s", "smoothness_index", "peak_tension_n")
#: The path optimiser's levels of the table's rows: each planner as its paper has it, then optimised
#: (:mod:`snakeplan.optimize`); an optimised row is labelled ``"<planner> +<level>"``.
OPTIMIZE_LEVELS = ("none", "fast")

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

#: The knowledge blocks of the table: paper 000's setting (learned planners and As-RRT plan in the unknown tank,
#: knowing its structure and what they sense; RRT* and Sp-RRT know the whole tank, §4.1), then every planner with
#: the whole scene.
KNOWLEDGE = ("sensed", "full")
#: The generalist policy's rows: ``sac`` planning with it (``policy="generalist"``) in every scene.
GENERALIST_ENTRY = ("sac", {"policy": "generalist"})


@dataclass(frozen=True)
class Table2Config:
    planners: tuple[str, ...] = DEFAULT_PLANNERS
    scenes: tuple[str, ...] = SCENES
    seeds: tuple[int, ...] = tuple(range(DEFAULT_RUNS))
    time_limit_s: float = DEFAULT_TIME_LIMIT_S
    #: One robot for every scene; empty: each scene's own (its spec; sjtu-snake-iii in both tanks, as the paper).
    robot: str = ""
    #: The knowledge blocks (see :data:`KNOWLEDGE`; a planner that needs the whole scene has full knowledge in all).
    knowledge: tuple[str, ...] = KNOWLEDGE
    #: Whether the generalist policy's rows go beside the family policies' (when the generalist is installed).
    generalist: bool = True
    #: The optimiser levels: every planner's rows at each (:data:`OPTIMIZE_LEVELS`).
    optimize: tuple[str, ...] = OPTIMIZE_LEVELS

    def planners_in(self, scene: str) -> tuple[str, ...]:
        """The planners compared in ``scene``: all but those whose trained policy ships only for other scene
        families (paper 000 pairs each learned planner with the scene it was trained in; elsewhere no row)."""
        return tuple(p for p in self.planners if scene in policy_scenes(p) or not policy_scenes(p))

    def check(self, field: str = "planners") -> None:
        """ValueError naming ``field`` when no planner is compared in any of the scenes (:meth:`planners_in`)."""
        if not any(self.planners_in(s) for s in self.scenes):
            raise ValueError(f"{field}: none is compared in {', '.join(self.scenes)} (a planner whose policy ships "
                             f"for some scene families is compared only in those)")

    def entries_in(self, scene: str) -> tuple[tuple[str, str, dict], ...]:
        """(label, planner, options) of each row group in ``scene``: :meth:`planners_in`, then the generalist, at
        each optimiser level (the first level's rows carry the planner's own name)."""
        base = [(p, p, {}) for p in self.planners_in(scene)]
        if self.generalist and generalist_installed():
            base.append(("generalist", *GENERALIST_ENTRY))
        return tuple((label if level == "none" else f"{label} +{level}", planner, {**options, "optimize": level})
                     for level in self.optimize for label, planner, options in base)

    def robot_in(self, scene: str) -> str:
        """The robot planned in ``scene``."""
        return self.robot or scene_spec(scene).robot

    def sweep(self) -> Sweep:
        """This table as a sweep of the benchmark runner."""
        entries: list[tuple[str, dict]] = []
        for s in self.scenes:
            entries += [(p, o) for _, p, o in self.entries_in(s) if (p, o) not in entries]

        def include(scene: str, planner: str, options: dict) -> bool:
            return any((p, o) == (planner, options) for _, p, o in self.entries_in(scene))

        return Sweep(CONFIG, self.scenes, self.seeds, tuple(entries), self.time_limit_s, self.robot, self.knowledge,
                     include=include)

    def blocks(self) -> tuple[int, ...]:
        """Indices of the knowledge blocks."""
        return tuple(range(len(self.knowledge)))

    def rows_of(self, rows: list[dict], scene: str, label: str, block: int) -> list[dict]:
        """The logged rows of one group: ``label``'s planner and options in ``scene`` with ``block``'s knowledge."""
        _, planner, options = next(e for e in self.entries_in(scene) if e[0] == label)
        knowledge = self.sweep().knowledge_of(planner)[block]
        return [r for r in rows if r["scene"] == scene and r["planner"] == planner
                and r.get("options", {}) == options and r.get("knowledge", "full") == knowledge]


def generalist_installed() -> bool:
    """Whether the generalist policy ships in this installation."""
    from snakeplan.planners.sac.policy import generalist_path

    return generalist_path() is not None


def policy_scenes(planner: str) -> tuple[str, ...]:
    """The scene families whose spec ships a policy for ``planner``."""
    return tuple(s for s in scene_names() if planner in scene_spec(s).policies)


def run_table2(config: Table2Config, out_dir: str | Path, fresh: bool = False, progress: bool = True,
               backend: Backend = Backend()) -> dict:
    """Run every missing (scene, seed, planner, knowledge) episode on ``backend`` (rows in ``out_dir/runs.jsonl``),
    then write the summary, statistics and Fig. 7 drawn from the logged rows; returns the summary."""
    outcome = run_sweep(config.sweep(), out_dir, backend, fresh=fresh, progress=progress)
    return table2_outputs(config, outcome.rows, Path(out_dir))


def table2_outputs(config: Table2Config, rows: list[dict], out: Path) -> dict:
    """Write ``table2.md`` (summary, smoothness against tension, Appendix A), ``table2.csv``, ``fig7_*.png`` and
    ``tension.png`` from logged rows."""
    summary = summarise(rows, config)
    atomic_write(out / "table2.md", summary_markdown(summary, config) + "\n\n" + tension_markdown(rows, config)
                 + "\n\n" + statistics_markdown(rows, config))
    _write_summary_csv(out / "table2.csv", summary)
    figure_7(config, rows, out)
    tension_figure(config, rows, out)
    return summary


def smoothness_and_tension(rows: list[dict], config: Table2Config, scene: str | None = None
                           ) -> tuple[np.ndarray, np.ndarray]:
    """(smoothness index, peak tension N) of every successful run of the table (of ``scene`` when given), each run
    once whatever its knowledge blocks."""
    runs = {r["key"]: r for s in ((scene,) if scene else config.scenes) for label, _, _ in config.entries_in(s)
            for block in config.blocks() for r in config.rows_of(rows, s, label, block) if r["success"]}
    pairs = [(r["metrics"]["smoothness_index"], r["metrics"]["peak_tension_n"]) for r in runs.values()
             if r["metrics"].get("peak_tension_n") is not None]
    kept = np.array(pairs, dtype=float).reshape(-1, 2)
    return kept[:, 0], kept[:, 1]


def tension_markdown(rows: list[dict], config: Table2Config) -> str:
    """Spearman's rank correlation of the smoothness index with the peak cable tension over the table's successful
    plans, per scene and in all (paper 000 §1: abrupt curvature means unfavourable tensions)."""
    from scipy.stats import spearmanr

    lines = ["## Smoothness against cable tension", "",
             "Spearman's rank correlation of each successful plan's smoothness index with its peak cable tension "
             "(`tension.png`); paper 000 argues that smoother paths need lower tensions, which is a negative rho.",
             "", "| plans | n | rho | p |", "|---|---|---|---|"]
    for scene in (*config.scenes, None):
        S, T = smoothness_and_tension(rows, config, scene)
        if S.size < 3:
            continue
        rho, p = spearmanr(S, T)
        lines.append(f"| {scene or 'all'} | {S.size} | {rho:.3f} | {p:.3g} |")
    return "\n".join(lines)


def tension_figure(config: Table2Config, rows: list[dict], out: Path) -> Path | None:
    """``tension.png``: every successful plan's peak cable tension against its smoothness index, per scene."""
    import matplotlib.pyplot as plt

    from snakeplan.viz.figures import save_figure

    fig, ax = plt.subplots(figsize=(7, 5))
    drawn = False
    for i, scene in enumerate(config.scenes):
        S, T = smoothness_and_tension(rows, config, scene)
        if S.size:
            ax.scatter(S, T, s=10, alpha=0.6, color=f"C{i}", label=f"{scene} ({S.size} plans)")
            drawn = True
    if not drawn:
        plt.close(fig)
        return None
    ax.set_xlabel("smoothness index S (eq. 20)")
    ax.set_ylabel("peak cable tension (N)")
    ax.set_title("Table 2's plans: smoothness against the tension that holds the arm")
    ax.grid(alpha=0.3)
    ax.legend()
    return save_figure(fig, out / "tension.png")


def _values(rows: list[dict], metric: str, successful_only: bool) -> np.ndarray:
    """``metric`` of each row (the plan's compute time, or the judge's metric), of the judged successes only when
    ``successful_only``."""
    vals = [r[metric] if metric in r else (r["metrics"] or {}).get(metric) for r in rows
            if not successful_only or r["success"]]
    return np.array([v for v in vals if v is not None], dtype=float)


def summarise(rows: list[dict], config: Table2Config) -> dict:
    """Per knowledge block, scene and row group: mean, std and count of each metric, success rate, the knowledge
    the planner had, and the paper's figures (beside the block of paper 000's setting, the first)."""
    out = {}
    for block in config.blocks():
        for s in config.scenes:
            for label, planner, _ in config.entries_in(s):
                group = config.rows_of(rows, s, label, block)
                knowledge = config.sweep().knowledge_of(planner)[block]
                entry = {"block": config.knowledge[block], "knowledge": knowledge, "runs": len(group),
                         "success_rate": float(np.mean([r["success"] is True for r in group])) if group
                         else math.nan}
                for metric in METRICS:
                    v = _values(group, metric, successful_only=metric != "compute_time_s")
                    entry[metric] = (float(v.mean()) if v.size else math.nan,
                                     float(v.std(ddof=1)) if v.size > 1 else math.nan)
                entry["median_compute_time_s"] = float(np.median(_values(group, "compute_time_s", False))) \
                    if group else math.nan
                smooth = _values(group, "smoothness_index", True)
                entry["median_smoothness_index"] = float(np.median(smooth)) if smooth.size else math.nan
                entry["paper"] = PAPER_TABLE2.get((s, planner)) if block == 0 else None
                out[f"{s}/{label}/{config.knowledge[block]}"] = entry
    return out


def _pm(pair: tuple[float, float] | None, digits: int) -> str:
    if pair is None or math.isnan(pair[0]):
        return "-"
    mean, std = pair
    return f"{mean:.{digits}f} ± {std:.{digits}f}" if not math.isnan(std) else f"{mean:.{digits}f}"


def summary_markdown(summary: dict, config: Table2Config) -> str:
    head = ("| scene | planner | knowledge | runs | success | path length (mm) | paper | time (s) | paper | "
            "smoothness index | median | paper | peak tension (N) |\n" + "|---" * 13 + "|")
    seeds = list(config.seeds)
    contiguous = len(seeds) > 2 and seeds == list(range(seeds[0], seeds[-1] + 1))
    shown = f"{seeds[0]}-{seeds[-1]}" if contiguous else ", ".join(map(str, seeds))
    lines = [f"Table 2 on seeds {shown} with a {config.time_limit_s:g} s budget per plan "
             f"({', '.join(dict.fromkeys(map(config.robot_in, config.scenes)))}); length and smoothness over "
             f"successful runs, time over all runs. Knowledge: what the planner knew (sensed: the tank's coarse "
             f"structure, walls and partitions, and what its tip sensor revealed; the judge always uses the whole "
             f"scene). A row \"+fast\" is the same planner with the path optimiser (time: plan and optimisation); "
             f"peak tension: the largest least cable tension holding the arm along the crawl.", ""]
    for block, mode in enumerate(config.knowledge):
        title = ("Paper 000's setting: planners that can plan sensed do" if mode == "sensed"
                 else f"Every planner with {mode} knowledge")
        lines += [f"**{title}**", "", head]
        for key, e in summary.items():
            if e["block"] != mode:
                continue
            s, label, _ = key.split("/")
            paper = e["paper"] or {}
            lines.append(
                f"| {s} | {label} | {e['knowledge']} | {e['runs']} | {100 * e['success_rate']:.0f} % | "
                f"{_pm(e['path_length_mm'], 1)} | {_pm(paper.get('path_length_mm'), 1)} | "
                f"{_pm(e['compute_time_s'], 3)} | {_pm(paper.get('compute_time_s'), 3)} | "
                f"{_pm(e['smoothness_index'], 4)} | {e['median_smoothness_index']:.4f} | "
                f"{_pm(paper.get('smoothness_index'), 4)} | "
                f"{_pm(e['peak_tension_n'], 1)} |")
        lines.append("")
    return "\n".join(lines).rstrip()


def statistics_markdown(rows: list[dict], config: Table2Config) -> str:
    """Appendix A on the block of paper 000's setting: Shapiro-Wilk per group, Levene and Welch's ANOVA per
    metric, Games-Howell against the scene's learned planner (as the paper) when it is compared, else against the
    first planner."""
    lines = ["## Statistics (Appendix A)", ""]
    for s in config.scenes:
        labels = [e[0] for e in config.entries_in(s)]
        if not labels:
            continue
        ref = next((p for p in labels if p in scene_spec(s).policies), labels[0])
        for metric in METRICS:
            groups = {p: _values(config.rows_of(rows, s, p, 0), metric, metric != "compute_time_s") for p in labels}
            groups = {p: v for p, v in groups.items() if v.size}
            if len(groups) < 2:
                continue
            anova = welch_anova(list(groups.values()))
            normal = ", ".join(f"{p} {shapiro_p(v):.3g}" for p, v in groups.items())
            lines.append(f"**{s}, {metric}**: Shapiro-Wilk p: {normal}; Levene p = {levene_p(list(groups.values())):.3g}; "
                         f"Welch ANOVA F({anova.df1:.3g}, {anova.df2:.3g}) = {anova.f:.4g}, p = {anova.p:.3g}")
            for c in games_howell(groups, reference=ref if ref in groups else next(iter(groups))):
                lines.append(f"- Games-Howell {c.a} vs {c.b}: difference {c.mean_difference:.4g}, "
                             f"adjusted p = {c.p_adjusted:.3g}")
            lines.append("")
    return "\n".join(lines)


def _write_summary_csv(path: Path, summary: dict) -> None:
    text = io.StringIO()
    w = csv.writer(text)
    w.writerow(["scene", "planner", "block", "knowledge", "runs", "success_rate", "path_length_mean",
                "path_length_std", "time_mean", "time_std", "time_median", "smoothness_mean", "smoothness_std",
                "smoothness_median", "peak_tension_mean", "peak_tension_std", "paper_path_length", "paper_time",
                "paper_smoothness"])
    for key, e in summary.items():
        s, label, _ = key.split("/")
        paper = e["paper"] or {}
        w.writerow([s, label, e["block"], e["knowledge"], e["runs"], e["success_rate"], *e["path_length_mm"],
                    *e["compute_time_s"], e["median_compute_time_s"], *e["smoothness_index"],
                    e["median_smoothness_index"], *e["peak_tension_n"],
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
        logged = {label: r for label, _, _ in config.entries_in(s) for r in config.rows_of(rows, s, label, 0)
                  if r["seed"] == seed}
        fig = plt.figure(figsize=(14, 6))
        ax = fig.add_subplot(1, 2, 1, projection="3d")
        ax2 = fig.add_subplot(1, 2, 2)
        draw_scene(ax, scene)
        for i, (p, _, _) in enumerate(config.entries_in(s)):
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
