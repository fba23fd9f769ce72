"""Trajectories: time scaling against hand-computed durations, the replay check on judged plans (FK of the written
URDF against follow-the-leader, every limit, cables back to joints), the files, and the command line."""

import json
import math

import numpy as np
import pytest
import yaml

from snakeplan.cli import main
from snakeplan.episode import run_episode
from snakeplan.planners import Problem
from snakeplan.robots import Chain, get_robot
from snakeplan.scenes import make_scene
from snakeplan.trajectory import (
    SCHEMA,
    InfeasiblePlan,
    build_trajectory,
    replay,
    ros_message,
    time_scale,
    to_csv,
    to_dict,
)
from snakeplan.trajectory.replay import urdf_link_poses

SJTU = get_robot("sjtu-snake-iii")
LIMITS = SJTU.limits  # feed 50 mm/s, 100 mm/s^2; joints 0.3 rad/s, 0.6 rad/s^2
STEP = 5.0


def trapezoid(length: float, speed: float, acceleration: float) -> float:
    """Rest-to-rest time over ``length`` at most ``speed`` and ``acceleration`` (hand formula)."""
    if length >= speed**2 / acceleration:
        return length / speed + speed / acceleration
    return 2 * math.sqrt(length / acceleration)


# ---------------------------------------------------------------- time scaling, hand-computed
def test_straight_insertion_runs_at_the_feed_speed_limit():
    s = np.arange(0.0, 300.0 + STEP, STEP)
    q = np.zeros((s.size, SJTU.dof))
    q[:, 0] = s
    timing = time_scale(s, q, LIMITS)
    expected = trapezoid(300.0, 50.0, 100.0)  # 6 + 0.5 = 6.5 s
    # TOPP-RA switches acceleration only at grid points: within one grid step at full speed of the optimum.
    assert abs(timing.duration_s - expected) <= STEP / 50.0
    assert timing.duration_s >= expected - 1e-9
    cruise = (s >= 12.5 + STEP) & (s <= 287.5 - STEP)  # v^2 / 2a = 12.5 mm to reach full speed
    np.testing.assert_allclose(timing.velocities[cruise, 0], 50.0, rtol=1e-6)
    assert np.all(np.abs(timing.velocities[:, 0]) <= 50.0) and timing.velocities[0, 0] == 0.0
    assert np.all(np.abs(timing.accelerations[:, 0]) <= 100.0)


def test_a_bend_is_slowed_by_the_joint_rate_limit():
    # Feed 100 mm while one joint turns 0.8 rad at a constant 0.008 rad per mm: the joint allows at most
    # 0.3 / 0.008 = 37.5 mm/s of insertion (below the feed's 50) and 0.6 / 0.008 = 75 mm/s^2 (below 100).
    s = np.arange(0.0, 100.0 + STEP, STEP)
    q = np.zeros((s.size, SJTU.dof))
    q[:, 0] = s
    q[:, 3] = 0.008 * s
    timing = time_scale(s, q, LIMITS)
    expected = trapezoid(100.0, 37.5, 75.0)  # 2.667 + 0.5 = 3.167 s
    assert abs(timing.duration_s - expected) <= STEP / 37.5
    assert timing.duration_s > trapezoid(100.0, 50.0, 100.0) + 0.5
    assert np.max(np.abs(timing.velocities[:, 3])) == pytest.approx(0.3, rel=1e-6)  # the rate limit binds
    assert np.max(np.abs(timing.velocities[:, 0])) == pytest.approx(37.5, rel=1e-6)


def test_straight_plan_becomes_a_constant_speed_insertion():
    scene = make_scene("fuel-tank", 1)
    e, d = scene.entrance.position, scene.entrance.direction
    path = e + np.linspace(0.0, 150.0, 7)[:, None] * d
    traj = build_trajectory(scene, SJTU, path)
    assert traj.timing.duration_s == pytest.approx(trapezoid(150.0, 50.0, 100.0), abs=STEP / 50.0)
    np.testing.assert_allclose(traj.positions[:, 1:], 0.0, atol=1e-12)
    np.testing.assert_allclose(traj.positions[:, 0], traj.depths, atol=1e-9)  # feed = insertion depth
    np.testing.assert_allclose(traj.tip_poses[:, :3, 3], e + traj.depths[:, None] * d, atol=1e-9)


# ---------------------------------------------------------------- replay of judged plans
PLANNERS = {"fuel-tank": ("sac-her", "sjtu-snake-iii"), "oil-tank": ("sac-per", "sjtu-snake-iii"),
            "pipe": ("sscc", "sscc-24")}


def judged_plans(count: int, skipped: list | None = None):
    """The first ``count`` plans the judge finds feasible, over fuel-tank, oil-tank and pipe in turn by seed (the
    others' scene and seed go to ``skipped``)."""
    seed, found = 0, 0
    while found < count:
        for scene_name, (planner, robot) in PLANNERS.items():
            scene = make_scene(scene_name, seed)
            episode = run_episode(Problem(scene, get_robot(robot), time_limit_s=10.0), planner)
            if episode.report is None or episode.report.first_failure_depth_mm is not None:
                if skipped is not None:
                    skipped.append((scene_name, seed))
            else:
                found += 1
                yield episode
                if found == count:
                    return
        seed += 1


def check_replay(episode) -> tuple:
    scene, robot, report = episode.problem.scene, episode.problem.robot, episode.report
    traj = build_trajectory(scene, robot, episode.plan.path, {"scene": {"name": scene.name, "seed": scene.seed}},
                            report)
    doc = json.loads(json.dumps(to_dict(traj), allow_nan=False))
    result = replay(doc)
    assert result.points == report.crawl_steps  # every insertion step the judge took
    assert result.body_error_mm <= 1e-6
    assert result.limit_excess == 0.0, result.worst_limit
    assert result.times_increase and result.starts_and_ends_at_rest
    if robot.cables is not None:
        assert result.cable_angle_error_rad <= 1e-6 and result.cable_length_error_mm <= 1e-6
    # The last point's body is the judge's last body (the URDF's links, placed by base_pose).
    last = np.array(doc["points"][-1]["positions"])[None]
    links = np.array(doc["base_pose"]) @ urdf_link_poses(doc["urdf"], last, doc["body_links"])[0]
    np.testing.assert_allclose(links[:, :3, 3], report.body_mm, atol=1e-6)
    return result, traj


def test_replay_of_judged_plans_over_three_scene_families():
    results = [check_replay(episode) for episode in judged_plans(10)]
    assert {traj.provenance["scene"]["name"] for _, traj in results} == set(PLANNERS)


@pytest.mark.slow
@pytest.mark.skipif("'slow' not in config.getoption('markexpr')", reason="long: run with -m slow")
def test_replay_of_100_judged_plans():
    worst = {"body_mm": 0.0, "cable_rad": 0.0, "cable_mm": 0.0}
    scenes, skipped = {}, []
    for episode in judged_plans(100, skipped):
        result, traj = check_replay(episode)
        scenes[traj.provenance["scene"]["name"]] = scenes.get(traj.provenance["scene"]["name"], 0) + 1
        worst["body_mm"] = max(worst["body_mm"], result.body_error_mm)
        if result.cable_angle_error_rad is not None:
            worst["cable_rad"] = max(worst["cable_rad"], result.cable_angle_error_rad)
            worst["cable_mm"] = max(worst["cable_mm"], result.cable_length_error_mm)
    print(f"replayed {sum(scenes.values())} judged plans {scenes}; infeasible, skipped: {skipped}; worst {worst}")
    assert sum(scenes.values()) == 100


def test_an_infeasible_plan_or_a_short_feed_gives_no_trajectory():
    scene = make_scene("fuel-tank", 1)
    e = scene.entrance.position
    with pytest.raises(InfeasiblePlan, match=r"plan: the judge rejects it \(collision"):
        build_trajectory(scene, SJTU, [e, e + [0.0, 0.0, -400.0]])
    # A 1200 mm arm on a 400 mm feed stroke, 600 mm straight into the pipe (feasible for the judge).
    sscc = get_robot("sscc-24")
    short = Chain(sscc.sections, name="short-feed", feed_range=(0.0, 400.0))
    with pytest.raises(InfeasiblePlan, match="needs 600 mm of feed, the feed stage of short-feed strokes 400 mm"):
        build_trajectory(make_scene("pipe", 0), short, [[0.0, 0.0, 0.0], [600.0, 0.0, 0.0]])


# ---------------------------------------------------------------- the files
@pytest.fixture(scope="module")
def oil_tank_trajectory():
    scene = make_scene("oil-tank", 1)
    episode = run_episode(Problem(scene, SJTU, time_limit_s=10.0), "sac-per")
    return build_trajectory(scene, SJTU, episode.plan.path, {"planner": "sac-per"}, episode.report)


def test_trajectory_document_is_self_contained(oil_tank_trajectory):
    traj = oil_tank_trajectory
    doc = to_dict(traj)
    assert doc["schema"] == SCHEMA and doc["units"] == {"length": "mm", "angle": "rad", "time": "s"}
    assert doc["urdf"].lstrip().startswith("<?xml") and doc["tip_link"] == "s11_end"
    assert doc["joint_names"] == list(SJTU.joint_names) and len(doc["points"]) == len(traj.t)
    assert doc["limits"]["joint_rate_rad_s"] == 0.3 and doc["time_scaling"]["method"] == "TOPP-RA"
    point = doc["points"][100]
    assert point["deviation_percent"] == pytest.approx(100 * point["deviation_mm"] / 2130.0)
    assert len(point["cable_lengths"]) == 36 and len(doc["cables"]["names"]) == 36
    assert max(p["deviation_mm"] for p in doc["points"]) == pytest.approx(traj.report.max_deviation_mm, abs=1e-9)
    assert doc["provenance"]["planner"] == "sac-per" and doc["provenance"]["path"] == traj.path.tolist()


def test_csv_has_one_row_per_point_with_units_in_the_header(oil_tank_trajectory):
    traj = oil_tank_trajectory
    lines = to_csv(traj).splitlines()
    header = lines[0].split(",")
    assert header[:4] == ["t_s", "depth_mm", "feed_mm", "s0_a_rad"] and "s11_c2_tension_n" == header[-1]
    assert header.index("s11_c2_mm") == header.index("s0_c0_tension_n") - 1
    assert len(lines) == len(traj.t) + 1
    row = dict(zip(header, map(float, lines[50].split(","))))
    assert row["t_s"] == traj.t[49] and row["s3_b_vel_rad_s"] == traj.velocities[49, 8]
    assert row["s5_c1_tension_n"] == traj.statics.tensions_n[49, 16]


def test_ros_message_is_a_joint_trajectory_in_si_units(oil_tank_trajectory):
    traj = oil_tank_trajectory
    msg = ros_message(traj)
    assert set(msg) == {"header", "joint_names", "points"} and msg["header"]["frame_id"] == "world"
    assert set(msg["points"][0]) == {"positions", "velocities", "accelerations", "effort", "time_from_start"}
    k = 120
    point = msg["points"][k]
    assert point["positions"][0] == pytest.approx(traj.positions[k, 0] / 1000)  # feed in m
    assert point["velocities"][1:] == pytest.approx(traj.velocities[k, 1:].tolist())  # angles in rad/s
    stamp = point["time_from_start"]
    assert stamp["sec"] + stamp["nanosec"] * 1e-9 == pytest.approx(traj.t[k], abs=1e-9)
    assert 0 <= stamp["nanosec"] < 1_000_000_000


# ---------------------------------------------------------------- the command line
def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_plan_fuel_tank_seed_3_writes_a_trajectory(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, "plan", "--scene", "fuel-tank", "--seed", "3", "--trajectory", "t.json")
    assert code == 0 and "wrote t.json (trajectory:" in err
    doc = json.loads((tmp_path / "t.json").read_text())
    assert doc["schema"] == SCHEMA and doc["provenance"]["scene"] == {"name": "fuel-tank", "seed": 3}
    assert replay(doc).body_error_mm <= 1e-6


def test_trajectory_command_from_a_plan_file_in_every_format(capsys, tmp_path):
    plan_file = tmp_path / "plan.json"
    code, out, _ = run(capsys, "plan", "--scene", "oil-tank", "--seed", "1", "--json")
    plan_file.write_text(out)
    outs = [tmp_path / n for n in ("t.json", "t.csv", "t.yaml", "t.ros.json")]
    code, _, err = run(capsys, "trajectory", str(plan_file), *[a for o in outs for a in ("-o", str(o))])
    assert code == 0 and err.count("wrote") == 4
    doc = json.loads(outs[0].read_text())
    assert doc["provenance"]["planner"] == json.loads(out)["planner"]
    ros_yaml, ros_json = yaml.safe_load(outs[2].read_text()), json.loads(outs[3].read_text())
    assert ros_yaml == ros_json and ros_yaml["joint_names"] == doc["joint_names"]
    assert len(outs[1].read_text().splitlines()) == len(doc["points"]) + 1


def test_trajectory_command_errors(capsys, tmp_path):
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(json.dumps({"scene": {"name": "oil-tank", "seed": 1}, "path": [[0, 450, 450],
                                                                                        [0, 450, 50]]}))
    code, _, err = run(capsys, "trajectory", str(plan_file), "-o", str(tmp_path / "t.json"))
    assert code == 1 and err.startswith("snakeplan: no trajectory: plan: the judge rejects it")
    code, _, err = run(capsys, "trajectory", str(plan_file), "-o", str(tmp_path / "t.txt"))
    assert code == 2 and err.count("\n") == 1 and "-o: " in err
    plan_file.write_text(json.dumps({"path": [[0, 450, 450], [10, 450, 450]]}))
    code, _, err = run(capsys, "trajectory", str(plan_file), "-o", str(tmp_path / "t.json"))
    assert code == 2 and "give --scene and --seed" in err
    code, _, err = run(capsys, "plan", "--trajectory", str(tmp_path / "no" / "t.json"))
    assert code == 2 and "--trajectory: folder" in err


def test_the_sscc_agent_trained_by_the_package_plans_from_the_command_line(capsys):
    from snakeplan.planners.sscc.agent import shipped_agent_path

    agent16, agent24 = str(shipped_agent_path("sscc-16")), str(shipped_agent_path("sscc-24"))
    code, out, _ = run(capsys, "plan", "--scene", "pipe", "--planner", "sscc", "--policy", agent24, "--json")
    data = json.loads(out)
    assert code == 0 and data["details"]["search"] == "agent"
    code, out, err = run(capsys, "plan", "--scene", "pipe", "--planner", "sscc", "--policy", agent16)
    assert code == 2 and out == "" and err.count("\n") == 1 and "sscc-24" in err  # an agent for another arm
    code, _, err = run(capsys, "plan", "--scene", "pipe", "--planner", "rrt-star", "--policy", agent24)
    assert code == 2 and "--policy: planner rrt-star rolls out no trained policy" in err
