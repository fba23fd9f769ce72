"""``snakeplan bench table2``: paper 000's Table 2, planners on the same seeded fuel-tank and oil-tank episodes
(:mod:`snakeplan.bench.table2`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from snakeplan.commands.bench_run import outcome_line
from snakeplan.commands.common import EXIT_OK, UsageError, finite, name_list, print_json, seed
from snakeplan.commands.options import backend, backend_args
from snakeplan.commands.ros import check_ros, live_args, live_rows, serving


def add_parser(bsub) -> None:
    p = bsub.add_parser("table2", help="paper 000's Table 2: planners on the same seeded episodes",
                        description="Run planners on identical fuel-tank and oil-tank episodes, judge every plan, "
                                    "and write runs.jsonl (resumable; one writer per folder), table2.md/csv with "
                                    "the paper's figures, Appendix A statistics and fig7_*.png.")
    p.add_argument("--planners", help="comma-separated planner names (default rrt-star,sp-rrt,as-rrt,sac-her,"
                                      "sac-per; sac-her has rows in fuel-tank, sac-per in oil-tank)")
    p.add_argument("--scenes", default="fuel-tank,oil-tank", help="comma-separated scene names")
    p.add_argument("--runs", type=int, default=10, help="seeds per scene (default 10, as the paper)")
    p.add_argument("--seed", type=seed, default=0, help="first seed (default 0)")
    p.add_argument("--time-limit", type=finite, help="budget per plan in seconds (default 10; 30 per mission with "
                                                      "--search)")
    p.add_argument("--optimize", default="none,fast",
                   help="comma-separated path optimiser levels: every planner's rows at each (default none,fast: "
                        "each planner as its paper has it, then optimised)")
    p.add_argument("--out", help="output folder (default bench-table2; bench-search with --search)")
    p.add_argument("--search", action="store_true",
                   help="the search setting: targets hidden until the tip camera sees them, clutter unknown; each "
                        "planner reaches for each search explorer (explore-reach, frontier), and search.md/json and "
                        "search-<scene>.png give found, reached and the times to find and reach")
    p.add_argument("--explorers", help="with --search: comma-separated search planners (default explore-reach,"
                                       "frontier)")
    p.add_argument("--fresh", action="store_true", help="discard earlier runs instead of resuming")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    live_args(p, "the benchmark while it runs: each reach plan shown in its scene as it is judged, a line for "
                 "every row")
    backend_args(p)
    p.set_defaults(func=cmd_bench_table2)


def cmd_bench_table2(args: argparse.Namespace) -> int:
    from snakeplan.bench.table2 import DEFAULT_PLANNERS, SCENES, Table2Config, summary_markdown, table2_outputs
    from snakeplan.optimize import LEVELS
    from snakeplan.planners import planner_names

    if args.runs < 1:
        raise UsageError(f"--runs: expected a positive integer, got {args.runs}")
    if args.explorers is not None and not args.search:
        raise UsageError("--explorers: only the search setting (--search) has explorers")
    planners = DEFAULT_PLANNERS if args.planners is None else name_list(args.planners, planner_names("reach"),
                                                                         "--planners")
    scenes = name_list(args.scenes, list(SCENES), "--scenes")
    seeds = tuple(range(args.seed, args.seed + args.runs))
    if args.search:
        return _search(args, planners, scenes, seeds)
    levels = name_list(args.optimize, list(LEVELS), "--optimize")
    config = Table2Config(planners=planners, scenes=scenes, seeds=seeds,
                          time_limit_s=10.0 if args.time_limit is None else args.time_limit, optimize=tuple(levels))
    config.check("--planners")
    return _run(args, config, args.out or "bench-table2", table2_outputs, summary_markdown,
                "table2.md, table2.csv, runs.jsonl, fig7_*.png")


def _run(args: argparse.Namespace, config, out: str, outputs, markdown, written: str) -> int:
    """Run ``config``'s sweep into ``out`` (resuming), write its ``outputs`` and print its ``markdown`` summary (or
    the summary and the runner's account as JSON)."""
    from snakeplan.bench.runner import run_sweep

    check_ros(args)
    with serving(args) as view:
        outcome = run_sweep(config.sweep(), out, backend(args), fresh=args.fresh, progress=not args.json,
                            on_row=live_rows(view))
    summary = outputs(config, outcome.rows, Path(out))
    if args.json:
        print_json({"summary": summary, "runner": outcome.to_dict()})
    else:
        sys.stdout.write(markdown(summary, config) + f"\n\n{outcome_line(outcome)}\nwrote {out}/{written}\n")
    return EXIT_OK


def _search(args: argparse.Namespace, planners: tuple[str, ...], scenes: tuple[str, ...], seeds: tuple[int, ...]
            ) -> int:
    """Table 2 in the search setting (:mod:`snakeplan.bench.search`)."""
    from snakeplan.bench.search import DEFAULT_OUT_DIR, EXPLORERS, TIME_LIMIT_S, SearchConfig, search_outputs
    from snakeplan.bench.search import summary_markdown
    from snakeplan.planners import planner_names

    explorers = EXPLORERS if args.explorers is None else name_list(args.explorers, planner_names("search"),
                                                                     "--explorers")
    config = SearchConfig(scenes, seeds, tuple(planners), tuple(explorers),
                          TIME_LIMIT_S if args.time_limit is None else args.time_limit)
    if not any(config.entries_in(s) for s in scenes):
        raise UsageError("--planners: none is compared in these scenes (a learned planner only where its policy "
                         "ships)")
    return _run(args, config, args.out or DEFAULT_OUT_DIR, search_outputs, summary_markdown,
                "search.md, search.json, runs.jsonl, search-*.png")
