"""``snakeplan bench station``, ``ablation`` and ``sscc``: the papers' other figures (paper 002's inspection
methods, paper 000's Fig. 4, paper 001's Tables 4 and 6)."""

from __future__ import annotations

import argparse
import sys

from snakeplan.commands.common import EXIT_OK, UsageError, finite, name_list, print_json, seed
from snakeplan.commands.options import backend, backend_args
from snakeplan.extras import require_training


def add_parsers(bsub) -> None:
    p = bsub.add_parser("station", help="paper 002: informative vs coverage vs random inspection of the station",
                        description="Fly IP, CP and RP missions on station seeds; RMSE and covariance-trace curves "
                                    "(Fig. 9) and maps (Figs. 6-8) as pictures in --out.")
    p.add_argument("--seeds", type=int, default=5, help="station seeds to average over (default 5)")
    p.add_argument("--seed", type=seed, default=0, help="first seed (default 0)")
    p.add_argument("--out", default="bench-station", help="results folder (default bench-station; resumed)")
    p.add_argument("--fresh", action="store_true", help="forget the rows in --out and fly every mission again")
    p.add_argument("--json", action="store_true",
                   help="print per method the final RMSE, final covariance trace and planning time as JSON")
    backend_args(p)
    p.set_defaults(func=cmd_bench_station)

    p = bsub.add_parser("ablation", help="paper 000's Fig. 4: learning with and without HER / PER (long)",
                        description="Train the scene's learned planner with and without its replay (HER in "
                                    "fuel-tank, PER in oil-tank; or the two observation designs) over several "
                                    "seeds; learning curves, steps to convergence and the speed-up. Each run "
                                    "resumes from its folder. Further options set the training configuration, "
                                    "as for 'snakeplan train rl'.")
    p.add_argument("--scene", default="fuel-tank",
                   help="a scene family planned by a learned planner (default fuel-tank)")
    p.add_argument("--compare", choices=("replay", "observation"), default="replay",
                   help="what to ablate (default replay)")
    p.add_argument("--seeds", type=int, default=3, help="training seeds per variant (default 3)")
    p.add_argument("--seed", type=seed, default=0, help="first training seed (default 0)")
    p.add_argument("--steps", type=int, default=30000, help="environment steps per run (default 30000)")
    p.add_argument("--eval-every", type=int, default=2500, help="validation period in steps (default 2500)")
    p.add_argument("--eval-episodes", type=int, default=20, help="validation episodes (default 20)")
    p.add_argument("--threshold", type=finite,
                   help="validation success that counts as converged (default 0.6)")
    p.add_argument("--out", default="bench-ablation", help="output folder (default bench-ablation)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    backend_args(p)
    p.set_defaults(func=cmd_bench_ablation, takes_options=True)
    p = bsub.add_parser("sscc", help="paper 001's Tables 4 and 6: SSCC in the pipe and the concentric pipe",
                        description="SSCC with the shipped DDPG agent and the non-learning searches on seeded "
                                    "targets (30 in pipe for sscc-16 and sscc-24, 52 in concentric-pipe); success, "
                                    "time per target, D, the paper's figures beside ours, pictures.")
    p.add_argument("--out", default="bench-sscc", help="output folder (default bench-sscc)")
    p.add_argument("--variants", help="comma-separated searches to compare")
    p.add_argument("--targets", type=int, help="targets per setting (default: the paper's 30 / 52)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    backend_args(p)
    p.set_defaults(func=cmd_bench_sscc)


def cmd_bench_station(args: argparse.Namespace) -> int:
    from snakeplan.bench.station import run_station_bench, summary_markdown

    if args.seeds < 1:
        raise UsageError(f"--seeds: expected a positive integer, got {args.seeds}")
    summary = run_station_bench(seeds=args.seeds, seed0=args.seed, out_dir=args.out, backend=backend(args),
                                fresh=args.fresh, progress=not args.json)
    if args.json:
        print_json(summary)
    else:
        sys.stdout.write(summary_markdown(summary) + f"\n\nwrote {args.out}/station.md, station.json, runs.jsonl, "
                         + ", ".join(summary["figures"]) + "\n")
    return EXIT_OK


def cmd_bench_ablation(args: argparse.Namespace) -> int:
    require_training("bench ablation")
    from dataclasses import replace

    from snakeplan.rl.ablation import CONVERGENCE_SUCCESS, run_ablation, variants
    from snakeplan.rl.train import parse_config

    for field in ("seeds", "steps", "eval_every", "eval_episodes"):
        if getattr(args, field) < 1:
            raise UsageError(f"--{field.replace('_', '-')}: expected a positive integer, got {getattr(args, field)}")
    if args.threshold is not None and not 0.0 < args.threshold <= 1.0:
        raise UsageError(f"--threshold: expected a success rate in (0, 1], got {args.threshold}")
    try:
        variants(args.scene, args.compare)  # a scene that is not planned by a learned planner: ValueError
    except KeyError as exc:
        raise UsageError(f"--scene: {exc.args[0]}") from None
    config = replace(parse_config(args.extra), eval_every=args.eval_every, eval_episodes=args.eval_episodes)
    seeds = list(range(args.seed, args.seed + args.seeds))
    threshold = CONVERGENCE_SUCCESS if args.threshold is None else args.threshold
    result = run_ablation(args.scene, seeds, args.steps, args.out, args.compare, config, threshold, backend(args),
                          progress=not args.json)
    if args.json:
        print_json(result)
        return EXIT_OK
    for label, runs in result["runs"].items():
        steps = ", ".join(f"{r['steps_to_converge']:.0f}" + ("" if r["converged"] else " (not converged)")
                          for r in runs)
        sys.stdout.write(f"{label}: steps to {threshold:g} validation success per seed: {steps}; mean validation "
                         f"success over the run {result['mean_success'][label]:.3f}\n")
    bound = " (at least: a baseline run never converged)" if result["speedup_is_lower_bound"] else ""
    speedup = "n/a" if result["speedup"] is None else f"{result['speedup']:.2f}x"
    paper = "" if result["paper_speedup"] is None else f"; paper 000: {result['paper_speedup']:.2f}x"
    sys.stdout.write(f"speed-up to convergence: {speedup}{bound}{paper}\n"
                     f"wrote {args.out}/ablation-{args.scene}-{args.compare}.png and .json\n")
    return EXIT_OK


def cmd_bench_sscc(args: argparse.Namespace) -> int:
    """--variants: names of :data:`snakeplan.bench.sscc.VARIANTS` (default all of them)."""
    from snakeplan.bench.sscc import VARIANTS, run_sscc_bench, summary_markdown

    if args.targets is not None and args.targets < 1:
        raise UsageError(f"--targets: expected a positive integer, got {args.targets}")
    variants = tuple(VARIANTS) if args.variants is None else name_list(args.variants, list(VARIANTS), "--variants")
    if "agent-learning" in variants:
        require_training("bench sscc --variants agent-learning")
    summary = run_sscc_bench(out_dir=args.out, variants=variants, targets=args.targets, progress=not args.json,
                             backend=backend(args))
    if args.json:
        print_json(summary)
    else:
        sys.stdout.write(summary_markdown(summary["settings"]) + f"\n\nwrote {args.out}\n")
    return EXIT_OK
