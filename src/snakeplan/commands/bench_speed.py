"""``snakeplan bench kernels``, ``speed``, ``mesh`` and ``rl``: how fast the kernels, the planners, planning on
meshes and training are, each beside a baseline."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from snakeplan.commands.common import EXIT_OK, UsageError, finite, name_list, print_json, seed
from snakeplan.commands.options import backend, backend_args
from snakeplan.extras import require_training
from snakeplan.files import check_output


def add_parsers(bsub) -> None:
    p = bsub.add_parser("kernels", help="speed of the collision and follow-the-leader kernels",
                        description="Time the collision and follow-the-leader kernels against baselines in the "
                                    "same process; medians over repeats.")
    p.add_argument("--repeats", type=int, default=7, help="timed repeats (default 7)")
    p.add_argument("--batch", type=int, default=20000, help="configurations per repeat (default 20000)")
    p.add_argument("--seed", type=seed, default=0, help="seed for scenes and configurations")
    p.add_argument("--json", action="store_true", help="also print the figures as JSON")
    p.set_defaults(func=cmd_bench_kernels)

    p = bsub.add_parser("speed", help="planning times against their baselines: station, RRT*, learned, start-up, judge",
                        description="Time every planner row of the speed table (median and worst case over seeds) "
                                    "beside the implementation it replaced, in the same process; the station "
                                    "missions run beside a busy process; the load average is recorded. Writes a "
                                    "markdown table (--out) and its figures as JSON beside it. Each finished row "
                                    "is saved at once in a .partial.json beside --out: rerun an interrupted command to "
                                    "measure only the rows it lacks.")
    p.add_argument("--seeds", type=int, default=100, help="seeds per planner and scene (default 100)")
    p.add_argument("--station-seeds", type=int, default=20, help="station missions (default 20)")
    p.add_argument("--station-baseline-seeds", type=int, default=2,
                   help="station missions also flown by the previous implementation (default 2: it is slow)")
    p.add_argument("--repeats", type=int, default=5, help="runs of the plan command (default 5)")
    p.add_argument("--rows", help="comma-separated rows to measure (default all: rrt-star,sp-rrt,as-rrt,sac-her,"
                                  "optimize,command,judge,station)")
    p.add_argument("--out", default="bench-speed.md", help="markdown table to write (default bench-speed.md)")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.set_defaults(func=cmd_bench_speed)

    p = bsub.add_parser("mesh", help="planning on meshes: speed on 100k-triangle scenes, success in mesh families",
                        description="speed: judge, as-rrt and clearance figures on 100k-triangle watertight "
                                    "scenes against the same scene from primitives; families: rrt-star, sp-rrt "
                                    "and as-rrt over seeds of pipework, vessel and engine (resumable runs.jsonl).")
    p.add_argument("part", choices=("speed", "families"), help="which figures")
    p.add_argument("--seeds", type=int, default=5, help="seeds (default 5; the families figure uses 20)")
    p.add_argument("--time-limit", type=finite, default=10.0, help="budget per plan in seconds (default 10)")
    p.add_argument("--out", default="bench-mesh", help="families: output folder (default bench-mesh)")
    p.set_defaults(func=cmd_bench_mesh)

    p = bsub.add_parser("cloud", help="planning in point clouds: scans of every family judged in the exact scene; "
                                      "cloud speed and scale",
                        description="families: as-rrt, sp-rrt, rrt-star and the generalist in scans (5 mm, 2 mm "
                                    "noise, holes) of every reach family, and of --mesh, each plan judged in the "
                                    "cloud and in the exact scene (the runner's resumable rows in --out); speed: a "
                                    "million-point cloud loaded, capsule queries against the same tank as a mesh, "
                                    "ten million points refused.")
    p.add_argument("part", choices=("speed", "families"), help="which figures")
    p.add_argument("--seeds", type=int, default=20, help="families: seeds per family (default 20)")
    p.add_argument("--families", help="families: comma-separated families to scan (default every reach family)")
    p.add_argument("--mesh", help="families: also a real CAD mesh file in metres, placed as gymnasium-robotics' "
                                  "kitchen base cabinets (cabinetbase.stl) on a floor")
    p.add_argument("--time-limit", type=finite, default=10.0, help="budget per plan in seconds (default 10)")
    p.add_argument("--out", default="bench-cloud", help="output folder (default bench-cloud)")
    backend_args(p)
    p.set_defaults(func=cmd_bench_cloud)

    p = bsub.add_parser("rl", help="training throughput of the learned planners; --arms: the arm-conditioned "
                                   "generalist on held-out arms",
                        description="Environment steps, SAC-HER training steps and actor calls per second, each "
                                    "against a baseline in the same process; medians over repeats. With --arms: the "
                                    "arm-conditioned generalist on arms it never saw, beside policies trained for "
                                    "each arm alone in each family (--train-steps), judged on sensed plans in "
                                    "families sized to each arm.")
    p.add_argument("--repeats", type=int, default=5, help="timed repeats (default 5)")
    p.add_argument("--seed", type=seed, default=0, help="seed for scenes and actions (default 0)")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.add_argument("--arms", nargs="?", const="held-out", default=None,
                   help="comma-separated presets or robot files (default: the three held-out arms)")
    p.add_argument("--seeds", type=int, default=100, help="--arms: seeds per family (default 100)")
    p.add_argument("--scenes", default="confined,fuel-tank", help="--arms: families (default confined,fuel-tank)")
    p.add_argument("--train-steps", type=int, default=0,
                   help="--arms: train a policy for each arm alone in each family for this many environment steps "
                        "(default 0: none)")
    p.add_argument("--time-limit", type=finite, default=10.0, help="--arms: budget per plan in seconds (default 10)")
    p.add_argument("--out", default="bench-arms", help="--arms: output folder (default bench-arms)")
    backend_args(p)
    p.set_defaults(func=cmd_bench_rl)


def cmd_bench_kernels(args: argparse.Namespace) -> int:
    from snakeplan.bench.kernels import run_kernel_bench

    if args.repeats < 1 or args.batch < 10:
        raise UsageError("--repeats must be >= 1 and --batch >= 10")
    result = run_kernel_bench(repeats=args.repeats, batch=args.batch, seed=args.seed)
    if args.json:
        print_json(result)
    return EXIT_OK


def cmd_bench_speed(args: argparse.Namespace) -> int:
    from snakeplan.bench.speed import ROWS, run_speed_table, speed_markdown

    out = check_output(args.out, "--out", (".md",))
    for field, value in (("--seeds", args.seeds), ("--station-seeds", args.station_seeds), ("--repeats", args.repeats)):
        if value < 1:
            raise UsageError(f"{field}: expected a positive integer, got {value}")
    if args.station_baseline_seeds < 0:
        raise UsageError(f"--station-baseline-seeds: expected a non-negative integer, "
                         f"got {args.station_baseline_seeds}")
    rows = ROWS if args.rows is None else name_list(args.rows, list(ROWS), "--rows")
    summary = run_speed_table(out, seeds=args.seeds, station_seeds=args.station_seeds, rows=rows,
                              station_baseline_seeds=args.station_baseline_seeds, repeats=args.repeats,
                              progress=None if args.json else lambda line: sys.stderr.write(line + "\n"))
    if args.json:
        print_json(summary)
    else:
        sys.stdout.write(speed_markdown(summary) + f"\nwrote {out} and {out.with_suffix('.json')}\n")
    return EXIT_OK


def cmd_bench_mesh(args: argparse.Namespace) -> int:
    from snakeplan.bench import mesh

    if args.seeds < 1:
        raise UsageError(f"--seeds: expected a positive integer, got {args.seeds}")
    if args.part == "speed":
        result = mesh.speed(seeds=args.seeds, time_limit=args.time_limit)
    else:
        if not Path(args.out).parent.is_dir():
            raise UsageError(f"--out: folder {str(Path(args.out).parent)!r} does not exist (create it first)")
        Path(args.out).mkdir(exist_ok=True)
        check_output(Path(args.out) / "summary.json", "--out")
        result = mesh.families(Path(args.out), seeds=args.seeds, time_limit=args.time_limit)
    print_json(result)
    return EXIT_OK


def cmd_bench_cloud(args: argparse.Namespace) -> int:
    from snakeplan.bench import cloud
    from snakeplan.scenes.registry import SCANNED

    if not Path(args.out).parent.is_dir():
        raise UsageError(f"--out: folder {str(Path(args.out).parent)!r} does not exist (create it first)")
    if args.part == "speed":
        result = cloud.speed(Path(args.out))
    else:
        if args.seeds < 1:
            raise UsageError(f"--seeds: expected a positive integer, got {args.seeds}")
        families = name_list(args.families, list(SCANNED), "--families") if args.families else None
        mesh = None
        if args.mesh:
            mesh = Path(args.mesh)
            if not mesh.is_file():
                raise UsageError(f"--mesh: file not found: {args.mesh}")
        Path(args.out).mkdir(exist_ok=True)
        check_output(Path(args.out) / "summary.json", "--out")
        result = cloud.families(Path(args.out), args.seeds, families, mesh=mesh, backend=backend(args),
                                time_limit=args.time_limit)
    print_json(result)
    return EXIT_OK


def cmd_bench_rl(args: argparse.Namespace) -> int:
    require_training("bench rl")
    if args.arms is not None:
        return _bench_arms(args)
    from snakeplan.bench.rl import rl_markdown, run_rl_bench

    if args.repeats < 1:
        raise UsageError(f"--repeats: expected a positive integer, got {args.repeats}")
    result = run_rl_bench(repeats=args.repeats, seed=args.seed)
    if args.json:
        print_json(result)
    else:
        sys.stdout.write(rl_markdown(result) + "\n")
    return EXIT_OK


def _bench_arms(args: argparse.Namespace) -> int:
    from snakeplan.bench import arms
    from snakeplan.bench.runner import check_robot
    from snakeplan.scenes import scene_names

    chosen = arms.HELD_OUT if args.arms == "held-out" else tuple(a.strip() for a in args.arms.split(",") if a.strip())
    for arm in chosen:
        try:
            check_robot(arms.arm_source(arm), "--arms")
        except ValueError as exc:
            raise UsageError(str(exc.args[0])) from None
    if args.seeds < 1 or args.train_steps < 0:
        raise UsageError(f"--seeds, --train-steps: expected a positive and a non-negative integer, got {args.seeds} "
                         f"and {args.train_steps}")
    scenes = name_list(args.scenes, scene_names(), "--scenes")
    if not Path(args.out).parent.is_dir():
        raise UsageError(f"--out: folder {str(Path(args.out).parent)!r} does not exist (create it first)")
    Path(args.out).mkdir(exist_ok=True)
    check_output(Path(args.out) / "summary.json", "--out")
    result = arms.run(Path(args.out), chosen, args.seeds, scenes, args.train_steps, args.time_limit, backend(args))
    if args.json:
        print_json(result)
    else:
        sys.stdout.write(arms.markdown(result))
    return EXIT_OK
