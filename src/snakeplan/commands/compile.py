"""``snakeplan compile``: compile the kernels the commands call ahead of time (:mod:`snakeplan.precompile`), or
remove the compiled module."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from functools import partial

from snakeplan.commands.common import EXIT_OK, UsageError


def add_parser(sub, run: Callable[[list[str]], int]) -> None:
    """``run``: the command line's entry point (:func:`snakeplan.cli.main`), which the recording runs the workload's
    commands through; handed down so that no module below :mod:`snakeplan.cli` imports it."""
    p = sub.add_parser("compile", help="compile the kernels ahead of time, so that commands start without numba",
                       description="Run each scene family's plan command (and every planner on fuel-tank) once, "
                                   "recording the kernels they call, and compile those into one module in the "
                                   "cache folder ($SNAKEPLAN_CACHE_DIR, else ~/.cache/snakeplan). Commands then "
                                   "load it instead of numba while snakeplan's sources match it. Needs a C "
                                   "compiler; takes about two minutes.")
    p.add_argument("--scene", action="append", help="only this scene family's commands (may be repeated)")
    p.add_argument("--remove", action="store_true", help="delete the compiled module")
    p.set_defaults(func=partial(cmd_compile, run=run))


def cmd_compile(args: argparse.Namespace, run: Callable[[list[str]], int]) -> int:
    from snakeplan import precompile
    from snakeplan.jit import compiled_dir

    if args.remove:
        found = precompile.remove()
        sys.stdout.write(f"{'removed' if found else 'there was no'} compiled module in {compiled_dir()}\n")
        return EXIT_OK
    from snakeplan.scenes import scene_names

    for name in args.scene or []:
        if name not in scene_names():
            raise UsageError(f"--scene: unknown scene family {name!r} (known: {', '.join(scene_names())})")
    return precompile.main(args.scene, run)
