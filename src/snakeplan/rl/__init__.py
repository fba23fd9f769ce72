"""Learned planners (paper 000): Gymnasium environments, rewards, prioritised replay, training, policy files.

Training needs the ``train`` extra (torch, Stable-Baselines3, Gymnasium): importing this package without it
raises :class:`~snakeplan.extras.MissingExtra` saying so. Planning with a trained policy needs none of it
(:mod:`snakeplan.planners.sac`). Importing the package registers ``snakeplan/FuelTank-v0`` and
``snakeplan/OilTank-v0`` with Gymnasium.
"""

from snakeplan.extras import require_training

require_training("snakeplan.rl")

from snakeplan.rl.envs import ENV_IDS, FuelTankEnv, OilTankEnv, SnakeEnv, register_envs  # noqa: E402

register_envs()

__all__ = ["ENV_IDS", "FuelTankEnv", "OilTankEnv", "SnakeEnv", "register_envs"]
