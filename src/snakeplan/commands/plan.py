"""``snakeplan plan``: plan the scene's task (reach its targets, or inspect its surface: station) with a planner
and judge it (exit 0 feasible, 1 no feasible plan, 2 bad input)."""

from __future__ import annotations

import argparse
import sys
import time
import warnings

from snakeplan.commands.common import (
    EXIT_INFEASIBLE,
    EXIT_OK,
    UsageError,
    as_option,
    finite,
    optimize_line,
    print_json,
    seed,
    status,
    warning_line,
    where,
    why_line,
)
from snakeplan.commands.inputs import load_planner, scene_and_robot
from snakeplan.commands.options import ROBOT_HELP, TRAJECTORY_HELP, scene_args, view_args
from snakeplan.commands.ros import check_ros, check_ros_robot, recordings, ros_args, serving, write_ros
from snakeplan.commands.trajectory import check_trajectories, write_trajectories
from snakeplan.commands.views import check_picture, check_views, write_episode_views


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
    p.add_argument("--optimize", choices=("none", "fast", "full"),  # optimize.LEVELS, without importing it
                   help="the path optimiser on a found reach path: none, fast (a few ms, bounded) or full (a wider "
                        "search); smoother, never less clear, judged (default: fast for rrt-star, sp-rrt and as-rrt, "
                        "none for the others)")
    p.add_argument("--knowledge", choices=("full", "sensed"),
                   help="what the planner may know: the whole scene, or what its sensor revealed (default: full; "
                        "sensed for a search)")
    p.add_argument("--sensor", choices=("exact", "depth"), default="exact",  # planners.SENSORS, without importing them
                   help="with --knowledge sensed, the tip sensor: exact (whole obstacles revealed within range) or "
                        "depth (a depth camera's noisy returns, with dropouts, kept as points; default exact)")
    p.add_argument("--task", choices=("reach", "inspect", "search"),  # scenes.TASKS, without importing the scenes
                   help="reach the scene's targets, inspect its surface, or search for its targets, hidden until the "
                        "tip camera sees them (default: the scene's task)")
    p.add_argument("--reach", metavar="PLANNER",
                   help="a search planner's reaching planner, which grows its branches and reaches each target seen "
                        "(default as-rrt; any reaching planner: rrt-star, sp-rrt, sac-her, ...)")
    p.add_argument("--json", action="store_true", help="print snakeplan.plan/1 JSON")
    p.add_argument("--plot", help="also write a PNG picture of the plan (an inspection mission: its maps)")
    view_args(p, "the plan (an inspection mission: the camera's flight and the map filling in)")
    p.add_argument("--trajectory", action="append", metavar="FILE", help=TRAJECTORY_HELP)
    ros_args(p, "the judged plan (a mission: its motions, views and coverage)",
             live="the plan: the scene at once, then the judged plan replayed at mission speed until Ctrl-C")
    p.set_defaults(func=cmd_plan)


def cmd_plan(args: argparse.Namespace) -> int:
    from snakeplan.episode import run_episode
    from snakeplan.planners import Problem
    from snakeplan.scenes import Task, as_task, scale_warnings, spec_for
    from snakeplan.world.validity import kernels_ready

    check_picture(args.plot, "--plot")
    check_views(args)
    check_trajectories(args.trajectory, "--trajectory")
    check_ros(args)
    scene, robot = scene_and_robot(args)
    check_ros_robot(args, robot)
    spec = spec_for(scene)
    task = as_task(args.task or spec.task)
    options = {} if args.policy is None else {"policy": args.policy}
    if args.reach is not None:
        if task is not Task.SEARCH:
            raise UsageError(f"--reach: only a search task has a reaching planner to choose (this one is {task})")
        options["reach"] = args.reach
    if args.optimize is not None:
        options["optimize"] = args.optimize
    knowledge = args.knowledge or ("sensed" if task is Task.SEARCH else "full")
    planner = load_planner(args.planner or spec.planner_for(task), **options)
    blame = "--task" if args.task else "--planner"
    try:
        planner.check_task(task)
    except ValueError as exc:
        raise UsageError(f"{blame}: {str(exc).removeprefix('task: ')}; scene {scene.name}'s task is "
                         f"{spec.task}") from None
    try:
        problem = Problem(scene, robot, time_limit_s=args.time_limit, knowledge=knowledge, task=task,
                          sensor=args.sensor)
    except ValueError as exc:
        if args.task and str(exc).startswith(("scene:", "task:")):
            raise UsageError(f"--task: {str(exc).split(': ', 1)[1]}") from None
        if str(exc).startswith(("knowledge:", "sensor:")):
            raise UsageError(f"--{exc}") from None
        raise
    for line in scale_warnings(scene, robot):
        sys.stderr.write(f"snakeplan: warning: {line}\n")
    if not kernels_ready():
        sys.stderr.write("snakeplan: compiling the planning kernels on first use (about a minute, once: numba keeps "
                         "them; 'snakeplan compile' builds them ahead of time)\n")
    with serving(args) as view:
        if view is not None:
            view.show_scene(scene)
        wall = time.perf_counter()
        with warnings.catch_warnings():
            warnings.showwarning = warning_line
            try:
                episode = run_episode(problem, planner, seed=args.planner_seed)
            except ValueError as exc:
                raise ValueError(as_option(str(exc))) from None
        wall = time.perf_counter() - wall
        plan = episode.plan
        write_episode_views(args, episode, args.plot)
        if args.json:
            print_json(episode.to_dict())
        else:
            sys.stdout.write(f"{plan.planner} on {where(scene)} with {robot.name}: {status(plan)} "
                             f"in {plan.compute_time_s:.3f} s ({wall:.2f} s wall, judging and loading included)\n"
                             f"{why_line(plan)}{optimize_line(plan)}")
            if episode.report is not None:
                sys.stdout.write("\n".join(episode.report.lines()) + "\n")
        code = EXIT_OK if episode.success else EXIT_INFEASIBLE
        traj = None
        if args.trajectory:
            if episode.report is None or plan.mission is not None:
                sys.stderr.write("snakeplan: no trajectory: the planner returned no tip path to time"
                                 f"{' (a mission is its motions)' if plan.mission is not None else ''}\n")
                code = EXIT_INFEASIBLE
            else:
                written, traj = write_trajectories(args.trajectory, scene, robot, plan.path, episode.report,
                                                   plan.planner, planner_seed=args.planner_seed,
                                                   status=str(plan.status))
                code = written or code
        made = None
        if episode.report is None:
            if args.rosbag is not None or args.mcap is not None:
                sys.stderr.write("snakeplan: no bag or MCAP: the planner returned no plan to record\n")
                code = EXIT_INFEASIBLE
        else:
            written, made = write_ros(args, scene, robot, plan.path, episode.report, plan.mission, traj)
            code = written or code
        if view is not None:
            if made is None and episode.report is not None:
                made = recordings(scene, robot, plan.path, episode.report, plan.mission, traj)
            hold_live(view, made.shown if made is not None else None)
    return code


def hold_live(view, shown) -> None:
    """Replay the judged plan (its recording ``shown``, or None) on the live view at mission speed until Ctrl-C (or
    SIGTERM) stops it."""
    from snakeplan.interrupt import interruptible

    sys.stderr.write("live view: replaying the plan; Ctrl-C stops\n" if shown is not None else
                     "live view: no plan to show; Ctrl-C stops\n")
    with interruptible() as stop:
        while not stop.requested:
            if shown is None or not view.show(shown, speed=1.0, stopped=lambda: stop.requested):
                time.sleep(0.1)
