"""``snakeplan demo``: the main job at a glance: plan the default robot into a fuel-tank scene with the default
planner, print the judge's metrics and write a picture."""

from __future__ import annotations

import argparse
import sys
import time

from snakeplan.commands.common import EXIT_INFEASIBLE, EXIT_OK, seed, status, where, why_line
from snakeplan.commands.inputs import load_planner, load_robot
from snakeplan.commands.options import DEFAULT_SCENE
from snakeplan.commands.views import check_picture, write_plot

#: Planning budget (s) of `snakeplan demo`, per call.
DEMO_TIME_LIMIT_S = 30.0


def add_parser(sub) -> None:
    p = sub.add_parser("demo", help="the main job: plan the arm into a fuel tank, judge it, draw it",
                       description="Plan sjtu-snake-iii into a fuel-tank scene with the default planner, print "
                                   "the judge's metrics and write a picture.")
    p.add_argument("--seed", type=seed, default=0, help="scene seed (default 0)")
    p.add_argument("--out", default="snakeplan-demo.png", help="output PNG (default snakeplan-demo.png)")
    p.set_defaults(func=cmd_demo)


def cmd_demo(args: argparse.Namespace) -> int:
    from snakeplan.episode import run_episode
    from snakeplan.planners import Problem
    from snakeplan.scenes import make_scene, scene_spec

    check_picture(args.out, "--out")
    scene, spec = make_scene(DEFAULT_SCENE, args.seed), scene_spec(DEFAULT_SCENE)
    robot = load_robot(spec.robot)
    planner = load_planner(spec.planner)
    problem = Problem(scene, robot, time_limit_s=DEMO_TIME_LIMIT_S)
    wall = time.perf_counter()
    planner.plan(problem, seed=0)  # on a fresh install this compiles the jitted kernels (cached on disk)
    wall = time.perf_counter() - wall
    episode = run_episode(problem, planner)
    plan = episode.plan
    sys.stdout.write(f"{robot.name} in {where(scene)}, planned by {plan.planner}: {status(plan)} "
                     f"in {plan.compute_time_s:.3f} s (the first call took {wall:.2f} s of wall time, loading or "
                     f"compiling the kernels)\n{why_line(plan)}")
    if episode.report is None:
        return EXIT_INFEASIBLE
    sys.stdout.write("\n".join(episode.report.lines()) + "\n")
    write_plot(args.out, scene, robot, plan.path, episode.report, plan.planner)
    sys.stdout.write(f"wrote {args.out}\n")
    return EXIT_OK if episode.success else EXIT_INFEASIBLE
