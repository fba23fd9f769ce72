"""The planner contract: `Status`, the status/path rule of `Plan`, `Problem` validation, and the conformance suite
`check_planner` run on every registered planner and on toy planners that each break one rule."""

import json
import math
import time

import numpy as np
import pytest

from snakeplan.planners import (
    ConformanceError,
    Plan,
    Planner,
    Problem,
    Status,
    check_planner,
    get_planner,
    planner_names,
)
from snakeplan.planners.conformance import TINY_TIME_LIMIT_S, deadline_slack_s
from snakeplan.planners.sac import policy_path
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene

ROBOT = get_robot("sjtu-snake-iii")
PATH = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 100.0]])

#: Where each built-in planner can plan, when not the checker's default tanks: SSCC in pipes with its own arm, the
#: learned planners where their policy ships (plain `sac` ships none, so it is given the fuel-tank policy).
SUPPORTED = {"sscc": {"scenes": ("pipe",), "robot": "sscc-24"}, "sac-her": {"scenes": ("fuel-tank",)},
             "sac-per": {"scenes": ("oil-tank",)}, "sac": {"scenes": ("fuel-tank",)}}
OPTIONS = {"sac": {"policy": policy_path("fuel-tank", "sac-her")}}


# --- Status and Plan -------------------------------------------------------------------------------------------
def test_status_keeps_its_plain_string_values():
    assert [s.value for s in Status] == ["found", "approximate", "timeout", "no_progress", "invalid_start",
                                         "invalid_target"]
    assert Status.FOUND == "found" and f"{Status.APPROXIMATE}" == "approximate"
    assert json.loads(json.dumps({"status": Status.TIMEOUT})) == {"status": "timeout"}


def test_failed_as_written_before_reads_as_no_progress():
    """Plans and rows written before the causes were told apart said "failed"; they read back as no_progress,
    and a plugin's Status.FAILED is that member."""
    assert Status("failed") is Status.NO_PROGRESS is Status.FAILED
    plan = Plan("old", "approximate", PATH, 0.1, {"stopped": "failed"}, why="from an old file")
    assert plan.details["stopped"] is Status.NO_PROGRESS


def test_plan_takes_a_status_string_and_keeps_the_path_as_floats():
    plan = Plan("toy", "found", [[0, 0, 0], [0, 0, 1]], 0.1)
    assert plan.status is Status.FOUND and plan.path.dtype == np.float64


@pytest.mark.parametrize(("status", "path", "details", "field"), [
    ("found", None, {}, "path"),
    ("approximate", None, {"stopped": "no_progress"}, "path"),
    ("timeout", PATH, {}, "path"),
    ("no_progress", PATH, {}, "path"),
    ("invalid_start", PATH, {}, "path"),
    ("approximate", PATH, {}, "details"),
    ("approximate", PATH, {"stopped": "found"}, "details"),
    ("found", PATH[:1], {}, "path"),
    ("found", [[0.0, 0.0, math.nan], [0.0, 0.0, 1.0]], {}, "path"),
    ("done", PATH, {}, "status"),
])
def test_plan_rejects_a_status_that_disagrees_with_its_path(status, path, details, field):
    with pytest.raises(ValueError, match=rf"^{field}\b"):
        Plan("toy", status, path, 0.1, details, why="a reason")


@pytest.mark.parametrize(("status", "path", "details", "why"), [
    ("timeout", None, {}, ""), ("no_progress", None, {}, "  "), ("invalid_target", None, {}, ""),
    ("approximate", PATH, {"stopped": "timeout"}, ""), ("no_progress", None, {}, "two\nlines"),
    ("found", PATH, {}, None),
])
def test_every_plan_but_a_found_one_says_why_in_one_line(status, path, details, why):
    with pytest.raises(ValueError, match=r"^why\b"):
        Plan("toy", status, path, 0.1, details, why=why)


def test_plan_is_frozen():
    plan = Plan("toy", Status.TIMEOUT, None, 0.1, why="the time limit ran out")
    with pytest.raises(AttributeError):
        plan.status = Status.FOUND


@pytest.mark.parametrize(("field", "value"), [
    ("time_limit_s", 0.0), ("time_limit_s", -2.0), ("time_limit_s", math.nan), ("time_limit_s", math.inf),
    ("time_limit_s", True), ("knowledge", "psychic"), ("sensor_range_mm", 0.0), ("sensor_range_mm", math.nan),
    ("robot", "sjtu-snake-iii"), ("scene", "fuel-tank"),
])
def test_problem_names_the_malformed_field(field, value):
    fields = {"scene": make_scene("fuel-tank", 0), "robot": ROBOT, field: value}
    with pytest.raises(ValueError, match=rf"^{field}\b"):
        Problem(**fields)


# --- every registered planner ----------------------------------------------------------------------------------
@pytest.mark.parametrize("name", planner_names())
def test_registered_planner_conforms(name):
    report = check_planner(get_planner(name, **OPTIONS.get(name, {})), time_limit_s=3.0, **SUPPORTED.get(name, {}))
    assert report.planner == name and report.plans


# --- toy planners, one per broken rule -------------------------------------------------------------------------
class Straight(Planner):
    """Straight segments from the entrance through the targets: conforms to every rule."""

    name = "toy"

    def _solve(self, problem, rng, deadline):
        return Status.FOUND, self.path(problem, rng), {}

    def path(self, problem, rng):
        return np.vstack([problem.start, problem.goals])


class OffEntrance(Straight):
    def path(self, problem, rng):
        p = super().path(problem, rng)
        p[0, 0] += 1.0
        return p


class FoundShort(Straight):
    """Calls a path found that stops halfway to the last target."""

    def path(self, problem, rng):
        p = super().path(problem, rng)
        p[-1] = 0.5 * (p[-2] + p[-1])
        return p


class ForgedPlan(Straight):
    """Overrides `plan` and strips the path from a found plan behind Plan's back."""

    def plan(self, problem, seed=0):
        plan = super().plan(problem, seed)
        object.__setattr__(plan, "path", None)
        return plan


class Overruns(Straight):
    """Ignores its deadline: always works 0.8 s."""

    def _solve(self, problem, rng, deadline):
        time.sleep(0.8)
        return super()._solve(problem, rng, deadline)


class Unseeded(Straight):
    """Draws a detour from an unseeded generator instead of ``rng``."""

    def path(self, problem, rng):
        p = super().path(problem, rng)
        detour = 0.5 * (p[0] + p[1]) + np.random.default_rng().normal(0.0, 5.0, 3)
        return np.vstack([p[:1], detour, p[1:]])


class SkipsKnowledgeCheck(Straight):
    """Needs the whole scene but overrides `plan` without refusing a sensed problem."""

    def plan(self, problem, seed=0):
        status, path, details = self._solve(problem, np.random.default_rng(seed), math.inf)
        return Plan(self.name, status, path, 0.0, details)


class RefusesWithRuntimeError(SkipsKnowledgeCheck):
    def plan(self, problem, seed=0):
        if problem.knowledge != "full":
            raise RuntimeError("this planner needs the whole scene")
        return super().plan(problem, seed)


class RefusesWithoutField(SkipsKnowledgeCheck):
    def plan(self, problem, seed=0):
        if problem.knowledge != "full":
            raise ValueError("this planner needs the whole scene")
        return super().plan(problem, seed)


class Peeks(Straight):
    """Declares sensed support, then reads the whole scene's obstacles."""

    needs_full_scene = False

    def path(self, problem, rng):
        len(problem.scene.obstacles)
        return super().path(problem, rng)


class Crashes(Straight):
    def _solve(self, problem, rng, deadline):
        raise ZeroDivisionError("oops")


def test_a_conforming_toy_passes():
    report = check_planner(Straight(), scenes=("oil-tank",), time_limit_s=0.5)
    assert report.planner == "toy" and len(report.plans) == 2 and report.skipped == ()


@pytest.mark.parametrize(("toy", "rule"), [
    (Crashes, "runs"),
    (OffEntrance, "entrance"),
    (FoundShort, "status-path"),
    (ForgedPlan, "status-path"),
    (Overruns, "deadline"),
    (Unseeded, "determinism"),
    (Peeks, "honesty"),
    (SkipsKnowledgeCheck, "malformed"),
    (RefusesWithRuntimeError, "malformed"),
    (RefusesWithoutField, "malformed"),
])
def test_checker_catches_each_broken_rule(toy, rule):
    with pytest.raises(ConformanceError, match=rf"^\[{rule}\]") as caught:
        check_planner(toy(), scenes=("oil-tank",), time_limit_s=0.5)
    assert caught.value.rule == rule


def test_deadline_slack_is_half_a_second_or_a_fifth():
    assert deadline_slack_s(TINY_TIME_LIMIT_S) == 0.5
    assert deadline_slack_s(2.5) == 0.5
    assert deadline_slack_s(10.0) == pytest.approx(2.0)
