"""A recording in Foxglove's own schemas (``foxglove-sdk``): an MCAP file Foxglove opens (:func:`write_mcap`), and a
live WebSocket view of plans and missions as they are judged (:class:`LiveView`), served on loopback unless asked
otherwise.

Topics (metres, the ``scene`` frame): ``/scene`` the obstacles (one entity each, triangles; grey known before the job,
orange sensed during it), ``/targets`` (red; a search's turn green when found), ``/arm`` the body as one cylinder per
section at every sample, ``/tip_path`` each path flown as a line from when it starts, ``/tf`` the tip's frame
(``scene`` -> ``tip``), ``/joint_states`` (feed m, angles rad), ``/views`` each view's pose (x along the view),
``/coverage`` the points of interest green once seen and orange before, ``/judge`` the verdict and the first failure
(a red sphere where the tip is when it happens), ``/log`` the same as text.
"""

from __future__ import annotations

import heapq

import numpy as np

from snakeplan.extras import require_ros
from snakeplan.files import atomic_path, check_output
from snakeplan.ros.messages import (
    DISCOVERED,
    FAILURE,
    FAILURE_M,
    FOUND,
    KNOWN,
    M,
    PATH,
    SCENE_FRAME,
    SEEN,
    TARGET,
    TARGET_M,
    UNSEEN,
    quaternion,
    view_rotation,
)
from snakeplan.ros.recording import Recording, scene_triangles
from snakeplan.trajectory.documents import ros_time, si_scale

#: Width (m) of the tip path's line.
LINE_M = 0.004


def _fg():
    import foxglove.messages as fm

    return fm


def _ts(t: float):
    """A Foxglove timestamp of ``t`` s (:func:`snakeplan.trajectory.documents.ros_time`)."""
    stamp = ros_time(t)
    return _fg().Timestamp(sec=stamp["sec"], nsec=stamp["nanosec"])


def _colour(rgba):
    r, g, b, a = rgba
    return _fg().Color(r=r, g=g, b=b, a=a)


def _vec(p):
    x, y, z = (np.asarray(p, dtype=float) * M).tolist()
    return _fg().Vector3(x=x, y=y, z=z)


def _quat(R: np.ndarray):
    q = quaternion(R)
    return _fg().Quaternion(**q)


def _pose(p, R: np.ndarray | None = None):
    fm = _fg()
    return fm.Pose(position=_vec(p), orientation=fm.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0) if R is None else _quat(R))


def _entity(t: float, ident: str, **primitives):
    return _fg().SceneEntity(timestamp=_ts(t), frame_id=SCENE_FRAME, id=ident, **primitives)


def _points(ps: np.ndarray) -> list:
    fm = _fg()
    return [fm.Point3(x=x, y=y, z=z) for x, y, z in (np.asarray(ps, dtype=float) * M).tolist()]


def obstacles(triangles: list[np.ndarray], prior: np.ndarray, t: float = 0.0):
    """``SceneUpdate`` of a scene's obstacles (their ``triangles`` (k, 3, 3) mm, whether each is known before the
    job), one entity of triangles each."""
    fm = _fg()
    entities = []
    for i, (tris, known) in enumerate(zip(triangles, prior)):
        tris = tris.reshape(-1, 3)
        entities.append(_entity(t, f"obstacle-{i}", triangles=[fm.TriangleListPrimitive(
            pose=_pose(np.zeros(3)), points=_points(tris), color=_colour(KNOWN if known else DISCOVERED))],
            metadata=[fm.KeyValuePair(key="known", value=str(bool(known)).lower())]))
    return fm.SceneUpdate(entities=entities)


def _spheres(t: float, ident: str, points: np.ndarray, size: float, rgba):
    fm = _fg()
    return _entity(t, ident, spheres=[fm.SpherePrimitive(pose=_pose(p), size=fm.Vector3(x=size, y=size, z=size),
                                                        color=_colour(rgba)) for p in points])


def z_to(d: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4), x y z w, of the shortest rotations taking +z onto the unit vectors ``d`` (..., 3)
    (about x for -z)."""
    q = np.stack([-d[..., 1], d[..., 0], np.zeros(d.shape[:-1]), 1.0 + d[..., 2]], axis=-1)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    flip = n[..., 0] < 1e-12
    q[flip] = [1.0, 0.0, 0.0, 0.0]
    n[flip] = 1.0
    return q / n


def bodies(joints: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The arm's cylinders at every sample, all at once: the joints (T, n+1, 3) mm give one per section from joint i
    to i+1, as centres (T, n, 3) m, quaternions (T, n, 4) and sizes (T, n, 3) m."""
    d = joints[:, 1:] - joints[:, :-1]
    length = np.linalg.norm(d, axis=-1)
    unit = d / np.where(length > 0, length, 1.0)[..., None]
    sizes = np.stack(np.broadcast_arrays(2 * radii * M, 2 * radii * M, length * M), axis=-1)
    return (joints[:, 1:] + joints[:, :-1]) / 2 * M, z_to(unit), sizes


def body(t: float, sample) -> object:
    """``SceneUpdate`` of the arm at one sample of :func:`bodies` (its centres, quaternions and sizes as lists)."""
    fm = _fg()
    grey = _colour((0.27, 0.27, 0.27, 1.0))
    cylinders = [fm.CylinderPrimitive(pose=fm.Pose(position=fm.Vector3(x=c[0], y=c[1], z=c[2]),
                                                   orientation=fm.Quaternion(x=q[0], y=q[1], z=q[2], w=q[3])),
                                      size=fm.Vector3(x=z[0], y=z[1], z=z[2]), bottom_scale=1.0, top_scale=1.0,
                                      color=grey) for c, q, z in zip(*sample) if z[2] > 0.0]
    return fm.SceneUpdate(entities=[_entity(t, "arm", cylinders=cylinders)])


def _coverage(t: float, points: np.ndarray, seen: np.ndarray):
    fm = _fg()
    n = len(points)
    rec = np.zeros(n, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("red", "u1"), ("green", "u1"),
                             ("blue", "u1"), ("alpha", "u1")])
    rec["x"], rec["y"], rec["z"] = (points * M).T
    rgba = np.round(np.where(seen[:, None], np.array(SEEN), np.array(UNSEEN)) * 255).astype(np.uint8)
    for k, name in enumerate(("red", "green", "blue", "alpha")):
        rec[name] = rgba[:, k]
    f32, u8 = fm.PackedElementFieldNumericType.Float32, fm.PackedElementFieldNumericType.Uint8
    fields = [fm.PackedElementField(name=name, offset=off, type=kind) for name, off, kind in
              (("x", 0, f32), ("y", 4, f32), ("z", 8, f32), ("red", 12, u8), ("green", 13, u8), ("blue", 14, u8),
               ("alpha", 15, u8))]
    return fm.PointCloud(timestamp=_ts(t), frame_id=SCENE_FRAME, pose=_pose(np.zeros(3)), point_stride=16,
                         fields=fields, data=rec.tobytes())


def messages(rec: Recording, start_s: float = 0.0, speed: float = 1.0):
    """Every message of the recording as (topic, time s, Foxglove message) in time order, the arm's made as they
    are written; a message at recording time t is stamped ``start_s`` + t / ``speed``."""
    fm = _fg()
    out = []

    def stamp(t: float) -> float:
        return start_s + t / speed

    def add(topic: str, t: float, msg) -> None:
        out.append((topic, stamp(t), msg))

    scene = rec.scene
    add("/scene", 0.0, obstacles(rec.triangles, scene.prior, stamp(0.0)))
    found = rec.found_s
    if len(scene.targets):
        add("/targets", 0.0, fm.SceneUpdate(entities=[_spheres(stamp(0.0), "targets", scene.targets, TARGET_M,
                                                              TARGET if found is None else UNSEEN)]))
        if found is not None:
            for i in np.flatnonzero(np.isfinite(found)):
                t = float(found[i])
                add("/targets", t, fm.SceneUpdate(entities=[_spheres(stamp(t), f"found-{i}", scene.targets[i:i + 1],
                                                                     TARGET_M * 1.2, FOUND)]))
    for i, (path, start) in enumerate(zip(rec.paths, rec.path_starts_s.tolist())):
        add("/tip_path", start, fm.SceneUpdate(entities=[_entity(stamp(start), f"path-{i}", lines=[fm.LinePrimitive(
            type=fm.LinePrimitiveLineType.LineStrip, pose=_pose(np.zeros(3)), thickness=LINE_M,
            scale_invariant=False, points=_points(path), color=_colour(PATH))])]))
    if rec.views is not None:
        for t, p, d in zip(rec.views.times_s.tolist(), rec.views.positions, rec.views.directions):
            add("/views", t, fm.PoseInFrame(timestamp=_ts(stamp(t)), frame_id=SCENE_FRAME,
                                            pose=_pose(p, view_rotation(d))))
    for t, seen in rec.coverage_updates():
        add("/coverage", t, _coverage(stamp(t), rec.points, seen))
    level = fm.LogLevel.Info if rec.success else fm.LogLevel.Warning
    add("/log", 0.0, fm.Log(timestamp=_ts(stamp(0.0)), level=level, message=rec.verdict, name="judge"))
    verdict = fm.TextPrimitive(pose=_pose(scene.entrance.position), billboard=True, font_size=14.0,
                               scale_invariant=True, color=_colour(FOUND if rec.success else FAILURE),
                               text=rec.verdict)
    add("/judge", 0.0, fm.SceneUpdate(entities=[_entity(stamp(0.0), "verdict", texts=[verdict])]))
    f = rec.failure
    if f is not None:
        add("/log", f.time_s, fm.Log(timestamp=_ts(stamp(f.time_s)), level=fm.LogLevel.Error, name="judge",
                                     message=f"first failure: {f.reason} at {f.time_s:.2f} s"))
        mark = _spheres(stamp(f.time_s), "failure", f.position[None], FAILURE_M, FAILURE)
        add("/judge", f.time_s, fm.SceneUpdate(entities=[mark]))
    out.sort(key=lambda m: m[1])
    return heapq.merge(out, _motion(rec, stamp), key=lambda m: m[1])


def _motion(rec: Recording, stamp):
    """``/arm``, ``/tf`` (the tip) and ``/joint_states`` at every sample, made as they are written."""
    fm = _fg()
    robot = rec.robot
    joints = rec.joint_positions()
    centres, quats, sizes = bodies(joints, robot.radii)
    axis = joints[:, -1] - joints[:, -2]
    tip_rotations = z_to(axis / np.linalg.norm(axis, axis=-1, keepdims=True))
    positions = rec.q * si_scale(robot)
    for k, t in enumerate(rec.t.tolist()):
        yield "/arm", stamp(t), body(stamp(t), (centres[k].tolist(), quats[k].tolist(), sizes[k].tolist()))
        (x, y, z), (qx, qy, qz, qw) = (joints[k, -1] * M).tolist(), tip_rotations[k].tolist()
        yield "/tf", stamp(t), fm.FrameTransforms(transforms=[fm.FrameTransform(
            timestamp=_ts(stamp(t)), parent_frame_id=SCENE_FRAME, child_frame_id="tip",
            translation=fm.Vector3(x=x, y=y, z=z), rotation=fm.Quaternion(x=qx, y=qy, z=qz, w=qw))])
        yield "/joint_states", stamp(t), fm.JointStates(timestamp=_ts(stamp(t)), joints=[
            fm.JointState(name=name, position=v) for name, v in zip(robot.joint_names, positions[k].tolist())])


class _Channels:
    """Typed channels (each with its Foxglove schema: foxglove-sdk's channel class named for the message's) made on
    first use, in one logging context."""

    def __init__(self, context) -> None:
        self.context = context
        self.channels: dict[str, object] = {}

    def log(self, topic: str, msg, log_time_ns: int | None = None) -> None:
        import foxglove.channels as fc

        channel = self.channels.get(topic)
        if channel is None:
            channel = getattr(fc, f"{type(msg).__name__}Channel")(topic, context=self.context)
            self.channels[topic] = channel
        channel.log(msg, log_time=log_time_ns)


def write_mcap(rec: Recording, filename: str) -> dict[str, int]:
    """Write ``rec`` as a Foxglove MCAP file (atomically: a temporary file beside it, fsync'ed and renamed over
    it). Returns the message count per topic."""
    require_ros("--mcap")
    import foxglove

    check_output(filename, "--mcap", (".mcap",))
    counts: dict[str, int] = {}
    with atomic_path(filename) as tmp:
        context = foxglove.Context()
        writer = foxglove.open_mcap(tmp, allow_overwrite=True, context=context)
        try:
            channels = _Channels(context)
            for topic, t, msg in messages(rec):
                channels.log(topic, msg, int(round(t * 1e9)))
                counts[topic] = counts.get(topic, 0) + 1
        finally:
            writer.close()
    return counts


class LiveView:
    """A Foxglove WebSocket server that shows each recording handed to :meth:`show` as it comes (plans and
    missions of a run as they are judged). Bound to ``host`` (the command line's is loopback unless told
    otherwise) on ``port`` (0: any free one)."""

    def __init__(self, host: str, port: int, name: str = "snakeplan") -> None:
        require_ros("--live")
        import foxglove

        self.context = foxglove.Context()
        self.server = foxglove.start_server(name=name, host=host, port=port, context=self.context)
        self.host = host
        self.channels = _Channels(self.context)

    @property
    def port(self) -> int:
        return self.server.port

    @property
    def url(self) -> str:
        return f"ws://{f'[{self.host}]' if ':' in self.host else self.host}:{self.port}"

    def show_scene(self, scene) -> None:
        """Send the scene's obstacles now (before a plan of it is ready)."""
        import time

        now = time.time()
        self.channels.log("/scene", obstacles(scene_triangles(scene), scene.prior, now), int(round(now * 1e9)))

    def note(self, text: str) -> None:
        """A line on ``/log`` now."""
        import time

        now = time.time()
        self.channels.log("/log", _fg().Log(timestamp=_ts(now), level=_fg().LogLevel.Info, message=text,
                                            name="snakeplan"), int(round(now * 1e9)))

    def show(self, rec: Recording, speed: float = 0.0, stopped=None) -> bool:
        """Send ``rec``'s messages now: with ``speed`` > 0 paced at that multiple of mission time, else all at once;
        stamped when due. ``stopped()`` is asked while waiting; returns False when it said stop."""
        import time

        start = time.time()
        for topic, t, msg in messages(rec, start, speed if speed > 0 else 1.0):
            while speed > 0 and time.time() < t:
                if stopped is not None and stopped():
                    return False
                time.sleep(min(0.05, max(0.0, t - time.time())))
            self.channels.log(topic, msg, int(round(t * 1e9)))
        return not (stopped is not None and stopped())

    def stop(self) -> None:
        self.server.stop()
