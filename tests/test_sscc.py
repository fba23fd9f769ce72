"""SSCC (paper 001): crawling control, swinging search, the shipped agents, the planner and its bench."""

import math
from pathlib import Path

import numpy as np
import pytest

from snakeplan.evaluation import evaluate
from snakeplan.geometry.transforms import rot_y
from snakeplan.planners import Problem, get_planner
from snakeplan.planners.sscc import SSCCPlanner
from snakeplan.planners.sscc.agent import ONLINE_MIN_BUFFER, SwingAgent, shipped_agent_path
from snakeplan.planners.sscc.crawling import Directive, arm_base, crawl, joint_angles
from snakeplan.planners.sscc.swinging import (
    InnerArm,
    action_size,
    inner_module_counts,
    observation_size,
)
from snakeplan.rl.sscc import SwingEnv
from snakeplan.robots import get_robot
from snakeplan.scenes import Entrance, Scene, make_scene
from snakeplan.world import FullView

ROBOT24 = get_robot("sscc-24")  # 12 x 100 mm
ROBOT16 = get_robot("sscc-16")  # 8 x 150 mm
X = np.array([1.0, 0.0, 0.0])


def bent_directive(robot, n_inner: int, turn: float, overhang: float) -> Directive:
    """A planar directive: base and critical modules on the x axis, then inner modules turning by ``turn`` rad
    once, at the first inner joint."""
    n, l = robot.n_sections, float(robot.lengths[0])
    c = n - n_inner - 1
    first_inner = overhang * X
    joints = [first_inner - (c + 1 - j) * l * X for j in range(c + 1)] + [first_inner]
    d = rot_y(-turn) @ X
    for _ in range(n_inner):
        joints.append(joints[-1] + l * d)
    return Directive(np.array(joints), n_inner, np.zeros(3), X)


def test_crawl_ends_on_the_directive_configuration_and_angles_reproduce_it():
    directive = bent_directive(ROBOT24, 4, math.radians(40), 30.0)
    motion = crawl(directive, ROBOT24.lengths)
    assert np.allclose(motion.states.joints[-1], directive.joints, atol=1e-6)
    assert np.all(motion.states.insertion_ok)
    q = joint_angles(ROBOT24, motion)
    arm = ROBOT24.with_base(arm_base(ROBOT24, directive.entrance, directive.direction))
    assert np.allclose(arm.joint_positions(q), motion.states.joints, atol=1e-6)


def test_maximum_deviation_of_one_bend_is_the_half_chord_sagitta():
    # A chord of length l sliding over one vertex of turn theta is farthest from the two modules when it sits
    # symmetrically: (l / 2) sin(theta / 2).
    turn = math.radians(50)
    directive = bent_directive(ROBOT24, 4, turn, 50.0)
    motion = crawl(directive, ROBOT24.lengths, step_mm=0.5, e=101)
    assert motion.D == pytest.approx(50.0 * math.sin(turn / 2), abs=0.3)
    straight = crawl(bent_directive(ROBOT24, 4, 0.0, 50.0), ROBOT24.lengths)
    assert straight.D == pytest.approx(0.0, abs=1e-9)


def test_swing_keeps_the_tip_on_the_target_and_forces_push_joints():
    scene = make_scene("concentric-pipe", 3)
    target = scene.targets[0]
    k = inner_module_counts(ROBOT24, scene.entrance.position, target)[-1]
    arm = InnerArm(ROBOT24, FullView(scene), target, k)
    rng = np.random.default_rng(0)
    q = arm.initial(rng)
    assert q is not None and arm.tip_error(q) <= 1.0
    start = q.copy()
    for _ in range(40):
        q = arm.swing(q, rng.standard_normal(2 * k + 1))
        assert arm.tip_error(q) < 3.0  # each step pulls the tip back; the bend cones may hold it off a little
        assert np.all(arm.sub.bend_angles(q) <= arm.sub.max_bends + 1e-9)
    assert np.max(np.abs(q - start)) > 0.1  # the body moved
    f = np.zeros((k, 3))
    f[-1] = [1.0, 0.0, 0.0]  # push the last inner joint radially outwards (search frame x)
    z = arm.forces_to_z(q, f)
    before = arm.sub.joint_positions(q)[k - 1]
    after = arm.sub.joint_positions(q + 1e-4 * z * arm.scale)[k - 1]
    assert (after - before) @ arm.frame[:, 0] > 0


def test_observation_and_action_sizes_match_the_environment():
    env = SwingEnv("sscc-16", scenes=("pipe",), targets=1)
    obs, _ = env.reset(seed=1)
    assert obs.shape == (observation_size(8),) and np.all(np.isfinite(obs))
    assert env.action_space.shape == (action_size(8),)
    obs2, reward, terminated, _, _ = env.step(np.zeros(action_size(8), dtype=np.float32))
    assert obs2.shape == obs.shape and reward <= 0 and isinstance(terminated, bool)


@pytest.mark.parametrize("robot", ["sscc-16", "sscc-24"])
def test_shipped_agent_is_plain_data_and_its_numpy_actor_matches_torch(robot):
    torch = pytest.importorskip("torch")
    with np.load(shipped_agent_path(robot), allow_pickle=False) as data:
        assert all(data[k].dtype == np.float32 for k in data.files)
    agent = SwingAgent.load(robot)
    from snakeplan.planners.sscc.ddpg import ddpg_model as _ddpg, spaces_env as _Spaces

    model = _ddpg(_Spaces(get_robot(robot).n_sections), seed=0)
    model.policy.load_state_dict({k: torch.as_tensor(v) for k, v in agent.weights.items()})
    obs = np.random.default_rng(0).uniform(-1, 1, (5, observation_size(get_robot(robot).n_sections)))
    with torch.no_grad():
        expected = model.actor(torch.as_tensor(obs, dtype=torch.float32)).numpy()
    assert np.allclose([agent.act(o) for o in obs], expected, atol=1e-5)


@pytest.mark.parametrize("scene_name, robot, seeds", [("pipe", ROBOT16, (0, 1, 2)),
                                                       ("pipe", ROBOT24, (3, 4)),
                                                       ("concentric-pipe", ROBOT24, (0, 3, 4, 5))])
def test_shipped_agent_plans_judged_feasible_crawls(scene_name, robot, seeds):
    planner = SSCCPlanner(search="agent", learning=False)
    for seed in seeds:
        scene = make_scene(scene_name, seed)
        plan = planner.plan(Problem(scene, robot, 10.0), seed=seed)
        assert plan.status == "found" and plan.details["search"] == "agent"
        report = evaluate(scene, robot, plan.path)
        assert report.success, (seed, report.reason)
        assert plan.details["max_deviation_D_mm"] == pytest.approx(report.max_deviation_mm, rel=0.25)


def test_baselines_and_registry():
    scene = make_scene("concentric-pipe", 1)
    for search in ("random", "gradient"):
        plan = get_planner("sscc", search=search).plan(Problem(scene, ROBOT24, 10.0), seed=1)
        assert plan.details["search"] == search
        assert evaluate(scene, ROBOT24, plan.path).success


def test_same_seed_same_plan():
    scene = make_scene("concentric-pipe", 4)
    a = SSCCPlanner(learning=False).plan(Problem(scene, ROBOT24, 10.0), seed=7)
    b = SSCCPlanner(learning=False).plan(Problem(scene, ROBOT24, 10.0), seed=7)
    assert np.array_equal(a.path, b.path)


def test_several_targets_are_refused():
    scene = Scene("two", None, [-100, -200, -200], [900, 200, 200], Entrance([0, 0, 0], X),
                  np.array([[300.0, 0, 0], [500.0, 0, 0]]))
    plan = SSCCPlanner(search="gradient").plan(Problem(scene, ROBOT24, 1.0))
    assert plan.status == "invalid_target" and plan.path is None and "one target" in plan.why


def test_online_learning_updates_the_agent():
    pytest.importorskip("stable_baselines3")
    env = SwingEnv("sscc-24", scenes=("concentric-pipe",), targets=2)
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=0)
    transitions = []
    while len(transitions) < ONLINE_MIN_BUFFER:
        action = rng.uniform(-1, 1, action_size(12))
        nxt, reward, done, truncated, _ = env.step(action)
        transitions.append((obs, action, reward, nxt, done))
        obs = env.reset()[0] if done or truncated else nxt
    agent = SwingAgent.load("sscc-24", learning=True)
    before = agent.act(obs)
    assert agent.learn(transitions) > 0
    assert not np.allclose(agent.act(obs), before)


def test_bench_writes_its_table_and_pictures(tmp_path):
    from snakeplan.bench.sscc import SETTINGS, run_sscc_bench
    from snakeplan.parallel import Backend

    result = run_sscc_bench(tmp_path, variants=("agent", "random"), settings=SETTINGS[:1], targets=2, progress=False,
                            backend=Backend("serial"))
    entry = result["settings"]["pipe/sscc-16"]
    assert entry["paper_success_rate"] == 0.833
    assert set(entry["variants"]) == {"agent", "random"} and entry["variants"]["agent"]["runs"] == 2
    assert (tmp_path / "runs.jsonl").exists() and (tmp_path / "sscc.md").read_text().count("| pipe/sscc-16") == 2
    assert all(Path(p).stat().st_size > 0 for p in result["figures"])
