"""A judged plan or mission out into the tools robot teams use, with no ROS installation: a ROS 2 bag that
``ros2 bag play`` replays to the controllers and RViz (:mod:`.bag`), a Foxglove-ready MCAP file, and a live
Foxglove view served on loopback (:mod:`.foxglove`). Both are written from one :class:`.recording.Recording` (the
arm's motion over time beside the scene and the judge's verdict), in ROS's SI units. Needs the ``ros`` extra
(``pip install "snakeplan[ros]"``); the libraries load inside the writers. Topics and frames: docs/ROS.md.

Layering: beside :mod:`snakeplan.trajectory`, whose trajectories it records; only the command line imports it.
"""

from snakeplan.ros.recording import Failure, Recording, of_mission, of_plan, of_trajectory

__all__ = ["Failure", "Recording", "of_mission", "of_plan", "of_trajectory"]
