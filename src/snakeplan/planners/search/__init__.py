"""Search planners: find the targets with the tip camera, then reach each (paper 000's task: debris "labelled only
when it appears within the agent's field of view"). :class:`SearchPlanner` is the loop they share (an explorer
proposes branches, each is flown, its views looked through, and every target seen is reached by a reaching planner
before exploring on); ``explore-reach`` explores by inspecting where debris can lie, ``frontier`` by the boundary
between seen and unseen space."""

from snakeplan.planners.search.loop import REACH_TIME_S, REACH_TRIES, Explorer, SearchPlanner

__all__ = ["REACH_TIME_S", "REACH_TRIES", "Explorer", "SearchPlanner"]
