"""Paper 000's Table 2 in the search setting (``snakeplan bench table2 --search``): the targets hidden until the tip
camera sees them, the clutter unknown, every Table 2 planner as the reaching planner of each search explorer, judged.

A configuration of the benchmark runner (:mod:`snakeplan.bench.runner`): scenes x seeds x (explorer, reaching
planner), each scene given the search task with sensed knowledge, one row per mission in ``runs.jsonl`` (resumable,
on any backend). The summary is drawn from the logged rows, per scene and combination: the share of the targets
found and reached, the share of missions that reached every target, the robot time (mission time) to find and to
reach each target, the feed's travel, the retractions, the planning compute time (median and worst) and how many
missions the judge found valid. ``frontier`` is the anchor baseline; the "exploration" of paper 000's Table 2
(its words, "Limited" or "Effective") stands beside each planner's own figures. A learned planner is compared in the
scenes its policy ships for, as in Table 2.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from snakeplan.bench.runner import Sweep
from snakeplan.bench.table2 import DEFAULT_PLANNERS, SCENES, policy_scenes
from snakeplan.files import atomic_write
from snakeplan.jsonable import jsonable

SCHEMA = "snakeplan.bench.search/1"
CONFIG = "table2-search"
#: The explorers compared (``frontier``: the baseline), seeds per scene, planning budget (s), output folder.
EXPLORERS = ("explore-reach", "frontier")
DEFAULT_RUNS = 100
TIME_LIMIT_S = 30.0
DEFAULT_OUT_DIR = "bench-search"
#: Paper 000, Table 2's "Exploration" column, per scene and planner.
PAPER_EXPLORATION = {("fuel-tank", "rrt-star"): "Limited", ("fuel-tank", "sp-rrt"): "Limited",
                     ("fuel-tank", "as-rrt"): "Effective", ("fuel-tank", "sac-her"): "Effective",
                     ("oil-tank", "rrt-star"): "Limited", ("oil-tank", "sp-rrt"): "Limited",
                     ("oil-tank", "as-rrt"): "Effective", ("oil-tank", "sac-per"): "Effective"}


@dataclass(frozen=True)
class SearchConfig:
    """Which scenes, seeds, explorers and reaching planners, under which planning budget (s)."""

    scenes: tuple[str, ...] = SCENES
    seeds: tuple[int, ...] = tuple(range(DEFAULT_RUNS))
    reachers: tuple[str, ...] = DEFAULT_PLANNERS
    explorers: tuple[str, ...] = EXPLORERS
    time_limit_s: float = TIME_LIMIT_S

    def reachers_in(self, scene: str) -> tuple[str, ...]:
        """The reaching planners compared in ``scene``: a learned one only where its policy ships (Table 2's
        pairs)."""
        return tuple(r for r in self.reachers if scene in policy_scenes(r) or not policy_scenes(r))

    def entries_in(self, scene: str) -> tuple[tuple[str, str, str], ...]:
        """(explorer, reaching planner, label) of each combination compared in ``scene``."""
        return tuple((e, r, f"{e} + {r}") for e in self.explorers for r in self.reachers_in(scene))

    def sweep(self) -> Sweep:
        """This table as a sweep of the benchmark runner: the search task, sensed knowledge."""
        entries = tuple((e, {"reach": r}) for e in self.explorers for r in self.reachers)

        def include(scene: str, planner: str, options: dict) -> bool:
            return options["reach"] in self.reachers_in(scene)

        return Sweep(CONFIG, self.scenes, self.seeds, entries, self.time_limit_s, knowledge="sensed", task="search",
                     include=include)


def _finite(values) -> np.ndarray:
    a = np.array([v for v in values if v is not None], dtype=float)
    return a[np.isfinite(a)]


def summarise(rows: list[dict], config: SearchConfig) -> dict:
    """Per scene and combination, from the logged rows (see the module): found and reached are shares of every
    run's targets (a run with no mission counts its family's), seen or reached in missions the judge found valid;
    times of targets never found or reached are left out of the time medians."""
    out = {}
    for scene in config.scenes:
        per_run = max((int((r["metrics"] or {}).get("targets") or 0) for r in rows if r["scene"] == scene),
                      default=0)  # a family's count; a run with no mission judged has no metrics
        for explorer, reach, label in config.entries_in(scene):
            group = [r for r in rows if r["scene"] == scene and r["planner"] == explorer
                     and r.get("options", {}).get("reach") == reach]
            m = [r["metrics"] or {} for r in group]
            valid = [x for x in m if x.get("searched")]
            found_s = _finite(t for x in valid for t in x.get("found_s") or [])
            reached_s = _finite(t for x in valid for t in x.get("reached_s") or [])
            targets = sum(int(x.get("targets") or per_run) for x in m)
            compute = np.array([r["compute_time_s"] for r in group], dtype=float)
            out[f"{scene}/{label}"] = {
                "scene": scene, "explorer": explorer, "reach": reach, "runs": len(group),
                "valid": int(sum(bool(x.get("searched")) for x in m)),
                "found": float(found_s.size / targets) if targets else math.nan,
                "reached": float(reached_s.size / targets) if targets else math.nan,
                "success": float(np.mean([r["success"] is True for r in group])) if group else math.nan,
                "median_find_s": float(np.median(found_s)) if found_s.size else math.nan,
                "median_reach_s": float(np.median(reached_s)) if reached_s.size else math.nan,
                "motion_m": float(np.mean([x.get("motion_mm") or 0.0 for x in m]) / 1000) if m else math.nan,
                "retractions": float(np.mean([x.get("retractions") or 0 for x in m])) if m else math.nan,
                "median_compute_s": float(np.median(compute)) if compute.size else math.nan,
                "worst_compute_s": float(compute.max()) if compute.size else math.nan,
                "paper_exploration": PAPER_EXPLORATION.get((scene, reach), "-")}
    return out


def summary_markdown(summary: dict, config: SearchConfig) -> str:
    """The search table: one row per scene and combination (see the module)."""
    seeds = list(config.seeds)
    shown = f"{seeds[0]}-{seeds[-1]}" if len(seeds) > 1 and seeds == list(range(seeds[0], seeds[-1] + 1)) else \
        ", ".join(map(str, seeds))
    lines = [f"Search (targets hidden until seen, clutter unknown) on seeds {shown}, {config.time_limit_s:g} s "
             f"planning budget per mission; found and reached: shares of the targets; success: missions that "
             f"reached every target; times: medians of the mission (robot) time at which each target was first "
             f"seen and reached; paper: Table 2's exploration column for the reaching planner.", "",
             "| scene | explorer + reaching planner | runs | valid | found | reached | success | find (s) | "
             "reach (s) | feed travel (m) | retractions | compute median (s) | worst (s) | paper |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for key, e in summary.items():
        lines.append(f"| {e['scene']} | {key.split('/', 1)[1]} | {e['runs']} | {e['valid']} | {_pc(e['found'])} | "
                     f"{_pc(e['reached'])} | {_pc(e['success'])} | {_num(e['median_find_s'], 0)} | "
                     f"{_num(e['median_reach_s'], 0)} | {_num(e['motion_m'], 1)} | {_num(e['retractions'], 1)} | "
                     f"{_num(e['median_compute_s'], 2)} | {_num(e['worst_compute_s'], 1)} | "
                     f"{e['paper_exploration']} |")
    return "\n".join(lines)


def _pc(x: float) -> str:
    return "-" if math.isnan(x) else f"{100 * x:.1f} %"


def _num(x: float, digits: int) -> str:
    return "-" if math.isnan(x) else f"{x:.{digits}f}"


def reached_curves(rows: list[dict], config: SearchConfig, out: Path) -> list[Path]:
    """Per scene, a figure of the share of the targets reached by each mission time, one curve per combination
    (``search-<scene>.png``)."""
    import matplotlib.pyplot as plt

    from snakeplan.viz.figures import save_figure

    written = []
    for scene in config.scenes:
        fig, ax = plt.subplots(figsize=(8, 5))
        reachers = config.reachers_in(scene)
        for explorer, reach, label in config.entries_in(scene):
            m = [r["metrics"] or {} for r in rows if r["scene"] == scene and r["planner"] == explorer
                 and r.get("options", {}).get("reach") == reach]
            targets = sum(int(x.get("targets") or 0) for x in m)
            if not targets:
                continue
            t = np.sort(_finite(v for x in m for v in x.get("reached_s") or []))
            ax.step(np.r_[0.0, t], np.arange(t.size + 1) / targets * 100, where="post", label=label,
                    color=f"C{reachers.index(reach)}", ls=("-", "--", ":", "-.")[config.explorers.index(explorer) % 4])
        ax.set_xlabel("mission time (s)")
        ax.set_ylabel("targets reached (%)")
        ax.set_ylim(0, 100)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_title(f"{scene}: targets reached over mission time, seeds {config.seeds[0]}-{config.seeds[-1]}",
                     fontsize=10)
        written.append(save_figure(fig, out / f"search-{scene}.png"))
    return written


def search_outputs(config: SearchConfig, rows: list[dict], out: Path) -> dict:
    """Write ``search.md``, ``search.json`` and the ``search-<scene>.png`` curves from logged rows; returns the
    summary."""
    summary = summarise(rows, config)
    atomic_write(out / "search.md", summary_markdown(summary, config) + "\n")
    atomic_write(out / "search.json", json.dumps(jsonable({"schema": SCHEMA, "summary": summary}), indent=1))
    reached_curves(rows, config, out)
    return summary
