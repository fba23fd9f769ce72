"""Hindsight experience replay (paper 000 eqs. 9-14) without per-sample dict copies: SB3's ``HerReplayBuffer``
('future' goals) that keeps the goal-free reward inputs of every transition in arrays.

SB3's buffer deep-copies each relabelled transition's info dict and calls the environment's ``compute_reward``
through the vectorised env; this one stores ``heading``, ``goal``, ``visible`` and ``shaping``
(:func:`snakeplan.rl.rewards.compute_reward`'s inputs) at ``add`` and recomputes the relabelled rewards (eq. 14)
in one vectorised call: a mini-batch of 128 takes 0.34 ms instead of 1.2 ms (measured on the 2-core CPU, about
a tenth of a SAC update with 128 x 128 networks).
"""

from __future__ import annotations

import numpy as np
from stable_baselines3 import HerReplayBuffer
from stable_baselines3.common.type_aliases import DictReplayBufferSamples
from stable_baselines3.common.vec_env import VecNormalize

from snakeplan.rl.rewards import compute_reward

#: Info fields kept per transition, with their widths.
REWARD_FIELDS = {"heading": 3, "goal": 3, "visible": 1, "shaping": 1}


class FastHerReplayBuffer(HerReplayBuffer):
    """``HerReplayBuffer`` for :class:`snakeplan.rl.envs.SnakeEnv`; same arguments (``copy_info_dict`` unused)."""

    def __init__(self, *args, **kwargs):
        kwargs["copy_info_dict"] = False
        super().__init__(*args, **kwargs)
        self.reward_info = {k: np.zeros((self.buffer_size, self.n_envs, w), dtype=np.float64)
                            for k, w in REWARD_FIELDS.items()}

    def add(self, obs, next_obs, action, reward, done, infos) -> None:
        for key, store in self.reward_info.items():
            store[self.pos] = np.array([np.asarray(info[key], dtype=float).reshape(-1) for info in infos])
        super().add(obs, next_obs, action, reward, done, infos)

    def _get_virtual_samples(self, batch_indices: np.ndarray, env_indices: np.ndarray,
                             env: VecNormalize | None = None) -> DictReplayBufferSamples:
        obs = {key: o[batch_indices, env_indices, :] for key, o in self.observations.items()}
        next_obs = {key: o[batch_indices, env_indices, :] for key, o in self.next_observations.items()}
        new_goals = self._sample_goals(batch_indices, env_indices)
        obs["desired_goal"] = new_goals
        next_obs["desired_goal"] = new_goals
        info = {k: v[batch_indices, env_indices] for k, v in self.reward_info.items()}
        info["visible"], info["shaping"] = info["visible"][:, 0], info["shaping"][:, 0]
        rewards = compute_reward(next_obs["achieved_goal"], new_goals, info)
        obs = self._normalize_obs(obs, env)
        next_obs = self._normalize_obs(next_obs, env)
        return DictReplayBufferSamples(
            observations={key: self.to_torch(o) for key, o in obs.items()},
            actions=self.to_torch(self.actions[batch_indices, env_indices]),
            next_observations={key: self.to_torch(o) for key, o in next_obs.items()},
            dones=self.to_torch(self.dones[batch_indices, env_indices]
                                * (1 - self.timeouts[batch_indices, env_indices])).reshape(-1, 1),
            rewards=self.to_torch(self._normalize_reward(rewards.reshape(-1, 1), env)),
        )
