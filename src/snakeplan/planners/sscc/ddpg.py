"""The Swinging Search agent's DDPG (paper 001): its settings and its Stable-Baselines3 model.

One model for both ways the agent learns: offline training (:mod:`snakeplan.rl.sscc`, the ``train`` extra) builds
it on the search as a Gymnasium environment, and a learning agent (:meth:`.agent.SwingAgent.learn`, after each
plan) builds it on :func:`spaces_env` and keeps training it. The model lives here, beside the agent it trains,
so that the planner's online learning needs nothing from the learning layer (``snakeplan.rl``), which imports
this module, never the reverse. Gymnasium, torch and Stable-Baselines3 are imported inside the functions:
:mod:`.agent` imports the settings, and planning with a trained agent imports none of them.
"""

from __future__ import annotations

import numpy as np

from snakeplan.planners.sscc.swinging import action_size, observation_size

#: DDPG settings of training: hidden layers, Adam's learning rate, replay buffer size, random steps before the
#: first update, batch size, target network rate, discount and the std of the Gaussian exploration noise.
NET_ARCH = (128, 128)
LEARNING_RATE = 3e-4
BUFFER_SIZE = 100_000
LEARNING_STARTS = 1_000
BATCH_SIZE = 128
TAU = 0.005
GAMMA = 0.95
ACTION_NOISE = 0.3
#: Online learning after each plan: a learning rate a tenth of training's (longer DDPG training drifted away from
#: its best, see :func:`snakeplan.rl.sscc.train_agent`) and a smaller replay buffer.
ONLINE_LEARNING_RATE = LEARNING_RATE / 10
ONLINE_BUFFER_SIZE = 20_000


def agent_spaces(n_sections: int):
    """The agent's state and action spaces (Gymnasium boxes) for an arm of ``n_sections``."""
    import gymnasium as gym

    return (gym.spaces.Box(-np.inf, np.inf, (observation_size(n_sections),), np.float32),
            gym.spaces.Box(-1.0, 1.0, (action_size(n_sections),), np.float32))


def spaces_env(n_sections: int):
    """A Gymnasium environment with just the spaces of an arm of ``n_sections``: enough to build a DDPG model
    (:func:`ddpg_model`), not to run one (its ``step`` raises)."""
    import gymnasium as gym

    env = gym.Env()
    env.observation_space, env.action_space = agent_spaces(n_sections)
    return env


def ddpg_model(env, seed: int, learning_rate: float = LEARNING_RATE, buffer_size: int = BUFFER_SIZE,
               learning_starts: int = LEARNING_STARTS):
    """A fresh Stable-Baselines3 DDPG model on Gymnasium environment ``env`` with this module's settings."""
    from stable_baselines3 import DDPG
    from stable_baselines3.common.noise import NormalActionNoise

    n_act = env.action_space.shape[0]
    noise = NormalActionNoise(np.zeros(n_act), ACTION_NOISE * np.ones(n_act))
    return DDPG("MlpPolicy", env, learning_rate=learning_rate, buffer_size=buffer_size,
                learning_starts=learning_starts, batch_size=BATCH_SIZE, tau=TAU, gamma=GAMMA,
                action_noise=noise, policy_kwargs={"net_arch": list(NET_ARCH)}, seed=seed, device="cpu")


def online_model(n_sections: int, seed: int, weights: dict[str, np.ndarray]):
    """A DDPG model for online learning (:meth:`.agent.SwingAgent.learn`): the online learning rate and buffer,
    its policy set to ``weights``, logging off."""
    import torch
    from stable_baselines3.common.logger import Logger

    model = ddpg_model(spaces_env(n_sections), seed, ONLINE_LEARNING_RATE, ONLINE_BUFFER_SIZE)
    model.policy.load_state_dict({k: torch.as_tensor(v) for k, v in weights.items()})
    model.set_logger(Logger(None, []))
    return model


def model_weights(model) -> dict[str, np.ndarray]:
    """The policy weights of a Stable-Baselines3 model as NumPy arrays (its ``state_dict``)."""
    return {k: v.detach().cpu().numpy().copy() for k, v in model.policy.state_dict().items()}
