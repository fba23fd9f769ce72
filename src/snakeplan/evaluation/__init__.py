"""Evaluation: the one judge of plans (feasibility and metrics); planners never judge themselves."""

from snakeplan.evaluation.judge import JudgeSettings, Reason, Report, evaluate
from snakeplan.evaluation.metrics import curvature_profile, curvature_stats, path_length, smoothness_index

__all__ = ["JudgeSettings", "Reason", "Report", "evaluate", "curvature_profile", "curvature_stats", "path_length",
           "smoothness_index"]
