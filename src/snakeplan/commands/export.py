"""``snakeplan export``: a saved plan (``plan --json``) judged again and written for ROS 2 and Foxglove (exit 0
written, 1 a bag asked for a plan the judge refuses, 2 bad input)."""

from __future__ import annotations

import argparse
import sys

from snakeplan.commands.check import judge_plan, plan_robot
from snakeplan.commands.common import UsageError
from snakeplan.commands.inputs import given_robot, load_plan_file, plan_scene
from snakeplan.commands.options import ROBOT_HELP, plan_scene_args
from snakeplan.commands.ros import check_ros, check_ros_robot, ros_args, write_ros


def add_parser(sub) -> None:
    p = sub.add_parser("export", help="write a saved plan as a ROS 2 bag or a Foxglove MCAP file",
                       description="Judge a plan file (as plan --json writes it: a reach or search plan, "
                                   "snakeplan.plan/1, or an inspect mission, snakeplan.inspection/1) in its scene "
                                   "and write it as a ROS 2 bag (--rosbag) and/or a Foxglove MCAP file (--mcap). "
                                   "Exit 0 written, 1 a bag asked for a plan the judge refuses or the robot cannot "
                                   "execute (the MCAP is still written, the failure marked), 2 bad input.")
    p.add_argument("plan_file", metavar="PLAN.json", help="the plan file ('-' reads standard input)")
    plan_scene_args(p)
    p.add_argument("--robot", help=ROBOT_HELP + "; a plan file's own arm is used when it carries one")
    ros_args(p, "the plan")
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    if args.rosbag is None and args.mcap is None:
        raise UsageError("--rosbag: give --rosbag DIR, --mcap FILE or both")
    check_ros(args)
    plan = load_plan_file(args.plan_file)
    given = given_robot(args)
    scene = plan_scene(args, plan.scene, robot=plan.arm or given)
    robot, source = plan_robot(args, scene, plan, given)
    check_ros_robot(args, robot)
    _, report = judge_plan(scene, robot, plan)
    sys.stderr.write(f"arm: {robot.name} ({source}); {report.lines()[0]}\n")
    return write_ros(args, scene, robot, plan.path, report, plan.mission)[0]
