"""``snakeplan plan``: plan a tip path with a planner and judge it (exit 0 feasible, 1 no feasible plan, 2 bad
input); a scene whose task is to inspect a surface (station) flies an inspection mission instead."""

from __future__ import annotations

import argparse
import sys
import warnings

from snakeplan.commands.common import (
    EXIT_INFEASIBLE,
    EXIT_OK,
    UsageError,
    as_option,
    finite,
    print_json,
    report_lines,
    seed,
    status,
    warning_line,
)
from snakeplan.commands.inputs import load_planner, load_scene, robot_for
from snakeplan.commands.options import ROBOT_HELP, TRAJECTORY_HELP, scene_args, view_args
from snakeplan.commands.trajectory import check_trajectories, write_trajectories
from snakeplan.commands.views import check_picture, check_views, write_plot, write_views


def add_parser(sub) -> None:
    p = sub.add_parser("plan", help="plan a tip path with a planner and judge it",
                       description="Plan a path for a robot in a scene; the judge's verdict comes with it. "
                                   "Exit 0 feasible, 1 no feasible plan, 2 bad input.")
    scene_args(p)
    p.add_argument("--robot", help=ROBOT_HELP)
    p.add_argument("--planner", help="planner name (default: the best shipped planner for the scene)")
    p.add_argument("--planner-seed", type=seed, default=0, help="the planner's random seed (default 0)")
    p.add_argument("--policy", help="a trained policy file: .npz from 'snakeplan train rl' for sac-her, sac-per or "
                                    "sac ('generalist': the shipped generalist), or from 'snakeplan train sscc' for "
                                    "sscc (default: the shipped one for the scene and robot; the learned planners: "
                                    "the generalist where the scene's family ships none)")
    p.add_argument("--time-limit", type=finite, default=30.0, help="planning budget in seconds (default 30)")
    p.add_argument("--knowledge", choices=("full", "sensed"), default="full",
                   help="what the planner may know: the whole scene, or what its sensor revealed")
    p.add_argument("--json", action="store_true", help="print snakeplan.plan/1 JSON")
    p.add_argument("--plot", help="also write a PNG picture of the plan (an inspection mission: its maps)")
    view_args(p, "the plan (an inspection mission: the camera's flight and the map filling in)")
    p.add_argument("--trajectory", action="append", metavar="FILE", help=TRAJECTORY_HELP)
    p.set_defaults(func=cmd_plan)


def cmd_plan(args: argparse.Namespace) -> int:
    from snakeplan.episode import run_episode
    from snakeplan.planners import Problem
    from snakeplan.scenes import spec_for

    check_picture(args.plot, "--plot")
    check_views(args)
    check_trajectories(args.trajectory, "--trajectory")
    scene = load_scene(args)
    robot = robot_for(args, scene)
    spec = spec_for(scene)
    if spec.task == "inspect":
        return _plan_inspection(args, scene, robot, spec.planner)
    options = {} if args.policy is None else {"policy": args.policy}
    planner = load_planner(args.planner or spec.planner, **options)
    problem = Problem(scene, robot, time_limit_s=args.time_limit, knowledge=args.knowledge)
    with warnings.catch_warnings():
        warnings.showwarning = warning_line
        try:
            episode = run_episode(problem, planner, seed=args.planner_seed)
        except ValueError as exc:
            raise ValueError(as_option(str(exc))) from None
    plan = episode.plan
    if args.plot:
        write_plot(args.plot, scene, robot, plan.path, episode.report, plan.planner)
    write_views(args, scene, robot, plan.path, episode.report, plan.planner)
    if args.json:
        print_json(episode.to_dict())
    else:
        sys.stdout.write(f"{plan.planner} on {scene.name} (seed {scene.seed}): {status(plan)} "
                         f"in {plan.compute_time_s:.3f} s\n")
        if episode.report is not None:
            sys.stdout.write("\n".join(report_lines(episode.report)) + "\n")
    if args.trajectory:
        if episode.report is None:
            sys.stderr.write("snakeplan: no trajectory: the planner returned no path\n")
            return EXIT_INFEASIBLE
        if write_trajectories(args.trajectory, scene, robot, plan.path, episode.report, plan.planner,
                              planner_seed=args.planner_seed, status=str(plan.status)):
            return EXIT_INFEASIBLE
    return EXIT_OK if episode.success else EXIT_INFEASIBLE


def _plan_inspection(args: argparse.Namespace, scene, robot, default: str) -> int:
    """Fly an inspection mission (a scene whose task is to inspect a surface, e.g. station) with --planner, else
    ``default``."""
    from snakeplan.episode import run_mission
    from snakeplan.planners.inspection import INSPECTION_PLANNERS, InspectionProblem

    name = args.planner or default
    if name not in INSPECTION_PLANNERS:
        raise UsageError(f"--planner: unknown inspection planner {name!r} (known: "
                         f"{', '.join(INSPECTION_PLANNERS.names())})")
    record = None
    if args.animate is not None or args.html is not None:
        from snakeplan.viz.mission import MissionRecord

        record = MissionRecord()
    problem = InspectionProblem(scene, robot)
    mission = run_mission(problem, name, seed=args.planner_seed, on_measure=record)
    result = mission.result
    _write_mission_views(args, problem, result, record)
    if args.json:
        print_json(mission.to_dict())
    else:
        sys.stdout.write(f"{name} on {scene.name} (seed {scene.seed}) with {robot.name}: final RMSE "
                         f"{result.rmse[-1]:.3f} K, covariance trace {result.trace[-1]:.1f} K^2, "
                         f"{len(result.times)} measurements, planning {result.compute_time_s:.2f} s\n")
    return EXIT_OK


def _write_mission_views(args: argparse.Namespace, problem, result, record) -> None:
    """The pictures of an inspection mission: --plot its maps, --animate the flight with the map filling in,
    --html the station with the map at every measurement."""
    if args.plot is None and args.animate is None and args.html is None:
        return
    from snakeplan.viz.mission import mission_title, save_mission_maps, save_mission_page, save_mission_video

    title = mission_title(problem, result)
    if args.plot:
        save_mission_maps(args.plot, problem, result, title)
        sys.stderr.write(f"wrote {args.plot}\n")
    if args.animate is not None:
        save_mission_video(args.animate, problem.scene, result, record, args.frames, args.fps, args.frame_size,
                           title, progress=sys.stderr.isatty())
        sys.stderr.write(f"wrote {args.animate} ({args.frames} frames at {args.fps:g} fps)\n")
    if args.html is not None:
        save_mission_page(args.html, problem.scene, result, record, title)
        sys.stderr.write(f"wrote {args.html}\n")
