"""``snakeplan robot``: list the robot presets, or print a preset or robot file as snakeplan understands it."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from snakeplan.commands.common import EXIT_OK, print_json
from snakeplan.commands.inputs import load_robot


def add_parser(sub) -> None:
    p = sub.add_parser("robot", help="print a robot preset or what a robot file describes",
                       description="Print a robot (mm, rad, s): a preset, or a URDF, DH YAML or robot/1 JSON file "
                                   "as snakeplan understands it.")
    p.add_argument("name", nargs="?", metavar="NAME", help="preset name or robot file; omit to list the presets")
    p.add_argument("--json", action="store_true", help="print snakeplan.robot/1 JSON")
    p.set_defaults(func=cmd_robot)


def cmd_robot(args: argparse.Namespace) -> int:
    from snakeplan.robots import robot_names

    if args.name is None:
        sys.stdout.write("\n".join(robot_names()) + "\n")
        return EXIT_OK
    robot = load_robot(args.name, args.name if Path(args.name).suffix else "robot")  # an error names the file
    if args.json:
        print_json(robot.to_dict())
        return EXIT_OK
    from rich.console import Console
    from rich.table import Table

    sys.stdout.write(f"robot {robot.name}: {robot.n_sections} sections, {robot.total_length:g} mm, "
                     f"k_UL {robot.k_ul:.4g} /mm\n")
    table = Table()
    for col in ("section", "length (mm)", "radius (mm)", "max bend (deg)"):
        table.add_column(col, justify="right")
    for i, sec in enumerate(robot.sections):
        table.add_row(str(i), f"{sec.length:g}", f"{sec.radius:g}", f"{math.degrees(sec.max_bend):.1f}")
    lim = robot.limits
    feed = f"feed {robot.feed_range[0]:g}..{robot.feed_range[1]:g} mm, " if robot.has_feed else "no feed, "
    cables = (f"{len(robot.cables.names)} driving cables" if robot.cables is not None else "not cable-driven")
    Console().print(table)
    sys.stdout.write(f"{feed}{lim.feed_speed_mm_s:g} mm/s, {lim.feed_acceleration_mm_s2:g} mm/s^2; joints "
                     f"{lim.joint_rate_rad_s:g} rad/s, {lim.joint_acceleration_rad_s2:g} rad/s^2; {cables}\n")
    return EXIT_OK
