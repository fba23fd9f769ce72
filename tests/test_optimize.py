"""The path optimiser (snakeplan.optimize): never a worse path, fits that hold what they must, and its option.

The promise is checked against the judge, the library's independent rules: for planners' valid paths in the tanks
(full and sensed knowledge), the optimised path is judged valid, reaches every target, and has a smoothness index
and a least clearance at least the input's. The fits are checked against closed forms (a straight path stays
straight; with the second-difference penalty at a large scale, the fit between two held points is their chord) and
the compiled banded solve against a dense one.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from snakeplan.cli import main
from snakeplan.evaluation import judge
from snakeplan.optimize import LEVELS, optimize_path
from snakeplan.optimize.optimizer import EFFORT
from snakeplan.optimize.fits import _banded, _difference_normal, _solve_penalised, gaussian_fits, penalised_fits
from snakeplan.planners import Problem, get_planner
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene
from snakeplan.world import FullView, SensedView, targets_reached

ROBOT = get_robot("sjtu-snake-iii")


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(family=st.sampled_from(("fuel-tank", "oil-tank")), seed=st.integers(0, 10_000),
       planner=st.sampled_from(("rrt-star", "sp-rrt", "as-rrt")), level=st.sampled_from(("fast", "full")),
       sensed=st.booleans())
def test_optimised_path_is_never_worse(family, seed, planner, level, sensed):
    scene = make_scene(family, seed)
    knowledge = "sensed" if sensed and planner == "as-rrt" else "full"
    plan = get_planner(planner, optimize="none").plan(Problem(scene, ROBOT, 10.0, knowledge=knowledge), seed=seed)
    raw = judge(scene, ROBOT, plan.path) if plan.path is not None else None
    if raw is None or not raw.success:
        return
    world = SensedView.of(scene) if knowledge == "sensed" else FullView(scene)
    if knowledge == "sensed":
        world.sense(plan.path)
    done = optimize_path(plan.path, world, ROBOT, scene.targets, level)
    after = judge(scene, ROBOT, done.path)
    assert after.success, (family, seed, planner, level, after.reason)
    assert targets_reached(done.path, scene.targets) == len(scene.targets)
    assert after.smoothness_index >= raw.smoothness_index
    if knowledge == "full":  # a sensed optimiser keeps the clearance of what it knows
        assert after.min_clearance_mm >= raw.min_clearance_mm
    assert np.array_equal(done.path[0], scene.entrance.position)
    if not done.kept:
        assert np.array_equal(done.path, plan.path)
    else:
        assert done.after["smoothness_index"] == pytest.approx(after.smoothness_index, abs=1e-12)


def test_deterministic_and_recorded(monkeypatch):
    """The same plan twice is the same to the bit, and the plan's details say what the optimiser did: the crawl
    checks it records are those the validity checker was asked for (counted here), within the level's budget, and
    the smoothness it records is the judge's."""
    from snakeplan.world import ValidityChecker

    scene = make_scene("oil-tank", 3)
    plans = [get_planner("sp-rrt", optimize="none").plan(Problem(scene, ROBOT, 10.0), seed=1) for _ in range(2)]
    assert np.array_equal(plans[0].path, plans[1].path)
    asked = []
    feasible = ValidityChecker.feasible
    monkeypatch.setattr(ValidityChecker, "feasible", lambda self, path: asked.append(1) or feasible(self, path))
    done = optimize_path(plans[0].path, FullView(scene), ROBOT, scene.targets, "fast").to_dict()
    assert done["level"] == "fast" and set(done["before"]) >= {"smoothness_index", "min_clearance_mm", "length_mm"}
    assert done["checks"] == len(asked) and 0 < len(asked) <= EFFORT["fast"].checks + EFFORT["full"].checks
    assert len(done["kept"]) <= EFFORT["fast"].rounds + EFFORT["full"].rounds
    assert done["before"]["smoothness_index"] == pytest.approx(judge(scene, ROBOT, plans[0].path).smoothness_index)
    planned = get_planner("sp-rrt").plan(Problem(scene, ROBOT, 60.0), seed=1)  # no deadline cuts its optimiser
    assert planned.details["optimize"]["checks"] == done["checks"]


def test_straight_path_stays_straight():
    path = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 400.0], [0.0, 0.0, 1000.0]])
    for order, fits in penalised_fits(path, path[-1:], (10.0, 500.0), (2, 3, 4), feed=(0.0, 0.0, 1.0)).items():
        for fit in fits:
            assert np.abs(fit[:, :2]).max() < 1e-9
            assert np.array_equal(fit[0], path[0]) and np.allclose(fit[-1], path[-1], atol=1e-9)
    for fit in gaussian_fits(path, path[-1:], (50.0,)):
        assert np.abs(fit[:, :2]).max() < 1e-9


def test_second_differences_at_large_scale_give_the_chord():
    """A zig-zag with its start and one target held: the second-difference fit tends to the straight chord."""
    t = np.linspace(0.0, 1.0, 41)
    zig = np.stack([30.0 * np.sin(9 * np.pi * t), np.zeros_like(t), 800.0 * t], axis=1)
    target = zig[-1:]
    fit = penalised_fits(zig, target, (1e5,), (2,))[2][0]
    assert np.array_equal(fit[0], zig[0]) and np.array_equal(fit[-1], target[0])
    assert np.abs(fit[:, 0]).max() < 1e-3


@settings(max_examples=30, deadline=None)
@given(n=st.integers(8, 60), order=st.sampled_from((2, 3, 4)), lam=st.floats(1e-3, 1e12), seed=st.integers(0, 99))
def test_banded_solve_matches_dense(n, order, lam, seed):
    """The compiled banded Cholesky solve is backward stable: its residual is round-off of the system's size
    (``I + lam A`` is ill-conditioned at large ``lam``, so two solvers may differ more than their residuals do),
    and it agrees with a dense solve where the system is well conditioned."""
    rng = np.random.default_rng(seed)
    keep = np.sort(rng.choice(n + 4, n, replace=False))
    a = _difference_normal(n + 4, order)[np.ix_(keep, keep)]
    rhs = rng.normal(size=(n, 3))
    system = np.eye(n) + lam * a
    got = _solve_penalised(_banded(a, order), lam, rhs)
    scale = np.linalg.norm(system, 2) * np.linalg.norm(got) + np.linalg.norm(rhs)
    assert np.linalg.norm(system @ got - rhs) <= 1e-12 * scale
    if np.linalg.cond(system) < 1e6:
        expected = np.linalg.solve(system, rhs)
        assert np.allclose(got, expected, rtol=1e-8, atol=1e-8 * np.abs(expected).max())


def test_levels_and_bad_input(capsys):
    assert LEVELS == ("none", "fast", "full")
    with pytest.raises(ValueError, match="^optimize: must be one of none, fast, full"):
        get_planner("as-rrt", optimize="quick")
    assert main(["plan", "--scene", "oil-tank", "--seed", "1", "--planner", "as-rrt", "--optimize", "quick"]) == 2
    assert main(["bench", "run", "--scenes", "oil-tank", "--planners", "as-rrt", "--seeds", "0",
                 "--option", "optimize=quick", "--out", "unused"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == "snakeplan: error: --option optimize: must be one of none, fast, full, got 'quick'"


def test_plan_command_optimises_by_level(capsys):
    """`plan --optimize none` plans the raw path; the default for as-rrt is fast, said on the console and in the
    document, and the judge's smoothness is at least the raw one's."""
    out = {}
    for level in ("none", None):
        argv = ["plan", "--scene", "oil-tank", "--seed", "4", "--planner", "as-rrt", "--json"]
        assert main(argv + (["--optimize", level] if level else [])) == 0
        doc = json.loads(capsys.readouterr().out)
        out[level] = doc
    assert "optimize" not in out["none"]["details"]
    done = out[None]["details"]["optimize"]
    assert done["level"] == "fast"
    assert done["before"]["smoothness_index"] == pytest.approx(out["none"]["metrics"]["smoothness_index"])
    assert out[None]["metrics"]["smoothness_index"] >= out["none"]["metrics"]["smoothness_index"]
