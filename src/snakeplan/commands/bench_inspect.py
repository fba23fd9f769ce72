"""``snakeplan bench inspect``: inspection of the scene families by a fed arm's tip camera, every inspection
planner on the same scenes (:mod:`snakeplan.bench.inspect`)."""

from __future__ import annotations

import argparse
import sys

from snakeplan.commands.common import EXIT_OK, UsageError, name_list, print_json, seed
from snakeplan.commands.options import backend, backend_args


def add_parser(bsub) -> None:
    from snakeplan.bench.inspect import DEFAULT_OUT_DIR, DEFAULT_SEEDS, FAMILIES, PLANNERS

    p = bsub.add_parser("inspect", help="inspection of the families by a fed arm's tip camera, planner against "
                                        "planner", description="Inspect seeded scenes of each family with each "
                                        "inspection planner, judge every mission, and table the share of the "
                                        "points of interest seen (and of those an offline oracle sees), mission "
                                        "time, feed travel, retractions and compute time; resumable.")
    p.add_argument("--families", default=",".join(FAMILIES), help=f"comma-separated families (default "
                                                                  f"{','.join(FAMILIES)})")
    p.add_argument("--planners", default=",".join(PLANNERS), help=f"comma-separated inspection planners "
                                                                  f"(default {','.join(PLANNERS)})")
    p.add_argument("--seeds", type=int, default=DEFAULT_SEEDS, help=f"seeds per family (default {DEFAULT_SEEDS})")
    p.add_argument("--seed", type=seed, default=0, help="first seed (default 0)")
    p.add_argument("--out", default=DEFAULT_OUT_DIR, help=f"results folder (default {DEFAULT_OUT_DIR}; resumed)")
    p.add_argument("--fresh", action="store_true", help="forget the rows in --out and inspect again")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    backend_args(p)
    p.set_defaults(func=cmd_bench_inspect)


def cmd_bench_inspect(args: argparse.Namespace) -> int:
    from snakeplan.bench.inspect import markdown, run_inspect_bench
    from snakeplan.planners import planner_names
    from snakeplan.scenes import scene_names

    if args.seeds < 1:
        raise UsageError(f"--seeds: expected a positive integer, got {args.seeds}")
    families = name_list(args.families, scene_names(), "--families")
    planners = name_list(args.planners, planner_names("inspect"), "--planners")
    summary = run_inspect_bench(families, args.seeds, args.seed, planners, args.out, backend(args), args.fresh,
                                progress=not args.json)
    if args.json:
        print_json(summary)
    else:
        sys.stdout.write(markdown(summary) + f"\n\nwrote {args.out}/inspect.md, inspect.json, runs.jsonl, "
                         + ", ".join(summary["figures"]) + "\n")
    return EXIT_OK
