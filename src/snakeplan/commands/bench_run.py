"""``snakeplan bench run`` (any planners on any episodes, through the benchmark runner) and ``snakeplan bench
report`` (tables and figures from a results folder)."""

from __future__ import annotations

import argparse
import json
import sys

from snakeplan.commands.common import EXIT_OK, UsageError, finite, name_list, print_json, seed_list
from snakeplan.commands.options import backend, backend_args
from snakeplan.commands.ros import check_ros, live_args, live_rows, serving
from snakeplan.files import check_output


def add_parsers(bsub) -> None:
    p = bsub.add_parser("run", help="any planners on any episodes: judged JSON Lines rows, resumable",
                        description="Plan every scene (a family with every seed, or a scene file planned from "
                                    "every seed) with every planner, judge each plan and append one row per run "
                                    "to OUT/runs.jsonl (resumes; one writer per folder), then write "
                                    "OUT/report.md and report.csv.")
    p.add_argument("--scenes", required=True, help="comma-separated scene families or scene .json files")
    p.add_argument("--planners", required=True, help="comma-separated planner names (inspection planners for a "
                                                     "scene whose task is to inspect, e.g. station)")
    p.add_argument("--seeds", default="0-9", help="seeds, e.g. 0-99 or 0,3,5-7 (default 0-9)")
    p.add_argument("--option", action="append", metavar="KEY=VALUE",
                   help="a planner option for every planner (value as JSON, else text); may be repeated")
    p.add_argument("--robot", help="robot preset or robot file (.urdf, DH .yaml, robot/1 .json) for every scene "
                                   "(default: each scene's own)")
    p.add_argument("--time-limit", type=finite, default=10.0, help="budget per plan in seconds (default 10)")
    p.add_argument("--knowledge", choices=("full", "sensed"), default="full",
                   help="what the planners may know (sensed: a planner that needs the whole scene still has it)")
    p.add_argument("--sensor", choices=("exact", "depth"), default="exact",
                   help="the tip sensor of the sensed runs: exact, or a depth camera (default exact)")
    p.add_argument("--task", choices=("reach", "inspect"),
                   help="the task every scene is given (default: each scene's own; inspect a tank with coverage)")
    p.add_argument("--name", default="run", help="configuration name recorded in every row (default run)")
    p.add_argument("--out", default="bench-run", help="results folder (default bench-run)")
    p.add_argument("--fresh", action="store_true", help="discard earlier runs instead of resuming")
    p.add_argument("--json", action="store_true", help="print the runner's outcome and the summary as JSON")
    live_args(p, "the benchmark while it runs: each reach plan shown in its scene as it is judged, a line for "
                 "every row")
    backend_args(p)
    p.set_defaults(func=cmd_bench_run)

    p = bsub.add_parser("report", help="markdown and CSV tables (and paper figures) from a results folder",
                        description="Summarise DIR/runs.jsonl per configuration, scene and planner: success with "
                                    "its Wilson 95 % interval, median/p90/max compute time, path length, "
                                    "smoothness, clearance, deviation; writes DIR/report.md and report.csv, and "
                                    "the paper's tables and figures where the rows' configuration names one.")
    p.add_argument("dir", metavar="DIR", help="a results folder (holding runs.jsonl)")
    p.add_argument("--html", metavar="FILE", help="also write a self-contained HTML report")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=cmd_bench_report)


def outcome_line(outcome) -> str:
    """What the runner did: runs, wall time, backend, and the runs skipped as already logged."""
    b = outcome.backend
    where = b["backend"] + (f", {b['workers']} workers" if b["backend"] != "serial" else "")
    return (f"ran {outcome.ran} runs in {outcome.wall_s:.1f} s ({where}); {outcome.skipped} already logged "
            f"were skipped")


def _option_value(text: str):
    """A --option value: JSON, else the text itself."""
    try:
        return json.loads(text)
    except ValueError:
        return text


def cmd_bench_run(args: argparse.Namespace) -> int:
    from snakeplan.bench.report import write_report
    from snakeplan.bench.runner import Sweep, check_robot, run_sweep
    from snakeplan.planners import planner_names

    planners = name_list(args.planners, planner_names(), "--planners")
    options = {}
    for item in args.option or ():
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise UsageError(f"--option: expected KEY=VALUE, got {item!r}")
        options[key] = _option_value(value)
    if "optimize" in options:
        from snakeplan.optimize import as_level

        try:
            as_level(options["optimize"])
        except ValueError as exc:
            raise UsageError(f"--option {exc}") from None
    scenes = tuple(n.strip() for n in args.scenes.split(",") if n.strip())
    if not scenes:
        raise UsageError("--scenes: empty list")
    if args.robot:
        check_robot(args.robot, "--robot")
    sweep = Sweep(args.name, scenes, seed_list(args.seeds, "--seeds"), tuple((p, options) for p in planners),
                  args.time_limit, args.robot or "", args.knowledge, args.task or "", sensor=args.sensor)
    try:
        runs = sweep.runs()
    except KeyError as exc:
        raise UsageError(f"--scenes: {exc.args[0]}") from None
    check_ros(args)
    with serving(args) as view:
        outcome = run_sweep(sweep, args.out, backend(args), fresh=args.fresh, progress=not args.json, runs=runs,
                            on_row=live_rows(view))
    result = write_report(args.out)
    if args.json:
        print_json({"runner": outcome.to_dict(), "summary": result["entries"]})
    else:
        sys.stdout.write(f"{outcome_line(outcome)}\nwrote {args.out}/runs.jsonl, report.md, report.csv\n")
    return EXIT_OK


def cmd_bench_report(args: argparse.Namespace) -> int:
    from snakeplan.bench.report import markdown, write_report

    if args.html:
        check_output(args.html, "--html", (".html", ".htm"))
    result = write_report(args.dir, args.html)
    if args.json:
        print_json(result)
    else:
        sys.stdout.write(markdown(result["entries"], result["heading"]) + "\n\nwrote "
                         + ", ".join(result["files"]) + "\n")
    return EXIT_OK
