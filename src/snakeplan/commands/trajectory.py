"""``snakeplan trajectory``: turn a plan file into the time-parameterised trajectory a controller runs; and the
trajectory files of ``plan --trajectory``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from snakeplan.commands.common import EXIT_INFEASIBLE, EXIT_OK, UsageError
from snakeplan.commands.inputs import load_robot, plan_scene, read_text
from snakeplan.commands.options import TRAJECTORY_HELP, plan_scene_args
from snakeplan.commands.ros import check_ros, check_ros_robot, ros_args, write_ros


def add_parser(sub) -> None:
    p = sub.add_parser("trajectory", help="turn a plan file into a trajectory a controller can run",
                       description="Judge a plan (snakeplan.plan/1, as plan --json writes) and write its "
                                   "time-parameterised trajectory: feed and joints (and cable lengths) at every "
                                   "crawl step. Exit 0 written, 1 the plan is infeasible or the robot cannot "
                                   "execute it, 2 bad input.")
    p.add_argument("plan_file", metavar="PLAN.json", help="the plan file ('-' reads standard input)")
    p.add_argument("--robot", help="robot preset or robot file (default: the plan's robot)")
    plan_scene_args(p)
    p.add_argument("-o", "--out", action="append", metavar="FILE", help=TRAJECTORY_HELP)
    ros_args(p, "the trajectory")
    p.set_defaults(func=cmd_trajectory)


def cmd_trajectory(args: argparse.Namespace) -> int:
    from snakeplan.evaluation import evaluate
    from snakeplan.scenes import spec_for
    from snakeplan.trajectory import read_plan

    if not args.out and args.rosbag is None and args.mcap is None:
        raise UsageError("-o: give at least one output: -o FILE, --rosbag DIR or --mcap FILE")
    check_trajectories(args.out, "-o")
    check_ros(args)
    plan = read_plan(read_text(args.plan_file, "PLAN"))
    named = args.robot or plan["robot"]
    given = load_robot(named) if named else None
    scene = plan_scene(args, (plan["scene"]["name"], plan["scene"]["seed"]), robot=given)
    robot = given or load_robot(spec_for(scene).robot)
    check_ros_robot(args, robot)
    report = evaluate(scene, robot, plan["path"])
    code, traj = EXIT_OK, None
    if args.out:
        code, traj = write_trajectories(args.out, scene, robot, plan["path"], report, plan["planner"],
                                        plan_file=Path(args.plan_file).name)
    return write_ros(args, scene, robot, plan["path"], report, trajectory=traj)[0] or code


def check_trajectories(filenames: list[str] | None, field: str) -> None:
    """Refuse trajectory files that could not be written or whose name picks no format, before any work."""
    if not filenames:
        return
    from snakeplan.trajectory import output_format

    for filename in filenames or ():
        output_format(filename, field)


def write_trajectories(filenames: list[str], scene, robot, path, report, planner: str, **source):
    """Build the trajectory of a judged path and write it to every file: (exit status, the trajectory); status 1
    (one line on stderr) and None when the plan cannot become one. Its provenance: the scene, the planner and
    ``source`` (where the path came from: the planner's seed and status, or the plan file)."""
    from snakeplan.trajectory import InfeasiblePlan, build_trajectory, write

    provenance = {"scene": {"name": scene.name, "seed": scene.seed}, "planner": planner, **source}
    try:
        traj = build_trajectory(scene, robot, path, provenance, report)
    except InfeasiblePlan as exc:
        sys.stderr.write(f"snakeplan: no trajectory: {exc}\n")
        return EXIT_INFEASIBLE, None
    for filename in filenames:
        kind = write(traj, filename)
        sys.stderr.write(f"wrote {filename} ({kind}: {len(traj.t)} points, {traj.timing.duration_s:.2f} s, "
                         f"{traj.method})\n")
    return EXIT_OK, traj
