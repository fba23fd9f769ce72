"""Learned planners (paper 000): Gymnasium environments, rewards, prioritised replay, training, policy files.

Importing the package registers ``snakeplan/FuelTank-v0`` and ``snakeplan/OilTank-v0`` with Gymnasium.
"""

from snakeplan.rl.envs import ENV_IDS, FuelTankEnv, OilTankEnv, SnakeEnv, register_envs

register_envs()

__all__ = ["ENV_IDS", "FuelTankEnv", "OilTankEnv", "SnakeEnv", "register_envs"]
