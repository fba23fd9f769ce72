"""Weight files are cached by content: a file rewritten in place (as training does) is read again."""

import numpy as np

from snakeplan.planners import Problem, get_planner
from snakeplan.planners.sac import NumpyPolicy, load_policy, policy_path
from snakeplan.planners.sscc import SSCCPlanner
from snakeplan.planners.sscc.agent import SwingAgent
from snakeplan.planners.sscc.swinging import observation_size
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene


def _constant_turn(policy: NumpyPolicy) -> NumpyPolicy:
    """The same network with its mean head replaced by a constant: every action turns as hard as it can."""
    w, b = policy.mu
    return NumpyPolicy(policy.layers, (np.zeros_like(w), np.full_like(b, 3.0)), policy.meta, policy.graph)


def test_a_policy_rewritten_in_place_is_planned_with_its_new_weights(tmp_path):
    shipped = NumpyPolicy.load(policy_path("fuel-tank", "sac-her"))
    turned = _constant_turn(shipped)
    here, elsewhere = tmp_path / "policy.npz", tmp_path / "other" / "policy.npz"
    shipped.save(here)
    turned.save(elsewhere)
    problem = Problem(make_scene("fuel-tank", 0), get_robot("sjtu-snake-iii"), time_limit_s=10.0)
    planner = get_planner("sac-her", policy=here)
    before = planner.plan(problem, seed=0)

    turned.save(here)  # rewritten under the same path, as training rewrites DIR/policy.npz
    after = planner.plan(problem, seed=0)
    reference = get_planner("sac-her", policy=elsewhere).plan(problem, seed=0)

    assert np.array_equal(after.path, reference.path)
    assert not np.array_equal(after.path, before.path)
    assert np.array_equal(load_policy(here).mu[1], turned.mu[1])


def test_the_same_policy_bytes_are_parsed_once_whatever_the_path(tmp_path):
    shipped = NumpyPolicy.load(policy_path("oil-tank", "sac-per"))
    shipped.save(tmp_path / "a.npz")
    (tmp_path / "b.npz").write_bytes((tmp_path / "a.npz").read_bytes())
    assert load_policy(tmp_path / "a.npz") is load_policy(tmp_path / "b.npz")


def test_an_sscc_agent_rewritten_in_place_is_swung_with_its_new_weights(tmp_path):
    robot = "sscc-16"
    shipped = SwingAgent.load(robot)
    halved = SwingAgent(robot, {k: 0.5 * v for k, v in shipped.weights.items()})
    here = shipped.save(tmp_path / "agent.npz")
    planner = SSCCPlanner(agent_path=str(here))
    state = np.random.default_rng(0).uniform(-1.0, 1.0, observation_size(get_robot(robot).n_sections))
    assert np.allclose(planner.agent(robot).act(state), shipped.act(state))

    halved.save(here)
    assert not np.allclose(halved.act(state), shipped.act(state))
    assert np.allclose(planner.agent(robot).act(state), halved.act(state))
