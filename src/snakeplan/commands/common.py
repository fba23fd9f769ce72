"""What every command shares: exit statuses, the one-line usage error, argument types and printing."""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from typing import Any, NoReturn

from snakeplan.jsonable import jsonable

EXIT_OK, EXIT_INFEASIBLE, EXIT_USAGE = 0, 1, 2


class UsageError(Exception):
    """A user's mistake: reported as one line, exit status 2."""


#: What argparse takes for a value, not an option, although it starts with '-': a negative number, or a list of
#: numbers that starts with one (``-300,180,100``: a point left of the origin).
NEGATIVE_VALUES = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?(,[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?)*$")


class Parser(argparse.ArgumentParser):
    """An argument parser whose mistakes are a :class:`UsageError` (one line) instead of usage and a message, and
    that reads a value starting with a negative number (``--target -300,180,100``) as the option's value."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_VALUES

    def error(self, message: str) -> NoReturn:
        raise UsageError(message)


def seed(text: str) -> int:
    """A non-negative integer (a seed)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {value}")
    return value


def finite(text: str) -> float:
    """A finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def frame_size(text: str) -> tuple[int, int]:
    """A video frame size ``WIDTHxHEIGHT`` in pixels."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels, e.g. 960x540, got {text!r}") from None
    return w, h


def name_list(text: str, known: list[str], field: str) -> tuple[str, ...]:
    """The comma-separated names in ``text``, each one of ``known``."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in known]
    if not names or unknown:
        raise UsageError(f"{field}: unknown {', '.join(unknown) or 'empty list'} (known: {', '.join(known)})")
    return names


def seed_list(text: str, field: str) -> tuple[int, ...]:
    """Seeds from ``0-9``, ``3`` or ``0,2,5-7``."""
    seeds: list[int] = []
    for part in text.split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            first, last = int(lo), int(hi) if sep else int(lo)
        except ValueError:
            raise UsageError(f"{field}: expected seeds like 0-9 or 0,3,5-7, got {text!r}") from None
        if first < 0 or last < first:
            raise UsageError(f"{field}: expected seeds like 0-9 or 0,3,5-7, got {text!r}")
        seeds += range(first, last + 1)
    return tuple(dict.fromkeys(seeds))


def print_json(obj: Any) -> None:
    sys.stdout.write(json.dumps(jsonable(obj), indent=2, allow_nan=False) + "\n")


def as_option(message: str) -> str:
    """A planner's message about its ``policy`` (the file it rolls out) as the command line names it: ``--policy``."""
    return f"--{message}" if message.startswith("policy:") else message


def warning_line(message, category, filename, lineno, file=None, line=None) -> None:
    """Print a warning raised while planning as one line (``snakeplan: warning: ...``)."""
    sys.stderr.write(f"snakeplan: warning: {as_option(str(message))}\n")


def status(plan) -> str:
    """The plan's status, with what stopped the planner when the path is only approximate."""
    stopped = plan.details.get("stopped")
    return f"{plan.status} (stopped: {stopped})" if stopped else str(plan.status)


def why_line(plan) -> str:
    """The console line saying why a plan ended so ("why: ..."), or "" for a found plan that gives none."""
    return f"why: {plan.why}\n" if plan.why else ""


def optimize_line(plan) -> str:
    """The console line saying what the path optimiser did ("optimize: ..."), or "" where it did not run."""
    done = plan.details.get("optimize")
    if not done:
        return ""
    b, a = done["before"]["smoothness_index"], done["after"]["smoothness_index"]
    what = (f"smoothness {b:.3f} -> {a:.3f}, length {done['before']['length_mm']:.0f} -> "
            f"{done['after']['length_mm']:.0f} mm" if done["kept"] else "no smoother path cleared the checks; "
                                                                       "the planner's path is kept")
    return f"optimize ({done['level']}): {what} ({done['checks']} crawl checks, {1e3 * done['time_s']:.1f} ms)\n"


def where(scene) -> str:
    """A scene as the console names it: "fuel-tank (seed 3)", "confined (seed 3, sized to a 1920 mm arm)" (see
    :mod:`snakeplan.scenes.sizing`), or a file scene's name alone (it has no seed)."""
    from snakeplan.scenes import scene_sizing

    if scene.seed is None:
        return scene.name
    sized = dict(scene_sizing(scene))
    return f"{scene.name} (seed {scene.seed}" + (f", sized to a {sized['arm_length_mm']:g} mm arm)" if sized else ")")
