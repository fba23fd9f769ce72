"""The ``snakeplan`` command: scenes, robots, judging tip paths, pictures, benchmarks.

Exit status: 0 success, 1 when a judged plan is infeasible, 2 for bad input (one line on stderr naming the
field and the problem; never a traceback for a user's mistake), 130 when interrupted (Ctrl-C). Output paths are
checked before any work starts. JSON output: docs/ARCHITECTURE.md, "JSON schemas".
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from snakeplan.extras import MissingExtra, require_training
from snakeplan.files import check_output
from snakeplan.interrupt import interruption, report as report_interrupt
from snakeplan.jsonable import jsonable

EXIT_OK, EXIT_INFEASIBLE, EXIT_USAGE = 0, 1, 2
#: Insertion depths the interactive page's slider steps through.
HTML_FRAMES = 121
DEFAULT_SCENE = "fuel-tank"
#: Planning budget (s) of `snakeplan demo`, per call.
DEMO_TIME_LIMIT_S = 30.0
ROBOT_HELP = ("robot preset, or a robot file: .urdf, DH .yaml or robot/1 .json (default: the one the scene is sized "
              "for, e.g. sjtu-snake-iii)")
TRAJECTORY_HELP = ("write the judged plan's trajectory (feed, joints, cables over time) to FILE: .json "
                   "snakeplan.trajectory/1, .csv, or .ros.json / .yaml (ROS JointTrajectory); may be repeated")


class UsageError(Exception):
    """A user's mistake: reported as one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line instead of usage + message
        raise UsageError(message)


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {value}")
    return value


def _print_json(obj: Any) -> None:
    sys.stdout.write(json.dumps(jsonable(obj), indent=2, allow_nan=False) + "\n")


# --- loading inputs ----------------------------------------------------------------------------------------
def _load_scene(args: argparse.Namespace):
    from snakeplan.scenes import Scene, make_scene

    if getattr(args, "scene_file", None):
        return Scene.from_json(_read_text(args.scene_file, "--scene-file"), "--scene-file",
                               _scene_dir(args.scene_file))
    try:
        return make_scene(args.scene, args.seed)
    except KeyError as exc:
        raise UsageError(f"--scene: {exc.args[0]}") from None


def _scene_dir(filename: str) -> Path:
    """The folder a scene file's mesh files are read relative to (the working directory for standard input)."""
    return Path(".") if filename == "-" else Path(filename).parent


def _robot_for(args: argparse.Namespace, scene):
    """The robot named by --robot (a preset or a robot file), else the one the scene's spec says it is sized for."""
    from snakeplan.scenes import spec_for

    return _load_robot(args.robot or spec_for(scene).robot)


def _load_robot(spec: str, field: str = "--robot"):
    from snakeplan.robots import load_robot

    try:
        return load_robot(spec)
    except (KeyError, ValueError) as exc:
        raise UsageError(f"{field}: {exc.args[0]}") from None


def _read_text(filename: str, field: str) -> str:
    """The UTF-8 text of ``filename`` ('-': standard input), at most :data:`snakeplan.inputs.MAX_INPUT_BYTES`."""
    from snakeplan.inputs import MAX_INPUT_BYTES

    where = "standard input" if filename == "-" else filename if filename.isprintable() else repr(filename)
    try:
        if filename == "-":
            data = sys.stdin.buffer.read(MAX_INPUT_BYTES + 1)
        else:
            with open(filename, "rb") as f:
                data = f.read(MAX_INPUT_BYTES + 1)
    except FileNotFoundError:
        raise UsageError(f"{field}: file not found: {where}") from None
    except OSError as exc:
        raise UsageError(f"{field}: cannot read {where}: {exc.__class__.__name__}") from None
    if len(data) > MAX_INPUT_BYTES:
        raise UsageError(f"{field}: {where} is larger than the {MAX_INPUT_BYTES // 2**20} MiB limit")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise UsageError(f"{field}: {where} is not UTF-8 text (byte {exc.start})") from None


def load_path_file(filename: str) -> np.ndarray:
    """Read ``{"path": [[x, y, z], ...]}`` (any plan file will do: other fields are ignored); at least 2 points of
    real numbers. ValueError names the field (``path[3][1]``), or ``PATH`` for the file as a whole."""
    from snakeplan.inputs import load_json, points, show

    data = load_json(_read_text(filename, "PATH"), "PATH")
    if not isinstance(data, dict):
        raise ValueError(f'PATH: expected an object with a "path" list of [x, y, z], got {show(data)}')
    if "path" not in data:
        raise ValueError('path: missing; PATH must hold an object with a "path" list of [x, y, z]')
    return points(data["path"], "path", min_count=2)


# --- commands ----------------------------------------------------------------------------------------------
def cmd_scene(args: argparse.Namespace) -> int:
    scene = _load_scene(args)
    if args.json:
        _print_json(scene.to_dict())
        return EXIT_OK
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"scene {scene.name} (seed {scene.seed})", show_header=False)
    table.add_row("bounds (mm)", f"{scene.bounds_min.tolist()} .. {scene.bounds_max.tolist()}")
    table.add_row("entrance (mm)", f"{np.round(scene.entrance.position, 1).tolist()} "
                                   f"dir {np.round(scene.entrance.direction, 3).tolist()}")
    table.add_row("targets (mm)", "\n".join(str(np.round(t, 1).tolist()) for t in scene.targets) or "none")
    kinds: dict[str, int] = {}
    for o in scene.obstacles:
        kinds[o.type] = kinds.get(o.type, 0) + 1
    table.add_row("obstacles", ", ".join(f"{n} {k}" for k, n in kinds.items()))
    Console().print(table)
    return EXIT_OK


def cmd_robot(args: argparse.Namespace) -> int:
    from snakeplan.robots import robot_names

    if args.name is None:
        sys.stdout.write("\n".join(robot_names()) + "\n")
        return EXIT_OK
    robot = _load_robot(args.name, "NAME")
    if args.json:
        _print_json(robot.to_dict())
        return EXIT_OK
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"robot {robot.name}: {robot.n_sections} sections, {robot.total_length:g} mm, "
                        f"k_UL {robot.k_ul:g} /mm")
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


def _report_lines(report) -> list[str]:
    m = report.metrics()
    lines = [f"verdict: {'feasible' if report.success else 'infeasible'} ({report.reason})"]
    for key, value in m.items():
        lines.append(f"  {key:24s} {value:.6g}" if isinstance(value, float) else f"  {key:24s} {value}")
    return lines


def cmd_check(args: argparse.Namespace) -> int:
    from snakeplan.episode import check_document
    from snakeplan.evaluation import evaluate

    _check_picture(args.plot, "--plot")
    _check_views(args)
    scene = _load_scene(args)
    robot = _robot_for(args, scene)
    path = load_path_file(args.path_file)
    report = evaluate(scene, robot, path)
    if args.plot:
        _write_plot(args.plot, scene, robot, path, report)
    _write_views(args, scene, robot, path, report)
    if args.json:
        _print_json(check_document(scene, robot, report))
    else:
        sys.stdout.write("\n".join(_report_lines(report)) + "\n")
    return EXIT_OK if report.success else EXIT_INFEASIBLE


def _write_plot(filename: str, scene, robot, path, report, planner: str = "") -> None:
    from snakeplan.viz.figures import save_plan_figure

    save_plan_figure(filename, scene, robot, path, report, planner)


def _check_picture(filename: str | None, field: str) -> None:
    """Refuse a picture path that could not be written, before any work is done."""
    if filename is not None:
        check_output(filename, field, (".png",))


def _frame_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels, e.g. 960x540, got {text!r}") from None
    return w, h


def _view_args(p: argparse.ArgumentParser, what: str) -> None:
    """--animate, --html and the video's options, on the commands that show a crawl."""
    p.add_argument("--animate", metavar="FILE", help=f"also write a video of {what}: .mp4 (H.264) or .gif")
    p.add_argument("--frames", type=int, default=120, help="frames in the video (default 120)")
    p.add_argument("--fps", type=_finite, default=30.0, help="frames per second of the video (default 30)")
    p.add_argument("--frame-size", type=_frame_size, default=(960, 540), metavar="WxH",
                   help="the video's frame size in pixels, both even (default 960x540)")
    p.add_argument("--html", metavar="FILE", help=f"also write an interactive 3-D page of {what} (.html: one "
                                                  "self-contained file that opens offline in any browser)")


def _check_views(args: argparse.Namespace) -> None:
    """Refuse a video or page that could not be written, before any work is done."""
    if args.animate is not None:
        from snakeplan.viz.animation import check_video_options

        check_output(args.animate, "--animate", (".mp4", ".gif"))
        check_video_options(args.animate, args.frames, args.fps, args.frame_size, "--animate")
    if args.html is not None:
        check_output(args.html, "--html", (".html", ".htm"))


def _write_views(args: argparse.Namespace, scene, robot, path, report, planner: str = "") -> None:
    """Write the video and the page a command was asked for (each says on stderr what it wrote, or why not)."""
    if args.animate is None and args.html is None:
        return
    if path is None:
        sys.stderr.write("snakeplan: no video or page: there is no path to show\n")
        return
    from snakeplan.viz.crawl import crawl_frames

    if args.animate is not None:
        from snakeplan.viz.animation import save_crawl_video

        frames = crawl_frames(scene, robot, path, args.frames, report)
        save_crawl_video(args.animate, frames, args.fps, args.frame_size, planner, progress=sys.stderr.isatty())
        sys.stderr.write(f"wrote {args.animate} ({len(frames.depths)} frames at {args.fps:g} fps)\n")
    if args.html is not None:
        from snakeplan.viz.page import save_crawl_page

        save_crawl_page(args.html, crawl_frames(scene, robot, path, HTML_FRAMES, report), planner)
        sys.stderr.write(f"wrote {args.html}\n")


def cmd_show(args: argparse.Namespace) -> int:
    _check_picture(args.out, "--out")
    if args.path is None and (args.animate or args.html):
        raise UsageError(f"{'--animate' if args.animate else '--html'}: needs --path (a crawl to show)")
    _check_views(args)
    scene = _load_scene(args)
    robot = _robot_for(args, scene)
    path = load_path_file(args.path) if args.path else None
    report = None
    if path is not None:
        from snakeplan.evaluation import evaluate

        report = evaluate(scene, robot, path)
    _write_plot(args.out, scene, robot, path, report)
    sys.stdout.write(f"wrote {args.out}\n")
    _write_views(args, scene, robot, path, report)
    return EXIT_OK


def cmd_demo(args: argparse.Namespace) -> int:
    from snakeplan.episode import run_episode
    from snakeplan.planners import Problem
    from snakeplan.scenes import make_scene, scene_spec

    _check_picture(args.out, "--out")
    scene, spec = make_scene(DEFAULT_SCENE, args.seed), scene_spec(DEFAULT_SCENE)
    robot = _load_robot(spec.robot)
    planner = _load_planner(spec.planner)
    problem = Problem(scene, robot, time_limit_s=DEMO_TIME_LIMIT_S)
    first = planner.plan(problem, seed=0)  # on a fresh install this compiles the jitted kernels (cached on disk)
    episode = run_episode(problem, planner)
    plan = episode.plan
    sys.stdout.write(f"{robot.name} in {scene.name} (seed {scene.seed}), planned by {plan.planner}: {_status(plan)} "
                     f"in {plan.compute_time_s:.3f} s (first call, with kernel compilation: "
                     f"{first.compute_time_s:.3f} s)\n")
    if episode.report is None:
        return EXIT_INFEASIBLE
    sys.stdout.write("\n".join(_report_lines(episode.report)) + "\n")
    _write_plot(args.out, scene, robot, plan.path, episode.report, plan.planner)
    sys.stdout.write(f"wrote {args.out}\n")
    return EXIT_OK if episode.success else EXIT_INFEASIBLE


def _status(plan) -> str:
    """The plan's status, with why the planner stopped when the path is only approximate."""
    stopped = plan.details.get("stopped")
    return f"{plan.status} (stopped: {stopped})" if stopped else str(plan.status)


def _as_option(message: str) -> str:
    """A planner's message about its ``policy`` (the file it rolls out) as the command line names it: ``--policy``."""
    return f"--{message}" if message.startswith("policy:") else message


def _warning_line(message, category, filename, lineno, file=None, line=None) -> None:
    """Print a warning raised while planning as one line (``snakeplan: warning: ...``)."""
    sys.stderr.write(f"snakeplan: warning: {_as_option(str(message))}\n")


def _load_planner(name: str, **options):
    from snakeplan.planners.registry import PLANNERS

    try:
        cls = PLANNERS.get(name)
    except KeyError as exc:
        raise UsageError(f"--planner: {exc.args[0]}") from None
    if "policy" in options and not cls.takes_policy:
        raise UsageError(f"--policy: planner {name} rolls out no trained policy")
    return cls(**options)


def _check_trajectories(filenames: list[str] | None, field: str) -> None:
    """Refuse trajectory files that could not be written or whose name picks no format, before any work."""
    if not filenames:
        return
    from snakeplan.trajectory import output_format

    for filename in filenames or ():
        output_format(filename, field)


def _write_trajectories(filenames: list[str], scene, robot, path, report, provenance: dict) -> int:
    """Build the trajectory of a judged path and write it to every file; exit status 1 (one line on stderr) when
    the plan cannot become one."""
    from snakeplan.trajectory import InfeasiblePlan, build_trajectory, write

    try:
        traj = build_trajectory(scene, robot, path, provenance, report)
    except InfeasiblePlan as exc:
        sys.stderr.write(f"snakeplan: no trajectory: {exc}\n")
        return EXIT_INFEASIBLE
    for filename in filenames:
        kind = write(traj, filename)
        sys.stderr.write(f"wrote {filename} ({kind}: {len(traj.t)} points, {traj.timing.duration_s:.2f} s, "
                         f"{traj.method})\n")
    return EXIT_OK


def cmd_plan(args: argparse.Namespace) -> int:
    from snakeplan.episode import run_episode
    from snakeplan.planners import Problem
    from snakeplan.scenes import spec_for

    _check_picture(args.plot, "--plot")
    _check_views(args)
    _check_trajectories(args.trajectory, "--trajectory")
    scene = _load_scene(args)
    robot = _robot_for(args, scene)
    spec = spec_for(scene)
    if spec.task == "inspect":
        return _plan_inspection(args, scene, robot, spec.planner)
    options = {} if args.policy is None else {"policy": args.policy}
    planner = _load_planner(args.planner or spec.planner, **options)
    problem = Problem(scene, robot, time_limit_s=args.time_limit, knowledge=args.knowledge)
    with warnings.catch_warnings():
        warnings.showwarning = _warning_line
        try:
            episode = run_episode(problem, planner, seed=args.planner_seed)
        except ValueError as exc:
            raise ValueError(_as_option(str(exc))) from None
    plan = episode.plan
    if args.plot:
        _write_plot(args.plot, scene, robot, plan.path, episode.report, plan.planner)
    _write_views(args, scene, robot, plan.path, episode.report, plan.planner)
    if args.json:
        _print_json(episode.to_dict())
    else:
        sys.stdout.write(f"{plan.planner} on {scene.name} (seed {scene.seed}): {_status(plan)} "
                         f"in {plan.compute_time_s:.3f} s\n")
        if episode.report is not None:
            sys.stdout.write("\n".join(_report_lines(episode.report)) + "\n")
    if args.trajectory:
        if episode.report is None:
            sys.stderr.write("snakeplan: no trajectory: the planner returned no path\n")
            return EXIT_INFEASIBLE
        provenance = {"scene": {"name": scene.name, "seed": scene.seed}, "planner": plan.planner,
                      "planner_seed": args.planner_seed, "status": str(plan.status)}
        if _write_trajectories(args.trajectory, scene, robot, plan.path, episode.report, provenance):
            return EXIT_INFEASIBLE
    return EXIT_OK if episode.success else EXIT_INFEASIBLE


def cmd_compile(args: argparse.Namespace) -> int:
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
    return precompile.main(args.scene)


def cmd_trajectory(args: argparse.Namespace) -> int:
    from snakeplan.scenes import Scene, make_scene, spec_for
    from snakeplan.trajectory import read_plan

    _check_trajectories(args.out, "-o")
    plan = read_plan(_read_text(args.plan_file, "PLAN"))
    if args.scene_file:
        scene = Scene.from_json(_read_text(args.scene_file, "--scene-file"), "--scene-file",
                                _scene_dir(args.scene_file))
    else:
        name = args.scene or plan["scene"]["name"]
        seed = args.seed if args.seed is not None else plan["scene"]["seed"]
        if name is None or seed is None:
            raise UsageError("--scene: the plan names no generated scene; give --scene and --seed, or --scene-file")
        try:
            scene = make_scene(name, seed)
        except KeyError as exc:
            raise UsageError(f"--scene: {exc.args[0]}") from None
    robot = _load_robot(args.robot or plan["robot"] or spec_for(scene).robot)
    provenance = {"scene": {"name": scene.name, "seed": scene.seed}, "planner": plan["planner"],
                  "plan_file": Path(args.plan_file).name}
    return _write_trajectories(args.out, scene, robot, plan["path"], None, provenance)


def _plan_inspection(args: argparse.Namespace, scene, robot, default: str) -> int:
    """Fly an inspection mission (a scene whose task is to inspect a surface, e.g. station) with --planner, else
    ``default``."""
    from snakeplan.episode import run_mission
    from snakeplan.planners.inspection import INSPECTION_PLANNERS, InspectionProblem

    name = args.planner or default
    if name not in INSPECTION_PLANNERS:
        raise UsageError(f"--planner: unknown inspection planner {name!r} (known: "
                         f"{', '.join(INSPECTION_PLANNERS.names())})")
    record = None
    if args.animate is not None or args.html is not None:
        from snakeplan.viz.mission import MissionRecord

        record = MissionRecord()
    problem = InspectionProblem(scene, robot)
    mission = run_mission(problem, name, seed=args.planner_seed, on_measure=record)
    result = mission.result
    _write_mission_views(args, problem, result, record)
    if args.json:
        _print_json(mission.to_dict())
    else:
        sys.stdout.write(f"{name} on {scene.name} (seed {scene.seed}) with {robot.name}: final RMSE "
                         f"{result.rmse[-1]:.3f} K, covariance trace {result.trace[-1]:.1f} K^2, "
                         f"{len(result.times)} measurements, planning {result.compute_time_s:.2f} s\n")
    return EXIT_OK


def _write_mission_views(args: argparse.Namespace, problem, result, record) -> None:
    """The pictures of an inspection mission: --plot its maps (true field, mean with the camera path, variance),
    --animate the flight with the map filling in, --html the station with the map at every measurement."""
    scene = problem.scene
    title = (f"{scene.label}, {problem.robot.name}, {result.planner}: final RMSE "
             f"{result.rmse[-1]:.2f} K, covariance trace {result.trace[-1]:.0f} K^2")
    if args.plot:
        from snakeplan.viz.figures import save_figure
        from snakeplan.viz.maps import inspection_figure
        from snakeplan.viz.mission import station_mesh

        nodes, _ = station_mesh(scene)
        save_figure(inspection_figure(nodes, problem.truth, result.final_map.mean, np.diag(result.final_map.cov),
                                      result.path, title), args.plot)
        sys.stderr.write(f"wrote {args.plot}\n")
    if args.animate is not None:
        from snakeplan.viz.mission import save_mission_video

        save_mission_video(args.animate, scene, result, record, args.frames, args.fps, args.frame_size, title,
                           progress=sys.stderr.isatty())
        sys.stderr.write(f"wrote {args.animate} ({args.frames} frames at {args.fps:g} fps)\n")
    if args.html is not None:
        from snakeplan.viz.mission import save_mission_page

        save_mission_page(args.html, scene, result, record, title)
        sys.stderr.write(f"wrote {args.html}\n")


def cmd_bench_kernels(args: argparse.Namespace) -> int:
    from snakeplan.bench.kernels import run_kernel_bench

    if args.repeats < 1 or args.batch < 10:
        raise UsageError("--repeats must be >= 1 and --batch >= 10")
    result = run_kernel_bench(repeats=args.repeats, batch=args.batch, seed=args.seed)
    if args.json:
        _print_json(result)
    return EXIT_OK


def cmd_bench_speed(args: argparse.Namespace) -> int:
    from snakeplan.bench.speed import ROWS, run_speed_bench, speed_markdown, write_speed

    out = check_output(args.out, "--out", (".md",))
    for field, value in (("--seeds", args.seeds), ("--station-seeds", args.station_seeds), ("--repeats", args.repeats)):
        if value < 1:
            raise UsageError(f"{field}: expected a positive integer, got {value}")
    if args.station_baseline_seeds < 0:
        raise UsageError(f"--station-baseline-seeds: expected a non-negative integer, "
                         f"got {args.station_baseline_seeds}")
    rows = ROWS if args.rows is None else _name_list(args.rows, list(ROWS), "--rows")
    state = out.with_suffix(".partial.json")
    summary = run_speed_bench(seeds=args.seeds, station_seeds=args.station_seeds, rows=rows,
                              station_baseline_seeds=args.station_baseline_seeds, repeats=args.repeats,
                              progress=None if args.json else lambda line: sys.stderr.write(line + "\n"),
                              state=state)
    write_speed(summary, out)
    state.unlink(missing_ok=True)
    if args.json:
        _print_json(summary)
    else:
        sys.stdout.write(speed_markdown(summary) + f"\nwrote {out} and {out.with_suffix('.json')}\n")
    return EXIT_OK


def cmd_bench_mesh(args: argparse.Namespace) -> int:
    from snakeplan.bench import mesh

    if args.seeds < 1:
        raise UsageError(f"--seeds: expected a positive integer, got {args.seeds}")
    if args.part == "speed":
        result = mesh.speed(seeds=args.seeds, time_limit=args.time_limit)
    else:
        if not Path(args.out).parent.is_dir():
            raise UsageError(f"--out: folder {str(Path(args.out).parent)!r} does not exist (create it first)")
        Path(args.out).mkdir(exist_ok=True)
        check_output(Path(args.out) / "summary.json", "--out")
        result = mesh.families(Path(args.out), seeds=args.seeds, time_limit=args.time_limit)
    _print_json(result)
    return EXIT_OK


def cmd_bench_rl(args: argparse.Namespace) -> int:
    require_training("bench rl")
    from snakeplan.bench.rl import rl_markdown, run_rl_bench

    if args.repeats < 1:
        raise UsageError(f"--repeats: expected a positive integer, got {args.repeats}")
    result = run_rl_bench(repeats=args.repeats, seed=args.seed)
    if args.json:
        _print_json(result)
    else:
        sys.stdout.write(rl_markdown(result) + "\n")
    return EXIT_OK


def _name_list(text: str, known: list[str], field: str) -> tuple[str, ...]:
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in known]
    if not names or unknown:
        raise UsageError(f"{field}: unknown {', '.join(unknown) or 'empty list'} (known: {', '.join(known)})")
    return names


def cmd_bench_ablation(args: argparse.Namespace) -> int:
    require_training("bench ablation")
    from dataclasses import replace

    from snakeplan.rl.ablation import CONVERGENCE_SUCCESS, run_ablation, variants
    from snakeplan.rl.train import parse_config

    for field in ("seeds", "steps", "eval_every", "eval_episodes"):
        if getattr(args, field) < 1:
            raise UsageError(f"--{field.replace('_', '-')}: expected a positive integer, got {getattr(args, field)}")
    if args.threshold is not None and not 0.0 < args.threshold <= 1.0:
        raise UsageError(f"--threshold: expected a success rate in (0, 1], got {args.threshold}")
    try:
        variants(args.scene, args.compare)  # a scene that is not planned by a learned planner: ValueError
    except KeyError as exc:
        raise UsageError(f"--scene: {exc.args[0]}") from None
    config = replace(parse_config(args.extra), eval_every=args.eval_every, eval_episodes=args.eval_episodes)
    seeds = list(range(args.seed, args.seed + args.seeds))
    threshold = CONVERGENCE_SUCCESS if args.threshold is None else args.threshold
    result = run_ablation(args.scene, seeds, args.steps, args.out, args.compare, config, threshold, _backend(args),
                          progress=not args.json)
    if args.json:
        _print_json(result)
        return EXIT_OK
    for label, runs in result["runs"].items():
        steps = ", ".join(f"{r['steps_to_converge']:.0f}" + ("" if r["converged"] else " (not converged)")
                          for r in runs)
        sys.stdout.write(f"{label}: steps to {threshold:g} validation success per seed: {steps}; mean validation "
                         f"success over the run {result['mean_success'][label]:.3f}\n")
    bound = " (at least: a baseline run never converged)" if result["speedup_is_lower_bound"] else ""
    speedup = "n/a" if result["speedup"] is None else f"{result['speedup']:.2f}x"
    paper = "" if result["paper_speedup"] is None else f"; paper 000: {result['paper_speedup']:.2f}x"
    sys.stdout.write(f"speed-up to convergence: {speedup}{bound}{paper}\n"
                     f"wrote {args.out}/ablation-{args.scene}-{args.compare}.png and .json\n")
    return EXIT_OK


def cmd_bench_station(args: argparse.Namespace) -> int:
    from snakeplan.bench.station import run_station_bench, summary_markdown

    if args.seeds < 1:
        raise UsageError(f"--seeds: expected a positive integer, got {args.seeds}")
    summary = run_station_bench(seeds=args.seeds, seed0=args.seed, out_dir=args.out, backend=_backend(args),
                                fresh=args.fresh, progress=not args.json)
    if args.json:
        _print_json(summary)
    else:
        sys.stdout.write(summary_markdown(summary) + f"\n\nwrote {args.out}/station.md, station.json, runs.jsonl, "
                         + ", ".join(summary["figures"]) + "\n")
    return EXIT_OK


def cmd_bench_sscc(args: argparse.Namespace) -> int:
    from snakeplan.bench.sscc import run_sscc_bench, summary_markdown

    if args.targets is not None and args.targets < 1:
        raise UsageError(f"--targets: expected a positive integer, got {args.targets}")
    variants = _name_list(args.variants, ["agent", "agent-learning", "gradient", "random"], "--variants")
    if "agent-learning" in variants:
        require_training("bench sscc --variants agent-learning")
    summary = run_sscc_bench(out_dir=args.out, variants=variants, targets=args.targets, progress=not args.json,
                             backend=_backend(args))
    if args.json:
        _print_json(summary)
    else:
        sys.stdout.write(summary_markdown(summary["settings"]) + f"\n\nwrote {args.out}\n")
    return EXIT_OK


def cmd_train(args: argparse.Namespace) -> int:
    """Interrupted (SIGINT, SIGTERM), it saves a checkpoint; main() says so in one line, exit 130."""
    require_training("train sscc")
    from snakeplan.rl.sscc import train_agent

    check_output(args.out, "--out")
    if args.steps < 1:
        raise UsageError(f"--steps: expected a positive integer, got {args.steps}")
    if args.checkpoint_every < 0:
        raise UsageError(f"--checkpoint-every: expected a non-negative integer, got {args.checkpoint_every}")
    if args.robot not in ("sscc-16", "sscc-24"):
        raise UsageError(f"--robot: the sscc agent is trained for sscc-16 or sscc-24, got {args.robot!r}")
    result = train_agent(args.robot, args.out, steps=args.steps, seed=args.seed, resume=not args.fresh,
                         checkpoint_every=args.checkpoint_every)
    sys.stdout.write(f"{result}\nwrote {args.out}\n")
    return EXIT_OK


def cmd_train_rl(args: argparse.Namespace) -> int:
    """Interrupted (SIGINT, SIGTERM), it saves a checkpoint; main() says so in one line, exit 130."""
    require_training("train rl")
    from snakeplan.rl.train import parse_config, train

    if args.steps < 1:
        raise UsageError(f"--steps: expected a positive integer, got {args.steps}")
    config = parse_config(args.extra)
    if args.seeds is not None:
        from snakeplan.rl.sweep import markdown, train_seeds

        if args.fresh:
            raise UsageError("--fresh: not with --seeds (delete the seed folders in --out to start over)")
        summary = train_seeds(args.scene, args.algorithm, args.steps, _seed_list(args.seeds, "--seeds"), args.out,
                              config, _backend(args))
        sys.stdout.write(markdown(summary) + f"\nwrote {args.out}/sweep.md, sweep.json, curves.png and one folder "
                         f"per seed\n")
        return EXIT_OK
    result = train(args.scene, args.algorithm, args.steps, args.seed, args.out, config, resume=not args.fresh)
    sys.stdout.write(f"wrote {result.policy}\n")
    return EXIT_OK


def cmd_bench_table2(args: argparse.Namespace) -> int:
    from snakeplan.bench.runner import run_sweep
    from snakeplan.bench.table2 import DEFAULT_PLANNERS, SCENES, Table2Config, summary_markdown, table2_outputs
    from snakeplan.planners import planner_names

    if args.runs < 1:
        raise UsageError(f"--runs: expected a positive integer, got {args.runs}")
    planners = DEFAULT_PLANNERS if args.planners is None else _name_list(args.planners, planner_names(), "--planners")
    config = Table2Config(planners=planners,
                          scenes=_name_list(args.scenes, list(SCENES), "--scenes"),
                          seeds=tuple(range(args.seed, args.seed + args.runs)),
                          time_limit_s=args.time_limit)
    if not any(config.planners_in(s) for s in config.scenes):
        raise UsageError(f"--planners: none is compared in {', '.join(config.scenes)} (a planner whose policy ships "
                         f"for some scene families is compared only in those)")
    outcome = run_sweep(config.sweep(), args.out, _backend(args), fresh=args.fresh, progress=not args.json)
    summary = table2_outputs(config, outcome.rows, Path(args.out))
    if args.json:
        _print_json({"summary": summary, "runner": outcome.to_dict()})
    else:
        sys.stdout.write(summary_markdown(summary, config) + f"\n\n{_outcome_line(outcome)}\nwrote {args.out}/"
                         f"table2.md, table2.csv, runs.jsonl, fig7_*.png\n")
    return EXIT_OK


def _backend(args: argparse.Namespace):
    """The runner's backend from --workers and --ray (a HOST:PORT that nothing answers at is refused here, before
    anything is written)."""
    from snakeplan.parallel import backend_from, check_ray_address

    if args.ray:
        from snakeplan.extras import require_cluster

        require_cluster("--ray")
        check_ray_address(args.ray)
    return backend_from(args.workers, args.ray)


def _outcome_line(outcome) -> str:
    b = outcome.backend
    where = b["backend"] + (f", {b['workers']} workers" if b["backend"] != "serial" else "")
    return (f"ran {outcome.ran} runs in {outcome.wall_s:.1f} s ({where}); {outcome.skipped} already logged "
            f"were skipped")


def _seed_list(text: str, field: str) -> tuple[int, ...]:
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


def _option_value(text: str):
    try:
        return json.loads(text)
    except ValueError:
        return text


def cmd_bench_run(args: argparse.Namespace) -> int:
    from snakeplan.bench.report import write_report
    from snakeplan.bench.runner import Sweep, run_sweep
    from snakeplan.planners import planner_names
    from snakeplan.planners.inspection import inspection_planner_names

    planners = _name_list(args.planners, planner_names() + inspection_planner_names(), "--planners")
    options = {}
    for item in args.option or ():
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise UsageError(f"--option: expected KEY=VALUE, got {item!r}")
        options[key] = _option_value(value)
    scenes = tuple(n.strip() for n in args.scenes.split(",") if n.strip())
    if not scenes:
        raise UsageError("--scenes: empty list")
    if args.robot:
        from snakeplan.robots import robot_names

        if args.robot not in robot_names():
            raise UsageError(f"--robot: bench run takes a robot preset (known: {', '.join(robot_names())}); "
                             f"register your robot to benchmark it (docs/ARCHITECTURE.md, 'Your robot')")
    sweep = Sweep(args.name, scenes, _seed_list(args.seeds, "--seeds"), tuple((p, options) for p in planners),
                  args.time_limit, args.robot or "", args.knowledge)
    try:
        runs = sweep.runs()
    except KeyError as exc:
        raise UsageError(f"--scenes: {exc.args[0]}") from None
    outcome = run_sweep(sweep, args.out, _backend(args), fresh=args.fresh, progress=not args.json, runs=runs)
    result = write_report(args.out)
    if args.json:
        _print_json({"runner": outcome.to_dict(), "summary": result["entries"]})
    else:
        sys.stdout.write(f"{_outcome_line(outcome)}\nwrote {args.out}/runs.jsonl, report.md, report.csv\n")
    return EXIT_OK


def cmd_bench_report(args: argparse.Namespace) -> int:
    from snakeplan.bench.report import markdown, write_report

    if args.html:
        check_output(args.html, "--html", (".html", ".htm"))
    result = write_report(args.dir, args.html)
    if args.json:
        _print_json(result)
    else:
        sys.stdout.write(markdown(result["entries"], f"Results in {args.dir}") + "\n\nwrote "
                         + ", ".join(result["files"]) + "\n")
    return EXIT_OK


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


# --- parser ------------------------------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    from snakeplan import __version__

    parser = _Parser(prog="snakeplan", description="Motion planning for snake-arm robots (mm, rad, s).",
                     epilog="Run 'snakeplan COMMAND --help' for a command's options.")
    parser.add_argument("--version", action="version", version=f"snakeplan {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser, metavar="COMMAND")

    def backend_args(p: argparse.ArgumentParser) -> None:
        p.add_argument("--workers", type=int, help="worker processes (default: the usable cores; 1: serial, in "
                                                   "this process)")
        p.add_argument("--ray", metavar="ADDRESS", help="run on Ray: 'local' starts an instance on this machine, "
                                                        "'auto' or HOST:PORT joins a cluster (the cluster extra)")

    def scene_args(p: argparse.ArgumentParser) -> None:
        p.add_argument("--scene", default=DEFAULT_SCENE,
                       help=f"scene name (default {DEFAULT_SCENE}); 'snakeplan scene --list' lists them")
        p.add_argument("--seed", type=_seed, default=0, help="scene seed (default 0)")
        p.add_argument("--scene-file", help="a scene JSON file (snakeplan.scene/1) instead of --scene/--seed")

    p = sub.add_parser("scene", help="generate a scene and print it, or import one from CAD meshes",
                       description="Generate a scene from a seed; 'snakeplan scene import MESH... -o scene.json' "
                                   "makes one from mesh files (see 'snakeplan scene import --help').")
    p.add_argument("name", nargs="?", help="scene name, or import; omit (or --list) to list them")
    p.add_argument("--seed", type=_seed, default=0, help="scene seed (default 0)")
    p.add_argument("--json", action="store_true", help="print snakeplan.scene/1 JSON")
    p.add_argument("--list", action="store_true", help="list the scene names")
    p.set_defaults(func=cmd_scene_entry, takes_options=True)

    p = sub.add_parser("robot", help="print a robot preset or what a robot file describes",
                       description="Print a robot (mm, rad, s): a preset, or a URDF, DH YAML or robot/1 JSON file "
                                   "as snakeplan understands it.")
    p.add_argument("name", nargs="?", metavar="NAME", help="preset name or robot file; omit to list the presets")
    p.add_argument("--json", action="store_true", help="print snakeplan.robot/1 JSON")
    p.set_defaults(func=cmd_robot)

    p = sub.add_parser("check", help="judge a tip path made elsewhere",
                       description="Judge a tip path ({\"path\": [[x, y, z], ...]}, any plan file will do) with "
                                   "snakeplan's judge. Exit 0 feasible, 1 infeasible, 2 bad input.")
    scene_args(p)
    p.add_argument("--robot", help=ROBOT_HELP)
    p.add_argument("--json", action="store_true", help="print the verdict as JSON")
    p.add_argument("--plot", help="also write a PNG picture of the judged path")
    _view_args(p, "the arm crawling along the path")
    p.add_argument("path_file", metavar="PATH.json", help="the tip path file ('-' reads standard input)")
    p.set_defaults(func=cmd_check)

    p = sub.add_parser("show", help="draw a scene (and a path) to a PNG",
                       description="Draw a scene, optionally with a tip path and the arm's body at its end.")
    scene_args(p)
    p.add_argument("--robot", help=ROBOT_HELP)
    p.add_argument("--path", help="a tip path JSON file to draw and judge")
    p.add_argument("--out", default="scene.png", help="output PNG (default scene.png)")
    _view_args(p, "the arm crawling along --path")
    p.set_defaults(func=cmd_show)

    p = sub.add_parser("demo", help="the main job: plan the arm into a fuel tank, judge it, draw it",
                       description="Plan sjtu-snake-iii into a fuel-tank scene with the default planner, print "
                                   "the judge's metrics and write a picture.")
    p.add_argument("--seed", type=_seed, default=0, help="scene seed (default 0)")
    p.add_argument("--out", default="snakeplan-demo.png", help="output PNG (default snakeplan-demo.png)")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("plan", help="plan a tip path with a planner and judge it",
                       description="Plan a path for a robot in a scene; the judge's verdict comes with it. "
                                   "Exit 0 feasible, 1 no feasible plan, 2 bad input.")
    scene_args(p)
    p.add_argument("--robot", help=ROBOT_HELP)
    p.add_argument("--planner", help="planner name (default: the best shipped planner for the scene)")
    p.add_argument("--planner-seed", type=_seed, default=0, help="the planner's random seed (default 0)")
    p.add_argument("--policy", help="a trained policy file: .npz from 'snakeplan train rl' for sac-her, sac-per or "
                                    "sac ('generalist': the shipped generalist), or from 'snakeplan train sscc' for "
                                    "sscc (default: the shipped one for the scene and robot; the learned planners: "
                                    "the generalist where the scene's family ships none)")
    p.add_argument("--time-limit", type=_finite, default=30.0, help="planning budget in seconds (default 30)")
    p.add_argument("--knowledge", choices=("full", "sensed"), default="full",
                   help="what the planner may know: the whole scene, or what its sensor revealed")
    p.add_argument("--json", action="store_true", help="print snakeplan.plan/1 JSON")
    p.add_argument("--plot", help="also write a PNG picture of the plan (an inspection mission: its maps)")
    _view_args(p, "the plan (an inspection mission: the camera's flight and the map filling in)")
    p.add_argument("--trajectory", action="append", metavar="FILE", help=TRAJECTORY_HELP)
    p.set_defaults(func=cmd_plan)

    p = sub.add_parser("compile", help="compile the kernels ahead of time, so that commands start without numba",
                       description="Run each scene family's plan command (and every planner on fuel-tank) once, "
                                   "recording the kernels they call, and compile those into one module in the "
                                   "cache folder ($SNAKEPLAN_CACHE_DIR, else ~/.cache/snakeplan). Commands then "
                                   "load it instead of numba while snakeplan's sources match it. Needs a C "
                                   "compiler; takes about two minutes.")
    p.add_argument("--scene", action="append", help="only this scene family's commands (may be repeated)")
    p.add_argument("--remove", action="store_true", help="delete the compiled module")
    p.set_defaults(func=cmd_compile)

    p = sub.add_parser("trajectory", help="turn a plan file into a trajectory a controller can run",
                       description="Judge a plan (snakeplan.plan/1, as plan --json writes) and write its "
                                   "time-parameterised trajectory: feed and joints (and cable lengths) at every "
                                   "crawl step. Exit 0 written, 1 the plan is infeasible or the robot cannot "
                                   "execute it, 2 bad input.")
    p.add_argument("plan_file", metavar="PLAN.json", help="the plan file ('-' reads standard input)")
    p.add_argument("--robot", help="robot preset or robot file (default: the plan's robot)")
    p.add_argument("--scene", help="scene name (default: the plan's)")
    p.add_argument("--seed", type=_seed, help="scene seed (default: the plan's)")
    p.add_argument("--scene-file", help="a scene JSON file (snakeplan.scene/1) instead of the plan's scene")
    p.add_argument("-o", "--out", action="append", required=True, metavar="FILE", help=TRAJECTORY_HELP)
    p.set_defaults(func=cmd_trajectory)

    bench = sub.add_parser("bench", help="benchmarks: run, report, kernels, speed, mesh, table2, station, sscc, rl, "
                           "ablation",
                           description="Benchmarks that reproduce the papers' figures and measure speed.")
    bsub = bench.add_subparsers(dest="bench", required=True, parser_class=_Parser, metavar="BENCH")
    p = bsub.add_parser("kernels", help="speed of the collision and follow-the-leader kernels",
                        description="Time the collision and follow-the-leader kernels against baselines in the "
                                    "same process; medians over repeats.")
    p.add_argument("--repeats", type=int, default=7, help="timed repeats (default 7)")
    p.add_argument("--batch", type=int, default=20000, help="configurations per repeat (default 20000)")
    p.add_argument("--seed", type=_seed, default=0, help="seed for scenes and configurations")
    p.add_argument("--json", action="store_true", help="also print the figures as JSON")
    p.set_defaults(func=cmd_bench_kernels)

    p = bsub.add_parser("speed", help="planning times against their baselines: station, RRT*, learned, start-up, judge",
                        description="Time every planner row of the speed table (median and worst case over seeds) "
                                    "beside the implementation it replaced, in the same process; the station "
                                    "missions run beside a busy process; the load average is recorded. Writes a "
                                    "markdown table (--out) and its figures as JSON beside it. Each finished row "
                                    "is saved at once in a .partial.json beside --out: rerun an interrupted command to "
                                    "measure only the rows it lacks.")
    p.add_argument("--seeds", type=int, default=100, help="seeds per planner and scene (default 100)")
    p.add_argument("--station-seeds", type=int, default=20, help="station missions (default 20)")
    p.add_argument("--station-baseline-seeds", type=int, default=2,
                   help="station missions also flown by the previous implementation (default 2: it is slow)")
    p.add_argument("--repeats", type=int, default=5, help="runs of the plan command (default 5)")
    p.add_argument("--rows", help="comma-separated rows to measure (default all: rrt-star,sp-rrt,as-rrt,sac-her,"
                                  "command,judge,station)")
    p.add_argument("--out", default="bench-speed.md", help="markdown table to write (default bench-speed.md)")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.set_defaults(func=cmd_bench_speed)

    p = bsub.add_parser("mesh", help="planning on meshes: speed on 100k-triangle scenes, success in mesh families",
                        description="speed: judge, as-rrt and clearance figures on 100k-triangle watertight "
                                    "scenes against the same scene from primitives; families: rrt-star, sp-rrt "
                                    "and as-rrt over seeds of pipework, vessel and engine (resumable runs.jsonl).")
    p.add_argument("part", choices=("speed", "families"), help="which figures")
    p.add_argument("--seeds", type=int, default=5, help="seeds (default 5; the families figure uses 20)")
    p.add_argument("--time-limit", type=_finite, default=10.0, help="budget per plan in seconds (default 10)")
    p.add_argument("--out", default="bench-mesh", help="families: output folder (default bench-mesh)")
    p.set_defaults(func=cmd_bench_mesh)

    p = bsub.add_parser("rl", help="training throughput of the learned planners",
                        description="Environment steps, SAC-HER training steps and actor calls per second, each "
                                    "against a baseline in the same process; medians over repeats.")
    p.add_argument("--repeats", type=int, default=5, help="timed repeats (default 5)")
    p.add_argument("--seed", type=_seed, default=0, help="seed for scenes and actions (default 0)")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.set_defaults(func=cmd_bench_rl)

    p = bsub.add_parser("table2", help="paper 000's Table 2: planners on the same seeded episodes",
                        description="Run planners on identical fuel-tank and oil-tank episodes, judge every plan, "
                                    "and write runs.jsonl (resumable; one writer per folder), table2.md/csv with "
                                    "the paper's figures, Appendix A statistics and fig7_*.png.")
    p.add_argument("--planners", help="comma-separated planner names (default rrt-star,sp-rrt,as-rrt,sac-her,"
                                      "sac-per; sac-her has rows in fuel-tank, sac-per in oil-tank)")
    p.add_argument("--scenes", default="fuel-tank,oil-tank", help="comma-separated scene names")
    p.add_argument("--runs", type=int, default=10, help="seeds per scene (default 10, as the paper)")
    p.add_argument("--seed", type=_seed, default=0, help="first seed (default 0)")
    p.add_argument("--time-limit", type=_finite, default=10.0, help="budget per plan in seconds (default 10)")
    p.add_argument("--out", default="bench-table2", help="output folder (default bench-table2)")
    p.add_argument("--fresh", action="store_true", help="discard earlier runs instead of resuming")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    backend_args(p)
    p.set_defaults(func=cmd_bench_table2)

    p = bsub.add_parser("run", help="any planners on any episodes: judged JSON Lines rows, resumable",
                        description="Plan every scene (a family with every seed, or a scene file planned from "
                                    "every seed) with every planner, judge each plan and append one row per run "
                                    "to OUT/runs.jsonl (resumes; one writer per folder), then write "
                                    "OUT/report.md and report.csv.")
    p.add_argument("--scenes", required=True, help="comma-separated scene families or scene .json files")
    p.add_argument("--planners", required=True, help="comma-separated planner names (inspection planners for a "
                                                     "scene whose task is to inspect, e.g. station)")
    p.add_argument("--seeds", default="0-9", help="seeds, e.g. 0-99 or 0,3,5-7 (default 0-9)")
    p.add_argument("--option", action="append", metavar="KEY=VALUE",
                   help="a planner option for every planner (value as JSON, else text); may be repeated")
    p.add_argument("--robot", help="robot preset for every scene (default: each scene's own)")
    p.add_argument("--time-limit", type=_finite, default=10.0, help="budget per plan in seconds (default 10)")
    p.add_argument("--knowledge", choices=("full", "sensed"), default="full",
                   help="what the planners may know (sensed: a planner that needs the whole scene still has it)")
    p.add_argument("--name", default="run", help="configuration name recorded in every row (default run)")
    p.add_argument("--out", default="bench-run", help="results folder (default bench-run)")
    p.add_argument("--fresh", action="store_true", help="discard earlier runs instead of resuming")
    p.add_argument("--json", action="store_true", help="print the runner's outcome and the summary as JSON")
    backend_args(p)
    p.set_defaults(func=cmd_bench_run)

    p = bsub.add_parser("report", help="markdown and CSV tables (and paper figures) from a results folder",
                        description="Summarise DIR/runs.jsonl per configuration, scene and planner: success with "
                                    "its Wilson 95 % interval, median/p90/max compute time, path length, "
                                    "smoothness, clearance, deviation; writes DIR/report.md and report.csv, and "
                                    "the paper's tables and figures where the rows' configuration names one.")
    p.add_argument("dir", metavar="DIR", help="a results folder (holding runs.jsonl)")
    p.add_argument("--html", metavar="FILE", help="also write a self-contained HTML report")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=cmd_bench_report)

    p = bsub.add_parser("station", help="paper 002: informative vs coverage vs random inspection of the station",
                        description="Fly IP, CP and RP missions on station seeds; RMSE and covariance-trace curves "
                                    "(Fig. 9) and maps (Figs. 6-8) as pictures in --out.")
    p.add_argument("--seeds", type=int, default=5, help="station seeds to average over (default 5)")
    p.add_argument("--seed", type=_seed, default=0, help="first seed (default 0)")
    p.add_argument("--out", default="bench-station", help="results folder (default bench-station; resumed)")
    p.add_argument("--fresh", action="store_true", help="forget the rows in --out and fly every mission again")
    p.add_argument("--json", action="store_true",
                   help="print per method the final RMSE, final covariance trace and planning time as JSON")
    backend_args(p)
    p.set_defaults(func=cmd_bench_station)

    p = bsub.add_parser("ablation", help="paper 000's Fig. 4: learning with and without HER / PER (long)",
                        description="Train the scene's learned planner with and without its replay (HER in "
                                    "fuel-tank, PER in oil-tank; or the two observation designs) over several "
                                    "seeds; learning curves, steps to convergence and the speed-up. Each run "
                                    "resumes from its folder. Further options set the training configuration, "
                                    "as for 'snakeplan train rl'.")
    p.add_argument("--scene", default="fuel-tank",
                   help="a scene family planned by a learned planner (default fuel-tank)")
    p.add_argument("--compare", choices=("replay", "observation"), default="replay",
                   help="what to ablate (default replay)")
    p.add_argument("--seeds", type=int, default=3, help="training seeds per variant (default 3)")
    p.add_argument("--seed", type=_seed, default=0, help="first training seed (default 0)")
    p.add_argument("--steps", type=int, default=30000, help="environment steps per run (default 30000)")
    p.add_argument("--eval-every", type=int, default=2500, help="validation period in steps (default 2500)")
    p.add_argument("--eval-episodes", type=int, default=20, help="validation episodes (default 20)")
    p.add_argument("--threshold", type=_finite,
                   help="validation success that counts as converged (default 0.6)")
    p.add_argument("--out", default="bench-ablation", help="output folder (default bench-ablation)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    backend_args(p)
    p.set_defaults(func=cmd_bench_ablation, takes_options=True)
    p = bsub.add_parser("sscc", help="paper 001's Tables 4 and 6: SSCC in the pipe and the concentric pipe",
                        description="SSCC with the shipped DDPG agent and the non-learning searches on seeded "
                                    "targets (30 in pipe for sscc-16 and sscc-24, 52 in concentric-pipe); success, "
                                    "time per target, D, the paper's figures beside ours, pictures.")
    p.add_argument("--out", default="bench-sscc", help="output folder (default bench-sscc)")
    p.add_argument("--variants", default="agent,agent-learning,gradient,random",
                   help="comma-separated searches to compare")
    p.add_argument("--targets", type=int, help="targets per setting (default: the paper's 30 / 52)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    backend_args(p)
    p.set_defaults(func=cmd_bench_sscc)

    p = sub.add_parser("train", help="train a learned agent (sscc, rl)",
                       description="Train a learned agent; writes plain .npz weights.")
    tsub = p.add_subparsers(dest="train", required=True, parser_class=_Parser, metavar="AGENT")
    t = tsub.add_parser("sscc", help="the SSCC swinging-search agent (DDPG)")
    t.add_argument("--robot", default="sscc-24", help="sscc-16 or sscc-24 (default sscc-24)")
    t.add_argument("--out", required=True, help="output .npz weight file; its resumable state goes to the folder "
                                                "OUT.state beside it")
    t.add_argument("--steps", type=int, default=12000, help="environment steps (default 12000)")
    t.add_argument("--seed", type=_seed, default=0, help="training seed (default 0)")
    t.add_argument("--checkpoint-every", type=int, default=0,
                   help="environment steps between checkpoints (default: a tenth of --steps, 1000-10000)")
    t.add_argument("--fresh", action="store_true", help="delete the checkpoint in OUT.state and start over")
    t.set_defaults(func=cmd_train)
    t = tsub.add_parser("rl", help="a learned tip planner (sac-her, sac-per, sac)",
                        description="Train sac-her / sac-per / sac on fuel-tank or oil-tank; resumes from the "
                                    "checkpoint in --out (Ctrl-C saves one; --checkpoint-every N, default a tenth "
                                    "of --steps within 1000-10000). Any further option sets the training configuration "
                                    "(--paper, --turn-radius-mm 215, --capture-steps 4, --eval-episodes 50, ...; "
                                    "the list: 'python -m snakeplan.rl.train --help').")
    t.add_argument("scene", help="a scene family with targets (fuel-tank, oil-tank, pipe, or one you registered)")
    t.add_argument("algorithm", choices=("sac-her", "sac-per", "sac"))
    t.add_argument("--steps", type=int, required=True, help="environment steps")
    t.add_argument("--seed", type=_seed, default=0, help="training seed (default 0)")
    t.add_argument("--out", required=True, help="output folder (policy.npz, curve.png, checkpoints)")
    t.add_argument("--fresh", action="store_true", help="delete the checkpoint in --out and start over")
    t.add_argument("--seeds", help="a training sweep: one resumable training per seed (e.g. 0-9) in --out/seed<N>, "
                                   "on --workers processes or Ray, and a summary of the learning curves")
    backend_args(t)
    t.set_defaults(func=cmd_train_rl, takes_options=True)
    return parser


def cmd_scene_entry(args: argparse.Namespace) -> int:
    from snakeplan.scenes import scene_names

    if args.name == "import":  # options before 'import' (main sends 'scene import ...' straight there)
        return cmd_scene_import(args.extra)
    if args.extra:
        raise UsageError(f"unrecognized arguments: {' '.join(args.extra)}")
    if args.list or args.name is None:
        sys.stdout.write("\n".join(scene_names()) + "\n")
        return EXIT_OK
    args.scene, args.scene_file = args.name, None
    return cmd_scene(args)


def _import_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="snakeplan scene import",
                description="Make a scene/1 file from CAD meshes (STL, OBJ, PLY, GLB/GLTF, OFF): the meshes are "
                            "referred to by their path relative to the scene file. The entrance and every target "
                            "must lie in free space inside the bounds.")
    p.add_argument("meshes", nargs="+", metavar="MESH", help="mesh files; closed meshes are solids, open ones "
                                                             "shells (see --thickness)")
    p.add_argument("--units", required=True, choices=("m", "cm", "mm", "in"), help="the unit the files are in")
    p.add_argument("--entrance", required=True, metavar="X,Y,Z", help="where the arm enters (mm)")
    p.add_argument("--direction", required=True, metavar="DX,DY,DZ", help="feed direction into the scene")
    p.add_argument("--target", action="append", default=[], metavar="X,Y,Z", help="a target (mm); may be repeated")
    p.add_argument("--bounds", default="auto", metavar="auto|X0,Y0,Z0,X1,Y1,Z1",
                   help="workspace box (mm); auto: around the meshes, entrance and targets with a 50 mm margin")
    p.add_argument("--thickness", type=float, help="take every mesh as a shell this thick (mm)")
    p.add_argument("--name", help="scene name (default: the first mesh's file name)")
    p.add_argument("-o", "--out", required=True, help="the scene JSON file to write")
    return p


def cmd_scene_import(argv: list[str]) -> int:
    """``snakeplan scene import MESH... -o scene.json``: check everything, then write the scene atomically."""
    from snakeplan.files import atomic_write
    from snakeplan.inputs import length, unit
    from snakeplan.scenes.importing import import_scene, parse_bounds, parse_triple

    args = _import_parser().parse_args(argv)
    check_output(args.out, "-o", (".json",))
    entrance = parse_triple(args.entrance, "--entrance")
    direction = unit(parse_triple(args.direction, "--direction"), "--direction")
    targets = [parse_triple(t, f"--target[{i}]") for i, t in enumerate(args.target)]
    thickness = None if args.thickness is None else length(args.thickness, "--thickness")
    scene = import_scene(args.meshes, args.units, entrance, direction, targets, args.out,
                         parse_bounds(args.bounds), args.name, thickness)
    atomic_write(args.out, scene.to_json(indent=1) + "\n")
    triangles = sum(len(o.faces) for o in scene.obstacles)
    sys.stdout.write(f"wrote {args.out}: {len(scene.obstacles)} meshes, {triangles} triangles, "
                     f"{len(scene.targets)} targets, bounds {scene.bounds_min.round(1).tolist()} .. "
                     f"{scene.bounds_max.round(1).tolist()} mm\n")
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _warning_line
            if argv[:2] == ["scene", "import"]:  # its own parser, --help included
                return int(cmd_scene_import(argv[2:]))
            args, extra = build_parser().parse_known_args(argv)
            if extra and not getattr(args, "takes_options", False):
                raise UsageError(f"unrecognized arguments: {' '.join(extra)}")
            args.extra = extra
            return int(args.func(args))
    except BrokenPipeError:
        return EXIT_OK
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
