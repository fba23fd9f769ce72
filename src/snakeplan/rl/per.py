"""Prioritised experience replay (paper 000 eqs. 15-19, Algorithm 3) as SB3 replay buffers, and SAC-PER.

A sum tree over ``p_i^alpha`` samples transition i with probability P(i) = p_i^alpha / sum_j p_j^alpha (eq. 15);
importance weights w_i = (|B| P(i))^-beta, normalised by the mini-batch's largest (eq. 16); beta is annealed
from ``BETA_START`` to 1 over training. :class:`PerSAC` weights each transition's critic loss by w_i and sets
p_i = |delta_i| + epsilon from the SAC TD error (eqs. 17-19). New transitions get the largest priority seen so
far (1 at the start, as Algorithm 3), so each is replayed at least about once.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import DictReplayBuffer, ReplayBuffer
from stable_baselines3.common.vec_env import VecNormalize

from snakeplan.rl.agents import EpsilonGreedySAC

#: PER exponents (paper 000 §4.1): prioritisation alpha, initial importance-sampling beta, priority epsilon.
ALPHA = 0.6
BETA_START = 0.4
PRIORITY_EPS = 1e-6
#: Priority of the first transitions (Algorithm 3).
INITIAL_PRIORITY = 1.0


class SumTree:
    """A complete binary tree of non-negative leaf values with batched updates and prefix-sum search (NumPy)."""

    def __init__(self, capacity: int):
        self.capacity = int(capacity)
        self.size = 1 << max(0, (self.capacity - 1).bit_length())
        self.tree = np.zeros(2 * self.size)

    @property
    def total(self) -> float:
        return float(self.tree[1])

    def __getitem__(self, idx) -> np.ndarray:
        return self.tree[self.size + np.asarray(idx)]

    def update(self, idx, values) -> None:
        """Set leaves ``idx`` to ``values`` (the last write wins for repeated indices) and refresh their sums."""
        node = self.size + np.asarray(idx, dtype=np.int64).ravel()
        self.tree[node] = np.broadcast_to(np.asarray(values, dtype=float).ravel(), node.shape)
        node = np.unique(node // 2)
        while node[0] >= 1:
            self.tree[node] = self.tree[2 * node] + self.tree[2 * node + 1]
            if node[0] == 1:
                break
            node = np.unique(node // 2)

    def find(self, mass) -> np.ndarray:
        """Leaf indices i with prefix(i) <= mass < prefix(i) + leaf(i), for ``mass`` in [0, total)."""
        m = np.asarray(mass, dtype=float).copy()
        node = np.ones(m.shape, dtype=np.int64)
        while node[0] < self.size:
            left = self.tree[2 * node]
            right = m >= left
            m -= np.where(right, left, 0.0)
            node = 2 * node + right
        return np.minimum(node - self.size, self.capacity - 1)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` leaves drawn proportionally to their values, one per equal slice of the total (stratified)."""
        edges = np.arange(n) * (self.total / n)
        return self.find(np.minimum(edges + rng.uniform(0.0, self.total / n, n), np.nextafter(self.total, 0.0)))


class PrioritizedSamples(NamedTuple):
    """A mini-batch with its importance weights ``(B, 1)`` and flat buffer indices for priority updates."""

    observations: Any
    actions: th.Tensor
    next_observations: Any
    dones: th.Tensor
    rewards: th.Tensor
    discounts: th.Tensor | None
    weights: th.Tensor
    indices: np.ndarray


class _Prioritized:
    """Priorities over a SB3 buffer's slots; flat index = position * n_envs + env."""

    def _init_priorities(self, alpha: float, beta: float, eps: float, seed: int | None) -> None:
        self.alpha, self.beta, self.eps = alpha, beta, eps
        self.tree = SumTree(self.buffer_size * self.n_envs)
        self.max_priority = INITIAL_PRIORITY
        self.rng = np.random.default_rng(seed)

    def _mark_new(self, pos: int) -> None:
        flat = pos * self.n_envs + np.arange(self.n_envs)
        self.tree.update(flat, self.max_priority ** self.alpha)

    def update_priorities(self, indices: np.ndarray, td_errors: np.ndarray) -> None:
        """Eq. 19: p_i = |delta_i| + eps for the sampled flat indices."""
        p = np.abs(np.asarray(td_errors, dtype=float)).ravel() + self.eps
        self.max_priority = max(self.max_priority, float(p.max()))
        self.tree.update(indices, p ** self.alpha)

    def __init__(self, buffer_size: int, observation_space: spaces.Space, action_space: spaces.Space,
                 device: th.device | str = "auto", n_envs: int = 1, optimize_memory_usage: bool = False,
                 handle_timeout_termination: bool = True, alpha: float = ALPHA, beta: float = BETA_START,
                 eps: float = PRIORITY_EPS, seed: int | None = None):
        super().__init__(buffer_size, observation_space, action_space, device, n_envs, False,
                         handle_timeout_termination)
        self._init_priorities(alpha, beta, eps, seed)

    def add(self, obs, next_obs, action, reward, done, infos) -> None:
        pos = self.pos
        super().add(obs, next_obs, action, reward, done, infos)
        self._mark_new(pos)

    def _draw(self, batch_size: int) -> tuple[np.ndarray, np.ndarray]:
        """Flat indices by eq. 15 and their normalised importance weights by eq. 16."""
        idx = self.tree.sample(batch_size, self.rng)
        count = self.size() * self.n_envs
        prob = self.tree[idx] / self.tree.total
        w = (count * prob) ** (-self.beta)
        return idx, w / w.max()


class PrioritizedReplayBuffer(_Prioritized, ReplayBuffer):
    """SB3 ``ReplayBuffer`` (Box observations) with prioritised sampling; see the module doc."""

    def sample(self, batch_size: int, env: VecNormalize | None = None) -> PrioritizedSamples:
        idx, w = self._draw(batch_size)
        b, e = idx // self.n_envs, idx % self.n_envs
        return PrioritizedSamples(
            self.to_torch(self._normalize_obs(self.observations[b, e], env)),
            self.to_torch(self.actions[b, e]),
            self.to_torch(self._normalize_obs(self.next_observations[b, e], env)),
            self.to_torch((self.dones[b, e] * (1 - self.timeouts[b, e])).reshape(-1, 1)),
            self.to_torch(self._normalize_reward(self.rewards[b, e].reshape(-1, 1), env)),
            None, self.to_torch(w.reshape(-1, 1).astype(np.float32)), idx)


class PrioritizedDictReplayBuffer(_Prioritized, DictReplayBuffer):
    """SB3 ``DictReplayBuffer`` (goal-conditioned dict observations) with prioritised sampling."""

    def sample(self, batch_size: int, env: VecNormalize | None = None) -> PrioritizedSamples:
        idx, w = self._draw(batch_size)
        b, e = idx // self.n_envs, idx % self.n_envs
        obs = self._normalize_obs({k: v[b, e] for k, v in self.observations.items()}, env)
        nxt = self._normalize_obs({k: v[b, e] for k, v in self.next_observations.items()}, env)
        return PrioritizedSamples(
            {k: self.to_torch(v) for k, v in obs.items()},
            self.to_torch(self.actions[b, e]),
            {k: self.to_torch(v) for k, v in nxt.items()},
            self.to_torch((self.dones[b, e] * (1 - self.timeouts[b, e])).reshape(-1, 1)),
            self.to_torch(self._normalize_reward(self.rewards[b, e].reshape(-1, 1), env)),
            None, self.to_torch(w.reshape(-1, 1).astype(np.float32)), idx)


class PerSAC(EpsilonGreedySAC):
    """SAC-PER (Algorithm 3): importance-weighted critic loss, priorities from the TD error, beta annealed to 1.

    Use with :class:`PrioritizedDictReplayBuffer` or :class:`PrioritizedReplayBuffer` as ``replay_buffer_class``.
    """

    def __init__(self, *args, beta_start: float = BETA_START, **kwargs):
        self.beta_start = beta_start
        super().__init__(*args, **kwargs)

    def _setup_model(self) -> None:
        if self.overlap:
            raise ValueError("overlap: SAC-PER sets its priorities from each call's TD errors before the next "
                             "sample; train it without overlap")
        super()._setup_model()

    def train(self, gradient_steps: int, batch_size: int = 64) -> None:
        buffer = self.replay_buffer
        buffer.beta = self.beta_start + (1.0 - self.beta_start) * (1.0 - self._current_progress_remaining)
        super().train(gradient_steps, batch_size)
        self.logger.record("train/beta", buffer.beta)

    def _sampled(self, data: PrioritizedSamples, td_errors: np.ndarray) -> None:
        self.replay_buffer.update_priorities(data.indices, td_errors)

    def _critic_loss(self, data: PrioritizedSamples, current: list[th.Tensor], target: th.Tensor) -> th.Tensor:
        """The importance-weighted critic loss (eq. 16); sets the sampled transitions' priorities to their mean
        absolute TD error over the Q networks (eqs. 17-19)."""
        deltas = [target - q for q in current]
        self.replay_buffer.update_priorities(data.indices, th.stack([d.detach().abs() for d in deltas]).mean(dim=0)
                                             .cpu().numpy())
        return 0.5 * sum((data.weights * d.pow(2)).mean() for d in deltas)
