"""Cable lengths against hand-computed geometry: the straight arm, one joint bent in a cable's plane, symmetric
routing to first order, the inverse, and sjtu-snake-iii's documented default routing."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.robots import (
    CableRouting,
    Chain,
    Section,
    SectionCables,
    cable_lengths,
    get_robot,
    joint_angles_from_cables,
    presets,
)

SJTU = get_robot("sjtu-snake-iii")
H = presets.SJTU_DISC_SPACING_MM / 2  # 15 mm: each disc's distance from its pivot
R = presets.SJTU_CABLE_PITCH_RADIUS_MM  # 22 mm


def test_straight_arm_keeps_every_cable_at_its_rest_length():
    # Hand: from the base disc (15 mm behind pivot 0) to the end of section i: 15 + 177.5 (i + 1) mm.
    expected = np.repeat(15.0 + 177.5 * np.arange(1, 13), 3)
    for feed in (0.0, 700.0, 2130.0):
        q = np.zeros(SJTU.dof)
        q[0] = feed
        np.testing.assert_allclose(cable_lengths(SJTU, q), expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(SJTU.cables.rest_lengths(SJTU.lengths), expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("theta", [0.05, 0.3, presets.SJTU_MAX_BEND_RAD])
def test_one_joint_bent_in_a_cables_plane_shortens_it_and_lengthens_the_other_two(theta):
    # Joint 0's second angle b0 (Ry) bends section 0 towards +x, in the plane of section 0's cable at 0 deg. Hand:
    # that cable's segment is 2 (h cos(t/2) - r sin(t/2)); the cables at +-120 deg (cos = -1/2) get
    # 2 (h cos(t/2) + r/2 sin(t/2)); every cable of every section passes joint 0, at its own hole angle.
    q = np.zeros(SJTU.dof)
    q[2] = theta
    change = cable_lengths(SJTU, q) - cable_lengths(SJTU, np.zeros(SJTU.dof))
    angles = np.array([a for s in SJTU.cables.sections for a in s.hole_angles])
    expected = 2 * (H * math.cos(theta / 2) - R * np.cos(angles) * math.sin(theta / 2)) - 2 * H
    np.testing.assert_allclose(change, expected, rtol=0, atol=1e-12)
    assert change[0] < 0 < min(change[1], change[2])
    assert change[0] == pytest.approx(2 * H * (math.cos(theta / 2) - 1) - 2 * R * math.sin(theta / 2), abs=1e-12)
    assert change[1] == pytest.approx(2 * H * (math.cos(theta / 2) - 1) + R * math.sin(theta / 2), abs=1e-12)


def test_a_bend_about_x_shortens_the_cable_on_the_minus_y_side():
    # Rx(a) turns +z towards -y; routing with a cable at 270 deg (on -y), the others at 30 and 150 deg.
    routing = CableRouting((SectionCables((1.5 * math.pi, math.pi / 6, 5 * math.pi / 6), 10.0, 8.0),))
    arm = Chain([Section(100.0, 12.0, 1.0)], cables=routing)
    a = 0.4
    change = cable_lengths(arm, [a, 0.0]) - cable_lengths(arm, [0.0, 0.0])
    h, r = 4.0, 10.0
    assert change[0] == pytest.approx(2 * h * (math.cos(a / 2) - 1) - 2 * r * math.sin(a / 2), abs=1e-12)
    assert change[1] == pytest.approx(2 * h * (math.cos(a / 2) - 1) + r * math.sin(a / 2), abs=1e-12)
    assert change[2] == pytest.approx(change[1], abs=1e-12)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_symmetric_routing_changes_sum_to_zero_to_first_order(seed):
    # Three cables 120 deg apart: the first-order changes are -r (bend component along each hole) and sum to zero,
    # so the sum's derivative at the straight arm vanishes while each cable's does not.
    rng = np.random.default_rng(seed)
    direction = np.zeros(SJTU.dof)
    direction[1:] = rng.normal(size=SJTU.dof - 1)
    direction /= np.linalg.norm(direction)
    eps = 1e-5
    change = (cable_lengths(SJTU, eps * direction) - cable_lengths(SJTU, -eps * direction)) / (2 * eps)
    per_section = change.reshape(12, 3).sum(axis=1)
    assert np.max(np.abs(per_section)) < 1e-6
    assert np.max(np.abs(change)) > 1.0
    # Second order: halving the bend quarters the sum of changes.
    rest = cable_lengths(SJTU, np.zeros(SJTU.dof)).reshape(12, 3).sum(axis=1)
    big = cable_lengths(SJTU, 0.02 * direction).reshape(12, 3).sum(axis=1) - rest
    small = cable_lengths(SJTU, 0.01 * direction).reshape(12, 3).sum(axis=1) - rest
    np.testing.assert_allclose(small, big / 4, rtol=2e-2, atol=1e-9)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_cable_lengths_invert_to_the_joint_angles(seed):
    q = SJTU.clip_to_limits(SJTU.random_q(seed, 8))
    back = joint_angles_from_cables(SJTU, cable_lengths(SJTU, q), feed=q[:, 0])
    np.testing.assert_allclose(back, q, rtol=0, atol=1e-9)


def test_sjtu_default_routing_is_as_documented():
    routing = SJTU.cables
    assert len(routing.sections) == 12 and len(routing.names) == 36 and routing.names[:4] == ("s0_c0", "s0_c1",
                                                                                               "s0_c2", "s1_c0")
    for i, s in enumerate(routing.sections):
        assert s.pitch_radius_mm == 22.0 and s.disc_spacing_mm == 30.0
        np.testing.assert_allclose(np.degrees(s.hole_angles), 10.0 * i + np.array([0.0, 120.0, 240.0]), atol=1e-12)
    holes = np.round(np.degrees([a for s in routing.sections for a in s.hole_angles]) % 360, 9)
    assert len(set(holes)) == 36  # every cable its own hole
    # The reason for 30 mm: two 55 mm discs 30 mm apart still clear each other at the 50.7 deg bend limit, and no
    # cable segment collapses (the 55 mm diameter is paper 000's Table 1).
    half = presets.SJTU_MAX_BEND_RAD / 2
    assert 2 * (H * math.cos(half) - 27.5 * math.sin(half)) > 0
    assert 2 * ((H - 5) * math.cos(half) - 27.5 * math.sin(half)) < 0  # 20 mm would not do
    q = np.zeros((36, SJTU.dof))
    for k, psi in enumerate(np.linspace(0, 2 * math.pi, 36, endpoint=False)):
        q[k, 1], q[k, 2] = -presets.SJTU_MAX_BEND_RAD * math.sin(psi), presets.SJTU_MAX_BEND_RAD * math.cos(psi)
    q = SJTU.clip_to_limits(q)
    shortest = (cable_lengths(SJTU, q) - cable_lengths(SJTU, np.zeros(SJTU.dof)))[:, :3].min() + 2 * H
    assert shortest > 0


def test_routing_is_a_robot_parameter_that_round_trips_and_is_checked():
    data = SJTU.to_dict()
    assert Chain.from_dict(data).cables == SJTU.cables
    assert get_robot("sscc-16").cables is None
    with pytest.raises(ValueError, match="cables: 2 sections of cables for 12 sections"):
        Chain(SJTU.sections, cables=CableRouting.uniform(2, 3, 22.0, 30.0))
    with pytest.raises(ValueError, match=r"cables.sections\[0\]: cables.pitch_radius_mm"):
        CableRouting.from_dict({"sections": [{"hole_angles_rad": [0.0], "pitch_radius_mm": -1.0,
                                              "disc_spacing_mm": 30.0}]})
    with pytest.raises(ValueError, match="not cable-driven"):
        cable_lengths(get_robot("sscc-16"), np.zeros(17))
