"""SAC with the paper's epsilon-greedy action replacement (paper 000 §4.1): the base of every learned planner.

With probability epsilon an action from the policy is replaced by a uniform random one; epsilon starts at
``EPSILON_START`` and is multiplied by ``EPSILON_DECAY`` every environment step down to ``EPSILON_MIN``.
"""

from __future__ import annotations

import numpy as np
from stable_baselines3 import SAC
from stable_baselines3.common.noise import ActionNoise

EPSILON_START = 1.0
EPSILON_MIN = 0.01
EPSILON_DECAY = 0.999


class EpsilonGreedySAC(SAC):
    """SAC whose exploratory actions are replaced by uniform ones with a decaying probability."""

    def __init__(self, *args, epsilon_start: float = EPSILON_START, epsilon_min: float = EPSILON_MIN,
                 epsilon_decay: float = EPSILON_DECAY, **kwargs):
        self.epsilon_start = epsilon_start
        self.epsilon_min = epsilon_min
        self.epsilon_decay = epsilon_decay
        super().__init__(*args, **kwargs)

    @property
    def epsilon(self) -> float:
        """The replacement probability at the current step."""
        return max(self.epsilon_min, self.epsilon_start * self.epsilon_decay ** self.num_timesteps)

    def _sample_action(self, learning_starts: int, action_noise: ActionNoise | None = None, n_envs: int = 1
                       ) -> tuple[np.ndarray, np.ndarray]:
        action, buffer_action = super()._sample_action(learning_starts, action_noise, n_envs)
        replace = self.np_random_eps.uniform(size=n_envs) < self.epsilon
        if replace.any():
            random = self.np_random_eps.uniform(-1.0, 1.0, size=buffer_action.shape)
            buffer_action = np.where(replace[:, None], random, buffer_action)
            action = self.policy.unscale_action(buffer_action)
        return action, buffer_action

    @property
    def np_random_eps(self) -> np.random.Generator:
        """The generator of the replacement draws, seeded from the algorithm's seed."""
        if getattr(self, "_eps_rng", None) is None:
            self._eps_rng = np.random.default_rng(self.seed)
        return self._eps_rng
