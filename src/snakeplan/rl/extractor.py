"""The policy's input layer in torch for SB3: :func:`snakeplan.planners.sac.policy_input`, batched, no weights.

Computing the goal and route features inside the network (from ``achieved_goal`` and ``desired_goal``) keeps
them consistent when HER relabels the goal. The ``guide`` design's route features are the route guide's, which
lead to the episode's own target and travel in the observation: a relabelled goal keeps them, so guide policies
are trained without relabelling (``sac``; the generalist).
"""

from __future__ import annotations

import torch as th
from gymnasium import spaces
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

from snakeplan.planners.sac.observation import FEATURE_CLIP, FEATURE_SCALE_MM, GOAL_SCALE_MM, input_dim


def _rel(frame: th.Tensor, vec: th.Tensor) -> th.Tensor:
    local = th.einsum("bij,bj->bi", frame, vec)
    dist = th.linalg.norm(local, dim=-1, keepdim=True)
    return th.cat([local / th.clamp(dist, min=1e-9), th.clamp(dist / FEATURE_SCALE_MM, max=FEATURE_CLIP)], dim=-1)


class GoalRouteExtractor(BaseFeaturesExtractor):
    """Observation dict -> actor/critic input; ``graph`` is :meth:`RoomGraph.arrays` (or None)."""

    def __init__(self, observation_space: spaces.Dict, mode: str = "local", graph: dict | None = None):
        super().__init__(observation_space, input_dim(mode, observation_space["observation"].shape[0]))
        self.mode = mode
        self.has_graph = graph is not None
        if graph is not None:
            for key in ("lo", "hi", "centre", "normal"):
                self.register_buffer(key, th.as_tensor(graph[key], dtype=th.float32))
            for key in ("next_portal", "after"):
                self.register_buffer(key, th.as_tensor(graph[key], dtype=th.long))

    def _room_of(self, p: th.Tensor) -> th.Tensor:
        q = p[:, None, :]
        gap = th.clamp(th.maximum(self.lo - q, q - self.hi), min=0.0)
        return th.argmin(th.linalg.norm(gap, dim=-1), dim=-1)

    def _waypoints(self, tip: th.Tensor, goal: th.Tensor):
        a, b = self._room_of(tip), self._room_of(goal)
        k = self.next_portal[a, b]
        has = k >= 0
        ks = th.clamp(k, min=0)
        first = th.where(has[:, None], self.centre[ks], goal)
        into = self.after[a, b]
        k2 = self.next_portal[into, b]
        second = th.where((has & (k2 >= 0))[:, None], self.centre[th.clamp(k2, min=0)], goal)
        towards = (self.lo[into] + self.hi[into]) / 2 - first
        sign = th.sign(th.sum(towards * self.normal[ks], dim=-1, keepdim=True))
        normal = th.where(has[:, None], sign * self.normal[ks], th.zeros_like(goal))
        return first, second, normal

    def forward(self, obs: dict[str, th.Tensor]) -> th.Tensor:
        o, ag, dg = obs["observation"], obs["achieved_goal"], obs["desired_goal"]
        if self.mode == "paper":
            return th.cat([o, ag, dg], dim=-1)
        frame = o[:, 3:12].reshape(-1, 3, 3)
        tip, goal = ag * GOAL_SCALE_MM, dg * GOAL_SCALE_MM
        if self.mode == "guide":  # the route guide's features are in the observation
            return th.cat([o, _rel(frame, goal - tip)], dim=-1)
        if self.has_graph:
            first, second, normal = self._waypoints(tip, goal)
        else:
            first, second, normal = goal, goal, th.zeros_like(goal)
        n_local = th.einsum("bij,bj->bi", frame, normal)
        return th.cat([o, _rel(frame, goal - tip), _rel(frame, first - tip), _rel(frame, second - tip), n_local],
                         dim=-1)
