"""Roll-out outcomes are a str enum whose values are the plain strings, so JSON and printed output hold them."""

import json
import math

from snakeplan.planners.sac import Outcome, load_policy, policy_path, rollout
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene


def test_outcomes_print_and_serialise_as_their_plain_values():
    assert [o.value for o in Outcome] == ["reached", "out_of_bounds", "insertion", "steps", "timeout"]
    for o in Outcome:
        assert o == o.value and str(o) == f"{o}" == o.value and json.dumps(o) == json.dumps(o.value)
        assert Outcome(o.value) is o


def test_a_rollout_ends_in_an_outcome():
    policy = load_policy(policy_path("fuel-tank", "sac-her"))
    scene, robot = make_scene("fuel-tank", 0), get_robot("sjtu-snake-iii")
    _, outcome = rollout(policy, scene, robot)
    assert isinstance(outcome, Outcome) and outcome is not Outcome.TIMEOUT
    _, late = rollout(policy, scene, robot, deadline=-math.inf)
    assert late is Outcome.TIMEOUT and json.dumps({"outcome": late}) == '{"outcome": "timeout"}'
