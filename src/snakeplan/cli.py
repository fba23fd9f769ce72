"""The ``snakeplan`` command: scenes, robots, judging tip paths, pictures, benchmarks.

Exit status: 0 success, 1 when a judged plan is infeasible, 2 for bad input (one line on stderr naming the
field and the problem; never a traceback for a user's mistake), 130 when interrupted (Ctrl-C). Output paths are
checked before any work starts. JSON output: docs/ARCHITECTURE.md, "JSON schemas".

This module assembles the parser from the command modules (:mod:`snakeplan.commands`) and turns what a command
raises into its exit status; the commands parse, call the layers below and print.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from collections.abc import Callable

from snakeplan.commands import bench, check, demo, export, plan, robot, scene, show, train, trajectory
from snakeplan.commands import compile as compile_command
from snakeplan.commands.common import EXIT_OK, EXIT_USAGE, Parser, UsageError, warning_line
from snakeplan.extras import MissingExtra
from snakeplan.interrupt import interruption, report as report_interrupt


def build_parser() -> argparse.ArgumentParser:
    """The parser of every command but ``scene import`` (a parser of its own)."""
    from snakeplan import __version__

    parser = Parser(prog="snakeplan", description="Motion planning for snake-arm robots (mm, rad, s).",
                    epilog="Run 'snakeplan COMMAND --help' for a command's options.")
    parser.add_argument("--version", action="version", version=f"snakeplan {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser, metavar="COMMAND")
    for module in (scene, robot, check, show, demo, plan):
        module.add_parser(sub)
    compile_command.add_parser(sub, main)  # the recording runs the workload's commands through main
    for module in (trajectory, export, bench, train):
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)

    def command() -> int:
        if argv[:2] == ["scene", "import"]:  # its own parser, --help included
            return scene.cmd_scene_import(argv[2:])
        args, extra = build_parser().parse_known_args(argv)
        if extra and not getattr(args, "takes_options", False):
            raise UsageError(f"unrecognized arguments: {' '.join(extra)}")
        args.extra = extra
        return args.func(args)

    return _run(command)


def trainer_main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m snakeplan.rl.train`` (the command shipped policies record): ``snakeplan train
    rl`` with the trainer options among its own (:func:`snakeplan.commands.train.trainer_parser`)."""
    argv = sys.argv[1:] if argv is None else list(argv)

    def command() -> int:
        args = train.trainer_parser().parse_args(argv)
        args.extra = []
        return args.func(args)

    return _run(command)


#: Exit status when the output's reader went away: 128 + SIGPIPE, as a tool killed by it.
EXIT_BROKEN_PIPE = 141


def _run(command: Callable[[], int]) -> int:
    """Run a parsed command's handler: its exit status, one line and 2 for a user's mistake, 130 when
    interrupted; warnings as one line each."""
    try:
        with warnings.catch_warnings():
            warnings.showwarning = warning_line
            return int(command())
    except BrokenPipeError:  # the reader of the output went away (| head): stop as a Unix tool does, not as success
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error flushing at exit
        return EXIT_BROKEN_PIPE
    except BaseException as exc:
        stop = interruption(exc)
        if stop is not None:
            return report_interrupt(stop)
        if isinstance(exc, (UsageError, MissingExtra)):
            return _fail(str(exc))
        if isinstance(exc, (ValueError, KeyError)):
            return _fail(str(exc.args[0]) if exc.args else exc.__class__.__name__)
        raise


def _fail(message: str) -> int:
    sys.stderr.write(f"snakeplan: error: {message}\n")
    return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
