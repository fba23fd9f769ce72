"""A user's own arm: scenes sized to it, its turning radius, training a policy for it from the command line, and a
policy refused for any other arm with both named."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from snakeplan.cli import main
from snakeplan.planners.sac.crawler import TURN_BEND_FRACTION, TURN_RADIUS_MM, turn_radius_for
from snakeplan.planners.sac.policy import (
    NumpyPolicy,
    arm_record,
    check_policy_fits,
    fits_arm,
    generalist_path,
    load_policy,
)
from snakeplan.robots import get_robot, load_robot
from snakeplan.scenes import make_scene
from snakeplan.scenes.sizing import arm_sizing, sized_scene

ARMS = Path(__file__).resolve().parents[1] / "docs" / "arms"


def arm(name: str):
    return load_robot(str(ARMS / f"{name}.json"))


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_the_held_out_arms_are_what_the_issue_names():
    for name, (n, length, radius, bend_deg) in {"arm-16x120": (16, 120, 20, 40), "arm-24x90": (24, 90, 15, 30),
                                                "arm-10x220": (10, 220, 35, 55)}.items():
        a = arm(name)
        assert a.n_sections == n and np.allclose(a.lengths, length) and np.allclose(a.radii, radius)
        assert np.allclose(np.degrees(a.max_bends), bend_deg, atol=1e-4)


@pytest.mark.parametrize("family", ["fuel-tank", "oil-tank", "confined"])
def test_the_familys_own_arm_gets_its_scenes_unchanged(family):
    own = get_robot("sjtu-snake-iii")
    assert arm_sizing(family, own) == ()
    assert sized_scene(family, 4).to_dict() == make_scene(family, 4).to_dict()


@pytest.mark.parametrize("name", ["arm-16x120", "arm-10x220"])
def test_a_scene_sized_to_an_arm_keeps_its_targets_in_that_arms_reach_and_clear_of_its_body(name):
    """The generator's own reach rule, with the arm's length and its radius in the inflation: every target lies
    in free space at least the sized clearance from every obstacle, and the geodesic tour the scene records is
    within 0.85 of the arm's length (the families' reach fraction)."""
    a = arm(name)
    params = dict(arm_sizing("confined", a))
    assert params["arm_length_mm"] == pytest.approx(float(np.sum(a.lengths)))
    assert params["inflate_mm"] == pytest.approx(30.0 + float(np.max(a.radii)) - 27.5)
    for seed in range(3):
        scene = sized_scene("confined", seed, tuple(params.items()))
        assert scene.metadata["sizing"] == params
        clearance = scene.signed_distance(scene.targets)
        assert np.all(clearance >= params["target_clearance_mm"] - 1e-6)
        assert scene.metadata["tour_mm"] <= 0.85 * params["arm_length_mm"] + 1e-6


def test_a_family_without_arm_parameters_is_the_same_for_every_arm():
    assert arm_sizing("vessel", arm("arm-16x120")) == () and arm_sizing("fuel-tank-scan", arm("arm-10x220")) == ()


@pytest.mark.parametrize("name", ["arm-16x120", "arm-24x90", "arm-10x220", "sjtu-snake-iii"])
def test_an_arms_turning_radius_bends_its_longest_section_by_the_fraction_of_its_limit(name):
    """On the radius, a chord of the section's length subtends 2 asin(L / 2R): that is the fraction of the
    section's bend limit (to the 0.1 mm rounding); the SJTU-Snake III's is its default's 240 mm within 2 mm."""
    a = get_robot(name) if name == "sjtu-snake-iii" else arm(name)
    radius = turn_radius_for(a)
    bends = 2.0 * np.arcsin(a.lengths / (2.0 * radius))
    assert np.all(bends <= TURN_BEND_FRACTION * a.max_bends + 1e-3)
    assert np.max(bends / (TURN_BEND_FRACTION * a.max_bends)) == pytest.approx(1.0, abs=1e-3)
    if name == "sjtu-snake-iii":
        assert abs(radius - TURN_RADIUS_MM) < 2.0


def test_a_policy_recording_its_arm_fits_that_arm_alone():
    shipped = load_policy(generalist_path())
    a, b = arm("arm-16x120"), arm("arm-24x90")

    def recording(record):
        return NumpyPolicy(shipped.layers, shipped.mu, {**shipped.meta, "arm": record})

    policy = recording(arm_record(a))
    scene = make_scene("confined", 0)
    check_policy_fits(policy, scene, a)
    with pytest.raises(ValueError) as err:
        check_policy_fits(policy, scene, b)
    assert str(err.value).startswith("policy: trained for arm-16x120 (16 sections, 1920 mm, radius 20 mm, bend "
                                     "limit 40 deg), planning with arm-24x90 (24 sections, 2160 mm, radius 15 mm, "
                                     "bend limit 30 deg)")
    thinner = a.to_dict()
    thinner["sections"] = [{**s, "radius": 19.0} for s in thinner["sections"]]
    assert not fits_arm(arm_record(a), load_robot(thinner))
    for record, field in (({"name": "x", "lengths": "long", "radii": [1], "max_bends": [1]}, "meta.arm.lengths"),
                          ({**arm_record(a), "radii": [20.0]}, "meta.arm: lengths, radii and max_bends"),
                          ({**arm_record(a), "max_bends": [-1.0] * 16}, "meta.arm.max_bends[0]")):
        with pytest.raises(ValueError, match="^" + re.escape(f"policy: {field}")):
            recording(record)


def test_train_rl_for_an_arm_file_then_plan_and_check_with_it_alone(capsys, tmp_path):
    """``train rl --robot FILE`` trains in scenes sized to that arm on its own turning radius and records both in
    the policy's command; ``plan`` with the policy plans that arm in the sized scene, which ``check`` judges
    again from the plan file; another arm (a preset, or a file) is refused in one line naming both."""
    out, arm_file = tmp_path / "run", str(ARMS / "arm-16x120.json")
    code, _, err = run(capsys, "train", "rl", "confined", "sac", "--steps", "120", "--out", str(out), "--robot",
                       str(tmp_path / "none.json"))
    assert code == 2 and err.startswith("snakeplan: error: --robot: no such file") and not (out / "policy.npz").exists()
    code, stdout, _ = run(capsys, "train", "rl", "confined", "sac", "--steps", "120", "--out", str(out),
                          "--robot", arm_file, "--observation", "guide", "--residual", "true", "--knowledge",
                          "sensed", "--net-arch", "16", "16", "--learning-starts", "60", "--eval-every", "100",
                          "--eval-episodes", "2", "--train-scenes", "2", "--batch-size", "16")
    assert code == 0 and "policy.npz" in stdout
    meta = load_policy(str(out / "last.npz")).meta
    assert meta["robot"] == "arm-16x120" and fits_arm(meta["arm"], arm("arm-16x120"))
    assert meta["turn_radius_mm"] == pytest.approx(turn_radius_for(arm("arm-16x120")))
    assert f"--robot {arm_file}" in meta["command"]
    assert f"--turn-radius-mm {meta['turn_radius_mm']:g}" in meta["command"]
    code, stdout, err = run(capsys, "plan", "--scene", "confined", "--seed", "1", "--robot", arm_file, "--planner",
                            "sac", "--policy", str(out / "last.npz"), "--knowledge", "sensed", "--json")
    data = json.loads(stdout)
    assert data["robot"] == "arm-16x120" and len(data["path"]) > 1
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(stdout)
    code_check, checked, _ = run(capsys, "check", str(plan_file), "--json")
    assert code_check == code and json.loads(checked)["success"] == data["success"]
    for other in ("sjtu-snake-iii", str(ARMS / "arm-10x220.json")):
        code, stdout, err = run(capsys, "plan", "--scene", "confined", "--seed", "1", "--robot", other,
                                "--planner", "sac", "--policy", str(out / "last.npz"))
        assert code == 2 and stdout == "" and err.count("\n") == 1
        assert "trained for arm-16x120 (16 sections" in err and f"planning with {load_robot(other).name} (" in err
