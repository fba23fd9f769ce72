"""snakeplan.robots against independent facts: hand-computed poses, paper 002's eqs. 1-2, finite differences."""

import json
import math
import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.geometry.transforms import pose, rot_x, rot_y, rot_z
from snakeplan.robots import Chain, Section, get_robot, load_dh, register_robot, robot_names, to_urdf
from snakeplan.robots import presets

NAMES = ["sjtu-snake-iii", "sscc-16", "sscc-24", "hsr-10"]
seeds = st.integers(0, 2**32 - 1)
angle = st.floats(-1.2, 1.2, allow_nan=False)
fast = settings(max_examples=25, deadline=None)


def bent_within_limits(chain: Chain, seed: int) -> np.ndarray:
    """A random joint vector inside the box limits and every bend cone."""
    return chain.clip_to_limits(chain.random_q(seed))


def small_chain(feed=None, base=None) -> Chain:
    return Chain([Section(100, 10, 1.0), Section(200, 10, 1.0), Section(300, 10, 1.0)], feed_range=feed, base=base)


# ---------------------------------------------------------------- forward kinematics
@pytest.mark.parametrize("name", NAMES)
def test_straight_chain_points_along_base_z(name):
    chain = get_robot(name)
    q = np.zeros(chain.dof)
    if chain.has_feed:
        q[0] = 150.0
    p = chain.joint_positions(q)
    feed = 150.0 if chain.has_feed else 0.0
    expected_z = feed + np.concatenate([[0.0], np.cumsum(chain.lengths)])
    np.testing.assert_allclose(p[:, :2], 0.0, atol=1e-9)
    np.testing.assert_allclose(p[:, 2], expected_z, atol=1e-9)
    assert p[-1, 2] == pytest.approx(feed + chain.total_length)
    np.testing.assert_allclose(chain.bend_angles(q), 0.0, atol=1e-12)
    np.testing.assert_allclose(chain.fk(q)[:, :3, :3], np.broadcast_to(np.eye(3), (chain.n_sections + 1, 3, 3)),
                               atol=1e-12)


def test_straight_chain_with_base_pose_and_feed():
    base = pose(rot_y(math.pi / 2), [10.0, 20.0, 30.0])  # base z -> world x
    chain = small_chain(feed=(0, 500), base=base)
    p = chain.joint_positions([40.0, 0, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(p, [[50, 20, 30], [150, 20, 30], [350, 20, 30], [650, 20, 30]], atol=1e-9)


def test_one_bent_joint_hand_computed():
    chain = small_chain()
    th = 0.3
    q = np.zeros(chain.dof)
    q[2] = th  # a1: Rx at the start of section 1 turns z to (0, -sin, cos)
    d = np.array([0.0, -math.sin(th), math.cos(th)])
    p = chain.joint_positions(q)
    np.testing.assert_allclose(p, [[0, 0, 0], [0, 0, 100], [0, 0, 100] + 200 * d, [0, 0, 100] + 500 * d],
                               atol=1e-9)
    np.testing.assert_allclose(chain.bend_angles(q), [0, th, 0], atol=1e-12)
    q = np.zeros(chain.dof)
    q[1] = -0.4  # b0: Ry at the base turns z to (sin b, 0, cos b)
    p = chain.joint_positions(q)
    np.testing.assert_allclose(p[1], 100 * np.array([math.sin(-0.4), 0, math.cos(-0.4)]), atol=1e-9)
    np.testing.assert_allclose(p[3], 600 * np.array([math.sin(-0.4), 0, math.cos(-0.4)]), atol=1e-9)


def test_fk_is_batched():
    chain = get_robot("sscc-16")
    q = chain.random_q(3, size=(4, 5))
    frames = chain.fk(q)
    assert frames.shape == (4, 5, 9, 4, 4)
    np.testing.assert_allclose(frames[2, 3], chain.fk(q[2, 3]))
    assert chain.joint_positions(q).shape == (4, 5, 9, 3)
    with pytest.raises(ValueError, match="shape"):
        chain.fk(np.zeros(3))


def paper_unit(length: float, delta: float, gamma: float) -> np.ndarray:
    """Paper 002 eq. 1, written out literally."""
    cd, sd, cg, sg = math.cos(delta), math.sin(delta), math.cos(gamma), math.sin(gamma)
    return np.array([[cg, -sg, 0, 0], [cd * sg, cd * cg, -sd, length], [sd * sg, sd * cg, cd, 0], [0, 0, 0, 1.0]])


@fast
@given(seeds)
def test_hsr10_matches_paper_002_eqs_1_and_2(seed):
    chain = get_robot("hsr-10")
    rng = np.random.default_rng(seed)
    feed = rng.uniform(0, 2000)
    delta, gamma = rng.uniform(-math.pi, math.pi, (2, 10))
    q = np.concatenate([[feed], np.stack([delta, gamma], -1).ravel()])
    # Eq. 2 with l_0 the feed stroke and D_i^{i+1} = eq. 1 (length of unit i, angles of joint i+1).
    lengths = [feed] + [800.0] * 10
    M = np.eye(4)
    expected_p, expected_R = [M[:3, 3]], [M[:3, :3]]
    for i in range(10):
        M = M @ paper_unit(lengths[i], delta[i], gamma[i])
        end = M @ np.array([0, 800.0, 0, 1])
        expected_p.append(end[:3])
        expected_R.append(M[:3, :3])
    expected_p[0] = np.array([0, feed, 0])
    mount = rot_x(math.pi / 2)  # the YAML mount: the paper's y axis (arm and feed) onto snakeplan's +z
    frames = chain.fk(q)
    np.testing.assert_allclose(frames[:, :3, 3], np.array(expected_p) @ mount.T, atol=1e-9)
    expected_R[0] = np.eye(3)
    np.testing.assert_allclose(frames[:, :3, :3], mount @ np.array(expected_R) @ mount.T, atol=1e-12)


# ---------------------------------------------------------------- Jacobian and null space
def angular_velocity(R_plus, R_minus, R, h):
    W = (R_plus - R_minus) / (2 * h) @ R.T
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


@fast
@given(st.sampled_from(NAMES), seeds)
def test_jacobian_matches_finite_differences(name, seed):
    chain = get_robot(name)
    q = chain.random_q(seed)
    J = chain.tip_jacobian(q, orientation=True)
    assert J.shape == (6, chain.dof)
    np.testing.assert_allclose(chain.tip_jacobian(q), J[:3])
    h = 1e-6
    R = chain.fk(q)[-1, :3, :3]
    for j in range(chain.dof):
        dq = np.zeros(chain.dof)
        dq[j] = h
        Fp, Fm = chain.fk(q + dq)[-1], chain.fk(q - dq)[-1]
        np.testing.assert_allclose(J[:3, j], (Fp[:3, 3] - Fm[:3, 3]) / (2 * h), atol=2e-4 * (1 + chain.total_length))
        np.testing.assert_allclose(J[3:, j], angular_velocity(Fp[:3, :3], Fm[:3, :3], R, h), atol=1e-6)


@fast
@given(st.sampled_from(NAMES), seeds)
def test_null_space_projector(name, seed):
    chain = get_robot(name)
    q = chain.random_q(seed)
    J = chain.tip_jacobian(q)
    P = chain.null_space_projector(q)
    scale = np.abs(J).max()
    np.testing.assert_allclose(J @ P, 0.0, atol=1e-9 * scale)
    np.testing.assert_allclose(P @ P, P, atol=1e-9)
    np.testing.assert_allclose(P, P.T, atol=1e-9)
    assert np.trace(P) == pytest.approx(chain.dof - 3)
    z = np.random.default_rng(seed).normal(size=chain.dof)
    eps = 1e-4
    tip = chain.joint_positions(q)[-1]
    moved_null = np.linalg.norm(chain.joint_positions(q + eps * P @ z)[-1] - tip)
    moved_free = np.linalg.norm(chain.joint_positions(q + eps * z)[-1] - tip)
    assert moved_null < 1e-2 * moved_free


def test_null_space_projector_is_batched():
    chain = get_robot("sscc-24")
    q = chain.random_q(0, size=3)
    P = chain.null_space_projector(q)
    assert P.shape == (3, chain.dof, chain.dof)
    np.testing.assert_allclose(P[1], chain.null_space_projector(q[1]))


# ---------------------------------------------------------------- inverse kinematics
@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("seed", range(6))
def test_ik_reaches_reachable_targets_within_limits(name, seed):
    chain = get_robot(name)
    target = chain.joint_positions(bent_within_limits(chain, seed))[-1]
    result = chain.ik(target, seed=seed)
    assert result.converged
    assert result.error_mm <= 1e-3
    assert np.linalg.norm(chain.joint_positions(result.q)[-1] - target) <= 1e-3
    lo, hi = chain.joint_limits()
    assert np.all(result.q >= lo) and np.all(result.q <= hi)
    assert chain.within_bend_limits(result.q)


@pytest.mark.parametrize("name", NAMES)
def test_clip_to_limits_enters_the_bend_cones(name):
    chain = get_robot(name)
    lo, hi = chain.joint_limits()
    q = chain.random_q(0, size=200) * 1.3
    clipped = chain.clip_to_limits(q)
    assert np.all(clipped >= lo) and np.all(clipped <= hi)
    assert np.all(chain.within_bend_limits(clipped))
    inside = chain.within_bend_limits(q) & np.all((q >= lo) & (q <= hi), axis=-1)
    np.testing.assert_array_equal(clipped[inside], q[inside])
    edge = chain.bend_angles(clipped)[~inside].max(axis=-1)
    assert np.any(np.isclose(edge, chain.max_bends.max(), atol=1e-9))  # shrunk onto the cone, not inside it


def test_ik_is_deterministic_and_reports_unreachable():
    chain = get_robot("sscc-16")
    target = chain.joint_positions(bent_within_limits(chain, 7))[-1]
    a, b = chain.ik(target, seed=5), chain.ik(target, seed=5)
    np.testing.assert_array_equal(a.q, b.q)
    far = chain.ik([0, 0, 10 * chain.total_length], seed=1, restarts=1, iterations=50)
    assert not far.converged
    assert far.error_mm == pytest.approx(10 * chain.total_length - chain.total_length - 1200, rel=1e-3)


# ---------------------------------------------------------------- bend angles
@fast
@given(angle)
def test_bend_of_rx_alone_is_abs_a(a):
    chain = small_chain()
    q = np.zeros(chain.dof)
    q[2] = a
    assert chain.bend_angles(q)[1] == pytest.approx(abs(a), abs=1e-9)


@fast
@given(angle, angle)
def test_bend_of_rx_ry_is_arccos_cos_cos(a, b):
    chain = small_chain()
    q = np.zeros(chain.dof)
    q[2:4] = a, b
    bends = chain.bend_angles(q)
    assert bends[1] == pytest.approx(math.acos(math.cos(a) * math.cos(b)), abs=1e-7)
    assert bends[0] == pytest.approx(0.0, abs=1e-9) and bends[2] == pytest.approx(0.0, abs=1e-7)
    assert bool(chain.within_bend_limits(q)) == (math.acos(math.cos(a) * math.cos(b)) <= 1.0 + 1e-9)


def test_hsr_bend_is_arccos_cos_cos():
    chain = get_robot("hsr-10")
    q = np.zeros(chain.dof)
    q[3:5] = 0.2, -0.25  # delta2, gamma2
    np.testing.assert_allclose(chain.bend_angles(q)[1], math.acos(math.cos(0.2) * math.cos(0.25)), atol=1e-12)


# ---------------------------------------------------------------- directions -> joint angles
@fast
@given(st.sampled_from(NAMES), seeds)
def test_joint_angles_from_directions_round_trips_fk(name, seed):
    base = pose(rot_z(0.7) @ rot_x(-1.1), [5.0, -3.0, 2.0])
    chain = get_robot(name).with_base(base)
    q = chain.random_q(seed)
    p = chain.joint_positions(q)
    d = np.diff(p, axis=0)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    q2 = chain.joint_angles_from_directions(d, feed=q[0])
    np.testing.assert_allclose(q2, q, atol=1e-9)  # all angles within ±pi/2: the solution is unique
    np.testing.assert_allclose(chain.fk(q2), chain.fk(q), atol=1e-8)


def test_joint_angles_from_directions_is_batched_and_takes_base_rotation():
    chain = small_chain()
    q = chain.random_q(1, size=4)
    d = np.diff(chain.joint_positions(q), axis=-2)
    np.testing.assert_allclose(chain.joint_angles_from_directions(d), q, atol=1e-9)
    turned = chain.joint_angles_from_directions(d @ rot_z(0.5).T, base_rotation=rot_z(0.5))
    np.testing.assert_allclose(turned, q, atol=1e-9)


# ---------------------------------------------------------------- serialisation
@pytest.mark.parametrize("name", NAMES)
def test_to_dict_from_dict_round_trip(name):
    chain = get_robot(name).with_base(pose(rot_y(0.3), [1.0, 2.0, 3.0]))
    d = json.loads(json.dumps(chain.to_dict()))
    assert d["schema"] == "snakeplan.robot/1"
    assert d["total_length"] == pytest.approx(sum(s["length"] for s in d["sections"]))
    assert set(d["sections"][0]) == {"length", "radius", "max_bend", "mass_kg", "com_mm"}
    back = Chain.from_dict(d)
    assert back.name == chain.name and back.k_ul == chain.k_ul and back.feed_range == chain.feed_range
    assert back.sections == chain.sections
    q = chain.random_q(0, size=5)
    np.testing.assert_allclose(back.fk(q), chain.fk(q), atol=1e-12)


def test_from_dict_with_sections_only_builds_default_structure():
    chain = Chain.from_dict({"name": "mine", "sections": [{"length": 50, "radius": 5, "max_bend": 0.5}] * 3})
    assert chain.dof == 6 and not chain.has_feed and chain.total_length == 150
    assert chain.k_ul == pytest.approx(2 * math.sin(0.25) / 50)


def good_dict():
    return get_robot("sscc-16").to_dict()


@pytest.mark.parametrize(
    "edit, field",
    [
        (lambda d: d["sections"][3].update(length=-5), "section 3: length"),
        (lambda d: d["sections"][1].update(radius=float("nan")), "section 1: radius"),
        (lambda d: d["sections"][0].update(max_bend=4.0), "section 0: max_bend"),
        (lambda d: d["sections"][2].pop("radius"), "section 2: radius missing"),
        (lambda d: d["sections"][2].update(length="long"), "section 2: length"),
        (lambda d: d.pop("name"), "name"),
        (lambda d: d.pop("sections"), "sections"),
        (lambda d: d.update(schema="snakeplan.robot/9"), "schema"),
        (lambda d: d.update(total_length=1), "total_length"),
        (lambda d: d.update(k_ul=float("inf")), "k_ul: must be finite"),
        (lambda d: d.update(base=[[1, 0], [0, 1]]), "base"),
        (lambda d: d.update(feed_range=[5, 1]), "feed_range"),
        (lambda d: d["kinematics"].pop("frames"), "kinematics.frames"),
    ],
)
def test_from_dict_rejects_bad_input_naming_the_field(edit, field):
    d = good_dict()
    edit(d)
    with pytest.raises(ValueError) as info:
        Chain.from_dict(d)
    message = str(info.value)
    assert message.startswith(field) and "\n" not in message


def test_section_validation():
    with pytest.raises(ValueError, match="length must be > 0, got -5"):
        Section(-5, 1, 1)
    with pytest.raises(ValueError, match="radius must be finite"):
        Section(5, float("nan"), 1)
    with pytest.raises(ValueError, match="max_bend"):
        Section(5, 1, math.pi)


# ---------------------------------------------------------------- presets
def test_presets_have_the_papers_numbers():
    assert robot_names() == sorted(NAMES)
    sjtu = get_robot("sjtu-snake-iii")
    assert sjtu.n_sections == 12 and sjtu.dof == 25 and sjtu.total_length == pytest.approx(2130)
    np.testing.assert_allclose(sjtu.lengths, 177.5)
    np.testing.assert_allclose(sjtu.radii, 27.5)
    np.testing.assert_allclose(sjtu.max_bends, math.radians(50.7))
    assert sjtu.k_ul == 0.0055 and sjtu.feed_range == (0.0, 2130.0)
    s16, s24 = get_robot("sscc-16"), get_robot("sscc-24")
    assert (s16.dof - 1, s24.dof - 1) == (16, 24)
    assert s16.total_length == pytest.approx(s24.total_length) == pytest.approx(1200)
    assert s16.k_ul == pytest.approx(2 * math.sin(math.radians(30)) / 150)
    hsr = get_robot("hsr-10")
    assert hsr.n_sections == 10 and hsr.dof == 21 and hsr.feed_range == presets.HSR_FEED_RANGE_MM
    np.testing.assert_allclose(hsr.lengths, presets.HSR_LINK_LENGTH_MM)
    np.testing.assert_allclose(hsr.radii, presets.HSR_RADIUS_MM)
    np.testing.assert_allclose(hsr.max_bends, presets.HSR_MAX_BEND_RAD)
    lo, hi = hsr.joint_limits()
    np.testing.assert_allclose(hi[1:], presets.HSR_MAX_BEND_RAD)


def test_unknown_robot_lists_valid_names():
    with pytest.raises(KeyError) as info:
        get_robot("snakey")
    for name in NAMES:
        assert name in str(info.value)


def test_register_robot():
    register_robot("tiny", lambda: small_chain())
    try:
        assert get_robot("tiny").total_length == 600
        assert "tiny" in robot_names()
        with pytest.raises(ValueError, match="robot 'tiny' is registered twice"):
            register_robot("tiny", lambda: small_chain())
    finally:
        presets.ROBOTS.unregister("tiny")
    assert "tiny" not in robot_names()
    with pytest.raises(KeyError):
        get_robot("tiny")


# ---------------------------------------------------------------- DH tables
def test_standard_dh_table_matches_explicit_product():
    l1, l2 = 120.0, 80.0
    table = {
        "name": "std",
        "convention": "standard",
        "units": {"length": "cm", "angle": "deg"},
        "radius": 1,
        "max_bend": 40,
        "links": [
            {"theta": 0, "alpha": -90, "joint": "revolute", "limits": [-180, 180]},
            {"theta": 0, "alpha": 90, "joint": "revolute"},
            {"d": l1 / 10, "joint": "fixed"},
            {"theta": 0, "alpha": -90, "joint": "revolute", "limits": [-180, 180]},
            {"theta": 0, "alpha": 90, "joint": "revolute"},
            {"d": l2 / 10, "joint": "fixed", "radius": 2},
        ],
        "sections": [2, 5],
    }
    chain = load_dh(table)
    np.testing.assert_allclose(chain.lengths, [l1, l2])
    np.testing.assert_allclose(chain.radii, [10, 20])
    lo, hi = chain.joint_limits()
    np.testing.assert_allclose(hi, np.radians([180, 40, 180, 40]))
    q = np.array([0.4, -0.3, 1.9, 0.5])

    def row(theta, d, a, alpha):
        return pose(rot_z(theta)) @ pose(translation=[0, 0, d]) @ pose(translation=[a, 0, 0]) @ pose(rot_x(alpha))

    T1 = row(q[0], 0, 0, -math.pi / 2) @ row(q[1], 0, 0, math.pi / 2) @ row(0, l1, 0, 0)
    T2 = T1 @ row(q[2], 0, 0, -math.pi / 2) @ row(q[3], 0, 0, math.pi / 2) @ row(0, l2, 0, 0)
    np.testing.assert_allclose(chain.joint_positions(q), [[0, 0, 0], T1[:3, 3], T2[:3, 3]], atol=1e-9)
    d = np.diff(chain.joint_positions(q), axis=0)
    q2 = chain.joint_angles_from_directions(d)
    np.testing.assert_allclose(chain.joint_positions(q2), chain.joint_positions(q), atol=1e-9)


def test_hsr_yaml_loads_from_path_and_mapping(tmp_path):
    import yaml
    from importlib.resources import files

    path = files("snakeplan.robots").joinpath("data", "hsr-10.yaml")
    data = yaml.safe_load(path.read_text())
    q = get_robot("hsr-10").random_q(2)
    np.testing.assert_allclose(load_dh(data).fk(q), get_robot("hsr-10").fk(q))
    copy = tmp_path / "hsr.yaml"
    copy.write_text(path.read_text())
    np.testing.assert_allclose(load_dh(copy).fk(q), get_robot("hsr-10").fk(q))


@pytest.mark.parametrize(
    "edit, field",
    [
        (lambda d: d["links"][1].update(joint="ball"), "links[1].joint"),
        (lambda d: d["links"][2].update(alfa=3), "links[2].alfa"),
        (lambda d: d.update(sections=[3, 6]), "sections"),
        (lambda d: d.update(convention="weird"), "convention"),
        (lambda d: d.update(units={"length": "inch"}), "units.length"),
        (lambda d: d.pop("radius"), "section 0: radius"),
        (lambda d: d.pop("mount"), "kinematics"),
        (lambda d: d["feed"].update(axis="w"), "feed.axis"),
        (lambda d: d["links"][4].update(alpha="ninety"), "links[4].alpha"),
        (lambda d: d["links"][4].update(limits=[10, -10]), "links[4].limits"),
    ],
)
def test_dh_rejects_bad_tables_naming_the_field(edit, field):
    import yaml
    from importlib.resources import files

    d = yaml.safe_load(files("snakeplan.robots").joinpath("data", "hsr-10.yaml").read_text())
    edit(d)
    with pytest.raises(ValueError) as info:
        load_dh(d)
    assert str(info.value).startswith(field)


# ---------------------------------------------------------------- URDF
def urdf_tip(root: ElementTree.Element, q: dict[str, float], leaf: str) -> np.ndarray:
    """Tip pose by walking the URDF joint tree from ``leaf`` back to the root."""
    by_child = {j.find("child").get("link"): j for j in root.findall("joint")}
    chain = []
    link = leaf
    while link in by_child:
        chain.append(by_child[link])
        link = by_child[link].find("parent").get("link")
    T = np.eye(4)
    for j in reversed(chain):
        o = j.find("origin")
        r, p, y = map(float, o.get("rpy").split())
        T = T @ pose(rot_z(y) @ rot_y(p) @ rot_x(r), [float(v) for v in o.get("xyz").split()])
        if j.get("type") in ("revolute", "prismatic"):
            axis = np.array([float(v) for v in j.find("axis").get("xyz").split()])
            value = q[j.get("name")]
            k = int(np.argmax(axis))
            if j.get("type") == "revolute":
                T = T @ pose((rot_x, rot_y, rot_z)[k](value))
            else:
                T = T @ pose(translation=axis * value)
    return T


@pytest.mark.parametrize("name", NAMES)
def test_urdf_parses_and_matches_fk(name):
    chain = get_robot(name).with_base(pose(rot_x(0.4), [100.0, 0, -50.0]))
    root = ElementTree.fromstring(to_urdf(chain, length_scale=1.0))
    joints = root.findall("joint")
    types = [j.get("type") for j in joints]
    assert types.count("revolute") == 2 * chain.n_sections
    assert types.count("prismatic") == (1 if chain.has_feed else 0)
    links = {link.get("name") for link in root.findall("link")}
    assert all(j.find("parent").get("link") in links and j.find("child").get("link") in links for j in joints)
    assert len(root.findall("link/visual/geometry/cylinder")) == chain.n_sections
    q = chain.random_q(4)
    T = urdf_tip(root, dict(zip(chain.joint_names, q)), f"s{chain.n_sections - 1}_end")
    np.testing.assert_allclose(T, chain.fk(q)[-1], atol=1e-6)


def test_urdf_defaults_to_metres():
    root = ElementTree.fromstring(to_urdf(get_robot("sjtu-snake-iii")))
    cylinder = root.find("link/visual/geometry/cylinder")
    assert float(cylinder.get("length")) == pytest.approx(0.1775)
    assert float(cylinder.get("radius")) == pytest.approx(0.0275)
