"""``snakeplan check``: judge a tip path made elsewhere (exit 0 feasible, 1 infeasible, 2 bad input)."""

from __future__ import annotations

import argparse
import sys

from snakeplan.commands.common import EXIT_INFEASIBLE, EXIT_OK, UsageError, print_json
from snakeplan.commands.inputs import load_plan_file, load_scene, robot_for
from snakeplan.commands.options import ROBOT_HELP, scene_args, view_args
from snakeplan.commands.views import check_picture, check_views, write_episode_views, write_plot, write_views


def add_parser(sub) -> None:
    p = sub.add_parser("check", help="judge a tip path made elsewhere",
                       description="Judge a tip path ({\"path\": [[x, y, z], ...]}, any plan file will do) with "
                                   "snakeplan's judge. Exit 0 feasible, 1 infeasible, 2 bad input.")
    scene_args(p)
    p.add_argument("--robot", help=ROBOT_HELP + "; a plan file's own arm is used when it carries one")
    p.add_argument("--json", action="store_true", help="print the verdict as JSON")
    p.add_argument("--plot", help="also write a PNG picture of the judged path")
    view_args(p, "the arm crawling along the path")
    p.add_argument("path_file", metavar="PATH.json", help="the tip path file ('-' reads standard input)")
    p.set_defaults(func=cmd_check)


def cmd_check(args: argparse.Namespace) -> int:
    from snakeplan.evaluation import evaluate

    check_picture(args.plot, "--plot")
    check_views(args)
    scene = load_scene(args)
    path, arm, mission, task = load_plan_file(args.path_file)
    given = robot_for(args, scene) if args.robot is not None or arm is None else None
    if arm is not None and given is not None and given.to_dict() != arm.to_dict():
        raise UsageError(f"--robot: {args.robot} is not the arm the plan was made with ({arm.name}); check judges "
                         f"a plan with its own arm: leave --robot out")
    robot = given if arm is None else arm
    source = "--robot" if args.robot else "the plan's" if arm is not None else "the scene's"
    if mission is not None:
        report = _judge_mission(args, scene, robot, path, mission, "search" if task == "search" else "inspect")
    else:
        report = evaluate(scene, robot, path)
        if args.plot:
            write_plot(args.plot, scene, robot, path, report)
        write_views(args, scene, robot, path, report)
    if args.json:
        from snakeplan.episode import check_document

        print_json(check_document(scene, robot, report))
    else:
        sys.stdout.write(f"arm: {robot.name} ({source})\n" + "\n".join(report.lines()) + "\n")
    return EXIT_OK if report.success else EXIT_INFEASIBLE


def _judge_mission(args: argparse.Namespace, scene, robot, path, mission, task: str):
    """The judge's report on an inspect or search plan's mission (its motions, its views, the views measured again,
    or when they saw and reached each target) under the scene's ``task``, as plan judged it; its pictures written as
    asked."""
    from snakeplan.episode import Episode
    from snakeplan.evaluation import judge
    from snakeplan.planners import Plan, Problem

    try:
        problem = Problem(scene, robot, task=task, knowledge="sensed" if task == "search" else "full")
    except ValueError as exc:
        raise UsageError(f"--scene: {str(exc).removeprefix('scene: ')}") from None
    try:
        report = judge(scene, robot, path, mission, problem.inspection, task)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    write_episode_views(args, Episode(problem, Plan("check", "found", path, 0.0, {}, mission), report), args.plot)
    return report
