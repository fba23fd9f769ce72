"""`sscc`: Swinging Search and Crawling Control (paper 001) for a snake arm entering a pipe.

The Swinging Search (:mod:`.swinging`) finds a directive configuration, tip on the target and body clear, by
self-motion of the inner modules from an inverse-kinematics start, steered by the DDPG agent (:mod:`.agent`) or a
non-learning baseline; the Crawling Control (:mod:`.crawling`) checks the crawl along it and measures its maximum
deviation distance D. The plan is the directive configuration's tip path, entrance first: the judge crawls the
arm along it exactly as the Crawling Control does. One target per problem (paper 001 plans into a pipe once).

Options: ``search`` = ``"agent"`` (the shipped DDPG agent of the problem's robot; robots without one fall back to
``"gradient"``, said in the plan's details), ``"random"`` or ``"gradient"``; ``learning`` (the agent keeps learning
from every task, as in the paper: each search's transitions train it right after the plan is returned, while the
arm crawls, so the update is not in ``compute_time_s``; its cost is in the details as ``learning_time_s``);
``agent_path`` (an ``.npz`` from :func:`snakeplan.rl.sscc.train_agent` instead of the shipped agent; ``policy``,
the name every planner that rolls out a trained policy takes, and ``snakeplan plan --policy``, is the same). An agent is
trained for one registered arm (``sscc-16``, ``sscc-24``) and fits no other: its file's shapes are checked against
the problem's robot, and a robot that is not registered cannot use a given agent.

Planning with the agent needs no torch (its actor runs in NumPy); learning needs the ``train`` extra.

Learning is off by default so that a plan depends only on its problem and seed (docs/ARCHITECTURE.md, "Units and
conventions"), not on the tasks a planner saw before; ``snakeplan bench sscc`` runs the paper's learning mode beside it.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from snakeplan.extras import require_training
from snakeplan.planners.base import Plan, Planner, Problem, Solution, Status
from snakeplan.planners.registry import register_planner
from snakeplan.planners.sscc.agent import SwingAgent, load_agent, shipped_agent_path
from snakeplan.planners.sscc.crawling import Crawl, Directive, arm_base, crawl, joint_angles
from snakeplan.planners.sscc.swinging import (
    GradientSwing,
    RandomSwing,
    SwingPolicy,
    SwingSettings,
    swinging_search,
)
from snakeplan.robots import ROBOTS, Chain, robot_names
from snakeplan.scenes import SceneSpec

SEARCHES = ("agent", "random", "gradient")
#: Whether the agent keeps learning from every task by default (paper 001 does; see the module docstring).
ONLINE_LEARNING = False

__all__ = [
    "Crawl",
    "Directive",
    "SSCCPlanner",
    "SwingAgent",
    "SwingSettings",
    "crawl",
    "joint_angles",
    "swinging_search",
]


@register_planner
class SSCCPlanner(Planner):
    """Swinging Search and Crawling Control (paper 001); see the module docstring for the options."""

    name = "sscc"
    takes_policy = True

    def __init__(self, search: str = "agent", learning: bool = ONLINE_LEARNING, agent_path: str | None = None,
                 settings: SwingSettings = SwingSettings(), policy: str | None = None):
        if search not in SEARCHES:
            raise ValueError(f"search: must be one of {', '.join(SEARCHES)}, got {search!r}")
        if policy is not None and agent_path is not None and str(policy) != str(agent_path):
            raise ValueError("policy: give the agent file once, as policy or as agent_path")
        agent_path = agent_path if policy is None else policy
        self.search, self.learning, self.agent_path, self.settings = search, bool(learning), agent_path, settings
        self._agents: dict[str, SwingAgent] = {}
        self._pending: tuple[SwingAgent, list] | None = None
        if self.learning and search == "agent":
            require_training("sscc learning")  # and loaded here, before any timed planning

    def policy_file(self, spec: SceneSpec, robot: Chain) -> Path | None:
        """The agent file this planner swings ``robot`` with: the one given, else the shipped one where it ships;
        None for a search without an agent."""
        if self.search != "agent":
            return None
        path = Path(self.agent_path) if self.agent_path is not None else shipped_agent_path(robot.name)
        return path if path.is_file() else None

    def agent(self, robot: str) -> SwingAgent | None:
        """The agent this planner swings ``robot`` with, or None: a learning agent is loaded once and kept (it
        learns); otherwise the file's current content (:func:`.agent.load_agent`)."""
        if self.agent_path is None and not shipped_agent_path(robot).exists():
            return None
        if not self.learning:
            return load_agent(robot, self.agent_path)
        if robot not in self._agents:
            self._agents[robot] = SwingAgent.load(robot, self.agent_path, learning=True)
        return self._agents[robot]

    def _given_agent(self, robot: Chain) -> SwingAgent:
        """The agent in the file this planner was given, for ``robot``; ValueError ``policy: ...`` in one line when
        it is not an SSCC agent that fits the robot."""
        if robot.name not in ROBOTS:
            raise ValueError(f"policy: an SSCC agent is trained for a registered arm ({', '.join(robot_names())}); "
                             f"robot {robot.name} is not one")
        try:
            return self.agent(robot.name)
        except ValueError as exc:  # the loader's one line, "agent_path: <what is wrong>"
            why = str(exc).removeprefix("agent_path: ")
            raise ValueError(f"policy: {self.agent_path} is not an SSCC agent for {robot.name} (one that "
                             f"'snakeplan train sscc --robot {robot.name}' writes): {why}") from None

    def _policy(self, robot: Chain) -> tuple[str, SwingPolicy]:
        if self.search != "agent":
            agent = None
        elif self.agent_path is not None:
            agent = self._given_agent(robot)
        else:
            agent = self.agent(robot.name)
        if agent is not None:
            return "agent", agent
        if self.search == "random":
            return "random", RandomSwing()
        return "gradient", GradientSwing()

    def plan(self, problem: Problem, seed: int = 0) -> Plan:
        """Plan (timed like every planner); then, when learning, train the agent on the search's transitions and
        say how many updates that took (``learning_steps``) and how long (``learning_time_s``)."""
        plan = super().plan(problem, seed)
        if self._pending is not None:
            learner, transitions = self._pending
            self._pending = None
            t0 = time.perf_counter()
            plan.details["learning_steps"] = learner.learn(transitions)
            plan.details["learning_time_s"] = time.perf_counter() - t0
        return plan

    def _solve(self, problem: Problem, rng: np.random.Generator, deadline: float) -> Solution:
        if len(problem.goals) != 1:
            return Solution(Status.INVALID_TARGET, None, {},
                            f"sscc plans to one target, the scene has {len(problem.goals)}")
        used, policy = self._policy(problem.robot)
        learner = policy if isinstance(policy, SwingAgent) and self.learning else None
        out = swinging_search(problem, policy, rng, deadline, self.settings, record=learner is not None)
        if learner is not None:
            self._pending = (learner, out.transitions)
        details: dict = {"search": used, "episodes": out.episodes, "swing_steps": out.steps}
        if out.motion is None:
            if out.timed_out:
                return Solution(Status.TIMEOUT, None, details,
                                f"the time limit ran out after {out.episodes} swinging episodes with no feasible "
                                f"motion")
            return Solution(Status.NO_PROGRESS, None, details,
                            f"none of {out.episodes} swinging episodes found a feasible motion")
        d = out.motion.directive
        robot = problem.robot
        q = robot.joint_angles_from_directions(
            np.diff(d.joints, axis=0), base_rotation=arm_base(robot, d.entrance, d.direction)[:3, :3],
            feed=float((d.joints[0] - d.entrance) @ d.direction) + robot.total_length)
        details.update(n_inner=d.n_inner, critical_module=d.critical, overhang_mm=d.overhang_mm,
                       max_deviation_D_mm=out.motion.D, directive_joints=d.joints, directive_q=q)
        return Solution(Status.FOUND, d.tip_path(), details)
