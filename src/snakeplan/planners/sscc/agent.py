"""The Swinging Search's DDPG agent (paper 001): shipped weights, the NumPy actor that plans, online learning.

The agent is Stable-Baselines3's DDPG (actor-critic, target networks, Gaussian exploration noise; :mod:`.ddpg`)
on the Swinging Search as an environment (:class:`snakeplan.rl.sscc.SwingEnv`), whose state, action and reward
are those of :mod:`snakeplan.planners.sscc.swinging`. One agent per arm (``sscc-16``, ``sscc-24``), trained on
targets of both pipe scenes drawn from seeds :data:`snakeplan.rl.sscc.TRAIN_SEED_OFFSET` onwards, disjoint from
the benchmark's and the tests' seeds. Episodes whose inverse-kinematics start is already a solution are redrawn:
they teach nothing. This module holds the settings of planning and of online learning; :mod:`.ddpg` those of
DDPG, and :mod:`snakeplan.rl.sscc` trains with them.

Shipped weights are the policy's ``state_dict`` as a plain ``.npz`` (``data/<robot>.npz``, read with
``allow_pickle=False``). An agent file is checked before use (:func:`agent_shapes`): exactly the arrays of the
DDPG ``state_dict`` for its arm (actor, critic and their targets, ``NET_ARCH`` hidden units), each of the shape
the arm's state and action sizes give, real and finite within ``MAX_WEIGHT``; the file carries no other record
of its arm, so an agent for another section count is refused by its shapes. A file that is not one gives one
ValueError ``agent_path: ...``. Planning runs the actor in NumPy (a two-layer MLP), so this module imports neither
torch, Stable-Baselines3 nor Gymnasium; learning (the ``train`` extra) does. As in the paper, the agent can keep
learning from every task: with ``learning`` on, each search's transitions go to its replay buffer and up to
``ONLINE_GRADIENT_STEPS`` updates follow, on the model of :func:`.ddpg.online_model`: it lives in this package,
so the planner's online learning imports nothing of the learning layer (``snakeplan.rl``).

Training keeps the best checkpoint on held-out targets, not the last: on this task DDPG's actor peaks after a few
thousand updates and then drifts (see :func:`snakeplan.rl.sscc.train_agent`'s history).
"""

from __future__ import annotations

import hashlib
import itertools
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np

from snakeplan.files import atomic_path
from snakeplan.planners.sscc.ddpg import BATCH_SIZE, NET_ARCH, model_weights, online_model
from snakeplan.planners.sscc.swinging import SwingEpisode, Transition, action_size, observation_size
from snakeplan.planners.weights import read_npz, read_weights_file
from snakeplan.robots import get_robot

#: Online learning after each plan: gradient steps per task (at most one per new transition), smallest buffer,
#: and torch CPU threads (small networks: one thread avoids contention). Its learning rate and replay buffer size
#: are :mod:`.ddpg`'s.
ONLINE_GRADIENT_STEPS = 32
ONLINE_MIN_BUFFER = BATCH_SIZE
ONLINE_THREADS = 1
#: Exploration noise (std of the action) when the agent plans.
PLAN_NOISE = 0.1
#: Largest magnitude of a weight (a trained network's are O(1)); past it the actor's arithmetic could overflow.
MAX_WEIGHT = 1e6
#: Package whose ``data`` folder holds the shipped agents, one ``<robot>.npz`` each.
DATA_PACKAGE = "snakeplan.planners.sscc"


def shipped_agent_path(robot: str) -> Path:
    """Where the pretrained agent for ``robot`` ships: ``data/<robot>.npz`` inside this package."""
    return Path(str(files(DATA_PACKAGE).joinpath("data", f"{robot}.npz")))


def agent_shapes(n_sections: int) -> dict[str, tuple[int, ...]]:
    """The arrays of an agent for an arm of ``n_sections`` and their shapes: the DDPG policy's ``state_dict``
    (actor ``state -> NET_ARCH -> action``, one critic ``state + action -> NET_ARCH -> 1``, and their targets;
    linear layers at every second index, ReLUs between)."""
    state, action = observation_size(n_sections), action_size(n_sections)
    nets = {"actor.mu": (state, *NET_ARCH, action), "critic.qf0": (state + action, *NET_ARCH, 1)}
    shapes: dict[str, tuple[int, ...]] = {}
    for stem, sizes in nets.items():
        net, _, head = stem.partition(".")
        for prefix in (f"{net}.{head}", f"{net}_target.{head}"):
            for i, (into, out) in enumerate(itertools.pairwise(sizes)):
                shapes[f"{prefix}.{2 * i}.weight"] = (out, into)
                shapes[f"{prefix}.{2 * i}.bias"] = (out,)
    return shapes


def _weights_problem(robot: str, n_sections: int, weights: dict) -> str | None:
    """What is wrong with ``weights`` as the agent of ``robot`` (see :func:`agent_shapes`), or None."""
    shapes = agent_shapes(n_sections)
    missing = [k for k in shapes if k not in weights]
    if missing:
        return f"{missing[0]}: missing (an agent file holds the DDPG state_dict: {len(shapes)} arrays)"
    extra = sorted(set(weights) - set(shapes), key=str)
    if extra:
        return f"{extra[0]!r}: unexpected array (an agent file holds the DDPG state_dict only)"
    for key, shape in shapes.items():
        a = np.asarray(weights[key])
        if a.dtype.kind not in "fiu":
            return f"{key}: must hold real numbers, got dtype {a.dtype}"
        if a.shape != shape:
            return (f"{key}: shape {a.shape}, expected {shape} for {robot} ({n_sections} sections: state "
                    f"{observation_size(n_sections)}, action {action_size(n_sections)})")
        values = a.astype(np.float64)
        if not np.all(np.isfinite(values)):
            return f"{key}: values must be finite numbers"
        if np.any(np.abs(values) > MAX_WEIGHT):
            return f"{key}: values must be within +-{MAX_WEIGHT:g}"
    return None


class SwingAgent:
    """A DDPG swing policy for one arm: NumPy actor for planning, an SB3 model behind it for learning.

    ``weights`` are the SB3 policy's ``state_dict`` arrays. Use as a :class:`~.swinging.SwingPolicy`.
    """

    def __init__(self, robot: str, weights: dict[str, np.ndarray], learning: bool = False, seed: int = 0,
                 noise: float = PLAN_NOISE):
        self.robot = robot
        self.n_sections = get_robot(robot).n_sections
        self.weights = {k: np.asarray(v) for k, v in weights.items()}
        self.learning, self.seed, self.noise = learning, seed, noise
        self._model = None
        self.last_action: np.ndarray | None = None
        problem = _weights_problem(robot, self.n_sections, self.weights)
        if problem is not None:
            raise ValueError(f"weights: {problem}")
        self._layers = self._actor_layers()

    @classmethod
    def load(cls, robot: str, path: str | Path | None = None, **options: Any) -> SwingAgent:
        """The agent stored at ``path`` (default: the shipped one for ``robot``); ValueError ``agent_path: ...`` when
        the file is missing or not an agent for ``robot``."""
        return cls(robot, _weights(robot, _agent_bytes(robot, path)), **options)

    def save(self, path: str | Path) -> Path:
        """Write the weights as a plain ``.npz``."""
        out = Path(path)
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(out) as tmp, open(tmp, "wb") as fh:
            np.savez(fh, **self.weights)
        return out

    def _actor_layers(self) -> list[tuple[np.ndarray, np.ndarray]]:
        keys = sorted({k.rsplit(".", 1)[0] for k in self.weights if k.startswith("actor.mu.")},
                      key=lambda k: int(k.rsplit(".", 1)[1]))
        return [(self.weights[f"{k}.weight"].astype(np.float64), self.weights[f"{k}.bias"].astype(np.float64))
                for k in keys]

    def act(self, observation: np.ndarray) -> np.ndarray:
        """The deterministic action (the actor network: ReLU hidden layers, tanh output) for a state."""
        x = np.asarray(observation, dtype=np.float64)
        for i, (W, b) in enumerate(self._layers):
            x = W @ x + b
            x = np.maximum(x, 0.0) if i < len(self._layers) - 1 else np.tanh(x)
        return x

    def reset(self, episode: SwingEpisode, rng: np.random.Generator) -> None:
        return None

    def __call__(self, episode: SwingEpisode, rng: np.random.Generator) -> np.ndarray:
        a = self.act(episode.observation())
        if self.noise > 0:
            a = a + self.noise * rng.standard_normal(a.shape)
        self.last_action = np.clip(a, -1.0, 1.0)
        return episode.forces(self.last_action)

    def learn(self, transitions: list[Transition]) -> int:
        """Add a task's transitions to the replay buffer and train on it (``ONLINE_GRADIENT_STEPS`` at most, one
        per new transition, once the buffer holds ``ONLINE_MIN_BUFFER``); returns the gradient steps taken."""
        if not self.learning or not transitions:
            return 0
        import torch

        if self._model is None:
            self._model = online_model(self.n_sections, self.seed, self.weights)
        buffer = self._model.replay_buffer
        for obs, action, reward, next_obs, done in transitions:
            buffer.add(obs[None], next_obs[None], action[None], np.array([reward]), np.array([done]), [{}])
        if buffer.size() < ONLINE_MIN_BUFFER:
            return 0
        steps = min(ONLINE_GRADIENT_STEPS, len(transitions))
        threads = torch.get_num_threads()
        torch.set_num_threads(ONLINE_THREADS)
        try:
            self._model.train(gradient_steps=steps, batch_size=BATCH_SIZE)
        finally:
            torch.set_num_threads(threads)
        self.weights = model_weights(self._model)
        self._layers = self._actor_layers()
        return steps


def _agent_bytes(robot: str, path: str | Path | None) -> bytes:
    source = Path(path) if path is not None else shipped_agent_path(robot)
    if not source.exists():
        raise ValueError(f"agent_path: no SSCC agent for {robot} at {source}; train one with 'snakeplan train sscc'")
    return read_weights_file(source, "agent_path")


def _weights(robot: str, data: bytes) -> dict[str, np.ndarray]:
    """The arrays of an agent file's bytes, checked as the agent of ``robot``."""
    weights = read_npz(data, "agent_path")
    problem = _weights_problem(robot, get_robot(robot).n_sections, weights)
    if problem is not None:
        raise ValueError(f"agent_path: {problem}")
    return weights


#: Planning (not learning) agents by robot and the sha256 of their file's bytes.
_AGENTS: dict[tuple[str, str], SwingAgent] = {}


def load_agent(robot: str, path: str | Path | None = None) -> SwingAgent:
    """The planning agent (not learning) for ``robot`` stored at ``path`` (default: the shipped one), parsed once
    per content: keyed by the hash of the file's bytes, not its path, so a file that training rewrites in place
    is read again; ValueError ``agent_path: ...`` when the file is missing or not an agent for ``robot``."""
    data = _agent_bytes(robot, path)
    key = (robot, hashlib.sha256(data).hexdigest())
    if key not in _AGENTS:
        _AGENTS[key] = SwingAgent(robot, _weights(robot, data))
    return _AGENTS[key]
