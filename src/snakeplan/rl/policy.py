"""Policy files: export a trained SB3 actor as plain weights (``.npz``, loaded without pickle).

The NumPy actor itself, :class:`snakeplan.planners.sac.NumpyPolicy`, lives with the planners so that planning
never imports the training stack; this module turns an SB3 SAC model into one.
"""

from __future__ import annotations

import torch as th

from snakeplan.planners.sac.observation import RoomGraph
from snakeplan.planners.sac.policy import NumpyPolicy


def from_sb3(model, meta: dict, graph: RoomGraph | None = None) -> NumpyPolicy:
    """A :class:`NumpyPolicy` from an SB3 SAC model whose actor is an MLP over :class:`GoalRouteExtractor`."""
    actor = model.policy.actor
    linears = [m for m in actor.latent_pi if isinstance(m, th.nn.Linear)]
    layers = [(m.weight.detach().cpu().numpy().astype(float), m.bias.detach().cpu().numpy().astype(float))
              for m in linears]
    mu = (actor.mu.weight.detach().cpu().numpy().astype(float), actor.mu.bias.detach().cpu().numpy().astype(float))
    return NumpyPolicy(layers, mu, {**meta, "hidden_layers": len(layers)}, graph)
