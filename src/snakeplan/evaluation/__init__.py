"""Evaluation: the one judge of plans, reach, inspect and search (feasibility and metrics); planners never judge
themselves."""

from snakeplan.evaluation.judge import JudgeSettings, Reason, Report, evaluate
from snakeplan.evaluation.metrics import curvature_profile, curvature_stats, path_length, smoothness_index
from snakeplan.evaluation.mission import MissionFailure, MissionReport, evaluate_mission
from snakeplan.evaluation.search import SearchReport, evaluate_search
from snakeplan.evaluation.verdict import judge

__all__ = ["JudgeSettings", "MissionFailure", "MissionReport", "Reason", "Report", "SearchReport", "evaluate",
           "evaluate_mission", "evaluate_search", "judge", "curvature_profile", "curvature_stats", "path_length",
           "smoothness_index"]
