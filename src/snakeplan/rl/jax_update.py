"""The SAC update of :mod:`snakeplan.rl.agents` in JAX (``--autodiff jax``): the same update, compiled by XLA.

The same losses, in the same order (entropy coefficient, critics, actor, target critics), with Adam's own
formula (optax's ``scale_by_adam`` is torch's Adam), on float32 weights laid out as torch's (``W`` is
``(out, in)``). The weights and Adam's moments live here between updates; :meth:`JaxSAC.write` copies them into
the torch modules and optimisers, after every call for the actor (which the roll-outs and the exported policy
use) and before a checkpoint for everything, and :meth:`JaxSAC.from_model` reads them back, so checkpoints stay
SB3's and a resumed run continues the uninterrupted one. The Gaussian noise of update ``n`` comes from
``fold_in(PRNGKey(seed), n)``: it depends on the count of updates alone, which the checkpoint holds.

The observations' features are computed by the torch extractor (it has no weights) and passed in; a call runs
any number of updates in one compiled ``lax.scan``. XLA is held to one thread, as torch is while training. JAX
returns from a call before XLA has computed it (:meth:`JaxSAC.dispatch`), which lets a trainer with ``overlap``
run its next roll-outs meanwhile on the other core.
"""

from __future__ import annotations

import os
from functools import partial

import numpy as np
import torch as th
from stable_baselines3.sac.policies import LOG_STD_MAX, LOG_STD_MIN

os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")
_GLOBAL_DRAWS = np.random.get_state()
import jax  # noqa: E402  (after XLA_FLAGS)
import jax.numpy as jnp  # noqa: E402
import optax  # noqa: E402

np.random.set_state(_GLOBAL_DRAWS)  # importing JAX draws from NumPy's global generator; replay samples use it

#: SB3's squashing correction: log(1 - tanh(u)^2 + SQUASH_EPS).
SQUASH_EPS = 1e-6
_ADAM = optax.scale_by_adam(b1=0.9, b2=0.999, eps=1e-8)


def _linears(modules) -> list[th.nn.Linear]:
    return [m for m in modules if isinstance(m, th.nn.Linear)]


def _torch_layers(model) -> dict[str, list[list[th.nn.Linear]]]:
    """The torch layers of each parameter group, in the order of the JAX pytree."""
    actor = model.actor
    return {"actor": [_linears(actor.latent_pi) + [actor.mu, actor.log_std]],
            "critic": [_linears(q) for q in model.critic.q_networks],
            "target": [_linears(q) for q in model.critic_target.q_networks]}


def _linear(layer, x):
    w, b = layer
    return x @ w.T + b


def _hidden(layers, x):
    """The ReLU layers of an SB3 MLP."""
    for layer in layers:
        x = jax.nn.relu(_linear(layer, x))
    return x


def _mlp(layers, x):
    """ReLU between linear layers, none after the last."""
    return _linear(layers[-1], _hidden(layers[:-1], x))


def _policy(actor, features, noise):
    """The squashed Gaussian action for ``noise`` and its log-probability (SB3's ``log_prob_from_params``)."""
    *hidden, mu, log_std = actor[0]
    latent = _hidden(hidden, features)
    mean = _linear(mu, latent)
    log_std = jnp.clip(_linear(log_std, latent), LOG_STD_MIN, LOG_STD_MAX)
    action = jnp.tanh(mean + jnp.exp(log_std) * noise)
    log_prob = jnp.sum(-0.5 * noise ** 2 - log_std - 0.5 * jnp.log(2 * jnp.pi), axis=1)
    return action, log_prob - jnp.sum(jnp.log(1 - action ** 2 + SQUASH_EPS), axis=1)


def _q_all(critics, inputs):
    """Each Q network's value of each row, ``(n_critics, B)``."""
    return jnp.stack([_mlp(q, inputs)[:, 0] for q in critics])


def _adam(params, grads, state, lr):
    updates, state = _ADAM.update(grads, state)
    return jax.tree.map(lambda p, u: p - lr * u, params, updates), state


def _step(hyper, carry, batch):
    """One SAC update; ``hyper`` = (tau, target entropy, the fixed entropy coefficient or None when it is
    learned, target update interval), ``batch`` = one mini-batch's arrays and its index in the call."""
    tau, target_entropy, fixed_alpha, interval = hyper
    params, opt, lr = carry
    features, next_features, actions, rewards, not_done_discount, weights, noise, next_noise, index = batch
    _, log_prob = _policy(params["actor"], features, noise)
    if fixed_alpha is None:
        alpha = jnp.exp(params["log_alpha"])
        alpha_grad = -jnp.mean(log_prob + target_entropy)
        alpha_loss = alpha_grad * params["log_alpha"]
        new_log_alpha, opt_alpha = _adam(params["log_alpha"], alpha_grad, opt["alpha"], lr)
    else:
        alpha, alpha_loss = jnp.float32(fixed_alpha), jnp.float32(jnp.nan)
        new_log_alpha, opt_alpha = params["log_alpha"], opt["alpha"]
    next_actions, next_log_prob = _policy(params["actor"], next_features, next_noise)
    next_q = jnp.min(_q_all(params["target"], jnp.concatenate([next_features, next_actions], axis=1)), axis=0)
    target = rewards + not_done_discount * (next_q - alpha * next_log_prob)

    def critic_loss(critic):
        deltas = target - _q_all(critic, jnp.concatenate([features, actions], axis=1))
        return 0.5 * jnp.sum(jnp.mean(weights * deltas ** 2, axis=1)), jnp.mean(jnp.abs(deltas), axis=0)

    (q_loss, td), grads = jax.value_and_grad(critic_loss, has_aux=True)(params["critic"])
    critic, opt_critic = _adam(params["critic"], grads, opt["critic"], lr)

    def actor_loss(actor):
        acts, logp = _policy(actor, features, noise)
        q = jnp.min(_q_all(critic, jnp.concatenate([features, acts], axis=1)), axis=0)
        return jnp.mean(alpha * logp - q)

    pi_loss, grads = jax.value_and_grad(actor_loss)(params["actor"])
    actor, opt_actor = _adam(params["actor"], grads, opt["actor"], lr)
    moved = jax.tree.map(lambda t, c: (1.0 - tau) * t + tau * c, params["target"], critic)
    target_params = jax.tree.map(lambda m, t: jnp.where(index % interval == 0, m, t), moved, params["target"])
    params = {"actor": actor, "critic": critic, "target": target_params, "log_alpha": new_log_alpha}
    opt = {"actor": opt_actor, "critic": opt_critic, "alpha": opt_alpha}
    return (params, opt, lr), (jnp.stack([alpha, q_loss, pi_loss, alpha_loss]), td)


def _scan(hyper, params, opt, lr, batches, noise):
    (params, opt, _), (losses, td) = jax.lax.scan(partial(_step, hyper), (params, opt, lr),
                                                  (*batches, noise[0], noise[1], jnp.arange(len(batches[0]))))
    return params, opt, losses, td


@partial(jax.jit, static_argnums=0)
def updates(hyper, params, opt, lr, batches, noise):
    """One SAC update per mini-batch of ``batches`` in one compiled scan, with the Gaussian noise ``noise`` (the
    current and the next actions' of each update); returns the new weights and Adam states, each update's
    (entropy coefficient, critic loss, actor loss, entropy coefficient loss) and each sample's mean absolute TD
    error over the Q networks (the priorities of SAC-PER)."""
    return _scan(hyper, params, opt, lr, batches, noise)


@partial(jax.jit, static_argnums=0)
def seeded_updates(hyper, params, opt, lr, batches, seed, n_updates):
    """:func:`updates` with the noise of ``fold_in(PRNGKey(seed), n_updates)``."""
    key = jax.random.fold_in(jax.random.PRNGKey(seed), n_updates)
    return _scan(hyper, params, opt, lr, batches, jax.random.normal(key, (2, *batches[2].shape)))


class JaxSAC:
    """An SB3 SAC model's weights and Adam states in JAX, and its updates (see the module doc)."""

    def __init__(self, model, params: dict, opt: dict):
        fixed = None if model.ent_coef_optimizer is not None else float(model.ent_coef_tensor)
        self.hyper = (float(model.tau), float(model.target_entropy), fixed, int(model.target_update_interval))
        self.gamma, self.seed = float(model.gamma), int(model.seed or 0)
        self.params, self.opt = params, opt

    @classmethod
    def from_model(cls, model) -> JaxSAC:
        """The torch model's current weights and Adam moments (zero before its first step)."""
        layers = _torch_layers(model)
        params = {key: [[(_array(m.weight), _array(m.bias)) for m in net] for net in nets]
                  for key, nets in layers.items()}
        learned = model.log_ent_coef is not None
        params["log_alpha"] = _array(model.log_ent_coef).reshape(()) if learned else jnp.float32(0.0)
        opt = {"actor": _read_adam(model.actor.optimizer, layers["actor"]),
               "critic": _read_adam(model.critic.optimizer, layers["critic"]),
               "alpha": (_read_adam(model.ent_coef_optimizer, model.log_ent_coef) if learned
                         else _ADAM.init(params["log_alpha"]))}
        return cls(model, params, opt)

    def train(self, data, features: th.Tensor, count: int, n_updates: int, lr: float
              ) -> tuple[np.ndarray, np.ndarray]:
        """``count`` updates on the mini-batches of one SB3 sample ``data`` (split as :func:`_arrays` says) with
        ``features`` (its observations' features above its next observations'); ``n_updates``, counted before this
        call, keys the noise. Returns each update's losses and each row's TD error (see :func:`updates`)."""
        return ready(*self.dispatch(data, features, count, n_updates, lr))

    def dispatch(self, data, features: th.Tensor, count: int, n_updates: int, lr: float) -> tuple:
        """:meth:`train`'s updates, started and not waited for: XLA computes them on its own thread while the
        caller goes on (the roll-outs of :class:`snakeplan.rl.agents.EpsilonGreedySAC` with ``overlap``). The new
        weights are kept at once (as arrays still being computed); returns the losses and TD errors likewise."""
        self.params, self.opt, losses, td = seeded_updates(self.hyper, self.params, self.opt, np.float32(lr),
                                                           _arrays(data, features, count, self.gamma), self.seed,
                                                           n_updates)
        return losses, td

    def run(self, arrays: tuple, noise: np.ndarray, lr: float) -> tuple[np.ndarray, np.ndarray]:
        """The updates on ready arrays (:func:`_arrays`) with given noise, ``(2, updates, batch, action)``."""
        return self._keep(updates(self.hyper, self.params, self.opt, np.float32(lr), arrays, noise))

    def _keep(self, result) -> tuple[np.ndarray, np.ndarray]:
        """Keep the new state; the losses per update, and the TD errors in the sample's row order."""
        self.params, self.opt, losses, td = result
        return ready(losses, td)

    def write(self, model, actor_only: bool = False) -> None:
        """Copy the weights (and, unless ``actor_only``, the critics', targets', coefficient's and every Adam
        state) into the torch model."""
        layers = _torch_layers(model)
        keys = ("actor",) if actor_only else ("actor", "critic", "target")
        values = jax.device_get({key: self.params[key] for key in keys})
        for key in keys:
            _write_layers(layers[key], values[key])
        if actor_only:
            return
        if model.log_ent_coef is not None:
            model.log_ent_coef.detach().numpy()[...] = float(self.params["log_alpha"])
        _write_adam(model.actor.optimizer, layers["actor"], self.opt["actor"])
        _write_adam(model.critic.optimizer, layers["critic"], self.opt["critic"])
        if model.ent_coef_optimizer is not None:
            _write_adam(model.ent_coef_optimizer, model.log_ent_coef, self.opt["alpha"])


def ready(losses, td) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`JaxSAC.dispatch`'s losses per update and TD errors in the sample's row order, once computed."""
    return np.asarray(losses), np.asarray(td).T.reshape(-1)


def _write_layers(nets: list, values: list) -> None:
    """Weights ``values`` (per net, (weight, bias) pairs of arrays) into torch linear layers ``nets``."""
    for net, pairs in zip(nets, values):
        for m, (w, b) in zip(net, pairs):
            m.weight.detach().numpy()[...] = w
            m.bias.detach().numpy()[...] = b


def torch_actor(model) -> list:
    """A copy of the torch actor's weights, as :func:`write_actor` takes them."""
    return [[(m.weight.detach().numpy().copy(), m.bias.detach().numpy().copy()) for m in net]
            for net in _torch_layers(model)["actor"]]


def write_actor(model, weights: list) -> None:
    """:func:`torch_actor`'s weights back into the torch actor."""
    _write_layers(_torch_layers(model)["actor"], weights)


def _array(tensor: th.Tensor) -> jax.Array:
    """A copy: :meth:`JaxSAC.write` later writes into the tensor's memory, which a view would share."""
    return jnp.array(tensor.detach().numpy(), jnp.float32, copy=True)


def _tensors(layers) -> list[th.Tensor]:
    """The torch parameters in pytree order: one tensor, or nested lists of linear layers' (weight, bias)."""
    if isinstance(layers, th.Tensor):
        return [layers]
    return [t for net in layers for m in net for t in (m.weight, m.bias)]


def _read_adam(optimizer: th.optim.Optimizer, layers):
    """optax's Adam state from torch's (same moments, same step count)."""
    tensors = _tensors(layers)
    states = [optimizer.state.get(t, {}) for t in tensors]
    count = int(states[0]["step"]) if "step" in states[0] else 0
    moments = [[_array(s[key]) if key in s else jnp.zeros(t.shape, jnp.float32) for s, t in zip(states, tensors)]
               for key in ("exp_avg", "exp_avg_sq")]
    if isinstance(layers, th.Tensor):
        mu, nu = (m[0].reshape(()) for m in moments)
    else:
        mu, nu = (_nest(m, layers) for m in moments)
    return optax.ScaleByAdamState(count=jnp.asarray(count, jnp.int32), mu=mu, nu=nu)


def _nest(flat: list, layers) -> list:
    """A flat list in :func:`_tensors` order back into nets of (weight, bias) pairs."""
    it = iter(flat)
    return [[(next(it), next(it)) for _ in net] for net in layers]


def _write_adam(optimizer: th.optim.Optimizer, layers, state) -> None:
    """torch's Adam state from optax's."""
    count = int(state.count)
    if count == 0:
        return
    mu, nu = jax.tree.leaves(state.mu), jax.tree.leaves(state.nu)
    for t, m, v in zip(_tensors(layers), mu, nu):
        optimizer.state[t] = {"step": th.tensor(float(count), dtype=th.float32),
                              "exp_avg": th.from_numpy(np.array(m)).reshape(t.shape),
                              "exp_avg_sq": th.from_numpy(np.array(v)).reshape(t.shape)}


def _arrays(data, features: th.Tensor, count: int, gamma: float) -> tuple:
    """The JAX inputs of ``count`` mini-batches drawn as one SB3 sample: features, next features, actions, rewards,
    (1 - done) x discount and importance weights, each ``(count, batch, ...)``. Row ``r`` of the sample goes to
    mini-batch ``r % count``: strided, because a HER sample lists its real transitions before its relabelled ones
    and each mini-batch must mix them as a sample of its own would. Without PER the weights are ones; with it,
    each mini-batch's are normalised by its largest, as if it had been drawn alone."""
    n = len(data.actions)
    feats = features.numpy()

    def chunks(array: np.ndarray) -> np.ndarray:
        return array.reshape(n // count, count, *array.shape[1:]).swapaxes(0, 1).astype(np.float32, copy=False)

    def column(tensor: th.Tensor) -> np.ndarray:
        return chunks(tensor.numpy().reshape(n))

    discount = column(data.discounts) if data.discounts is not None else gamma
    weights = getattr(data, "weights", None)
    if weights is None:
        weights = np.ones((count, n // count), np.float32)
    else:
        weights = column(weights)
        weights = weights / weights.max(axis=1, keepdims=True)
    return (chunks(feats[:n]), chunks(feats[n:]), chunks(data.actions.numpy()), column(data.rewards),
            (1.0 - column(data.dones)) * discount, weights)
