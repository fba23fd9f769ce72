"""SAC with the paper's epsilon-greedy action replacement (paper 000 §4.1): the base of every learned planner.

With probability epsilon an action from the policy is replaced by a uniform random one; epsilon starts at
``EPSILON_START`` and is multiplied by ``EPSILON_DECAY`` every environment step down to ``EPSILON_MIN``.

Its gradient step is SB3's SAC update, computed with fewer calls: the features of a mini-batch's observations and of
its next observations are computed once, in one call (SB3 computes them five times per update, once per network
call; the feature extractors have no weights, so every call gives the same features), each critic input is
concatenated once for both Q networks, the actor's loss is differentiated through the critics without their weight
gradients (which SB3 computes and then discards), and the target networks move towards the critics in one fused
call. With the same seeds it gives the same weights as SB3's ``SAC.train`` (tests/test_rl.py checks it), in about
70 % of the time with 128 x 128 networks on the 2-core CPU (``snakeplan bench rl``). SAC-PER changes only the
critic loss (:meth:`EpsilonGreedySAC._critic_loss`) and anneals its importance exponent. With ``autodiff="jax"``
the same update runs in JAX (:mod:`snakeplan.rl.jax_update`), all of a call's updates in one compiled call; with
``overlap`` as well, the roll-outs after a call run while XLA computes its updates, acting with the actor of the
call before (:meth:`EpsilonGreedySAC._train_jax`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import torch as th
from stable_baselines3 import SAC
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.noise import ActionNoise
from stable_baselines3.common.type_aliases import ReplayBufferSamples
from stable_baselines3.sac.policies import LOG_STD_MAX, LOG_STD_MIN
from torch.nn import functional as F

EPSILON_START = 1.0
EPSILON_MIN = 0.01
EPSILON_DECAY = 0.999
#: The library that runs the gradient updates: torch (this module), or JAX (:mod:`snakeplan.rl.jax_update`, the same
#: update compiled by XLA).
AUTODIFF = ("torch", "jax")


class EpsilonGreedySAC(SAC):
    """SAC whose exploratory actions are replaced by uniform ones with a decaying probability."""

    def __init__(self, *args, epsilon_start: float = EPSILON_START, epsilon_min: float = EPSILON_MIN,
                 epsilon_decay: float = EPSILON_DECAY, autodiff: str = "torch", overlap: bool = False, **kwargs):
        self.epsilon_start = epsilon_start
        self.epsilon_min = epsilon_min
        self.epsilon_decay = epsilon_decay
        self.autodiff = autodiff
        self.overlap = overlap
        #: Whether the torch actor (the roll-outs') is a call of updates behind the JAX one (``overlap``).
        self._lagging = False
        #: The roll-outs' actor weights while the model is saved lagging (so a loaded model lags as it did).
        self._rollout_actor = None
        super().__init__(*args, **kwargs)
        if self.tensorboard_log is None and self.verbose == 0:  # nothing to log: SB3's own logger would make a
            self.set_logger(Logger(None, []))  # folder in the temporary folder per run all the same

    def _setup_model(self) -> None:
        if self.autodiff not in AUTODIFF:
            raise ValueError(f"autodiff: must be one of {AUTODIFF}, got {self.autodiff!r}")
        if self.overlap and self.autodiff != "jax":
            raise ValueError("overlap: the roll-outs overlap the updates only when JAX computes them "
                             "(autodiff='jax')")
        super()._setup_model()
        self._jax = None
        self._pending = None
        if self.use_sde:
            raise ValueError("use_sde: the epsilon-greedy SAC explores by uniform replacement, not by gSDE")
        for extractor in (self.actor.features_extractor, self.critic.features_extractor):
            if any(True for _ in extractor.parameters()):
                raise ValueError("features_extractor_class: must have no weights (each mini-batch's features are "
                                 "computed once and shared by the actor and the critics)")
        if self.batch_norm_stats:
            raise ValueError("policy: normalisation layers are not supported (their running statistics would "
                             "need copying to the target critics)")

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

    def train(self, gradient_steps: int, batch_size: int = 64) -> None:
        """``gradient_steps`` SAC updates on mini-batches of ``batch_size`` (SB3's ``SAC.train``, see the module
        doc)."""
        self.policy.set_training_mode(True)
        optimizers = [self.actor.optimizer, self.critic.optimizer]
        if self.ent_coef_optimizer is not None:
            optimizers.append(self.ent_coef_optimizer)
        self._update_learning_rate(optimizers)
        if self.autodiff == "jax":
            losses = self._train_jax(gradient_steps, batch_size)
        else:
            losses = np.array([self._update(self.replay_buffer.sample(batch_size, env=self._vec_normalize_env),
                                            step) for step in range(gradient_steps)])
        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        if losses is None:
            return
        for key, value in zip(("ent_coef", "critic_loss", "actor_loss", "ent_coef_loss"), losses.mean(axis=0)):
            if key != "ent_coef_loss" or self.ent_coef_optimizer is not None:
                self.logger.record(f"train/{key}", float(value))

    def _train_jax(self, gradient_steps: int, batch_size: int) -> np.ndarray | None:
        """The same updates by :class:`snakeplan.rl.jax_update.JaxSAC`, in one compiled call, on mini-batches drawn
        as one sample (independent uniform draws either way, in one call instead of ``gradient_steps``); the
        actor's new weights are copied back for the roll-outs. Returns the losses of each update.

        With ``overlap`` the call starts its updates and returns at once: XLA computes them on its own thread
        while the next roll-outs run, which act with the actor of the call before (one call behind: ``train_freq``
        steps). The next call first takes that call's actor for its roll-outs, and returns that call's losses
        (None when there are none: the first call, or the first after a load)."""
        from snakeplan.rl.jax_update import JaxSAC, ready

        if self._jax is None:
            self._jax = JaxSAC.from_model(self)
        losses = None
        if self._lagging:  # the last call's updates are the roll-outs' actor from now on
            self._jax.write(self, actor_only=True)
            if self._pending is not None:
                losses = ready(*self._pending)[0]
            self._lagging, self._pending = False, None
        data = self.replay_buffer.sample(batch_size * gradient_steps, env=self._vec_normalize_env)
        with th.no_grad():
            features = self.actor.extract_features(_stacked(data.observations, data.next_observations),
                                                   self.actor.features_extractor)
        lr = self.actor.optimizer.param_groups[0]["lr"]
        if self.overlap:
            self._pending = self._jax.dispatch(data, features, gradient_steps, self._n_updates, lr)
            self._lagging = True
            return losses
        losses, td = self._jax.train(data, features, gradient_steps, self._n_updates, lr)
        self._jax.write(self, actor_only=True)
        self._sampled(data, td)
        return losses

    @contextmanager
    def newest_actor(self) -> Iterator[list | None]:
        """Inside, the torch actor has the newest weights (with ``overlap`` the roll-outs' are a call behind; the
        exported and validated policy is read there, which waits for updates still computing); yields the
        roll-outs' weights, put back on leaving, or None when they are the newest."""
        if not self._lagging:
            yield None
            return
        from snakeplan.rl.jax_update import torch_actor, write_actor

        rollout = torch_actor(self)
        self._jax.write(self, actor_only=True)
        try:
            yield rollout
        finally:
            write_actor(self, rollout)

    def _sampled(self, data: ReplayBufferSamples, td_errors: np.ndarray) -> None:
        """What the JAX updates report of a call's samples after its updates: their mean absolute TD errors
        (SAC-PER's priorities; plain SAC keeps none)."""

    def save(self, *args, **kwargs) -> None:
        """SB3's save, with the JAX updates' weights and Adam states copied into the torch model first (and, while
        the roll-outs lag, their actor saved beside them: :meth:`load` puts it back)."""
        if self._jax is None:
            super().save(*args, **kwargs)
            return
        with self.newest_actor() as rollout:
            self._jax.write(self)
            self._rollout_actor = rollout
            try:
                super().save(*args, **kwargs)
            finally:
                self._rollout_actor = None

    @classmethod
    def load(cls, *args, **kwargs):
        """SB3's load; a model saved while its roll-outs lagged (``overlap``) gets its newest weights into JAX and
        the roll-outs' actor back into torch, as it was."""
        model = super().load(*args, **kwargs)
        if model._rollout_actor is not None:
            from snakeplan.rl.jax_update import JaxSAC, write_actor

            model._jax = JaxSAC.from_model(model)
            write_actor(model, model._rollout_actor)
            model._rollout_actor = None
        return model

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_jax", "_pending"]

    def _policy(self, features: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """The actor's squashed Gaussian sample and its log-probability, from ready features."""
        actor = self.actor
        latent = actor.latent_pi(features)
        mean, log_std = actor.mu(latent), actor.log_std(latent)
        return actor.action_dist.log_prob_from_params(mean, th.clamp(log_std, LOG_STD_MIN, LOG_STD_MAX))

    def _update(self, data: ReplayBufferSamples, step: int) -> tuple[float, float, float, float]:
        """One SAC update on ``data``: entropy coefficient, critics, actor, then the target critics (every
        ``target_update_interval`` steps). Returns (entropy coefficient, critic loss, actor loss, entropy
        coefficient loss: NaN when the coefficient is fixed)."""
        actor, critic = self.actor, self.critic
        features, next_features = actor.extract_features(_stacked(data.observations, data.next_observations),
                                                         actor.features_extractor).chunk(2)
        actions_pi, log_prob = self._policy(features)
        log_prob = log_prob.reshape(-1, 1)
        if self.ent_coef_optimizer is not None:
            ent_coef = th.exp(self.log_ent_coef.detach())
            ent_loss = -(self.log_ent_coef * (log_prob + self.target_entropy).detach()).mean()
            self.ent_coef_optimizer.zero_grad()
            ent_loss.backward()
            self.ent_coef_optimizer.step()
            ent_loss_value = ent_loss.item()
        else:
            ent_coef, ent_loss_value = self.ent_coef_tensor, math.nan
        with th.no_grad():
            next_actions, next_log_prob = self._policy(next_features)
            next_q = _q_min(self.critic_target.q_networks, th.cat([next_features, next_actions], dim=1))
            discounts = data.discounts if data.discounts is not None else self.gamma
            target = data.rewards + (1 - data.dones) * discounts * (next_q - ent_coef * next_log_prob.reshape(-1, 1))
        current = [q(th.cat([features, data.actions], dim=1)) for q in critic.q_networks]
        critic_loss = self._critic_loss(data, current, target)
        critic.optimizer.zero_grad()
        critic_loss.backward()
        critic.optimizer.step()
        critic.requires_grad_(False)  # the actor's loss needs the critics' input gradients, not their weights'
        try:
            actor_loss = (ent_coef * log_prob
                          - _q_min(critic.q_networks, th.cat([features, actions_pi], dim=1))).mean()
        finally:
            critic.requires_grad_(True)
        actor.optimizer.zero_grad()
        actor_loss.backward()
        actor.optimizer.step()
        if step % self.target_update_interval == 0:
            with th.no_grad():
                targets = list(self.critic_target.parameters())
                th._foreach_mul_(targets, 1.0 - self.tau)
                th._foreach_add_(targets, list(critic.parameters()), alpha=self.tau)
        return float(ent_coef), critic_loss.item(), actor_loss.item(), ent_loss_value

    def _critic_loss(self, data: ReplayBufferSamples, current: list[th.Tensor], target: th.Tensor) -> th.Tensor:
        """SAC's critic loss: half the summed mean squared TD errors of the Q networks."""
        return 0.5 * sum(F.mse_loss(q, target) for q in current)


def _stacked(first, second):
    """Two mini-batches of observations (tensors, or dicts of them) as one, ``first`` on top."""
    if isinstance(first, dict):
        return {key: th.cat([obs, second[key]]) for key, obs in first.items()}
    return th.cat([first, second])


def _q_min(networks, inputs: th.Tensor) -> th.Tensor:
    """The least of the Q networks' values for each row of ``inputs`` (twin-critic SAC), as a column."""
    return th.min(th.cat([q(inputs) for q in networks], dim=1), dim=1, keepdim=True)[0]
