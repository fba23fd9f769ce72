"""Trajectories a controller can run: a judged plan's crawl as feed, joint and cable commands over time.

A plan is a tip path; the judge crawls the arm along it by follow-the-leader (:mod:`snakeplan.ftl`) at its
insertion steps (``JUDGE.step_mm``). :func:`build_trajectory` takes those very states, turns each body into the
robot's joint vector (feed in mm, angles in rad; ``Chain.joint_angles_from_directions``) with the arm's base on
the feed axis behind the entrance, times them with TOPP-RA under the robot's motion limits
(:mod:`.timing`), and adds the tip pose, the body's deviation from the path, and, for a cable-driven robot, every
cable's length (:mod:`snakeplan.robots.cables`). :mod:`.documents` writes it as ``snakeplan.trajectory/1`` JSON
(self-contained: the robot's URDF is inside), CSV, and a ROS-2 ``trajectory_msgs/JointTrajectory``-shaped YAML or
JSON; :func:`.replay.replay` checks a written trajectory against the body the judge approved. Formats:
docs/TRAJECTORY.md.

Layering: above :mod:`snakeplan.evaluation` (it judges the plan it is given); planners do not import it.
"""

from snakeplan.trajectory.build import (
    FEED_SLACK_MM,
    LIMIT_SLACK,
    InfeasiblePlan,
    Trajectory,
    build_trajectory,
)
from snakeplan.trajectory.documents import (
    SCHEMA,
    output_format,
    read_plan,
    ros_message,
    to_csv,
    to_dict,
    write,
)
from snakeplan.trajectory.replay import ReplayReport, replay
from snakeplan.trajectory.timing import METHOD, Timing, time_scale

__all__ = ["FEED_SLACK_MM", "LIMIT_SLACK", "METHOD", "SCHEMA", "InfeasiblePlan", "ReplayReport", "Timing",
           "Trajectory", "build_trajectory", "output_format", "read_plan", "replay", "ros_message",
           "time_scale", "to_csv", "to_dict", "write"]
