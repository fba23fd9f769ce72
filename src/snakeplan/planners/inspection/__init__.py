"""Inspection planning (paper 002): the camera path, the station arm on its carriage, the viewpoint library, the
survey a mission needs, the mission loop and :class:`InspectionPlanner`, the base of the inspection planners
(``informative``, ``coverage``, ``random``), which register in the one planner registry for the inspect task.

Inspection has no targets: within a motion budget (130 s) the camera on the hsr-10's tip should learn the
station's surface field (temperature) as well as it can. A planner proposes camera paths; the mission loop flies
them with the arm, measures at a constant frequency, fuses every measurement into the surface map and asks the
planner again until the budget is spent. The plan carries the mission, which the judge replays
(:mod:`snakeplan.evaluation.mission`).
"""

from snakeplan.planners.inspection.arm import CARRIAGE_LEAD_MM, Follow, ReachReport, StationArm
from snakeplan.planners.inspection.camera_path import CHECK_STEP_MM, SPLINE_SAMPLES, CameraPath, natural_spline_samples
from snakeplan.planners.inspection.library import VIEW_STANDOFF_MM, ViewpointLibrary, library_positions
from snakeplan.planners.inspection.mission import FOLLOW_STEP_MM, FlownMission, MissionEnd, MissionState, fly
from snakeplan.planners.inspection.planner import N_CONTROL_POINTS, InspectionPlanner, mission_details
from snakeplan.planners.inspection.survey import KEEP_OUT_MM, REACH_RADIUS_MM, Survey, survey_for

__all__ = ["CARRIAGE_LEAD_MM", "CHECK_STEP_MM", "FOLLOW_STEP_MM", "KEEP_OUT_MM", "N_CONTROL_POINTS", "REACH_RADIUS_MM",
           "SPLINE_SAMPLES", "VIEW_STANDOFF_MM", "CameraPath", "FlownMission", "Follow", "InspectionPlanner",
           "MissionEnd", "MissionState", "ReachReport", "StationArm", "Survey", "ViewpointLibrary", "fly", "library_positions",
           "mission_details", "natural_spline_samples", "survey_for"]
