"""``snakeplan check``: judge a tip path made elsewhere (exit 0 feasible, 1 infeasible, 2 bad input)."""

from __future__ import annotations

import argparse
import sys

from snakeplan.commands.common import EXIT_INFEASIBLE, EXIT_OK, print_json
from snakeplan.commands.inputs import load_path_file, load_scene, robot_for
from snakeplan.commands.options import ROBOT_HELP, scene_args, view_args
from snakeplan.commands.views import check_picture, check_views, write_plot, write_views


def add_parser(sub) -> None:
    p = sub.add_parser("check", help="judge a tip path made elsewhere",
                       description="Judge a tip path ({\"path\": [[x, y, z], ...]}, any plan file will do) with "
                                   "snakeplan's judge. Exit 0 feasible, 1 infeasible, 2 bad input.")
    scene_args(p)
    p.add_argument("--robot", help=ROBOT_HELP)
    p.add_argument("--json", action="store_true", help="print the verdict as JSON")
    p.add_argument("--plot", help="also write a PNG picture of the judged path")
    view_args(p, "the arm crawling along the path")
    p.add_argument("path_file", metavar="PATH.json", help="the tip path file ('-' reads standard input)")
    p.set_defaults(func=cmd_check)


def cmd_check(args: argparse.Namespace) -> int:
    from snakeplan.episode import check_document
    from snakeplan.evaluation import evaluate

    check_picture(args.plot, "--plot")
    check_views(args)
    scene = load_scene(args)
    robot = robot_for(args, scene)
    path = load_path_file(args.path_file)
    report = evaluate(scene, robot, path)
    if args.plot:
        write_plot(args.plot, scene, robot, path, report)
    write_views(args, scene, robot, path, report)
    if args.json:
        print_json(check_document(scene, robot, report))
    else:
        sys.stdout.write("\n".join(report.lines()) + "\n")
    return EXIT_OK if report.success else EXIT_INFEASIBLE
