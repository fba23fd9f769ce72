"""Option groups several commands take: the scene (--scene, --seed, --scene-file), the robot, a crawl's video and
page (--animate, --html and the video's options), trajectory files, and the backend batches run on (--workers,
--ray)."""

from __future__ import annotations

import argparse

from snakeplan.commands.common import finite, frame_size, seed

DEFAULT_SCENE = "fuel-tank"
ROBOT_HELP = ("robot preset, or a robot file: .urdf, DH .yaml or robot/1 .json (default: the one the scene is sized "
              "for, e.g. sjtu-snake-iii)")
TRAJECTORY_HELP = ("write the judged plan's trajectory (feed, joints, cables over time) to FILE: .json "
                   "snakeplan.trajectory/1, .csv, or .ros.json / .yaml (ROS JointTrajectory); may be repeated")


def scene_args(p: argparse.ArgumentParser) -> None:
    """--scene, --seed and --scene-file."""
    p.add_argument("--scene", default=DEFAULT_SCENE,
                   help=f"scene name (default {DEFAULT_SCENE}); 'snakeplan scene --list' lists them")
    p.add_argument("--seed", type=seed, default=0, help="scene seed (default 0)")
    p.add_argument("--scene-file", help="a scene JSON file (snakeplan.scene/1) instead of --scene/--seed")


def plan_scene_args(p: argparse.ArgumentParser, fallback: bool = False) -> None:
    """--scene, --seed and --scene-file for a command that reads a plan file: each defaults to the plan's scene
    (``fallback``: then to the default scene, for a bare path file)."""
    also = f", else {DEFAULT_SCENE}" if fallback else ""
    p.add_argument("--scene", help=f"scene name (default: the plan's{also}); 'snakeplan scene --list' lists them")
    p.add_argument("--seed", type=seed, help=f"scene seed (default: the plan's{', else 0' if fallback else ''})")
    p.add_argument("--scene-file", help="a scene JSON file (snakeplan.scene/1) instead of the plan's scene")


def view_args(p: argparse.ArgumentParser, what: str) -> None:
    """--animate, --html and the video's options, on the commands that show a crawl."""
    p.add_argument("--animate", metavar="FILE", help=f"also write a video of {what}: .mp4 (H.264) or .gif")
    p.add_argument("--frames", type=int, default=120, help="frames in the video (default 120)")
    p.add_argument("--fps", type=finite, default=30.0, help="frames per second of the video (default 30)")
    p.add_argument("--frame-size", type=frame_size, default=(960, 540), metavar="WxH",
                   help="the video's frame size in pixels, both even (default 960x540)")
    p.add_argument("--html", metavar="FILE", help=f"also write an interactive 3-D page of {what} (.html: one "
                                                  "self-contained file that opens offline in any browser)")


def backend_args(p: argparse.ArgumentParser) -> None:
    """--workers and --ray: where batches of tasks run."""
    p.add_argument("--workers", type=int, help="worker processes (default: the usable cores; 1: serial, in "
                                               "this process)")
    p.add_argument("--ray", metavar="ADDRESS", help="run on Ray: 'local' starts an instance on this machine, "
                                                    "'auto' or HOST:PORT joins a cluster (the cluster extra)")


def backend(args: argparse.Namespace):
    """The runner's backend from --workers and --ray (a HOST:PORT that nothing answers at is refused here, before
    anything is written)."""
    from snakeplan.parallel import backend_from, check_ray_address

    if args.ray:
        from snakeplan.extras import require_cluster

        require_cluster("--ray")
        check_ray_address(args.ray)
    return backend_from(args.workers, args.ray)
