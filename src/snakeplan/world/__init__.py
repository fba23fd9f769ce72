"""The world a planner and the judge share: the one validity checker, its tolerance profiles, knowledge views."""

from snakeplan.world.knowledge import (
    DEFAULT_SENSOR_RANGE_MM,
    FullView,
    Knowledge,
    KnowledgeView,
    SensedView,
    SensingView,
    UnsensedObstacleError,
    as_knowledge,
    guarded,
    view_for,
)
from snakeplan.world.tolerances import (
    ENTRANCE_TOLERANCE_MM,
    JUDGE,
    PLANNING,
    REACH_TOLERANCE_MM,
    ROLLOUT,
    Tolerances,
)
from snakeplan.world.validity import (
    CrawlCheck,
    Failure,
    FailureKind,
    ValidityChecker,
    min_turn_radius,
    targets_reached,
)

__all__ = ["DEFAULT_SENSOR_RANGE_MM", "ENTRANCE_TOLERANCE_MM", "JUDGE", "PLANNING", "REACH_TOLERANCE_MM", "ROLLOUT",
           "CrawlCheck", "Failure", "FailureKind", "FullView", "Knowledge", "KnowledgeView", "SensedView",
           "SensingView", "Tolerances", "UnsensedObstacleError", "ValidityChecker", "as_knowledge", "guarded",
           "min_turn_radius", "targets_reached", "view_for"]
