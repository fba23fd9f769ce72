"""Replay check: a written ``snakeplan.trajectory/1`` document moves the body the judge approved.

Everything comes from the document itself, as it would for anyone replaying it without snakeplan's planner: the
URDF inside is parsed with yourdfpy (an independent URDF library) and the product of its joints' origins and
motions, at every point's positions, placed by ``base_pose``, gives the body links' positions (not snakeplan's
kinematics); the follow-the-leader body is fitted anew
(:func:`snakeplan.ftl.fit_states`) on the plan's path (``provenance.path``) at every point's depth with the section
lengths of that URDF. Every limit in ``limits`` is checked at every point, and for a cable-driven robot the cable
lengths are inverted back to joint angles (:func:`snakeplan.robots.cables.joint_angles_from_cables`) and, the
other way, recomputed from the URDF's section frames.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np

from snakeplan import ftl
from snakeplan.robots.cable_routing import CableRouting
from snakeplan.robots.cables import joint_angles_from_cables, lengths_from_rotations
from snakeplan.robots.chain import Chain
from snakeplan.robots.urdf import from_urdf

#: Round-off allowed on a position limit (mm or rad).
POSITION_SLACK = 1e-9


@dataclass(frozen=True)
class ReplayReport:
    """Worst errors over every point: body links' FK against the follow-the-leader joints (mm); how far any
    position, velocity or acceleration goes beyond its limit (its units; 0 when every limit holds) and which
    (``"<kind> <joint> at point <k>"``, None when none does); for a cable-driven robot, the joint angles recovered
    from the cable lengths against the positions (rad) and the cable lengths recomputed from the URDF's frames
    against the written ones (mm), else None."""

    points: int
    body_error_mm: float
    limit_excess: float
    worst_limit: str | None
    cable_angle_error_rad: float | None
    cable_length_error_mm: float | None
    times_increase: bool
    starts_and_ends_at_rest: bool


def _rotation(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rotations ``(T, 3, 3)`` by ``angles (T,)`` about the unit ``axis`` (Rodrigues)."""
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(angles)[:, None, None], np.cos(angles)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def urdf_joint_transforms(urdf: str, positions: np.ndarray) -> list[tuple[str, str, str, np.ndarray]]:
    """Every joint of the URDF as (name, parent link, child link, transforms ``(T, 4, 4)`` of the child in the
    parent, mm) at joint positions ``positions (T, dof)`` (prismatic joints in mm, revolute in rad) in the order of
    its movable joints: the URDF parsed by yourdfpy, each joint's origin times its motion."""
    import yourdfpy

    model = yourdfpy.URDF.load(io.StringIO(urdf), build_scene_graph=False, load_meshes=False,
                               build_collision_scene_graph=False, load_collision_meshes=False)
    T = positions.shape[0]
    movable = [j.name for j in model.robot.joints if j.type != "fixed"]
    out = []
    for joint in model.robot.joints:
        origin = np.eye(4) if joint.origin is None else np.array(joint.origin, dtype=np.float64)
        origin[:3, 3] *= 1e3
        M = np.broadcast_to(np.eye(4), (T, 4, 4)).copy()
        if joint.type != "fixed":
            axis = np.asarray(joint.axis, dtype=np.float64)
            axis = axis / np.linalg.norm(axis)
            q = positions[:, movable.index(joint.name)]
            if joint.type == "prismatic":
                M[:, :3, 3] = q[:, None] * axis
            else:
                M[:, :3, :3] = _rotation(axis, q)
        out.append((joint.name, joint.parent, joint.child, origin @ M))
    return out


def urdf_link_poses(urdf: str, positions: np.ndarray, links: list[str]) -> np.ndarray:
    """Poses ``(T, len(links), 4, 4)`` of ``links`` relative to the URDF's root link (mm) at joint positions
    ``positions (T, dof)``: :func:`urdf_joint_transforms` multiplied from the root."""
    T = positions.shape[0]
    by_child = {child: (parent, M) for _, parent, child, M in urdf_joint_transforms(urdf, positions)}
    poses: dict[str, np.ndarray] = {}

    def pose_of(link: str) -> np.ndarray:
        if link not in poses:
            if link not in by_child:
                poses[link] = np.broadcast_to(np.eye(4), (T, 4, 4))
            else:
                parent, M = by_child[link]
                poses[link] = pose_of(parent) @ M
        return poses[link]

    return np.stack([pose_of(link) for link in links], axis=1)


def replay(doc: dict) -> ReplayReport:
    """Check a ``snakeplan.trajectory/1`` document (parsed JSON) against the body the judge approved; see the
    module docstring."""
    points = doc["points"]
    positions = np.array([p["positions"] for p in points], dtype=np.float64)
    velocities = np.array([p["velocities"] for p in points], dtype=np.float64)
    accelerations = np.array([p["accelerations"] for p in points], dtype=np.float64)
    t = np.array([p["t"] for p in points], dtype=np.float64)
    depths = np.array([p["depth_mm"] for p in points], dtype=np.float64)
    chain = from_urdf(doc["urdf"])
    if list(chain.joint_names) != list(doc["joint_names"]):
        raise ValueError("joint_names: differ from the URDF's movable joints")
    base_pose = np.array(doc["base_pose"], dtype=np.float64)
    frames = base_pose @ urdf_link_poses(doc["urdf"], positions, doc["body_links"])
    provenance = doc["provenance"]
    entrance = provenance["entrance"]
    body = ftl.fit_states(provenance["path"], chain.lengths, depths, entrance["direction"],
                          entrance=entrance["position"]).joints
    body_error = float(np.max(np.linalg.norm(frames[:, :, :3, 3] - body, axis=-1)))

    limits = doc["limits"]
    feed = chain.has_feed
    v = np.full(chain.dof, limits["joint_rate_rad_s"])
    a = np.full(chain.dof, limits["joint_acceleration_rad_s2"])
    if feed:
        v[0], a[0] = limits["feed_speed_mm_s"], limits["feed_acceleration_mm_s2"]
    lower, upper = np.array(limits["lower"]), np.array(limits["upper"])
    excess = {"position": np.maximum(lower - POSITION_SLACK - positions, positions - upper - POSITION_SLACK),
              "velocity": np.abs(velocities) - v, "acceleration": np.abs(accelerations) - a}
    worst, where = 0.0, None
    for kind, e in excess.items():
        k, j = np.unravel_index(int(np.argmax(e)), e.shape)
        if e[k, j] > worst:
            worst, where = float(e[k, j]), f"{kind} {doc['joint_names'][j]} at point {k}"

    angle_error = length_error = None
    if "cables" in doc:
        routing = CableRouting.from_dict(doc["cables"]["routing"])
        cabled = Chain(chain.sections, name=chain.name, base=chain.base, kinematics=chain.kinematics,
                       limits=chain.limits, cables=routing)
        lengths = np.array([p["cable_lengths"] for p in points], dtype=np.float64)
        recovered = joint_angles_from_cables(cabled, lengths, feed=positions[:, 0] if feed else None)
        angle_error = float(np.max(np.abs(recovered - positions)[:, 1 if feed else 0:]))
        R = np.einsum("tkji,tkjl->tkil", frames[:, :-1, :3, :3], frames[:, 1:, :3, :3])
        length_error = float(np.max(np.abs(lengths_from_rotations(routing, chain.lengths, R) - lengths)))
    rest = bool(np.all(velocities[0] == 0.0) and np.all(velocities[-1] == 0.0))
    return ReplayReport(len(points), body_error, worst, where, angle_error, length_error,
                        bool(np.all(np.diff(t) > 0.0)), rest)
