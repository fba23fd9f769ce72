"""What the commands share to send plans out to ROS 2 and Foxglove: ``--rosbag DIR`` (a bag ``ros2 bag play``
replays), ``--mcap FILE`` (a Foxglove file) and ``--live`` (a Foxglove WebSocket view while a plan or a benchmark
runs); the ``ros`` extra. Every output is checked before any work and written whole or not at all."""

from __future__ import annotations

import argparse
import ipaddress
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import NamedTuple

from snakeplan.commands.common import EXIT_INFEASIBLE, EXIT_OK, UsageError

#: The live view's default port (Foxglove's), and where it listens unless --live-host says otherwise.
LIVE_PORT, LOOPBACK = 8765, "127.0.0.1"
LIVE_HELP = ("serve a live Foxglove view (WebSocket, ws://127.0.0.1:PORT; open it in Foxglove with 'Open connection') "
             "of {what}")


def ros_args(p: argparse.ArgumentParser, what: str, live: str | None = None) -> None:
    """--rosbag, --storage and --mcap for ``what``; --live, --live-port and --live-host when ``live`` says what the
    live view shows."""
    g = p.add_argument_group("ROS 2 and Foxglove (pip install \"snakeplan[ros]\"; docs/ROS.md)")
    g.add_argument("--rosbag", metavar="DIR", help=f"also write {what} as a ROS 2 bag in the new folder DIR: joint "
                                                   "trajectory, /robot_description, /tf, the scene's markers, the "
                                                   "tip path (only a plan the judge accepts)")
    g.add_argument("--storage", choices=("mcap", "sqlite3"),  # ros.bag.STORAGES, without importing the ros extra
                   help="the bag's storage format (default mcap)")
    g.add_argument("--mcap", metavar="FILE", help=f"also write {what} as a Foxglove MCAP file (.mcap): the scene, "
                                                  "the arm moving, the judge's first failure marked")
    if live is not None:
        live_args(g, live)


def live_args(g, what: str) -> None:
    """--live, --live-port and --live-host, for a live view of ``what``."""
    g.add_argument("--live", action="store_true", help=LIVE_HELP.format(what=what))
    g.add_argument("--live-port", type=int, help=f"the live view's port (default {LIVE_PORT}; 0: any free one)")
    g.add_argument("--live-host", metavar="ADDRESS",
                   help="bind the live view to ADDRESS instead of 127.0.0.1: other machines can then connect, and the "
                        "view has no authentication")


def _given(args: argparse.Namespace, name: str):
    return getattr(args, name, None)


def wants_ros(args: argparse.Namespace) -> bool:
    return _given(args, "rosbag") is not None or _given(args, "mcap") is not None or bool(_given(args, "live"))


def _first_option(args: argparse.Namespace) -> str:
    return "--rosbag" if _given(args, "rosbag") is not None else "--mcap" if _given(args, "mcap") is not None else (
        "--live")


def check_ros(args: argparse.Namespace) -> None:
    """Refuse, before any work, ROS outputs that could not be written, options that belong to one not asked for, or
    a missing ``ros`` extra."""
    for option, needs in (("live_host", "live"), ("live_port", "live"), ("storage", "rosbag")):
        if _given(args, option) is not None and not _given(args, needs):
            raise UsageError(f"--{option.replace('_', '-')}: only with --{needs}")
    if not wants_ros(args):
        return
    from snakeplan.extras import require_ros
    from snakeplan.files import check_output
    from snakeplan.ros.bag import check_bag

    require_ros(_first_option(args))
    if _given(args, "rosbag") is not None:
        check_bag(args.rosbag)
    if _given(args, "mcap") is not None:
        check_output(args.mcap, "--mcap", (".mcap",))
    port = _given(args, "live_port")
    if port is not None and not 0 <= port <= 65535:
        raise UsageError(f"--live-port: {port} is not a port (0-65535)")


def check_ros_robot(args: argparse.Namespace, robot) -> None:
    """Refuse, before any work, ROS outputs for an arm they cannot show: the exports replay a fed arm's crawl, its
    sections two-angle joints."""
    if not wants_ros(args):
        return
    field = _first_option(args)
    if not robot.has_feed:
        raise UsageError(f"{field}: robot {robot.name} has no feed joint; the exports replay a fed arm's crawl")
    try:
        robot.universal_joints()
    except ValueError as exc:
        raise UsageError(f"{field}: {str(exc).removeprefix('robot: ')}") from None


class Recordings(NamedTuple):
    """A judged plan as the exports record it: ``for_bag`` the recording a bag may carry (None when the judge
    refuses the plan or the robot cannot execute it, ``why`` then says so); ``shown`` the one a Foxglove file or the
    live view shows (any judged plan, its first failure marked)."""

    for_bag: object | None
    why: str
    shown: object


def recordings(scene, robot, path, report, mission=None, trajectory=None) -> Recordings:
    """The :class:`Recordings` of a judged plan (``path`` and ``report``, or ``mission``); ``trajectory``: the
    plan's, when one was built already."""
    from snakeplan.ros import of_mission, of_plan, of_trajectory

    if mission is not None:
        shown = of_mission(scene, robot, mission, report)
        if report.failure is not None:
            return Recordings(None, f"the judge refuses the mission ({report.reason} at {report.failure.time_s:.2f} "
                                    "s)", shown)
        if not mission.motions:
            return Recordings(None, "the mission has no motion", shown)
        return Recordings(shown, "", shown)
    if trajectory is None and report.success:
        from snakeplan.trajectory import InfeasiblePlan, build_trajectory

        try:
            trajectory = build_trajectory(scene, robot, path, report=report)
        except InfeasiblePlan as exc:
            return Recordings(None, str(exc).removeprefix("plan: "), of_plan(scene, robot, path, report))
    if trajectory is None:
        return Recordings(None, f"the judge rejects it ({report.reason})", of_plan(scene, robot, path, report))
    rec = of_trajectory(scene, trajectory)
    return Recordings(rec, "", rec)


def write_ros(args: argparse.Namespace, scene, robot, path, report, mission=None, trajectory=None
              ) -> tuple[int, Recordings | None]:
    """Write the judged plan (``path`` and ``report``, or ``mission``) to --rosbag and --mcap as asked: (exit
    status, 1 with one line when a bag was asked for a plan that cannot be one; the recordings, None when neither
    was asked for)."""
    rosbag, mcap = _given(args, "rosbag"), _given(args, "mcap")
    if rosbag is None and mcap is None:
        return EXIT_OK, None
    made = recordings(scene, robot, path, report, mission, trajectory)
    status = EXIT_OK
    if mcap is not None:
        from snakeplan.ros.foxglove import write_mcap

        counts = write_mcap(made.shown, mcap)
        sys.stderr.write(f"wrote {mcap} (Foxglove MCAP: {sum(counts.values())} messages on {len(counts)} "
                         f"topics, {made.shown.duration_s:.2f} s)\n")
    if rosbag is not None:
        if made.for_bag is None:
            sys.stderr.write(f"snakeplan: no bag: {made.why}; a bag goes to the controllers, so it holds only a plan "
                             "the judge accepts and the robot can execute\n")
            status = EXIT_INFEASIBLE
        else:
            from snakeplan.ros.bag import write_bag

            storage = args.storage or "mcap"
            counts = write_bag(made.for_bag, rosbag, storage)
            sys.stderr.write(f"wrote {rosbag} (ROS 2 bag, {storage}: {sum(counts.values())} messages on "
                             f"{len(counts)} topics, {made.for_bag.duration_s:.2f} s)\n")
    return status, made


def _is_loopback(host: str) -> bool:
    try:
        return host == "localhost" or ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


@contextmanager
def serving(args: argparse.Namespace) -> Iterator[object | None]:
    """The live view --live asks for (or None) while the block runs, stopped after it however it ends."""
    view = live_view(args)
    try:
        yield view
    finally:
        if view is not None:
            view.stop()


def live_view(args: argparse.Namespace):
    """The live view --live asks for, started (its address on stderr), or None."""
    if not _given(args, "live"):
        return None
    from snakeplan.ros.foxglove import LiveView

    host = args.live_host or LOOPBACK
    port = LIVE_PORT if args.live_port is None else args.live_port
    if not _is_loopback(host):
        sys.stderr.write(f"snakeplan: warning: the live view listens on {host}, not loopback: other machines can "
                         "connect to it, without authentication\n")
    try:
        view = LiveView(host, port)
    except Exception as exc:  # the port is taken, the address is not this machine's
        raise UsageError(f"--live: cannot serve on {host}:{port}: {exc}") from None
    sys.stderr.write(f"live view: {view.url} (Foxglove: Open connection, Foxglove WebSocket)\n")
    return view


def live_rows(view):
    """The runner's ``on_row`` for a live view of a benchmark: each reach plan, judged again in its scene, shown
    as it is logged (its first failure marked); any other row as a line on ``/log``."""
    if view is None:
        return None
    import numpy as np

    from snakeplan.evaluation import evaluate
    from snakeplan.ros import of_plan

    def on_row(run, row) -> None:
        view.note(f"{run.label}: {row['status']}, {'success' if row['success'] else row['reason']}")
        if row.get("task", "reach") != "reach" or row.get("path") is None:
            return
        try:
            scene, robot = run.make_scene(), run.arm()
            path = np.asarray(row["path"], dtype=float)
            view.show(of_plan(scene, robot, path, evaluate(scene, robot, path)))
        except (ValueError, TypeError) as exc:  # an arm the exports cannot show: the benchmark goes on
            view.note(f"{run.label}: not shown: {exc}")

    return on_row
