"""URDF export of a :class:`~snakeplan.robots.chain.Chain`.

Every joint of the ETS becomes a URDF joint (the feed a prismatic one, each universal joint two revolute ones
with a zero-length link between them); the fixed transforms before a joint become its origin. Each section's
body is a cylinder (visual and collision) from its start to its end point, on the link moved by the section's
last joint; a fixed frame ``s<i>_end`` marks each section end (``s<n-1>_end`` is the tip). URDF is in SI units,
so lengths are multiplied by ``length_scale`` (default 1e-3: mm to m); angles stay in rad.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ElementTree

import numpy as np

from snakeplan.geometry.transforms import frame_from_z
from snakeplan.robots.chain import Chain

_AXES = ("1 0 0", "0 1 0", "0 0 1")
_EFFORT = "100"  # placeholder actuator limits: URDF requires them, snakeplan does not model dynamics
_VELOCITY = "1"


def _fmt(values) -> str:
    return " ".join(f"{float(v):.12g}" for v in values)


def _rpy(R: np.ndarray) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw (rad) with ``R = Rz(yaw) · Ry(pitch) · Rx(roll)``; yaw = 0 at gimbal lock."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) > 1e-12:
        return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])
    return math.atan2(-R[1, 2], R[1, 1]), pitch, 0.0


def _origin(parent: ElementTree.Element, T: np.ndarray, scale: float) -> None:
    rpy = _rpy(T[:3, :3])
    ElementTree.SubElement(parent, "origin", xyz=_fmt(T[:3, 3] * scale), rpy=_fmt(rpy))


def _cylinder(link: ElementTree.Element, start: np.ndarray, end: np.ndarray, radius: float, scale: float) -> None:
    axis = end - start
    T = np.eye(4)
    T[:3, :3] = frame_from_z(axis)
    T[:3, 3] = 0.5 * (start + end)
    for tag in ("visual", "collision"):
        el = ElementTree.SubElement(link, tag)
        _origin(el, T, scale)
        geom = ElementTree.SubElement(el, "geometry")
        ElementTree.SubElement(geom, "cylinder", radius=_fmt([radius * scale]),
                               length=_fmt([np.linalg.norm(axis) * scale]))


def to_urdf(chain: Chain, *, length_scale: float = 1e-3) -> str:
    """URDF XML text of ``chain`` at its base pose (root link ``world``, arm root ``base_link``)."""
    kin = chain.kinematics
    lower, upper = chain.joint_limits()
    robot = ElementTree.Element("robot", name=chain.name)
    links = {"world": ElementTree.SubElement(robot, "link", name="world")}

    def add_joint(name: str, kind: str, parent: str, child: str, T: np.ndarray) -> ElementTree.Element:
        links[child] = ElementTree.SubElement(robot, "link", name=child)
        j = ElementTree.SubElement(robot, "joint", name=name, type=kind)
        _origin(j, T, length_scale)
        ElementTree.SubElement(j, "parent", link=parent)
        ElementTree.SubElement(j, "child", link=child)
        return j

    add_joint("base_mount", "fixed", "world", "base_link", chain.base)
    zero_points = (chain.joint_positions(np.zeros(chain.dof)) - chain.base[:3, 3]) @ chain.base[:3, :3]
    current, link_pose, acc = "base_link", np.eye(4), np.eye(4)
    mark = 0
    for index in range(kin.frames[-1] + 1):
        while mark < len(kin.frames) and kin.frames[mark] == index:
            if mark > 0:
                start = np.linalg.inv(link_pose) @ np.append(zero_points[mark - 1], 1.0)
                _cylinder(links[current], start[:3], acc[:3, 3], chain.radii[mark - 1], length_scale)
                # At zero joint values every recorded frame has the base's orientation.
                T = acc.copy()
                T[:3, :3] = acc[:3, :3] @ (link_pose @ acc)[:3, :3].T
                add_joint(f"s{mark - 1}_end_joint", "fixed", current, f"s{mark - 1}_end", T)
            mark += 1
        if index == kin.frames[-1]:
            break
        e = kin.ets[index]
        if e.joint is None:
            acc = acc @ e.matrix()
            continue
        name = kin.joint_names[e.joint]
        j = add_joint(name, "revolute" if e.is_rotation else "prismatic", current, f"{name}_link",
                      acc @ e.matrix(0.0))
        ElementTree.SubElement(j, "axis", xyz=_AXES[e.axis])
        lim_scale = 1.0 if e.is_rotation else length_scale
        ElementTree.SubElement(j, "limit", lower=_fmt([lower[e.joint] * lim_scale]),
                               upper=_fmt([upper[e.joint] * lim_scale]), effort=_EFFORT, velocity=_VELOCITY)
        link_pose = link_pose @ acc @ e.matrix(0.0)
        current, acc = f"{name}_link", np.eye(4)
    ElementTree.indent(robot)
    return '<?xml version="1.0"?>\n' + ElementTree.tostring(robot, encoding="unicode") + "\n"

