"""``snakeplan show``: draw a scene, optionally with a tip path judged and the arm's body at its end, to a PNG."""

from __future__ import annotations

import argparse
import sys

from snakeplan.commands.common import EXIT_OK, UsageError
from snakeplan.commands.inputs import load_path_file, scene_and_robot
from snakeplan.commands.options import ROBOT_HELP, scene_args, view_args
from snakeplan.commands.views import check_picture, check_views, write_plot, write_views


def add_parser(sub) -> None:
    p = sub.add_parser("show", help="draw a scene (and a path) to a PNG",
                       description="Draw a scene, optionally with a tip path and the arm's body at its end.")
    scene_args(p)
    p.add_argument("--robot", help=ROBOT_HELP)
    p.add_argument("--path", help="a tip path JSON file to draw and judge")
    p.add_argument("--out", default="scene.png", help="output PNG (default scene.png)")
    view_args(p, "the arm crawling along --path")
    p.set_defaults(func=cmd_show)


def cmd_show(args: argparse.Namespace) -> int:
    check_picture(args.out, "--out")
    if args.path is None and (args.animate or args.html):
        raise UsageError(f"{'--animate' if args.animate else '--html'}: needs --path (a crawl to show)")
    check_views(args)
    scene, robot = scene_and_robot(args)
    path = load_path_file(args.path) if args.path else None
    report = None
    if path is not None:
        from snakeplan.evaluation import evaluate

        report = evaluate(scene, robot, path)
    write_plot(args.out, scene, robot, path, report)
    sys.stdout.write(f"wrote {args.out}\n")
    write_views(args, scene, robot, path, report)
    return EXIT_OK
