"""Tables from any results folder of the benchmark runner: per configuration, scene and planner (with its
options), the judged success with its Wilson 95 % interval, median / p90 / max compute time, and the mean path
length, smoothness index, minimum clearance and maximum deviation of the judged successes.

``snakeplan bench report DIR`` writes ``DIR/report.md`` and ``DIR/report.csv``; where the rows' configuration
names a paper table (``table2``, ``sscc``, ``station``), that table's own markdown and figures are drawn from the
same rows and linked from the report. Nothing is planned again.
"""

from __future__ import annotations

import csv
import io
import math
from collections import Counter
from pathlib import Path

import numpy as np

from snakeplan.bench.runner import RUNS_FILE, current_rows, read_rows
from snakeplan.files import atomic_write

#: Normal quantile of a two-sided 95 % interval.
Z95 = 1.959963984540054
COLUMNS = ("config", "scene", "planner", "options", "runs", "successes", "success_rate", "success_lo95",
           "success_hi95", "time_median_s", "time_p90_s", "time_max_s", "path_length_mm", "smoothness_index",
           "min_clearance_mm", "max_deviation_mm", "ended")
#: Judge metrics averaged over the judged successes.
SUCCESS_METRICS = ("path_length_mm", "smoothness_index", "min_clearance_mm", "max_deviation_mm")


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a success rate (Wilson 1927); (nan, nan) for no trials."""
    if n == 0:
        return math.nan, math.nan
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return max(0.0, centre - half), min(1.0, centre + half)


def options_label(options: dict) -> str:
    """A run's options as the report's entries name them ("k=v,..." in key order)."""
    return ",".join(f"{k}={v}" for k, v in sorted(options.items()))


def summarise(rows: list[dict]) -> list[dict]:
    """One entry per (config, scene, planner, options), in the order they first appear (see :data:`COLUMNS`)."""
    from snakeplan.planners.base import Status  # "failed" in rows written before reads as no_progress

    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r.get("config", ""), r["scene"], r["planner"], options_label(r.get("options") or {})),
                          []).append(r)
    out = []
    for (config, scene, planner, options), group in groups.items():
        wins = [r for r in group if r["success"] is True]
        times = np.array([r["compute_time_s"] for r in group], dtype=float)
        lo, hi = wilson(len(wins), len(group))
        entry = {"config": config, "scene": scene, "planner": planner, "options": options, "runs": len(group),
                 "successes": len(wins), "success_rate": len(wins) / len(group), "success_lo95": lo,
                 "success_hi95": hi, "time_median_s": float(np.median(times)),
                 "time_p90_s": float(np.percentile(times, 90)), "time_max_s": float(times.max())}
        for m in SUCCESS_METRICS:
            vals = [(r["metrics"] or {}).get(m) for r in wins]
            vals = [v for v in vals if v is not None]
            entry[m] = float(np.mean(vals)) if vals else math.nan
        ended = Counter(Status(r["status"]).value if r.get("status") else "?" for r in group)
        entry["ended"] = ", ".join(f"{status} {n}" for status, n in ended.most_common())
        out.append(entry)
    return out


def _num(value: float, digits: int) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def markdown(entries: list[dict], title: str) -> str:
    """The summary as a markdown table."""
    lines = [f"# {title}", "",
             "Success: judged success rate with its Wilson 95 % interval; time: the planner's compute time over all "
             "runs (s); length (mm), smoothness index, minimum clearance (mm) and maximum deviation (mm): means "
             "over the judged successes; ended: how the planner said its runs ended (its status; each run's why is in "
             "its row).", "",
             "| config | scene | planner | options | runs | success | 95 % interval | median time | p90 time | "
             "max time | length | smoothness | clearance | deviation | ended |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for e in entries:
        lines.append(f"| {e['config']} | {e['scene']} | {e['planner']} | {e['options'] or '-'} | {e['runs']} | "
                     f"{100 * e['success_rate']:.1f} % | {100 * e['success_lo95']:.1f}-{100 * e['success_hi95']:.1f} % | "
                     f"{_num(e['time_median_s'], 3)} | {_num(e['time_p90_s'], 3)} | {_num(e['time_max_s'], 3)} | "
                     f"{_num(e['path_length_mm'], 1)} | {_num(e['smoothness_index'], 3)} | "
                     f"{_num(e['min_clearance_mm'], 1)} | {_num(e['max_deviation_mm'], 1)} | {e['ended']} |")
    return "\n".join(lines)


def csv_text(entries: list[dict]) -> str:
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=COLUMNS)
    writer.writeheader()
    writer.writerows(entries)
    return text.getvalue()


def paper_outputs(rows: list[dict], folder: Path) -> tuple[list[str], list[Path]]:
    """The paper tables' own markdown and figures for the configurations that name one, drawn from ``rows``:
    (markdown sections, figure files)."""
    sections, figures = [], []
    table2 = [r for r in rows if r.get("config") == "table2"]
    if table2:
        from snakeplan.bench.table2 import GENERALIST_ENTRY, Table2Config, statistics_markdown
        from snakeplan.bench.table2 import figure_7, summary_markdown
        from snakeplan.bench.table2 import summarise as table2_summary

        generalist = [r for r in table2 if (r["planner"], r.get("options", {})) == GENERALIST_ENTRY]
        config = Table2Config(planners=tuple(dict.fromkeys(r["planner"] for r in table2 if not r.get("options"))),
                              scenes=tuple(dict.fromkeys(r["scene"] for r in table2)),
                              seeds=tuple(sorted({r["seed"] for r in table2})),
                              time_limit_s=table2[0]["time_limit_s"],
                              knowledge=("sensed", "full") if any(r.get("knowledge") == "sensed" for r in table2)
                              else ("full",), generalist=bool(generalist))
        sections += ["## Paper 000, Table 2", "", summary_markdown(table2_summary(table2, config), config), "",
                     statistics_markdown(table2, config)]
        figures += figure_7(config, table2, folder)
    sscc = [r for r in rows if r.get("config") == "sscc"]
    if sscc:
        from snakeplan.bench.sscc import paper_sections

        text, files = paper_sections(sscc, folder)
        sections += ["## Paper 001, Tables 4 and 6", "", text]
        figures += files
    station = [r for r in rows if r.get("config") == "station" and r.get("task") == "inspect"]
    if station:
        from snakeplan.bench.station import station_outputs, summary_markdown

        summary = station_outputs(station, folder)
        sections += ["## Paper 002, Figs. 6-9", "", summary_markdown(summary)]
        figures += [folder / f for f in summary["figures"]]
    return sections, figures


def write_report(folder: str | Path, html: str | Path | None = None) -> dict:
    """Write ``report.md`` and ``report.csv`` (and the paper figures, and ``html`` when given) into ``folder``
    from its logged rows; returns the report's heading, the summary entries and the files written."""
    folder = Path(folder)
    if not (folder / RUNS_FILE).is_file():
        raise ValueError(f"DIR: {folder} holds no {RUNS_FILE} (a results folder of 'snakeplan bench ...')")
    render = _html_renderer() if html is not None else None
    rows, superseded = current_rows(read_rows(folder))
    if not rows:
        raise ValueError(f"DIR: {folder / RUNS_FILE} holds no complete row yet")
    entries = summarise(rows)
    sections, figures = paper_outputs(rows, folder)
    heading = f"Results in {folder.name}: {len(rows)} runs" + (
        f" ({superseded} older rows of runs planned again with changed files left out)" if superseded else "")
    text = "\n".join([markdown(entries, heading), "", *sections,
                      *[f"![{f.stem}]({f.name})" for f in figures]]) + "\n"
    written = [atomic_write(folder / "report.md", text), atomic_write(folder / "report.csv", csv_text(entries))]
    if render is not None:
        images = {f.name: f.read_bytes() for f in figures}
        written.append(atomic_write(html, render(text, images, f"snakeplan results: {folder.name}")))
    return {"heading": heading, "entries": entries, "files": [str(p) for p in written + figures]}


def _html_renderer():
    """``snakeplan.viz.report.report_html`` (markdown, images by name, title -> HTML), or ValueError naming
    ``--html`` when this snakeplan has none."""
    try:
        from snakeplan.viz.report import report_html
    except ImportError:
        raise ValueError("--html: this snakeplan cannot write HTML reports (snakeplan.viz.report is missing); "
                         "the markdown report is written without it when --html is left out") from None
    return report_html
