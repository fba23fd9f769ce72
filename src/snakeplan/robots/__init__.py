"""Snake-arm robots: :class:`Chain` (sections, feed axis, base pose; batched FK, tip Jacobian, null-space
projector, IK), presets by name, (modified) DH tables and URDF export. Units: mm, rad."""

from snakeplan.robots.chain import ET, SCHEMA, Chain, IKResult, Kinematics, Section, default_kinematics
from snakeplan.robots.dh import load_dh
from snakeplan.robots.presets import ROBOTS, get_robot, register_robot, robot_names
from snakeplan.robots.urdf import to_urdf

__all__ = [
    "ET",
    "ROBOTS",
    "SCHEMA",
    "Chain",
    "IKResult",
    "Kinematics",
    "Section",
    "default_kinematics",
    "get_robot",
    "load_dh",
    "register_robot",
    "robot_names",
    "to_urdf",
]
