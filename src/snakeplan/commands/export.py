"""``snakeplan export``: a saved plan (``plan --json``) judged again and written for ROS 2 and Foxglove (exit 0
written, 1 a bag asked for a plan the judge refuses, 2 bad input)."""

from __future__ import annotations

import argparse
import sys

from snakeplan.commands.check import judge_plan, plan_robot
from snakeplan.commands.common import UsageError, seed
from snakeplan.commands.inputs import load_plan_file, read_text, scene_dir
from snakeplan.commands.options import ROBOT_HELP
from snakeplan.commands.ros import check_ros, ros_args, write_ros


def add_parser(sub) -> None:
    p = sub.add_parser("export", help="write a saved plan as a ROS 2 bag or a Foxglove MCAP file",
                       description="Judge a plan file (snakeplan.plan/1, as plan --json writes; a reach plan or an "
                                   "inspect or search mission) in its scene and write it as a ROS 2 bag (--rosbag) "
                                   "and/or a Foxglove MCAP file (--mcap). Exit 0 written, 1 a bag asked for a plan "
                                   "the judge refuses (the MCAP is still written, the failure marked), 2 bad input.")
    p.add_argument("plan_file", metavar="PLAN.json", help="the plan file ('-' reads standard input)")
    p.add_argument("--scene", help="scene name (default: the plan's)")
    p.add_argument("--seed", type=seed, help="scene seed (default: the plan's)")
    p.add_argument("--scene-file", help="a scene JSON file (snakeplan.scene/1) instead of the plan's scene")
    p.add_argument("--robot", help=ROBOT_HELP + "; a plan file's own arm is used when it carries one")
    ros_args(p, "the plan")
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    from snakeplan.scenes import Scene, make_scene

    if not (args.rosbag or args.mcap):
        raise UsageError("--rosbag: give --rosbag DIR, --mcap FILE or both")
    check_ros(args)
    plan = load_plan_file(args.plan_file)
    if args.scene_file:
        scene = Scene.from_json(read_text(args.scene_file, "--scene-file"), "--scene-file",
                                scene_dir(args.scene_file))
    else:
        name, scene_seed = plan.scene or (None, None)
        name = args.scene or name
        scene_seed = args.seed if args.seed is not None else scene_seed
        if name is None or scene_seed is None:
            raise UsageError("--scene: the plan names no generated scene; give --scene and --seed, or --scene-file")
        try:
            scene = make_scene(name, scene_seed)
        except KeyError as exc:
            raise UsageError(f"--scene: {exc.args[0]}") from None
    robot, source = plan_robot(args, scene, plan)
    _, report = judge_plan(scene, robot, plan)
    sys.stderr.write(f"arm: {robot.name} ({source}); {report.lines()[0]}\n")
    return write_ros(args, scene, robot, plan.path, report, plan.mission)
