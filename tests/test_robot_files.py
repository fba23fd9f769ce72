"""Robots from files: URDF round trips of every preset, a hand-written URDF understood as drawn, bad URDFs refused
in one line naming the element, and every robot file usable from the command line."""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from snakeplan.cli import main
from snakeplan.geometry.transforms import pose, rot_x, rot_y
from snakeplan.robots import DEFAULT_LIMITS, Chain, from_urdf, get_robot, load_robot, robot_names, to_urdf

ARM6 = Path(__file__).parent / "data" / "arm6.urdf"


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


# ---------------------------------------------------------------- round trips
@pytest.mark.parametrize("name", robot_names())
@pytest.mark.parametrize("base", [np.eye(4), pose(rot_x(0.4) @ rot_y(-1.1), [100.0, -20.0, 35.0])])
def test_urdf_round_trip_of_every_preset_keeps_fk_to_1e_9_mm(name, base):
    chain = get_robot(name).with_base(base)
    back = from_urdf(to_urdf(chain))
    assert back.joint_names == chain.joint_names
    assert back.feed_range == chain.feed_range
    np.testing.assert_allclose(back.radii, chain.radii, rtol=0, atol=1e-12)
    np.testing.assert_allclose(back.max_bends, chain.max_bends, rtol=0, atol=1e-15)
    assert back.limits.feed_speed_mm_s == pytest.approx(chain.limits.feed_speed_mm_s, rel=1e-15)
    assert back.limits.joint_rate_rad_s == pytest.approx(chain.limits.joint_rate_rad_s, rel=1e-15)
    np.testing.assert_allclose(back.masses, chain.masses, rtol=1e-15)  # the inertials come back
    np.testing.assert_allclose(back.coms, chain.coms, rtol=0, atol=1e-9)
    q = chain.clip_to_limits(chain.random_q(7, 200))
    assert np.max(np.abs(back.joint_positions(q) - chain.joint_positions(q))) <= 1e-9


# ---------------------------------------------------------------- a hand-written URDF
def test_hand_written_urdf_is_understood_as_drawn():
    arm = load_robot(str(ARM6))
    assert arm.name == "arm6" and arm.n_sections == 6 and arm.has_feed
    assert arm.joint_names == ("feed",) + tuple(f"j{i}_{k}" for i in range(6) for k in ("yaw", "pitch"))
    np.testing.assert_allclose(arm.lengths, 200.0, atol=1e-12)
    np.testing.assert_allclose(arm.radii, 15.0, atol=1e-12)  # capsule in section 2, the larger cylinder in 4
    np.testing.assert_allclose(arm.max_bends, math.pi / 4, atol=1e-15)
    assert arm.feed_range == pytest.approx((0.0, 1200.0))
    assert arm.limits.feed_speed_mm_s == pytest.approx(40.0) and arm.limits.joint_rate_rad_s == pytest.approx(0.4)
    assert arm.limits.joint_acceleration_rad_s2 == DEFAULT_LIMITS.joint_acceleration_rad_s2  # URDF has none
    # Hand-computed: the base is 100 mm up the stage; feed 150 mm; the first pitch joint (about y) bends the whole
    # straight arm by theta at the first pivot, at z = 250 mm.
    theta, q = 0.3, np.zeros(arm.dof)
    q[0], q[2] = 150.0, theta
    p = arm.joint_positions(q)
    np.testing.assert_allclose(p[0], [0.0, 0.0, 250.0], atol=1e-12)
    np.testing.assert_allclose(p[-1], [1200 * math.sin(theta), 0.0, 250 + 1200 * math.cos(theta)], atol=1e-9)
    # A yaw joint (about x) turns the arm towards -y.
    q[2], q[3] = 0.0, theta
    np.testing.assert_allclose(arm.joint_positions(q)[-1],
                               [0.0, -1000 * math.sin(theta), 250 + 200 + 1000 * math.cos(theta)], atol=1e-9)


def test_hand_written_urdf_prints_what_was_understood(capsys):
    code, out, _ = run(capsys, "robot", str(ARM6), "--json")
    data = json.loads(out)
    assert code == 0 and data["schema"] == "snakeplan.robot/1" and data["name"] == "arm6"
    assert [s["radius"] for s in data["sections"]] == pytest.approx([15.0] * 6)
    assert data["feed_range"] == pytest.approx([0.0, 1200.0]) and data["cables"] is None
    assert data["kinematics"]["joint_names"][:3] == ["feed", "j0_yaw", "j0_pitch"]
    assert Chain.from_dict(data).total_length == pytest.approx(1200.0)


def test_hand_written_urdf_is_planned_from_the_command_line(capsys, tmp_path):
    out_file = tmp_path / "arm6.json"
    code, out, err = run(capsys, "plan", "--scene", "pipe", "--seed", "1", "--robot", str(ARM6), "--planner", "sscc",
                         "--json", "--trajectory", str(out_file))
    plan = json.loads(out)
    assert code == 0 and plan["robot"] == "arm6" and plan["success"]
    traj = json.loads(out_file.read_text())
    assert traj["joint_names"][:3] == ["feed", "j0_yaw", "j0_pitch"]
    assert traj["points"][-1]["tip"] == pytest.approx(plan["path"][-1], abs=1e-6)


# ---------------------------------------------------------------- other robot files
def test_dh_yaml_and_robot_json_files_load_by_suffix(tmp_path, capsys):
    hsr = get_robot("hsr-10")
    dh = tmp_path / "hsr.yaml"
    table = yaml.safe_load((Path(__file__).parents[1] / "src/snakeplan/robots/data/hsr-10.yaml").read_text())
    table["name"] = "my-hsr"
    dh.write_text(yaml.safe_dump(table))
    js = tmp_path / "sjtu.json"
    js.write_text(json.dumps(get_robot("sjtu-snake-iii").to_dict()))
    q = hsr.random_q(3)
    np.testing.assert_allclose(load_robot(str(dh)).joint_positions(q), hsr.joint_positions(q), atol=1e-9)
    sjtu = load_robot(str(js))
    assert sjtu.cables == get_robot("sjtu-snake-iii").cables and sjtu.limits == get_robot("sjtu-snake-iii").limits
    code, out, _ = run(capsys, "robot", str(dh), "--json")
    assert code == 0 and json.loads(out)["name"] == "my-hsr"


# ---------------------------------------------------------------- bad URDFs
def _edit(text: str, old: str, new: str, count: int = 1) -> str:
    assert old in text
    return text.replace(old, new, count)


ORIGINAL = ARM6.read_text()
SIDE_ARM = """  <link name="side"/>
  <joint name="side_joint" type="revolute">
    <parent link="s2"/><child link="side"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>"""

BAD = [
    ("branching tree", lambda t: _edit(t, "</robot>", SIDE_ARM), "link 's2' branches into 2 jointed chains"),
    ("missing limit", lambda t: re.sub(r'(<joint name="j3_pitch".*?)<limit [^>]*/>', r"\1", t, flags=re.S),
     "joint 'j3_pitch': <limit> missing"),
    ("limit without upper", lambda t: _edit(t, 'upper="0.7853981633974483" effort="10" velocity="0.4"/>\n  </joint>\n'
                                               '  <link name="s2">', 'effort="10" velocity="0.4"/>\n  </joint>\n'
                                               '  <link name="s2">'),
     "joint 'j2_yaw': <limit> needs lower and upper"),
    ("continuous joint", lambda t: _edit(t, '<joint name="j1_yaw" type="revolute">', '<joint name="j1_yaw" '
                                                                                    'type="continuous">'),
     "joint 'j1_yaw': a continuous joint has no limits"),
    ("two roots", lambda t: _edit(t, "</robot>", '  <link name="stray"/>\n</robot>'), "2 root links"),
    ("two parents", lambda t: _edit(t, "</robot>", '  <joint name="loop" type="fixed"><parent link="tip"/>'
                                                   '<child link="s3_cross"/></joint>\n</robot>'),
     "link 's3_cross' has two parent joints"),
    ("unknown link", lambda t: _edit(t, '<child link="tip"/>', '<child link="top"/>'),
     "joint 'tip_joint': child link 'top' is not defined"),
    ("lone revolute", lambda t: re.sub(r'  <link name="tip"/>.*</robot>',
                                       '  <link name="s6_cross"/>\n  <joint name="j6_yaw" type="revolute">\n'
                                       '    <origin xyz="0 0 0.2"/><parent link="s5"/><child link="s6_cross"/>\n'
                                       '    <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>\n'
                                       '  </joint>\n</robot>', t, flags=re.S),
     "joint 'j6_yaw': revolute joints come in pairs"),
    ("pivots apart", lambda t: re.sub(r'(<joint name="j4_pitch" type="revolute">)', r'\1<origin xyz="0 0 0.01"/>', t),
     "joint 'j4_pitch': the two revolute joints of a universal joint must share a pivot"),
    ("feed not first", lambda t: _edit(t, '<joint name="j5_yaw" type="revolute">', '<joint name="j5_yaw" '
                                                                                   'type="prismatic">'),
     "joint 'j5_yaw': a prismatic joint must be the first joint"),
    ("no radius", lambda t: _edit(t, '<collision><origin xyz="0 0 0.1"/><geometry><cylinder radius="0.015" '
                                     'length="0.2"/></geometry></collision>\n  </link>\n  <joint name="j1_pitch"',
                                  '</link>\n  <joint name="j1_pitch"'),
     "section 1 has no cylinder or capsule collision element"),
    ("bent at zero", lambda t: re.sub(r'(<joint name="j3_yaw" type="revolute">\s*<origin xyz="0 0 0.2")',
                                      r'\1 rpy="0.2 0 0"', t),
     "at zero joint values the arm must lie straight"),
    ("not XML", lambda t: t[:200], "not well-formed XML"),
]


@pytest.mark.parametrize("what, edit, fragment", BAD, ids=[b[0] for b in BAD])
def test_bad_urdf_exits_2_with_one_line_naming_the_element(capsys, tmp_path, what, edit, fragment):
    bad = tmp_path / "bad.urdf"
    bad.write_text(edit(ORIGINAL))
    code, out, err = run(capsys, "robot", str(bad), "--json")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"snakeplan: error: {bad}: urdf: ") and fragment in err, err
    code, _, err = run(capsys, "plan", "--scene", "pipe", "--robot", str(bad))
    assert code == 2 and err.startswith("snakeplan: error: --robot: urdf: ") and fragment in err


def test_unknown_robot_names_the_presets_and_the_file_kinds(capsys):
    code, _, err = run(capsys, "plan", "--robot", "nosuch")
    assert code == 2 and "unknown robot 'nosuch'" in err and "sjtu-snake-iii" in err and ".urdf" in err
    code, _, err = run(capsys, "plan", "--robot", "missing.urdf")
    assert code == 2 and "no such file missing.urdf" in err


def _own_arm() -> dict:
    """A newcomer's 16-section arm as robot/1 JSON (120 mm sections, radius 20 mm, 40 deg bends, a feed)."""
    return {"schema": "snakeplan.robot/1", "name": "my-arm", "feed_range": [0.0, 1500.0],
            "sections": [{"length": 120.0, "radius": 20.0, "max_bend": math.radians(40.0)}] * 16}


@pytest.mark.parametrize("mistake, expect", [
    (lambda d: d.update(feed=d.pop("feed_range")), "feed: unknown field (known: schema, name, sections"),
    (lambda d: d["sections"].__setitem__(3, {"length": 120.0, "radius": 20.0, "maxbend": 0.7}),
     "section 3: maxbend: unknown field (known: length, radius, max_bend, mass_kg, com_mm); did you mean max_bend?"),
    (lambda d: d["sections"].__setitem__(0, {"length": 120.0, "radius": 20.0, "max_bend": 40.0}),
     "section 0: max_bend must be in (0, pi) rad, got 40.0 (it looks like degrees: 40 deg is 0.6981 rad)"),
    (lambda d: d["sections"].__setitem__(0, {"length": 120.0, "radius": 20.0, "max_bend": 0.0122}),
     "section 0: max_bend 0.0122 rad (0.699 deg) is implausibly small"),
])
def test_robot_files_refuse_a_newcomers_typos_in_one_line(capsys, tmp_path, mistake, expect):
    """As a newcomer wrote them: 'feed' for feed_range (an arm with no feed, before), a misspelt section key (ignored,
    before), a bend limit in degrees, one a thousand times too small: one line naming the field, exit 2."""
    arm = _own_arm()
    arm["sections"] = [dict(s) for s in arm["sections"]]
    mistake(arm)
    f = tmp_path / "my-arm.json"
    f.write_text(json.dumps(arm))
    code, out, err = run(capsys, "plan", "--seed", "1", "--robot", str(f), "--planner", "as-rrt")
    assert (code, out) == (2, "") and err.count("\n") == 1 and err.startswith(f"snakeplan: error: --robot: {expect}")
    if "feed:" in expect:
        assert "did you mean feed_range?" in err


def test_a_dh_table_in_degrees_with_a_radian_bend_limit_and_a_yaml_typo_are_one_line_each(capsys, tmp_path):
    """hsr-10's table says its angles are degrees; a bend limit written in radians there (0.698) is a 0.7 deg arm:
    refused with the unit named. A missing bracket is named by line and column."""
    import snakeplan.robots

    text = (Path(snakeplan.robots.__file__).parent / "data" / "hsr-10.yaml").read_text()
    f = tmp_path / "arm.yaml"
    f.write_text(text.replace("max_bend: 30", "max_bend: 0.698"))
    code, out, err = run(capsys, "robot", str(f))
    assert code == 2 and err.count("\n") == 1 and err.startswith(f"snakeplan: error: {f}: section 0: ")  # not "NAME:"
    assert "max_bend 0.698 is 0.698 deg, implausibly small" in err and "angle unit is deg" in err
    f.write_text(text.replace("{alpha: 0, a: 0, theta: 90, d: 0, joint: fixed}",
                              "{alpha: 0, a: 0, theta: 90, d: 0, joint: fixed", 1))
    code, out, err = run(capsys, "robot", str(f))
    assert code == 2 and err.count("\n") == 1 and re.search(r"not valid YAML at line \d+ column \d+: ", err)
