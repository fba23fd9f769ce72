"""Optional dependencies, and the one check that says a missing one is needed.

Planning, judging and running the shipped policies need only the core dependencies: every shipped actor runs
in NumPy. Training needs PyTorch, Stable-Baselines3 and Gymnasium, which ``pip install "snakeplan[train]"``
adds. Every command and module that trains calls :func:`require_training` before it imports them, so a missing
extra reads as one line saying how to install it, not a traceback from deep inside an import. Running benchmarks
on a Ray cluster needs Ray, which ``pip install "snakeplan[cluster]"`` adds (:func:`require_cluster`); writing ROS 2
bags, Foxglove files and the live view needs rosbags, mcap and foxglove-sdk, which ``pip install "snakeplan[ros]"``
adds (:func:`require_ros`). This
module imports nothing from snakeplan, so any layer may use it.
"""

from __future__ import annotations

import importlib

#: What the ``train`` extra installs, by import name.
TRAINING_MODULES = ("torch", "stable_baselines3", "gymnasium")
TRAINING_INSTALL = 'pip install "snakeplan[train]"'
CLUSTER_INSTALL = 'pip install "snakeplan[cluster]"'
#: What writing needs of the ``ros`` extra, by import name (its readers serve the tests).
ROS_MODULES = ("rosbags", "foxglove")
ROS_INSTALL = 'pip install "snakeplan[ros]"'


class MissingExtra(ImportError):
    """An optional dependency is not installed; the message is one line that says how to install it."""


def require_training(what: str) -> None:
    """Import the training modules, or raise :class:`MissingExtra` saying that ``what`` (a command or module)
    needs the training extra."""
    for name in TRAINING_MODULES:
        try:
            importlib.import_module(name)
        except ImportError:
            raise MissingExtra(f"{what}: needs the training extra: {TRAINING_INSTALL}", name=name) from None


def require_cluster(what: str) -> None:
    """Import Ray, or raise :class:`MissingExtra` saying that ``what`` needs the cluster extra."""
    try:
        importlib.import_module("ray")
    except ImportError:
        raise MissingExtra(f"{what}: needs the cluster extra: {CLUSTER_INSTALL}", name="ray") from None


def require_ros(what: str) -> None:
    """Import the ROS and Foxglove writers, or raise :class:`MissingExtra` saying that ``what`` (an option or
    command) needs the ros extra."""
    for name in ROS_MODULES:
        try:
            importlib.import_module(name)
        except ImportError:
            raise MissingExtra(f"{what}: needs the ros extra: {ROS_INSTALL}", name=name) from None
