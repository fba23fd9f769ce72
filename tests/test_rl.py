"""Learned planners: environments, reward terms, HER relabelling, the sum tree and PER, policy files, planners."""

from __future__ import annotations

import json
import math

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chisquare

import snakeplan.rl  # noqa: F401  (registers the environments)
from snakeplan.bench.kernels import stepped_rollout
from snakeplan.evaluation import evaluate
from snakeplan.planners import Problem, get_planner
from snakeplan.planners.sac import (
    GOAL_SCALE_MM,
    Crawler,
    NumpyPolicy,
    RoomGraph,
    input_dim,
    load_policy,
    policy_input,
    policy_path,
    rollout,
)
from snakeplan.planners.sac.kernels import _actor_rows
from snakeplan.rl import rewards
from snakeplan.rl.envs import ENV_IDS, SnakeEnv
from snakeplan.rl.per import PrioritizedDictReplayBuffer, PrioritizedSamples, SumTree
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene
from snakeplan.world import view_for

#: Few training scenes keep the tests fast (scene generation dominates).
FEW_SEEDS = (1_000_000, 1_000_002)


def _env(scene: str = "fuel-tank", observation: str = "local") -> SnakeEnv:
    return gym.make(ENV_IDS[scene], observation=observation, seeds=FEW_SEEDS).unwrapped


@pytest.mark.parametrize("scene", ["fuel-tank", "oil-tank"])
@pytest.mark.parametrize("observation", ["local", "paper"])
def test_env_checkers_pass(scene, observation):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = _env(scene, observation)
    check_env(env, skip_render_check=True)
    sb3_check_env(env, warn=False)


def test_lookahead_observation_sees_the_next_target():
    from gymnasium.utils.env_checker import check_env

    env = gym.make(ENV_IDS["oil-tank"], seeds=FEW_SEEDS, lookahead=True).unwrapped
    check_env(env, skip_render_check=True)
    obs, _ = env.reset(seed=0)
    c = env.crawler
    nxt = obs["observation"][-4:]
    to = c.frame @ (env.scene.targets[1] - c.tip)
    np.testing.assert_allclose(nxt[:3], to / np.linalg.norm(to), atol=1e-5)


def test_reset_is_seeded_and_scene_options_work():
    env = _env()
    a, info_a = env.reset(seed=3)
    b, info_b = env.reset(seed=3)
    assert info_a == info_b
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    scene = make_scene("fuel-tank", 7)
    obs, info = env.reset(options={"scene": scene})
    assert info["scene_seed"] == 7
    np.testing.assert_allclose(obs["achieved_goal"] * GOAL_SCALE_MM, scene.entrance.position, atol=1e-3)


def test_straight_crawl_ends_on_the_far_wall_with_a_collision_penalty():
    env = _env("oil-tank")
    env.reset(options={"scene_seed": FEW_SEEDS[0]})
    total, terminated, info = 0.0, False, {}
    while not terminated:
        _, r, terminated, truncated, info = env.step(np.zeros(2))
        total += r
        assert not truncated
    assert info["outcome"] in ("collision", "reached")
    if info["outcome"] == "collision":
        assert r <= -rewards.COLLISION_PENALTY + 1.0


def test_reward_terms_on_hand_cases():
    assert rewards.local_reward([0.5, -0.5], [0.5, -0.5]) == 0.0
    assert rewards.local_reward([1.0, 1.0], [-1.0, 1.0]) == pytest.approx(-rewards.LOCAL_WEIGHT * 1.0)
    assert rewards.global_reward([1, 0, 0], [2, 0, 0]) == pytest.approx(-rewards.GLOBAL_EPS / 2.001, abs=1e-6)
    assert rewards.global_reward([1, 0, 0], [0, 1, 0]) == pytest.approx(-rewards.GLOBAL_WEIGHT)
    assert rewards.collide_reward(True) == -rewards.COLLISION_PENALTY
    assert rewards.collide_reward(False) == 0.0
    assert rewards.target_reward(0.005, False) == rewards.REACH_REWARD
    assert rewards.target_reward(0.5, True) == pytest.approx(-rewards.ERROR_WEIGHT * 0.5)
    assert rewards.target_reward(0.5, False) == -rewards.UNDETECTED_PENALTY


def test_detection_needs_view_range_and_line_of_sight():
    info = {"heading": np.array([1.0, 0, 0]), "goal": np.array([0.5, 0, 0]), "visible": 1.0, "shaping": 0.0}
    ahead = rewards.compute_reward(np.zeros(3), np.array([0.5, 0, 0]), info)
    assert ahead == pytest.approx(-rewards.ERROR_WEIGHT * 0.5)
    behind = rewards.compute_reward(np.zeros(3), np.array([-0.5, 0, 0]), info)
    assert behind == pytest.approx(-rewards.UNDETECTED_PENALTY)
    blocked = rewards.compute_reward(np.zeros(3), np.array([0.5, 0, 0]), {**info, "visible": 0.0})
    assert blocked == pytest.approx(-rewards.UNDETECTED_PENALTY)
    far = rewards.compute_reward(np.zeros(3), np.array([0.9, 0, 0]), {**info, "goal": np.array([0.9, 0, 0])})
    assert far == pytest.approx(-rewards.UNDETECTED_PENALTY)


def test_env_reward_is_compute_reward_and_her_relabelling_recomputes_it():
    from stable_baselines3.common.vec_env import DummyVecEnv

    from snakeplan.rl.her import FastHerReplayBuffer

    venv = DummyVecEnv([lambda: SnakeEnv("fuel-tank", seeds=FEW_SEEDS)])
    venv.seed(0)
    env = venv.envs[0]
    buf = FastHerReplayBuffer(500, env.observation_space, env.action_space, env=venv, n_sampled_goal=4)
    obs = venv.reset()
    rng = np.random.default_rng(0)
    for _ in range(200):
        action = rng.uniform(-1, 1, (1, 2)).astype(np.float32)
        nxt, reward, done, infos = venv.step(action)
        info = infos[0]
        real_next = info["terminal_observation"] if done[0] else {k: v[0] for k, v in nxt.items()}
        assert reward[0] == pytest.approx(float(env.compute_reward(real_next["achieved_goal"],
                                                                   obs["desired_goal"][0], info)), abs=1e-6)
        buf.add(obs, {k: v[None] for k, v in real_next.items()}, action, reward, done, infos)
        obs = nxt
    batch = buf._get_virtual_samples(np.arange(50), np.zeros(50, dtype=int))
    ag = batch.next_observations["achieved_goal"].numpy()
    dg = batch.observations["desired_goal"].numpy()
    infos = [{k: buf.reward_info[k][i, 0].squeeze() for k in buf.reward_info} for i in range(50)]
    expected = np.array([float(env.compute_reward(ag[i], dg[i], infos[i])) for i in range(50)])
    np.testing.assert_allclose(batch.rewards.numpy().ravel(), expected, atol=1e-5)
    at_goal = np.isclose(np.linalg.norm(ag - dg, axis=1) * GOAL_SCALE_MM, 0.0, atol=1e-3)
    assert at_goal.any()
    shaping = buf.reward_info["shaping"][:50, 0, 0]
    np.testing.assert_allclose(expected[at_goal] - shaping[at_goal], rewards.REACH_REWARD, atol=1e-4)


@settings(max_examples=20, deadline=None)
@given(st.lists(st.floats(0.05, 10.0), min_size=2, max_size=40))
def test_sum_tree_sampling_frequencies_match_priorities(priorities):
    tree = SumTree(len(priorities))
    tree.update(np.arange(len(priorities)), priorities)
    assert tree.total == pytest.approx(sum(priorities))
    rng = np.random.default_rng(0)
    n = 4000
    draws = np.concatenate([tree.sample(100, rng) for _ in range(n // 100)])
    counts = np.bincount(draws, minlength=len(priorities))
    expected = n * np.asarray(priorities) / sum(priorities)
    assert chisquare(counts, expected).pvalue > 1e-4


def test_sum_tree_updates_keep_sums():
    tree = SumTree(5)
    tree.update([0, 1, 2, 3, 4], [1, 2, 3, 4, 5])
    tree.update([2, 2], [0.5, 7.0])
    assert tree.total == pytest.approx(1 + 2 + 7 + 4 + 5)
    np.testing.assert_allclose(tree[[0, 2, 4]], [1, 7, 5])
    assert set(tree.find(np.array([0.0, 0.99, 1.0, 2.99, 3.0, 9.99, 10.0, 18.99]))) == {0, 1, 2, 3, 4}


def _per_buffer(n: int = 6) -> PrioritizedDictReplayBuffer:
    env = SnakeEnv("oil-tank", seeds=FEW_SEEDS)
    buf = PrioritizedDictReplayBuffer(16, env.observation_space, env.action_space, alpha=0.6, beta=0.4, seed=0)
    obs, _ = env.reset(seed=0)
    for _ in range(n):
        nxt, r, term, _trunc, info = env.step(np.zeros(2))
        buf.add({k: v[None] for k, v in obs.items()}, {k: v[None] for k, v in nxt.items()}, np.zeros((1, 2)),
                np.array([r]), np.array([term]), [info])
        obs = nxt
    return buf


def test_new_transitions_share_the_top_priority_and_weights_are_one():
    buf = _per_buffer()
    batch = buf.sample(32)
    np.testing.assert_allclose(batch.weights.numpy(), 1.0)
    assert set(batch.indices) <= set(range(6))


def test_importance_weights_follow_eq_16():
    buf = _per_buffer()
    td = np.array([0.5, 1.0, 2.0, 4.0, 0.1, 3.0])
    buf.update_priorities(np.arange(6), td)
    p = (np.abs(td) + buf.eps) ** buf.alpha
    prob = p / p.sum()
    batch = buf.sample(64)
    w = (6 * prob[batch.indices]) ** -buf.beta
    np.testing.assert_allclose(batch.weights.numpy().ravel(), w / w.max(), rtol=1e-5)
    assert buf.max_priority == pytest.approx(4.0 + buf.eps)


@pytest.mark.parametrize("autodiff", ["torch", "jax"])
def test_per_sac_updates_priorities_and_learns_a_few_steps(autodiff):
    from stable_baselines3.common.vec_env import DummyVecEnv

    from snakeplan.rl.per import PerSAC

    venv = DummyVecEnv([lambda: SnakeEnv("oil-tank", seeds=FEW_SEEDS)])
    model = PerSAC("MultiInputPolicy", venv, replay_buffer_class=PrioritizedDictReplayBuffer,
                   replay_buffer_kwargs={"seed": 0}, learning_starts=50, batch_size=16, seed=0,
                   policy_kwargs={"net_arch": [16, 16]}, device="cpu", autodiff=autodiff)
    model.learn(120)
    buf = model.replay_buffer
    leaves = buf.tree[np.arange(buf.size())]
    assert np.unique(np.round(leaves, 9)).size > 1
    assert 0.4 < buf.beta <= 1.0
    assert 0.0 < model.epsilon < 1.0


def _her_model(seed: int = 0, **kwargs):
    from stable_baselines3.common.vec_env import DummyVecEnv

    from snakeplan.rl.agents import EpsilonGreedySAC
    from snakeplan.rl.extractor import GoalRouteExtractor
    from snakeplan.rl.her import FastHerReplayBuffer

    venv = DummyVecEnv([lambda: SnakeEnv("fuel-tank", seeds=FEW_SEEDS)])
    graph = RoomGraph.from_scene(venv.envs[0].scene)
    return EpsilonGreedySAC("MultiInputPolicy", venv, replay_buffer_class=FastHerReplayBuffer,
                            replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future"},
                            learning_starts=300, batch_size=32, seed=seed, device="cpu", **kwargs,
                            policy_kwargs={"net_arch": [32, 32], "features_extractor_class": GoalRouteExtractor,
                                           "features_extractor_kwargs": {"mode": "local", "graph": graph.arrays()}})


@pytest.mark.parametrize("settings", [{}, {"ent_coef": 0.1, "target_update_interval": 2}])
def test_sac_update_gives_sb3s_weights(settings):
    """The shared update (features in one call per mini-batch, the actor's loss without the critics' weight
    gradients, fused target update) is SB3's SAC update: the same weights and logged losses after the same updates
    on the same draws (a learned entropy coefficient updating the targets every step, and a fixed one every second
    step)."""
    import copy

    from stable_baselines3 import SAC

    model = _her_model(**settings)
    model.learn(300)  # fills the buffer; learning starts after it
    reference = copy.deepcopy(model)
    logged = []
    for m, train in ((model, model.train), (reference, lambda n, b: SAC.train(reference, n, b))):
        np.random.seed(3)  # the buffer's draws
        th.manual_seed(3)  # the actor's samples
        train(25, 32)
        logged.append(dict(m.logger.name_to_value))
    ours, theirs = model.policy.state_dict(), reference.policy.state_dict()
    assert ours.keys() == theirs.keys()
    for key in ours:
        assert th.equal(ours[key], theirs[key]), key
    assert (model.log_ent_coef is None) == ("ent_coef" in settings)
    if model.log_ent_coef is not None:
        assert th.equal(model.log_ent_coef, reference.log_ent_coef)
    keys = {k for k in logged[1] if k.startswith("train/") and k != "train/n_updates"}
    assert keys == {k for k in logged[0] if k.startswith("train/") and k != "train/n_updates"}
    assert ("train/ent_coef_loss" in keys) == ("ent_coef" not in settings)
    for key in keys:
        assert logged[0][key] == pytest.approx(logged[1][key], rel=1e-6), key
    assert not th.equal(ours["actor.mu.weight"], _her_model(**settings).policy.state_dict()["actor.mu.weight"])


def _one_sample(batches):
    """SB3 samples joined into one as the JAX updates split a sample: row ``r`` from batch ``r % len(batches)``."""
    def cat(values):
        if values[0] is None:
            return None
        if isinstance(values[0], dict):
            return {key: cat([v[key] for v in values]) for key in values[0]}
        return th.stack(values, dim=1).reshape(-1, *values[0].shape[1:])

    return type(batches[0])(*[cat(list(values)) for values in zip(*batches)])


@pytest.mark.parametrize("settings", [{}, {"ent_coef": 0.1, "target_update_interval": 2}])
def test_jax_update_gives_the_torch_updates_weights(settings):
    """The JAX updates, 25 in one compiled call, on the same mini-batches with the same Gaussian noise,
    give the torch update's (SB3's) weights, Adam moments, entropy coefficient and logged losses to float32
    rounding; copied back into the torch model they are what a checkpoint saves."""
    import copy

    from snakeplan.rl.agents import _stacked
    from snakeplan.rl.jax_update import JaxSAC, _arrays

    model = _her_model(**settings)
    model.learn(300)
    reference = copy.deepcopy(model)
    count, size = 25, 32
    noise = np.random.default_rng(0).standard_normal((2, count, size, *model.action_space.shape))
    noise = noise.astype(np.float32)
    queue = [th.from_numpy(noise[j, i]) for i in range(count) for j in range(2)]  # actions, next actions

    def rsample(self, sample_shape=th.Size()):
        return self.loc + self.scale * queue.pop(0)

    np.random.seed(3)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(th.distributions.Normal, "rsample", rsample)
        model.train(count, size)
    assert not queue
    np.random.seed(3)
    data = _one_sample([reference.replay_buffer.sample(size) for _ in range(count)])
    with th.no_grad():
        features = reference.actor.extract_features(_stacked(data.observations, data.next_observations),
                                                    reference.actor.features_extractor)
    jax_sac = JaxSAC.from_model(reference)
    losses, td = jax_sac.run(_arrays(data, features, count, reference.gamma), noise, model.learning_rate)
    jax_sac.write(reference)
    before = _her_model(**settings).policy.state_dict()
    ours, theirs = reference.policy.state_dict(), model.policy.state_dict()
    for key, value in theirs.items():
        np.testing.assert_allclose(ours[key].numpy(), value.numpy(), atol=2e-6, rtol=0, err_msg=key)
        if key.endswith("weight"):
            assert not th.equal(value, before[key]), key  # the updates moved every layer
    for mine, torch_opt in ((reference.critic.optimizer, model.critic.optimizer),
                            (reference.actor.optimizer, model.actor.optimizer)):
        for (_, a), (_, b) in zip(mine.state.items(), torch_opt.state.items(), strict=True):
            assert float(a["step"]) == float(b["step"]) == count
            for key in ("exp_avg", "exp_avg_sq"):  # float32 rounding of the gradients, relative to their scale
                np.testing.assert_allclose(a[key].numpy(), b[key].numpy(), rtol=0,
                                           atol=1e-4 * float(b[key].abs().max()), err_msg=key)
    if "ent_coef" not in settings:
        assert float(reference.log_ent_coef.detach()) == pytest.approx(float(model.log_ent_coef.detach()), abs=1e-6)
    logged = model.logger.name_to_value
    assert losses.shape == (count, 4) and td.shape == (count * size,)
    for column, key in enumerate(("ent_coef", "critic_loss", "actor_loss")):
        assert losses[:, column].mean() == pytest.approx(logged[f"train/{key}"], rel=1e-5, abs=1e-5), key


def test_each_jax_mini_batch_mixes_the_sample_as_its_own_draw_would():
    """A HER sample lists its real transitions before its relabelled ones; each of the mini-batches one sample is
    split into holds its share of both, and a PER mini-batch's weights are normalised by its own largest."""
    from stable_baselines3.common.type_aliases import ReplayBufferSamples

    from snakeplan.rl.jax_update import _arrays

    count, size = 8, 16
    n = count * size
    part = th.arange(n, dtype=th.float32).reshape(-1, 1) >= n // 4  # a quarter real, then relabelled
    data = ReplayBufferSamples(th.zeros(n, 3), th.zeros(n, 2), th.zeros(n, 3), th.zeros(n, 1), part.float(), None)
    features = th.zeros(2 * n, 3)
    _, _, actions, rewards, not_done, weights = _arrays(data, features, count, 0.99)
    assert actions.shape == (count, size, 2) and rewards.shape == not_done.shape == weights.shape == (count, size)
    np.testing.assert_array_equal(rewards.sum(axis=1), np.full(count, 0.75 * size))
    np.testing.assert_allclose(not_done, 0.99)
    assert np.all(weights == 1.0)
    samples = PrioritizedSamples(*data, weights=th.linspace(0.1, 1.0, n).reshape(-1, 1), indices=np.arange(n))
    _, _, _, _, _, weights = _arrays(samples, features, count, 0.99)
    np.testing.assert_allclose(weights.max(axis=1), 1.0)
    assert np.ptp(weights.min(axis=1)) > 0  # each normalised by its own largest, not one shared factor


def test_importing_the_jax_updates_leaves_numpys_global_draws_alone():
    """Importing JAX draws from NumPy's global generator, which the replay buffers sample with; a resumed run
    imports the JAX updates after its saved generator states are restored, so the import must not move them."""
    import subprocess
    import sys

    code = ("import numpy as np; np.random.seed(0); state = np.random.get_state()[1].copy(); "
            "import snakeplan.rl.jax_update; print(np.array_equal(state, np.random.get_state()[1]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True"


def test_the_jax_updates_resume_from_a_saved_model_bit_for_bit(tmp_path):
    """Weights and Adam states go into SB3's files at a save and come back at a load, and the noise follows the
    count of updates: the loaded copy's next updates are the running model's, bit for bit."""
    from snakeplan.rl.agents import EpsilonGreedySAC

    model = _her_model(autodiff="jax")
    model.learn(400)  # 100 updates
    model.save(tmp_path / "model.zip")
    model.save_replay_buffer(tmp_path / "replay.pkl")
    copy = EpsilonGreedySAC.load(tmp_path / "model.zip", env=model.env, device="cpu")
    copy.load_replay_buffer(tmp_path / "replay.pkl", truncate_last_traj=False)
    copy.set_logger(model.logger)
    assert copy.autodiff == "jax" and copy._n_updates == model._n_updates == 100
    for m in (model, copy):
        np.random.seed(5)
        m.train(20, 32)
        m.save(tmp_path / "after.zip")  # copies every JAX weight into the torch modules
    ours, theirs = model.policy.state_dict(), copy.policy.state_dict()
    for key in ours:
        assert th.equal(ours[key], theirs[key]), key


def test_overlapped_roll_outs_act_one_call_behind_and_a_lagging_model_resumes_bit_for_bit(tmp_path):
    """With ``overlap`` a call starts its updates and returns: the roll-outs after it act with the actor of the
    call before, while the exported actor is the newest. A model saved while lagging loads lagging, and its next
    calls give the running model's weights, bit for bit."""
    import jax

    from snakeplan.rl.agents import EpsilonGreedySAC
    from snakeplan.rl.jax_update import torch_actor

    def newest(m) -> list:
        return jax.device_get(m._jax.params["actor"])

    def same(a, b) -> bool:
        return all(np.array_equal(x, y) for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True))

    model = _her_model(autodiff="jax", overlap=True, train_freq=5, gradient_steps=5)
    model.learn(300)  # learning starts at 300: no update yet
    before = torch_actor(model)
    model.train(5, 32)
    first = newest(model)
    assert model._lagging and same(torch_actor(model), before) and not same(first, before)
    model.train(5, 32)
    second = newest(model)
    assert same(torch_actor(model), first) and not same(second, first)  # one call behind
    with model.newest_actor():
        assert same(torch_actor(model), second)
    assert same(torch_actor(model), first)
    model.learn(60, reset_num_timesteps=False)  # roll-outs and calls in turn
    rollout = torch_actor(model)
    model.save(tmp_path / "model.zip")
    model.save_replay_buffer(tmp_path / "replay.pkl")
    assert same(torch_actor(model), rollout)  # the save leaves the roll-outs their actor
    copy = EpsilonGreedySAC.load(tmp_path / "model.zip", env=model.env, device="cpu")
    copy.load_replay_buffer(tmp_path / "replay.pkl", truncate_last_traj=False)
    assert copy._lagging and copy.overlap and same(torch_actor(copy), rollout)
    assert same(newest(copy), newest(model)) and not same(newest(model), rollout)
    for m in (model, copy):
        np.random.seed(5)
        m.train(5, 32)
        m.train(5, 32)
        m.save(tmp_path / "after.zip")  # copies the JAX weights into torch (the actor: the roll-outs' again after)
    ours, theirs = model.policy.state_dict(), copy.policy.state_dict()
    for key in ours:
        assert th.equal(ours[key], theirs[key]), key
    assert same(newest(model), newest(copy)) and same(jax.device_get(model._jax.opt), jax.device_get(copy._jax.opt))


def test_overlap_needs_the_jax_updates_and_no_priorities(tmp_path):
    from dataclasses import replace

    from stable_baselines3.common.vec_env import DummyVecEnv

    from snakeplan.rl.per import PerSAC
    from snakeplan.rl.train import DEFAULT_CONFIG, train

    config = replace(DEFAULT_CONFIG, autodiff="jax", overlap=True)
    with pytest.raises(ValueError, match="^--overlap: SAC-PER"):
        train("oil-tank", "sac-per", 10, 0, tmp_path / "run", config, progress=False)
    assert not (tmp_path / "run").exists()

    with pytest.raises(ValueError, match="^overlap: .*autodiff='jax'"):
        _her_model(overlap=True)
    venv = DummyVecEnv([lambda: SnakeEnv("oil-tank", seeds=FEW_SEEDS)])
    with pytest.raises(ValueError, match="^overlap: SAC-PER"):
        PerSAC("MultiInputPolicy", venv, replay_buffer_class=PrioritizedDictReplayBuffer,
               replay_buffer_kwargs={"seed": 0}, device="cpu", autodiff="jax", overlap=True)


def test_sac_refuses_an_extractor_with_weights():
    from stable_baselines3.common.torch_layers import FlattenExtractor
    from stable_baselines3.common.vec_env import DummyVecEnv

    from snakeplan.rl.agents import EpsilonGreedySAC

    class Learned(FlattenExtractor):
        def __init__(self, space):
            super().__init__(space)
            self.scale = th.nn.Parameter(th.ones(1))

    venv = DummyVecEnv([lambda: SnakeEnv("fuel-tank", seeds=FEW_SEEDS, observation="paper")])
    with pytest.raises(ValueError, match="features_extractor_class"):
        EpsilonGreedySAC("MlpPolicy", gym.wrappers.FlattenObservation(venv.envs[0]), device="cpu",
                         policy_kwargs={"features_extractor_class": Learned})


def test_room_graph_routes_through_holes():
    scene = make_scene("fuel-tank", 3)
    graph = RoomGraph.from_scene(scene)
    assert graph.lo.shape == (6, 3) and graph.centre.shape == (7, 3)
    tip, goal = np.array([300.0, 350, 200]), np.array([1500.0, 350, 200])
    first, second, normal = graph.waypoints(tip, goal)
    np.testing.assert_allclose(first, [600, 350, 200])
    np.testing.assert_allclose(second, [1200, 350, 200])
    np.testing.assert_allclose(normal, [1, 0, 0])
    first, _, normal = graph.waypoints(goal, tip)
    np.testing.assert_allclose(first, [1200, 350, 200])
    np.testing.assert_allclose(normal, [-1, 0, 0])
    oil = RoomGraph.from_scene(make_scene("oil-tank", 3))
    assert oil.lo.shape == (16, 3) and oil.centre.shape == (28, 3)


def test_torch_extractor_matches_numpy_features():
    from snakeplan.rl.extractor import GoalRouteExtractor

    env = _env()
    graph = RoomGraph.from_scene(env.scene)
    ext = GoalRouteExtractor(env.observation_space, "local", graph.arrays())
    obs, _ = env.reset(seed=1)
    rng = np.random.default_rng(1)
    batch = []
    for _ in range(10):
        obs, *_ = env.step(rng.uniform(-1, 1, 2))
        obs["desired_goal"] = rng.uniform(0.0, 1.4, 3).astype(np.float32)
        batch.append(obs)
    stacked = {k: np.stack([b[k] for b in batch]) for k in obs}
    ours = policy_input(stacked["observation"], stacked["achieved_goal"], stacked["desired_goal"], "local", graph)
    theirs = ext({k: th.as_tensor(v) for k, v in stacked.items()}).numpy()
    assert ours.shape == (10, input_dim("local", stacked["observation"].shape[1]))
    np.testing.assert_allclose(ours, theirs, atol=1e-4)


def test_policy_file_round_trip_matches_sb3_actor(tmp_path):
    from stable_baselines3.common.vec_env import DummyVecEnv

    from snakeplan.rl.agents import EpsilonGreedySAC
    from snakeplan.rl.extractor import GoalRouteExtractor
    from snakeplan.rl.policy import from_sb3

    venv = DummyVecEnv([lambda: SnakeEnv("fuel-tank", seeds=FEW_SEEDS)])
    graph = RoomGraph.from_scene(venv.envs[0].scene)
    model = EpsilonGreedySAC("MultiInputPolicy", venv, seed=0, device="cpu", learning_starts=10,
                             policy_kwargs={"net_arch": [32, 32], "features_extractor_class": GoalRouteExtractor,
                                            "features_extractor_kwargs": {"mode": "local", "graph": graph.arrays()}})
    from_sb3(model, {"observation": "local"}, graph).save(tmp_path / "p.npz")
    policy = NumpyPolicy.load(tmp_path / "p.npz")
    obs = venv.reset()
    ours = policy.act({k: v[0] for k, v in obs.items()})
    theirs, _ = model.predict(obs, deterministic=True)
    np.testing.assert_allclose(ours, theirs[0], atol=1e-4)


def test_local_actions_keep_the_bend_limits():
    robot = get_robot("sjtu-snake-iii")
    rng = np.random.default_rng(0)
    scene = make_scene("oil-tank", 0)
    crawler = Crawler(robot, check_body=False)
    crawler.reset(scene)
    side = np.sign(rng.uniform(-1, 1, 2))
    for _ in range(60):
        crawler.advance(side * rng.uniform(0.8, 1.0, 2))
    report = evaluate(scene, robot, crawler.tip_path())
    assert report.bend_limits_ok
    assert report.max_curvature_per_mm <= 1.0 / 200.0


SHIPPED = [("fuel-tank", "sac-her"), ("oil-tank", "sac-per")]
#: Fixed test episodes for shipped policies (test seeds; never trained on) and the success they must reach.
SHIPPED_SEEDS = range(10)
SHIPPED_MIN_SUCCESS = 0.9


@pytest.mark.parametrize("scene,planner", SHIPPED)
def test_shipped_policy_loads_and_succeeds(scene, planner):
    assert policy_path(scene, planner).is_file()
    robot = get_robot("sjtu-snake-iii")
    ok = 0
    for seed in SHIPPED_SEEDS:
        s = make_scene(scene, seed)
        plan = get_planner(planner).plan(Problem(s, robot, time_limit_s=5.0))
        ok += plan.path is not None and evaluate(s, robot, plan.path).success
    assert ok >= math.ceil(SHIPPED_MIN_SUCCESS * len(SHIPPED_SEEDS))


def test_planner_without_policy_file_is_a_clear_error(tmp_path):
    from snakeplan.planners.sac import SacPlanner

    problem = Problem(make_scene("oil-tank", 0), get_robot("sjtu-snake-iii"))
    with pytest.raises(ValueError, match="policy"):
        SacPlanner(policy=tmp_path / "missing.npz").plan(problem)


def test_train_writes_policy_curve_and_resumes_and_nothing_outside_its_folder(tmp_path, monkeypatch):
    import tempfile
    from dataclasses import replace

    from snakeplan.rl.train import DEFAULT_CONFIG, train

    scratch = tmp_path / "scratch"  # the temporary folder while training: SB3's default logger makes one there
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    monkeypatch.delenv("SB3_LOGDIR", raising=False)
    tmp_path = tmp_path / "run"
    config = replace(DEFAULT_CONFIG, net_arch=(16, 16), learning_starts=60, eval_every=100, eval_episodes=2,
                     checkpoint_every=100, train_scenes=2, batch_size=16)
    first = train("oil-tank", "sac-per", 150, 0, tmp_path, config, progress=False)
    assert (tmp_path / "policy.npz").is_file() and (tmp_path / "curve.png").is_file()
    state = json.loads((tmp_path / "state.json").read_text())
    assert [g["step"] for g in state["generations"]] == [150, 100]
    assert (tmp_path / "ckpt-00000150" / "model.zip").is_file()
    policy = NumpyPolicy.load(tmp_path / "last.npz")
    assert policy.meta["scene"] == "oil-tank" and "snakeplan.rl.train" in policy.meta["command"]
    second = train("oil-tank", "sac-per", 250, 0, tmp_path, config, progress=False)
    steps = [h["env_steps"] for h in second.history]
    assert steps[: len(first.history)] == [h["env_steps"] for h in first.history]
    assert steps[-1] == 250
    # torch's own compile cache (one per user, made by any Adam) is torch's; a training run adds nothing of its own
    assert [p.name for p in scratch.iterdir() if not p.name.startswith("torchinductor_")] == []


def test_convergence_and_variants():
    from snakeplan.rl.ablation import steps_to_converge, variants

    history = [{"env_steps": 1000, "success": 0.2}, {"env_steps": 2000, "success": 0.95},
               {"env_steps": 3000, "success": 0.9}]
    assert steps_to_converge(history) == (2000.0, True)
    assert steps_to_converge(history[:1]) == (1000.0, False)
    assert list(variants("fuel-tank", "replay").values()) == [("sac-her", "local"), ("sac", "local")]
    assert list(variants("oil-tank", "observation").values()) == [("sac-per", "local"), ("sac-per", "paper")]


def test_per_buffer_for_box_observations_trains():
    from stable_baselines3.common.vec_env import DummyVecEnv

    from snakeplan.rl.per import PerSAC, PrioritizedReplayBuffer

    venv = DummyVecEnv([lambda: gym.make("Pendulum-v1")])
    model = PerSAC("MlpPolicy", venv, replay_buffer_class=PrioritizedReplayBuffer, replay_buffer_kwargs={"seed": 0},
                   learning_starts=40, batch_size=16, seed=0, policy_kwargs={"net_arch": [16, 16]}, device="cpu")
    model.learn(80)
    batch = model.replay_buffer.sample(8)
    assert batch.weights.shape == (8, 1) and float(batch.weights.max()) == pytest.approx(1.0)


# --- the compiled roll-out ------------------------------------------------------------------------------------
@pytest.mark.parametrize("family, planner, knowledge", [("fuel-tank", "sac-her", "full"),
                                                        ("oil-tank", "sac-per", "sensed"),
                                                        ("confined", "sac", "sensed")])
def test_the_compiled_roll_out_is_the_crawlers_step_by_step(family, planner, knowledge):
    """The compiled roll-out (local design with routes; the generalist's residual guide design) gives the path,
    outcome, sensing and noise draws of the Crawler stepped in Python."""
    robot = get_robot("sjtu-snake-iii")
    policy = load_policy(policy_path(family, planner))
    for seed in range(3):
        scene = make_scene(family, seed)
        for noise in (0.0, 0.5):
            views = view_for(scene, knowledge), view_for(scene, knowledge)
            rngs = np.random.default_rng(seed), np.random.default_rng(seed)
            path, outcome = rollout(policy, scene, robot, noise=noise, rng=rngs[0], world=views[0])
            expect, expected = stepped_rollout(policy, scene, robot, views[1], noise, rngs[1])
            np.testing.assert_array_equal(path, expect)
            assert outcome == expected
            if knowledge == "sensed":
                assert list(views[0].known) == list(views[1].known)
            assert rngs[0].random() == rngs[1].random()


def test_the_compiled_actor_is_the_layers_in_numpy():
    policy = load_policy(policy_path("oil-tank", "sac-per"))
    obs = np.random.default_rng(0).normal(size=(50, policy.shapes[0, 1]))
    h = obs
    for w, b in policy.layers:
        h = np.maximum(h @ w.T + b, 0.0)
    expect = np.tanh(h @ policy.mu[0].T + policy.mu[1])
    ours = np.empty_like(expect)
    _actor_rows(obs, policy.weights, policy.biases, policy.shapes, ours)
    np.testing.assert_allclose(ours, expect, rtol=0, atol=1e-12)


def test_upcoming_scene_seeds_are_the_environments_own_draws():
    from snakeplan.rl.envs import upcoming

    envs = [SnakeEnv("fuel-tank", seeds=(1_000_000, 1_000_006)) for _ in range(2)]
    for k, env in enumerate(envs):
        env.reset(seed=k)
    predicted = upcoming(envs, 12)
    drawn: dict[int, None] = {}
    for _ in range(12):
        for env in envs:
            drawn.setdefault(env.reset()[1]["scene_seed"], None)
    assert predicted == list(drawn)
    assert len(predicted) == 6  # twelve draws each from six seeds


def test_prefetch_keeps_a_window_and_leaves_to_the_caller_what_a_worker_cannot_make(monkeypatch, capsys):
    from concurrent.futures import wait

    from snakeplan.scenes import prefetch

    monkeypatch.setattr(prefetch, "WINDOW", 2)
    keys = [("no-such-family", 1, ())] + [("fuel-tank", 1_000_000 + k, ()) for k in range(3)]
    ahead = prefetch.ScenePrefetch(keys, 1).start()
    made = []
    try:
        assert len(ahead._futures) == 2  # the window, not every key
        wait(list(ahead._futures.values()))
        assert ahead.take("no-such-family", 1) is None  # its worker failed: the caller makes it, and is told once
        assert capsys.readouterr().err.count("could not make no-such-family 1") == 1
        for family, seed, _ in keys[1:]:
            assert len(ahead._futures) <= 2
            wait(list(ahead._futures.values()))
            made.append(ahead.take(family, seed))
        assert ahead.take("fuel-tank", 1_000_000) is None  # taken once
    finally:
        ahead.close()
    assert prefetch.made_ahead("fuel-tank", 1_000_001) is None  # closed: nothing is made ahead
    assert [m.to_dict() for m in made] == [make_scene(f, s).to_dict() for f, s, _ in keys[1:]]


def test_scenes_made_ahead_train_the_same_weights(tmp_path, monkeypatch):
    """A run whose scenes workers make ahead learns exactly what a run making each scene itself learns."""
    from dataclasses import replace

    from snakeplan.rl import envs
    from snakeplan.rl.train import DEFAULT_CONFIG, train

    delivered = []

    def counted(family, seed, params=()):
        scene = made_ahead(family, seed, params)
        delivered.append(scene is not None)
        return scene

    made_ahead = envs.made_ahead
    monkeypatch.setattr(envs, "made_ahead", counted)
    config = replace(DEFAULT_CONFIG, net_arch=(8, 8), batch_size=16, learning_starts=100, eval_every=100,
                     eval_episodes=2, train_scenes=12, checkpoint_every=1000)
    weights, curves = [], []
    for workers in (0, 1):
        envs.family_scene.cache_clear()
        train("fuel-tank", "sac-her", 200, 0, tmp_path / str(workers), replace(config, scene_workers=workers),
              progress=False)
        with np.load(tmp_path / str(workers) / "last.npz") as last:
            weights.append({k: last[k] for k in last.files if k != "meta"})
        curves.append([{k: v for k, v in h.items() if k not in ("wall_s", "median_time_s")}
                       for h in json.loads((tmp_path / str(workers) / "curve.json").read_text())])
        if workers == 0:
            assert not any(delivered)
    assert sum(delivered) >= 4  # most of the second run's scenes came from the worker
    assert curves[0] == curves[1]
    for key in weights[0]:
        np.testing.assert_array_equal(weights[0][key], weights[1][key], err_msg=key)
