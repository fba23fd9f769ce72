"""A trajectory as files: ``snakeplan.trajectory/1`` JSON, CSV, and a ROS-2 ``JointTrajectory``-shaped YAML or JSON.

The output file's name picks the format (:func:`output_format`): ``.csv`` the table, ``.ros.json`` / ``.yaml`` /
``.yml`` the ROS-shaped message, any other ``.json`` the trajectory document. Fields: docs/TRAJECTORY.md.
"""

from __future__ import annotations

import csv
import io
import json
import math
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np

from snakeplan.files import atomic_write, check_output
from snakeplan.inputs import load_json
from snakeplan.geometry.polyline import validate_path
from snakeplan.jsonable import jsonable
from snakeplan.robots.urdf import to_urdf
from snakeplan.trajectory.build import Trajectory
from snakeplan.trajectory.timing import DISCRETISATION, METHOD
from snakeplan.world import JUDGE

SCHEMA = "snakeplan.trajectory/1"
#: Output formats by how a file name ends (checked in this order).
FORMATS = ((".ros.json", "ros-json"), (".yaml", "ros-yaml"), (".yml", "ros-yaml"), (".csv", "csv"),
           (".json", "trajectory"))
#: What the ROS-shaped message names as the frame its joints move in: the URDF's root link.
ROOT_LINK = "world"


def output_format(filename: str, field: str = "--trajectory") -> str:
    """The format a trajectory file of this name is written in, after checking it can be written (its folder
    exists); ValueError naming ``field`` otherwise."""
    check_output(filename, field)
    name = str(filename).lower()
    for suffix, kind in FORMATS:
        if name.endswith(suffix):
            return kind
    raise ValueError(f"{field}: {filename!r} must end in .json (snakeplan.trajectory/1), .csv, or .ros.json, .yaml, "
                     ".yml (the ROS JointTrajectory)")


def _library_version(name: str) -> str:
    try:
        return version(name)
    except PackageNotFoundError:
        return "unknown"


def _body_links(n: int) -> list[str]:
    return ["arm_base"] + [f"s{i}_end" for i in range(n)]


def to_dict(traj: Trajectory) -> dict[str, Any]:
    """The ``snakeplan.trajectory/1`` document (plain JSON; mm, rad, s)."""
    from snakeplan import __version__

    robot = traj.robot
    lower, upper = robot.joint_limits()
    report = traj.report
    doc: dict[str, Any] = {
        "schema": SCHEMA,
        "units": {"length": "mm", "angle": "rad", "time": "s"},
        "robot": robot.name,
        "urdf": to_urdf(robot.with_base(np.eye(4))),
        "base_pose": traj.base_pose + 0.0,  # no -0.0
        "tip_link": f"s{robot.n_sections - 1}_end",
        "body_links": _body_links(robot.n_sections),
        "joint_names": list(robot.joint_names),
        "limits": {**robot.limits.to_dict(), "lower": lower, "upper": upper},
        "time_scaling": {"method": METHOD, "library": f"toppra {_library_version('toppra')}",
                         "constraints": f"{DISCRETISATION} at every point",
                         "path": "cubic spline (not-a-knot) through the crawl states, in insertion depth",
                         "start": "rest", "end": "rest", "duration_s": traj.timing.duration_s},
        "arm_length_mm": robot.total_length,
        "crawl_step_mm": JUDGE.step_mm,
        "provenance": {"snakeplan": __version__, **traj.provenance,
                       "judge": {"success": report.success, "reason": report.reason,
                                 "max_deviation_mm": report.max_deviation_mm,
                                 "min_clearance_mm": report.min_clearance_mm,
                                 "peak_tension_n": report.peak_tension_n, "holdable": report.holdable},
                       "entrance": {"position": traj.entrance, "direction": traj.direction},
                       "path": traj.path},
    }
    if traj.cables is not None:
        routing = robot.cables
        section, angle, radius, spacing = routing.table()
        doc["cables"] = {"names": list(routing.names), "section": section, "hole_angle_rad": angle,
                         "pitch_radius_mm": radius, "disc_spacing_mm": spacing,
                         "rest_length_mm": routing.rest_lengths(robot.lengths), "routing": routing.to_dict()}
    points = []
    for k in range(len(traj.depths)):
        point = {"t": traj.t[k], "depth_mm": traj.depths[k], "positions": traj.positions[k],
                 "velocities": traj.velocities[k], "accelerations": traj.accelerations[k],
                 "tip": traj.tip_poses[k, :3, 3], "tip_rotation": traj.tip_poses[k, :3, :3],
                 "deviation_mm": traj.deviation_mm[k], "deviation_percent": traj.deviation_percent[k]}
        if traj.cables is not None:
            point["cable_lengths"] = traj.cables[k]
        if traj.statics is not None:
            point["cable_tensions_n"] = traj.statics.tensions_n[k]
            point["holdable"] = bool(traj.statics.holdable[k])
        points.append(point)
    doc["points"] = points
    return jsonable(doc)


def _unit(name: str, feed: str, length: str, angle: str) -> str:
    return length if name == feed else angle


def to_csv(traj: Trajectory) -> str:
    """One row per point: time, depth, positions, velocities, tip position, deviation, cable lengths and tensions
    (mm, rad, s, N; the column names say the unit)."""
    robot = traj.robot
    feed = robot.joint_names[0]
    header = ["t_s", "depth_mm"]
    header += [f"{n}_{_unit(n, feed, 'mm', 'rad')}" for n in robot.joint_names]
    header += [f"{n}_vel_{_unit(n, feed, 'mm_s', 'rad_s')}" for n in robot.joint_names]
    header += ["tip_x_mm", "tip_y_mm", "tip_z_mm", "deviation_mm", "deviation_percent"]
    if traj.cables is not None:
        header += [f"{n}_mm" for n in robot.cables.names]
    if traj.statics is not None:
        header += [f"{n}_tension_n" for n in robot.cables.names]
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    for k in range(len(traj.depths)):
        row = [traj.t[k], traj.depths[k], *traj.positions[k], *traj.velocities[k], *traj.tip_poses[k, :3, 3],
               traj.deviation_mm[k], traj.deviation_percent[k]]
        if traj.cables is not None:
            row += list(traj.cables[k])
        if traj.statics is not None:
            row += list(traj.statics.tensions_n[k])
        writer.writerow([repr(float(v)) for v in row])
    return out.getvalue()


def ros_time(t: float) -> dict[str, int]:
    """``builtin_interfaces/Time`` or ``Duration`` of ``t`` s (t >= 0): whole seconds and nanoseconds."""
    sec = math.floor(t)
    nanosec = int(round((t - sec) * 1e9))
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return {"sec": int(sec), "nanosec": nanosec}


def si_scale(robot) -> np.ndarray:
    """Per joint, the factor from snakeplan's units to ROS's: 1e-3 for a feed (mm to m), 1 for an angle."""
    scale = np.ones(robot.dof)
    if robot.has_feed:
        scale[0] = 1e-3
    return scale


def joint_trajectory(robot, t: np.ndarray, positions: np.ndarray, velocities: np.ndarray | None = None,
                     accelerations: np.ndarray | None = None) -> dict[str, Any]:
    """A ``trajectory_msgs/msg/JointTrajectory`` as plain data, in ROS's SI units (feed m, m/s, m/s²; angles rad,
    rad/s, rad/s²), one point per time ``t`` (s) of the joint arrays (T, dof) in snakeplan's units (velocities and
    accelerations when given); ``header.frame_id`` the URDF's root link."""
    scale = si_scale(robot)
    points = []
    for k in range(len(t)):
        point = {"positions": (positions[k] * scale).tolist()}
        if velocities is not None:
            point["velocities"] = (velocities[k] * scale).tolist()
            point["accelerations"] = (accelerations[k] * scale).tolist()
        points.append({**point, "effort": [], "time_from_start": ros_time(float(t[k]))})
    return {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ROOT_LINK},
            "joint_names": list(robot.joint_names), "points": points}


def ros_message(traj: Trajectory) -> dict[str, Any]:
    """The trajectory as a ``trajectory_msgs/msg/JointTrajectory`` (:func:`joint_trajectory`)."""
    return joint_trajectory(traj.robot, traj.t, traj.positions, traj.velocities, traj.accelerations)


def write(traj: Trajectory, filename: str, field: str = "--trajectory") -> str:
    """Write ``traj`` to ``filename`` atomically, in the format its name picks; returns the format."""
    kind = output_format(filename, field)
    if kind == "trajectory":
        text = json.dumps(to_dict(traj), allow_nan=False) + "\n"
    elif kind == "csv":
        text = to_csv(traj)
    elif kind == "ros-json":
        text = json.dumps(ros_message(traj), allow_nan=False) + "\n"
    else:
        import yaml

        text = ("# trajectory_msgs/msg/JointTrajectory (ROS 2) from snakeplan; SI units: feed m, angles rad\n"
                + yaml.safe_dump(ros_message(traj), sort_keys=False, default_flow_style=None, width=120))
    atomic_write(Path(filename), text)
    return kind


def read_plan(text: str, field: str = "PLAN") -> dict[str, Any]:
    """The parts of a ``snakeplan.plan/1`` document a trajectory needs: ``scene`` (name, seed), ``robot``,
    ``planner`` (each None when absent) and ``path`` ``(m, 3)`` mm; ValueError naming the field."""
    data = load_json(text, field)
    if not isinstance(data, dict) or "path" not in data:
        raise ValueError(f'{field}: must hold a plan (an object with a "path" list of [x, y, z], as plan --json '
                         "writes)")
    path = validate_path(data["path"])
    scene = data.get("scene") if isinstance(data.get("scene"), dict) else {}
    name, seed = scene.get("name"), scene.get("seed")
    if name is not None and not isinstance(name, str):
        raise ValueError(f"scene.name: must be a string, got {name!r}")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise ValueError(f"scene.seed: must be a non-negative integer or null, got {seed!r}")
    for key in ("robot", "planner"):
        if data.get(key) is not None and not isinstance(data[key], str):
            raise ValueError(f"{key}: must be a string, got {data[key]!r}")
    return {"scene": {"name": name, "seed": seed}, "robot": data.get("robot"), "planner": data.get("planner"),
            "path": path}
