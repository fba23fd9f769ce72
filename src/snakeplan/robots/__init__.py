"""Snake-arm robots: :class:`Chain` (sections, feed axis, base pose; batched FK, tip Jacobian, null-space
projector, IK), motion limits, cable routing and lengths, presets by name, robots from files (DH tables, URDF,
robot/1 JSON) and URDF export. Units: mm, rad, s."""

from snakeplan.robots.cable_routing import CableRouting, SectionCables
from snakeplan.robots.cables import cable_lengths, joint_angles_from_cables
from snakeplan.robots.chain import ET, SCHEMA, Chain, IKResult, Kinematics, Section, default_kinematics
from snakeplan.robots.dh import load_dh
from snakeplan.robots.limits import DEFAULT_LIMITS, MotionLimits
from snakeplan.robots.presets import ROBOTS, get_robot, load_robot, register_robot, robot_names
from snakeplan.robots.urdf import from_urdf, to_urdf

__all__ = [
    "DEFAULT_LIMITS",
    "ET",
    "ROBOTS",
    "SCHEMA",
    "CableRouting",
    "Chain",
    "IKResult",
    "Kinematics",
    "MotionLimits",
    "Section",
    "SectionCables",
    "cable_lengths",
    "default_kinematics",
    "from_urdf",
    "get_robot",
    "joint_angles_from_cables",
    "load_dh",
    "load_robot",
    "register_robot",
    "robot_names",
    "to_urdf",
]
