"""``snakeplan check``: judge a tip path made elsewhere (exit 0 feasible, 1 infeasible, 2 bad input)."""

from __future__ import annotations

import argparse
import sys

from snakeplan.commands.common import EXIT_INFEASIBLE, EXIT_OK, UsageError, print_json
from snakeplan.commands.inputs import PlanFile, given_robot, load_plan_file, plan_scene, scene_robot
from snakeplan.commands.options import DEFAULT_SCENE, ROBOT_HELP, plan_scene_args, view_args
from snakeplan.commands.ros import check_ros, check_ros_robot, ros_args, write_ros
from snakeplan.commands.views import check_picture, check_views, write_episode_views, write_plot, write_views


def add_parser(sub) -> None:
    p = sub.add_parser("check", help="judge a tip path made elsewhere",
                       description="Judge a tip path ({\"path\": [[x, y, z], ...]}, any plan file will do) with "
                                   "snakeplan's judge. Exit 0 feasible, 1 infeasible, 2 bad input.")
    plan_scene_args(p, fallback=True)
    p.add_argument("--robot", help=ROBOT_HELP + "; a plan file's own arm is used when it carries one")
    p.add_argument("--json", action="store_true", help="print the verdict as JSON")
    p.add_argument("--plot", help="also write a PNG picture of the judged path")
    view_args(p, "the arm crawling along the path")
    ros_args(p, "the judged path (a mission: its motions, views and coverage)")
    p.add_argument("path_file", metavar="PATH.json", help="the tip path file ('-' reads standard input)")
    p.set_defaults(func=cmd_check)


def cmd_check(args: argparse.Namespace) -> int:
    check_picture(args.plot, "--plot")
    check_views(args)
    check_ros(args)
    plan = load_plan_file(args.path_file)
    given = given_robot(args)
    scene = plan_scene(args, plan.scene, (DEFAULT_SCENE, 0), plan.arm or given)
    robot, source = plan_robot(args, scene, plan, given)
    check_ros_robot(args, robot)
    problem, report = judge_plan(scene, robot, plan)
    if plan.mission is not None:
        from snakeplan.episode import Episode
        from snakeplan.planners import Plan

        write_episode_views(args, Episode(problem, Plan("check", "found", plan.path, 0.0, {}, plan.mission), report),
                            args.plot)
    else:
        if args.plot:
            write_plot(args.plot, scene, robot, plan.path, report)
        write_views(args, scene, robot, plan.path, report)
    if args.json:
        from snakeplan.episode import check_document

        print_json(check_document(scene, robot, report))
    else:
        sys.stdout.write(f"arm: {robot.name} ({source})\n" + "\n".join(report.lines()) + "\n")
    written, _ = write_ros(args, scene, robot, plan.path, report, plan.mission)
    return EXIT_OK if report.success and not written else EXIT_INFEASIBLE


def plan_robot(args: argparse.Namespace, scene, plan: PlanFile, given):
    """(the arm to judge ``plan`` with: the plan's own, else ``given`` (the arm --robot names, or None), else the
    scene's; where it came from). A --robot other than the plan's own arm is refused."""
    arm = plan.arm
    if arm is not None and given is not None and given.to_dict() != arm.to_dict():
        raise UsageError(f"--robot: {args.robot} is not the arm the plan was made with ({arm.name}); a plan is judged "
                         f"with its own arm: leave --robot out")
    source = "--robot" if args.robot else "the plan's" if arm is not None else "the scene's"
    if arm is not None:
        return arm, source
    return (given if given is not None else scene_robot(scene)), source


def judge_plan(scene, robot, plan: PlanFile):
    """(the problem, the judge's report) of a plan file: a tip path by the judge of reaching; an inspect or search
    plan's mission (its motions, its views, the views measured again, or when they saw and reached each target)
    under its task, as plan judged it."""
    from snakeplan.evaluation import evaluate, judge
    from snakeplan.planners import Problem

    if plan.mission is None:
        return None, evaluate(scene, robot, plan.path)
    task = "search" if plan.task == "search" else "inspect"
    try:
        problem = Problem(scene, robot, task=task, knowledge="sensed" if task == "search" else "full")
    except ValueError as exc:
        raise UsageError(f"--scene: {str(exc).removeprefix('scene: ')}") from None
    try:
        return problem, judge(scene, robot, plan.path, plan.mission, problem.inspection, task)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
