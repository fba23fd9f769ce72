"""Evaluation: the one judge of plans, reach and inspect (feasibility and metrics); planners never judge themselves."""

from snakeplan.evaluation.judge import JudgeSettings, Reason, Report, evaluate
from snakeplan.evaluation.metrics import curvature_profile, curvature_stats, path_length, smoothness_index
from snakeplan.evaluation.mission import MissionFailure, MissionReport, evaluate_mission
from snakeplan.evaluation.verdict import judge

__all__ = ["JudgeSettings", "MissionFailure", "MissionReport", "Reason", "Report", "evaluate", "evaluate_mission",
           "judge", "curvature_profile", "curvature_stats", "path_length", "smoothness_index"]
