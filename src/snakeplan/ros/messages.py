"""A :class:`~snakeplan.ros.recording.Recording` as ROS 2 messages: plain data shaped as each message type, in ROS's
SI units (m, rad, s), with the topic and time each is published at. :mod:`.bag` turns them into a bag.

Frames: ``scene`` is the fixed frame (the scene's obstacles, paths, views and points); the URDF's root ``world``
stands in it at the arm's base pose (``scene`` -> ``world`` on ``/tf_static``, or on ``/tf`` when the base moves,
as the station's carriage does); every URDF joint is a transform from its parent link to its child (fixed joints on
``/tf_static``, movable ones on ``/tf`` at every sample), which is what ``robot_state_publisher`` would publish from
``/joint_states``, so RViz draws the ``/robot_description`` model with or without one.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from snakeplan.robots.urdf import to_urdf
from snakeplan.ros.recording import Recording
from snakeplan.trajectory.documents import joint_trajectory as trajectory_message
from snakeplan.trajectory.documents import ros_time, si_scale
from snakeplan.trajectory.replay import urdf_joint_transforms

#: The fixed frame of everything in the scene, and the URDF's root link.
SCENE_FRAME, ROOT_LINK = "scene", "world"
#: mm to m.
M = 1e-3
#: Colours (RGBA, 0-1): obstacles known before the job, those sensed during it, targets, targets found, points seen and
#: not seen, the judge's first failure, the tip path.
KNOWN, DISCOVERED = (0.6, 0.6, 0.62, 0.5), (0.85, 0.45, 0.1, 0.7)
TARGET, FOUND = (0.85, 0.1, 0.1, 1.0), (0.17, 0.63, 0.17, 1.0)
SEEN, UNSEEN = (0.17, 0.63, 0.17, 1.0), (1.0, 0.5, 0.05, 1.0)
FAILURE, PATH = (1.0, 0.0, 0.0, 0.9), (0.12, 0.47, 0.71, 1.0)
#: Diameter (m) of a target's sphere and of the failure's.
TARGET_M, FAILURE_M = 0.03, 0.05
#: Topics, and those latched (transient local: a late subscriber such as RViz still gets them).
TOPICS = {"/robot_description": "std_msgs/msg/String", "/tf_static": "tf2_msgs/msg/TFMessage",
          "/tf": "tf2_msgs/msg/TFMessage", "/joint_states": "sensor_msgs/msg/JointState",
          "/joint_trajectory": "trajectory_msgs/msg/JointTrajectory", "/tip_path": "nav_msgs/msg/Path",
          "/scene": "visualization_msgs/msg/MarkerArray", "/targets": "visualization_msgs/msg/MarkerArray",
          "/judge": "visualization_msgs/msg/MarkerArray", "/views": "geometry_msgs/msg/PoseStamped",
          "/coverage": "sensor_msgs/msg/PointCloud2"}
LATCHED = frozenset({"/robot_description", "/tf_static", "/scene", "/joint_trajectory"})


@dataclass(frozen=True)
class Message:
    """One message: its topic, its time (s from the start) and its content (plain data, ROS field names)."""

    topic: str
    t: float
    data: dict[str, Any]

    @property
    def msgtype(self) -> str:
        return TOPICS[self.topic]


def header(t: float, frame: str = SCENE_FRAME) -> dict[str, Any]:
    return {"stamp": ros_time(t), "frame_id": frame}


def quaternions(R: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) as unit quaternions (..., 4), x y z w, w >= 0."""
    from scipy.spatial.transform import Rotation

    R = np.asarray(R, dtype=float)
    q = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat()
    q *= np.where(q[:, 3:] < 0, -1.0, 1.0)
    return q.reshape(R.shape[:-2] + (4,))


def quaternion(R: np.ndarray) -> dict[str, float]:
    """A rotation matrix as a unit quaternion (x, y, z, w), w >= 0."""
    return dict(zip("xyzw", quaternions(R).tolist()))


def pose(T: np.ndarray) -> dict[str, Any]:
    """``geometry_msgs/Pose`` of a 4x4 pose in mm."""
    x, y, z = (T[:3, 3] * M).tolist()
    return {"position": {"x": x, "y": y, "z": z}, "orientation": quaternion(T[:3, :3])}


def transforms(T: np.ndarray) -> np.ndarray:
    """Poses (k, 4, 4) mm as rows (k, 7) of ``geometry_msgs/Transform``: translation x y z (m), rotation x y z w; all
    at once."""
    return np.concatenate([T[:, :3, 3] * M, quaternions(T[:, :3, :3])], axis=1)


def transform(t: float, parent: str, child: str, row: np.ndarray) -> dict[str, Any]:
    """``geometry_msgs/TransformStamped`` of ``child`` in ``parent``, from a row of :func:`transforms`."""
    x, y, z, qx, qy, qz, qw = row.tolist()
    return {"header": header(t, parent), "child_frame_id": child,
            "transform": {"translation": {"x": x, "y": y, "z": z}, "rotation": {"x": qx, "y": qy, "z": qz, "w": qw}}}


def _point(p: np.ndarray) -> dict[str, float]:
    x, y, z = (np.asarray(p, dtype=float) * M).tolist()
    return {"x": x, "y": y, "z": z}


def _colour(rgba) -> dict[str, float]:
    return dict(zip("rgba", map(float, rgba)))


def view_rotation(direction: np.ndarray) -> np.ndarray:
    """A camera's rotation, its x axis along the view ``direction`` (how RViz and Foxglove draw a pose: an arrow
    along x)."""
    from snakeplan.geometry.transforms import frame_from_z

    R = frame_from_z(direction)
    return R[:, [2, 0, 1]]


def joint_trajectory(rec: Recording) -> dict[str, Any]:
    """``trajectory_msgs/JointTrajectory`` of the whole motion (:func:`snakeplan.trajectory.documents.
    joint_trajectory`; velocities and accelerations where the motion was time-scaled), one point per sample whose
    time moves on (a trajectory's times increase)."""
    k = np.flatnonzero(np.r_[True, np.diff(rec.t) > 0]) if len(rec.t) else np.zeros(0, dtype=int)
    timed = rec.velocities is not None
    return trajectory_message(rec.robot, rec.t[k], rec.q[k], rec.velocities[k] if timed else None,
                              rec.accelerations[k] if timed else None)


def markers(rec: Recording) -> dict[str, Any]:
    """``visualization_msgs/MarkerArray``: one triangle-list marker per obstacle (m, scene frame), known ones grey,
    those not known before the job orange."""
    out = []
    for i, (triangles, known) in enumerate(zip(rec.triangles, rec.scene.prior)):
        tris = triangles.reshape(-1, 3) * M
        out.append({"header": header(0.0), "ns": "obstacles", "id": i, "type": 11, "action": 0,
                    "pose": {"orientation": {"w": 1.0}}, "scale": {"x": 1.0, "y": 1.0, "z": 1.0},
                    "color": _colour(KNOWN if known else DISCOVERED),
                    "points": [{"x": x, "y": y, "z": z} for x, y, z in tris.tolist()]})
    return {"markers": out}


def _sphere(t: float, ns: str, i: int, p: np.ndarray, size: float, rgba) -> dict[str, Any]:
    x, y, z = (np.asarray(p, dtype=float) * M).tolist()
    return {"header": header(t), "ns": ns, "id": i, "type": 2, "action": 0,
            "pose": {"position": {"x": x, "y": y, "z": z}, "orientation": {"w": 1.0}},
            "scale": {"x": size, "y": size, "z": size}, "color": _colour(rgba)}


def _text(t: float, ns: str, i: int, p: np.ndarray, text: str, rgba) -> dict[str, Any]:
    return {**_sphere(t, ns, i, p, 0.04, rgba), "type": 9, "text": text}


def coverage_cloud(t: float, points: np.ndarray, seen: np.ndarray) -> dict[str, Any]:
    """``sensor_msgs/PointCloud2`` of the points of interest (m), x y z float32 and RViz's packed ``rgb``: green
    seen, orange not yet."""
    n = len(points)
    rgb = np.where(seen[:, None], np.array(SEEN[:3]), np.array(UNSEEN[:3]))
    packed = (np.round(rgb * 255).astype(np.uint32) << np.array([16, 8, 0], dtype=np.uint32)).sum(axis=1)
    rec = np.zeros(n, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4")])
    rec["x"], rec["y"], rec["z"] = (points * M).T
    rec["rgb"] = packed.astype(np.uint32)
    fields = [{"name": name, "offset": 4 * k, "datatype": 7, "count": 1} for k, name in enumerate(("x", "y", "z",
                                                                                                  "rgb"))]
    return {"header": header(t), "height": 1, "width": n, "fields": fields, "is_bigendian": False,
            "point_step": 16, "row_step": 16 * n, "data": np.frombuffer(rec.tobytes(), dtype=np.uint8),
            "is_dense": True}


def messages(rec: Recording) -> Iterator[Message]:
    """Every message of the recording in time order (a message at an equal time in topic order), made as they are
    written: one topic's stream at a time, merged."""
    urdf = to_urdf(rec.robot)
    movable = set(rec.robot.joint_names)
    joints = urdf_joint_transforms(urdf, rec.q if len(rec.q) else np.zeros((1, rec.robot.dof)))
    fixed = [(parent, child, T[0]) for name, parent, child, T in joints if name not in movable]
    moving = [(parent, child, T) for name, parent, child, T in joints if name in movable]
    return heapq.merge(_latched(rec, urdf, fixed), _motion(rec, moving), _paths(rec), _targets(rec), _views(rec),
                       _coverage(rec), _judge(rec), key=lambda m: m.t)


def _still(rec: Recording) -> bool:
    return len(rec.t) > 0 and bool(np.all(rec.bases == rec.bases[0]))


def _latched(rec: Recording, urdf: str, fixed: list) -> Iterator[Message]:
    """The URDF, the fixed joints (and a base that stands still), the scene and the whole trajectory, at 0."""
    yield Message("/robot_description", 0.0, {"data": urdf})
    static = [transform(0.0, parent, child, transforms(T[None])[0]) for parent, child, T in fixed]
    if _still(rec):
        static.append(transform(0.0, SCENE_FRAME, ROOT_LINK, transforms(rec.bases[:1])[0]))
    yield Message("/tf_static", 0.0, {"transforms": static})
    yield Message("/scene", 0.0, markers(rec))
    yield Message("/joint_trajectory", 0.0, joint_trajectory(rec))


def _motion(rec: Recording, moving: list) -> Iterator[Message]:
    """``/tf`` (the ``moving`` joints' transforms, and the base when it moves) and ``/joint_states`` at every
    sample."""
    if not len(rec.t):
        return
    rows = [(parent, child, transforms(T)) for parent, child, T in moving]
    if not _still(rec):
        rows.append((SCENE_FRAME, ROOT_LINK, transforms(rec.bases)))
    robot = rec.robot
    scale = si_scale(robot)
    for k, t in enumerate(rec.t.tolist()):
        yield Message("/tf", t, {"transforms": [transform(t, parent, child, r[k]) for parent, child, r in rows]})
        state = {"header": header(t, ROOT_LINK), "name": list(robot.joint_names), "position": rec.q[k] * scale}
        if rec.velocities is not None:
            state["velocity"] = rec.velocities[k] * scale
        yield Message("/joint_states", t, state)


def _paths(rec: Recording) -> Iterator[Message]:
    for path, start in zip(rec.paths, rec.path_starts_s.tolist()):
        yield Message("/tip_path", start, {"header": header(start), "poses": [
            {"header": header(start), "pose": {"position": _point(p), "orientation": {"w": 1.0}}} for p in path]})


def _targets(rec: Recording) -> Iterator[Message]:
    targets = rec.scene.targets
    found = np.full(len(targets), np.inf) if rec.found_s is None else rec.found_s
    if len(targets):
        colour = TARGET if rec.found_s is None else UNSEEN
        yield Message("/targets", 0.0, {"markers": [_sphere(0.0, "targets", i, p, TARGET_M, colour)
                                                    for i, p in enumerate(targets)]})
    for i in np.argsort(found, kind="stable"):
        if np.isfinite(found[i]):
            yield Message("/targets", float(found[i]), {"markers": [
                _sphere(float(found[i]), "targets", int(i), targets[i], TARGET_M, FOUND)]})


def _views(rec: Recording) -> Iterator[Message]:
    if rec.views is None:
        return
    for t, p, d in zip(rec.views.times_s.tolist(), rec.views.positions, rec.views.directions):
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = view_rotation(d), p
        yield Message("/views", t, {"header": header(t), "pose": pose(T)})


def _coverage(rec: Recording) -> Iterator[Message]:
    for t, seen in rec.coverage_updates():
        yield Message("/coverage", t, coverage_cloud(t, rec.points, seen))


def _judge(rec: Recording) -> Iterator[Message]:
    entrance = rec.scene.entrance.position
    out = [_text(0.0, "verdict", 0, entrance, rec.verdict, FOUND if rec.success else FAILURE)]
    yield Message("/judge", 0.0, {"markers": out})
    f = rec.failure
    if f is not None:
        yield Message("/judge", f.time_s, {"markers": [
            _sphere(f.time_s, "failure", 0, f.position, FAILURE_M, FAILURE),
            _text(f.time_s, "failure", 1, f.position, f"{f.reason} at {f.time_s:.2f} s", FAILURE)]})
