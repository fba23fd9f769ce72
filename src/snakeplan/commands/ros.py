"""What the commands share to send plans out to ROS 2 and Foxglove: ``--rosbag DIR`` (a bag ``ros2 bag play``
replays), ``--mcap FILE`` (a Foxglove file) and ``--live`` (a Foxglove WebSocket view while a plan or a benchmark
runs); the ``ros`` extra. Every output is checked before any work and written whole or not at all."""

from __future__ import annotations

import argparse
import sys

from snakeplan.commands.common import EXIT_INFEASIBLE, EXIT_OK, UsageError

LIVE_HELP = ("serve a live Foxglove view (WebSocket, ws://127.0.0.1:PORT; open it in Foxglove with 'Open connection') "
             "of {what} while it runs; Ctrl-C stops it")


def ros_args(p: argparse.ArgumentParser, what: str, live: str | None = None) -> None:
    """--rosbag, --storage and --mcap for ``what``; --live, --live-port and --live-host when ``live`` says what the
    live view shows."""
    g = p.add_argument_group("ROS 2 and Foxglove (pip install \"snakeplan[ros]\"; docs/ROS.md)")
    g.add_argument("--rosbag", metavar="DIR", help=f"also write {what} as a ROS 2 bag in the new folder DIR: joint "
                                                   "trajectory, /robot_description, /tf, the scene's markers, the "
                                                   "tip path (only a plan the judge accepts)")
    g.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap",
                   help="the bag's storage format (default mcap)")
    g.add_argument("--mcap", metavar="FILE", help=f"also write {what} as a Foxglove MCAP file (.mcap): the scene, "
                                                  "the arm moving, the judge's first failure marked")
    if live is not None:
        live_args(g, live)


def live_args(g, what: str) -> None:
    """--live, --live-port and --live-host, for a live view of ``what``."""
    g.add_argument("--live", action="store_true", help=LIVE_HELP.format(what=what))
    g.add_argument("--live-port", type=int, default=8765, help="the live view's port (default 8765; 0: any free one)")
    g.add_argument("--live-host", metavar="ADDRESS",
                   help="bind the live view to ADDRESS instead of 127.0.0.1: other machines can then connect, and the "
                        "view has no authentication")


def wants_ros(args: argparse.Namespace) -> bool:
    return bool(getattr(args, "rosbag", None) or getattr(args, "mcap", None) or getattr(args, "live", False))


def check_ros(args: argparse.Namespace) -> None:
    """Refuse, before any work, ROS outputs that could not be written, or a missing ``ros`` extra."""
    if getattr(args, "live_host", None) and not args.live:
        raise UsageError("--live-host: only with --live")
    if not wants_ros(args):
        return
    from snakeplan.extras import require_ros
    from snakeplan.files import check_output
    from snakeplan.ros.bag import check_bag

    rosbag, mcap = getattr(args, "rosbag", None), getattr(args, "mcap", None)
    require_ros("--rosbag" if rosbag else "--mcap" if mcap else "--live")
    if rosbag:
        check_bag(rosbag)
    if mcap:
        if not mcap.lower().endswith(".mcap"):
            raise UsageError(f"--mcap: {mcap!r} must end in .mcap")
        check_output(mcap, "--mcap")
    if getattr(args, "live", False) and not 0 <= args.live_port <= 65535:
        raise UsageError(f"--live-port: {args.live_port} is not a port (0-65535)")


def recordings(scene, robot, path, report, mission=None, trajectory=None):
    """(the recording a bag may carry: None when the judge refuses the plan or the robot cannot execute it, with
    why; the recording a Foxglove file shows: any judged plan, its first failure marked)."""
    from snakeplan.ros import of_mission, of_plan, of_trajectory

    if mission is not None:
        shown = of_mission(scene, robot, mission, report)
        if report.failure is not None:
            return (None, f"the judge refuses the mission ({report.reason} at {report.failure.time_s:.2f} s)"), shown
        return (shown, ""), shown
    if trajectory is None and report.success:
        from snakeplan.trajectory import InfeasiblePlan, build_trajectory

        try:
            trajectory = build_trajectory(scene, robot, path, report=report)
        except InfeasiblePlan as exc:
            return (None, str(exc).removeprefix("plan: ")), of_plan(scene, robot, path, report)
    if trajectory is None:
        return (None, f"the judge rejects it ({report.reason})"), of_plan(scene, robot, path, report)
    rec = of_trajectory(scene, trajectory)
    return (rec, ""), rec


def write_ros(args: argparse.Namespace, scene, robot, path, report, mission=None, trajectory=None) -> int:
    """Write the judged plan (``path`` and ``report``, or ``mission``) to --rosbag and --mcap as asked; exit status
    1 (one line) when a bag was asked for a plan that cannot be one."""
    if not (args.rosbag or args.mcap):
        return EXIT_OK
    (for_bag, why), shown = recordings(scene, robot, path, report, mission, trajectory)
    status = EXIT_OK
    if args.mcap:
        from snakeplan.ros.foxglove import write_mcap

        counts = write_mcap(shown, args.mcap)
        sys.stderr.write(f"wrote {args.mcap} (Foxglove MCAP: {sum(counts.values())} messages on {len(counts)} "
                         f"topics, {shown.duration_s:.2f} s)\n")
    if args.rosbag:
        if for_bag is None:
            sys.stderr.write(f"snakeplan: no bag: {why}; only a plan the judge accepts goes to the controllers\n")
            status = EXIT_INFEASIBLE
        else:
            from snakeplan.ros.bag import write_bag

            counts = write_bag(for_bag, args.rosbag, args.storage)
            sys.stderr.write(f"wrote {args.rosbag} (ROS 2 bag, {args.storage}: {sum(counts.values())} messages on "
                             f"{len(counts)} topics, {for_bag.duration_s:.2f} s)\n")
    return status


def live_view(args: argparse.Namespace):
    """The live view --live asks for, started (its address on stderr), or None."""
    if not getattr(args, "live", False):
        return None
    from snakeplan.ros.foxglove import LOOPBACK, LiveView

    host = args.live_host or LOOPBACK
    if host != LOOPBACK:
        sys.stderr.write(f"snakeplan: warning: the live view listens on {host}, not loopback: other machines can "
                         "connect to it, without authentication\n")
    try:
        view = LiveView(host, args.live_port)
    except Exception as exc:  # the port is taken, the address is not this machine's
        raise UsageError(f"--live: cannot serve on {host}:{args.live_port}: {exc}") from None
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
        line = f"{run.label}: {row['status']}, {'success' if row['success'] else row['reason']}"
        if row.get("task", "reach") != "reach" or row.get("path") is None:
            view.note(line)
            return
        scene, robot = run.make_scene(), run.arm()
        path = np.asarray(row["path"], dtype=float)
        view.note(line)
        view.show(of_plan(scene, robot, path, evaluate(scene, robot, path)))

    return on_row
